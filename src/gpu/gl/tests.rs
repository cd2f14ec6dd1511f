//! Checks of the GL helpers against the driver: exact float round trips, pixel-centre
//! coordinates, discard and occlusion counts, mapped shader errors, limits; all of them
//! again under Mesa forced to OpenGL 2.1.
use super::program::parse_error_line;
use super::*;
use crate::gpu::context::test_support::{mesa_or_acknowledged_skip, run_ignored_test_in_child};
use crate::gpu::context::with_test_context;
use glow::HasContext;

/// Environment that makes Mesa expose exactly OpenGL 2.1 / GLSL 1.20.
const GL21_ENV: [(&str, &str); 2] = [
    ("MESA_GL_VERSION_OVERRIDE", "2.1"),
    ("MESA_GLSL_VERSION_OVERRIDE", "120"),
];

fn build(ctx: &GlContext, pass: &str, fragment: &str) -> Program {
    compile_program(
        ctx,
        pass,
        QUAD_VERTEX_SHADER,
        fragment,
        &single_file_line_map("test.frag"),
    )
    .unwrap_or_else(|e| panic!("{e}"))
}

/// Renders `fragment` over a fresh `w`×`h` target with `attachments` outputs, with
/// `input` (if any) bound to unit 0 as `u_input`; returns the target for read-back.
fn render(
    ctx: &GlContext,
    fragment: &str,
    w: u32,
    h: u32,
    attachments: usize,
    input: Option<&Texture>,
) -> RenderTarget {
    let gl = ctx.gl();
    let program = build(ctx, "test", fragment);
    let target = RenderTarget::new(ctx, w, h, attachments).unwrap();
    let quad = FullscreenQuad::new(ctx).unwrap();
    target.bind(gl);
    // SAFETY: the test context is current, `program` and `tex` are live objects of it, and
    // the location is looked up in the program it is set on.
    unsafe {
        gl.use_program(Some(program.name()));
        if let Some(tex) = input {
            gl.active_texture(glow::TEXTURE0);
            gl.bind_texture(glow::TEXTURE_2D, Some(tex.name()));
            let loc = gl.get_uniform_location(program.name(), "u_input");
            assert!(loc.is_some(), "u_input not active");
            gl.uniform_1_i32(loc.as_ref(), 0);
        }
    }
    quad.draw(gl, &program);
    check_gl_error(gl, "test draw").unwrap();
    // SAFETY: the test context is current; unbinding takes no object.
    unsafe { gl.bind_texture(glow::TEXTURE_2D, None) };
    target
}

/// Float MRT: attachment 0 gets the pixel centre and two constants (one negative, to
/// prove no clamping), attachment 1 a copy of an input texture sampled at `v_uv`.
fn check_mrt_exact_floats(ctx: &GlContext) {
    let (w, h) = (7u32, 5u32);
    let input: Vec<f32> = (0..w * h * 4).map(|i| i as f32 * 0.25 - 3.0).collect();
    let tex = Texture::new_f32(ctx, w, h, Some(&input)).unwrap();
    // `input` is a reserved word in GLSL 1.20, hence `u_input`.
    let fs = "#version 120
uniform sampler2D u_input;
varying vec2 v_uv;
void main() {
gl_FragData[0] = vec4(gl_FragCoord.xy, 1.5, -2.25);
gl_FragData[1] = texture2D(u_input, v_uv);
}
";
    let target = render(ctx, fs, w, h, 2, Some(&tex));
    let a0 = target.read_attachment(ctx.gl(), 0).unwrap();
    let a1 = target.read_attachment(ctx.gl(), 1).unwrap();
    for j in 0..h as usize {
        for i in 0..w as usize {
            let p = (j * w as usize + i) * 4;
            let want = [i as f32 + 0.5, j as f32 + 0.5, 1.5, -2.25];
            assert_eq!(&a0[p..p + 4], &want, "attachment 0 at ({i},{j})");
            assert_eq!(&a1[p..p + 4], &input[p..p + 4], "attachment 1 at ({i},{j})");
        }
    }
    // glGetTexImage sees the same data as glReadPixels.
    let via_tex = target.texture(1).read(ctx.gl()).unwrap();
    assert_eq!(via_tex, a1);
}

/// The interpolated texture coordinate is the pixel centre over the target size.
fn check_uv_at_pixel_centres(ctx: &GlContext) {
    let (w, h) = (9u32, 4u32);
    let fs = "#version 120
varying vec2 v_uv;
void main() { gl_FragData[0] = vec4(v_uv, 0.0, 1.0); }
";
    let target = render(ctx, fs, w, h, 1, None);
    let out = target.read_attachment(ctx.gl(), 0).unwrap();
    for j in 0..h as usize {
        for i in 0..w as usize {
            let p = (j * w as usize + i) * 4;
            let (u, v) = ((i as f32 + 0.5) / w as f32, (j as f32 + 0.5) / h as f32);
            assert!(
                (out[p] - u).abs() < 1e-6 && (out[p + 1] - v).abs() < 1e-6,
                "v_uv at ({i},{j}) = ({}, {}), want ({u}, {v})",
                out[p],
                out[p + 1]
            );
        }
    }
}

/// `discard` removes fragments from GL_SAMPLES_PASSED: a pass that discards every
/// even column of an 8x6 target reports exactly the 24 odd-column fragments.
fn check_discard_occlusion_count(ctx: &GlContext) {
    let gl = ctx.gl();
    let (w, h) = (8u32, 6u32);
    let fs = "#version 120
void main() {
if (mod(floor(gl_FragCoord.x), 2.0) == 0.0) discard;
gl_FragData[0] = vec4(1.0);
}
";
    let program = build(ctx, "discard", fs);
    let target = RenderTarget::new(ctx, w, h, 1).unwrap();
    let quad = FullscreenQuad::new(ctx).unwrap();
    let query = OcclusionQuery::new(ctx).unwrap();
    target.bind(gl);
    // SAFETY: the test context is current; clearing the bound target takes no pointer.
    unsafe {
        gl.clear_color(0.0, 0.0, 0.0, 0.0);
        gl.clear(glow::COLOR_BUFFER_BIT);
    }
    query.begin(ctx);
    quad.draw(gl, &program);
    query.end(ctx);
    assert_eq!(query.result(ctx).unwrap(), w * h / 2);
    // And the surviving fragments are exactly the odd columns.
    let out = target.read_attachment(gl, 0).unwrap();
    for (k, px) in out.chunks(4).enumerate() {
        let want = if k % w as usize % 2 == 1 { 1.0 } else { 0.0 };
        assert_eq!(px[0], want, "pixel {k}");
    }
    // With nothing discarded the count is the whole target (each pixel once, the fan's
    // shared diagonal included).
    let all = build(
        ctx,
        "all",
        "#version 120\nvoid main() { gl_FragData[0] = vec4(2.0); }\n",
    );
    query.begin(ctx);
    quad.draw(gl, &all);
    query.end(ctx);
    assert_eq!(query.result(ctx).unwrap(), w * h);
    if ctx.info.timer_query {
        let timer = TimerQuery::new(ctx).unwrap();
        timer.begin(ctx);
        quad.draw(gl, &all);
        timer.end(ctx);
        timer.result_ns(ctx).unwrap();
    } else {
        assert!(TimerQuery::new(ctx).is_err());
    }
}

/// A compile error in the third line of the second of two concatenated files comes back
/// as Error::Shader naming the pass and that file/line.
fn check_broken_shader_maps_line(ctx: &GlContext) {
    let header = "#version 120\nvarying vec2 v_uv;\nuniform float u_scale;\n"; // common.glsl 1-3
    let body = "void main() {\n    float x = u_scale;\n    gl_FragData[0] = vec4(x, undefined_thing, 0.0, 1.0);\n}\n"; // trace.frag 1-4
    let src = format!("{header}{body}");
    let map = |line: usize| {
        if line <= 3 {
            ("common.glsl".to_string(), line)
        } else {
            ("trace.frag".to_string(), line - 3)
        }
    };
    match compile_program(ctx, "intersect", QUAD_VERTEX_SHADER, &src, &map) {
        Err(Error::Shader {
            pass,
            file,
            line,
            log,
        }) => {
            eprintln!("driver log for the broken shader:\n{log}");
            assert_eq!(pass, "intersect");
            assert_eq!((file.as_str(), line), ("trace.frag", 3), "log: {log}");
            assert!(log.contains("undefined_thing"), "log: {log}");
        }
        other => panic!("expected Error::Shader, got {other:?}"),
    }
    // A broken vertex shader is reported against the vertex shader, not the map.
    let err = compile_program(
        ctx,
        "quad",
        "#version 120\nvoid main() { oops }\n",
        "#version 120\nvoid main() { gl_FragData[0] = vec4(0.0); }\n",
        &map,
    )
    .unwrap_err();
    assert!(
        matches!(&err, Error::Shader { file, line: 2, .. } if file == "<vertex shader>"),
        "{err:?}"
    );
    check_gl_error(ctx.gl(), "after failed compiles").unwrap();
}

/// Indices up to 2^24 - 1 survive texture upload, sampling, render-to-texture and
/// read-back unchanged, and so do integer-valued results computed in the shader.
fn check_large_values_exact(ctx: &GlContext) {
    let (w, h) = (3u32, 2u32);
    let specials = [
        16777215.0f32,
        16777214.0,
        -16777215.0,
        8388607.5,
        1.0e30,
        -0.0,
    ];
    let input: Vec<f32> = (0..w * h)
        .flat_map(|k| {
            let s = specials[k as usize % specials.len()];
            [s, 16777215.0 - k as f32, k as f32, f32::MIN_POSITIVE]
        })
        .collect();
    let tex = Texture::new_f32(ctx, w, h, Some(&input)).unwrap();
    assert_eq!(tex.read(ctx.gl()).unwrap(), input);
    let fs = "#version 120
uniform sampler2D u_input;
varying vec2 v_uv;
void main() {
gl_FragData[0] = texture2D(u_input, v_uv);
// A linear index computed in the shader, offset to the top of the exact range.
float index = floor(gl_FragCoord.y) * 3.0 + floor(gl_FragCoord.x);
gl_FragData[1] = vec4(16777215.0 - index, index, 16777215.0, -16777215.0);
}
";
    let target = render(ctx, fs, w, h, 2, Some(&tex));
    let copy = target.read_attachment(ctx.gl(), 0).unwrap();
    assert_eq!(
        copy.iter().map(|v| v.to_bits()).collect::<Vec<_>>(),
        input.iter().map(|v| v.to_bits()).collect::<Vec<_>>()
    );
    let computed = target.read_attachment(ctx.gl(), 1).unwrap();
    for (k, px) in computed.chunks(4).enumerate() {
        assert_eq!(
            px,
            [16777215.0 - k as f32, k as f32, 16777215.0, -16777215.0]
        );
    }
    // Region read-back addresses the right texels.
    let region = target
        .read_attachment_region(ctx.gl(), 1, 1, 1, 2, 1)
        .unwrap();
    assert_eq!(region, [&computed[16..20], &computed[20..24]].concat());
}

fn check_limits_and_errors(ctx: &GlContext) {
    let gl = ctx.gl();
    let too_many = ctx.info.max_draw_buffers as usize + 1;
    assert!(matches!(
        RenderTarget::new(ctx, 4, 4, too_many),
        Err(Error::Limit(_))
    ));
    let too_wide = ctx.info.max_texture_size as u32 + 1;
    assert!(matches!(
        Texture::new_f32(ctx, too_wide, 1, None),
        Err(Error::Limit(_))
    ));
    assert!(matches!(
        Texture::new_f32(ctx, 2, 2, Some(&[0.0; 3])),
        Err(Error::Internal(_))
    ));
    let rt = RenderTarget::new(ctx, 4, 4, 1).unwrap();
    assert!(rt.read_attachment(gl, 1).is_err());
    assert!(rt.read_attachment_region(gl, 0, 3, 0, 2, 1).is_err());
    check_gl_error(gl, "limits").unwrap();
}

fn all_checks(ctx: &GlContext) {
    check_mrt_exact_floats(ctx);
    check_uv_at_pixel_centres(ctx);
    check_discard_occlusion_count(ctx);
    check_broken_shader_maps_line(ctx);
    check_large_values_exact(ctx);
    check_limits_and_errors(ctx);
}

#[test]
fn mrt_float_fbo_reads_back_exact_floats() {
    with_test_context(check_mrt_exact_floats);
}

#[test]
fn quad_texcoords_are_pixel_centres() {
    with_test_context(check_uv_at_pixel_centres);
}

#[test]
fn discard_is_excluded_from_occlusion_count() {
    with_test_context(check_discard_occlusion_count);
}

#[test]
fn broken_shader_reports_mapped_line() {
    with_test_context(check_broken_shader_maps_line);
}

#[test]
fn large_values_round_trip_exactly() {
    with_test_context(check_large_values_exact);
}

#[test]
fn limits_are_reported_as_errors() {
    with_test_context(check_limits_and_errors);
}

#[test]
fn error_line_parsing() {
    assert_eq!(
        parse_error_line("0:12(5): error: `x' undeclared\n"),
        Some(12)
    );
    assert_eq!(
        parse_error_line("0(7) : error C1008: undefined variable \"x\"\n"),
        Some(7)
    );
    assert_eq!(
        parse_error_line("ERROR: 0:33: 'x' : undeclared identifier\n"),
        Some(33)
    );
    assert_eq!(
        parse_error_line("0:3(1): warning: unused\n0:9(2): error: syntax error\n"),
        Some(9)
    );
    assert_eq!(parse_error_line("error: linking failed\n"), None);
    assert_eq!(parse_error_line(""), None);
}

/// Runs every check in a child process whose Mesa is forced to OpenGL 2.1 / GLSL 1.20,
/// proving the backend needs nothing newer. Non-Mesa drivers ignore the override
/// variables: there the test fails unless FRAGTRACE_ALLOW_SKIP=1 acknowledges the skip.
#[test]
fn gl21_override_passes_all_checks() {
    if !mesa_or_acknowledged_skip("forcing OpenGL 2.1 / GLSL 1.20") {
        return;
    }
    let (ok, out) = run_ignored_test_in_child("gpu::gl::tests::gl21_override_inner", &GL21_ENV);
    assert!(ok, "{out}");
}

/// The body of [`gl21_override_passes_all_checks`]; run only in that child process.
#[test]
#[ignore = "run by gl21_override_passes_all_checks with Mesa overridden to GL 2.1"]
fn gl21_override_inner() {
    with_test_context(|ctx| {
        let forced = GL21_ENV
            .iter()
            .all(|(k, v)| std::env::var(k).as_deref() == Ok(*v));
        if forced {
            assert_eq!(ctx.info.gl_major_minor, (2, 1), "{}", ctx.info);
            assert_eq!(ctx.info.glsl_version, "1.20", "{}", ctx.info);
            // The override must really cap GLSL, or this test would prove nothing.
            let newer = "#version 130\nout vec4 c;\nvoid main() { c = vec4(0.0); }\n";
            let map = single_file_line_map("v130.frag");
            assert!(compile_program(ctx, "v130", QUAD_VERTEX_SHADER, newer, &map).is_err());
        }
        eprintln!("{}", ctx.info);
        all_checks(ctx);
    });
}
