//! Drawing into the window: a finished picture (the render's image or an AOV, encoded to
//! 8-bit sRGB on the host by the same code that writes PNGs, so the window holds exactly
//! the bytes `fragtrace render` would write), or a render in progress from its
//! [`Snapshot`]: the colour so far, with the rays of the wave in flight tinted, so the
//! wave is seen advancing pass by pass, and on request the tiles the last traversal pass
//! drew outlined, so the passes are seen shrinking to what is left (issue 49). Also reads
//! the window back for screenshots.
//!
//! The presenter draws in the render's own context between two of its passes, so it
//! saves and restores every piece of GL state it touches (`gpu::gl::SavedState`): the
//! renderer never learns that it was watched.

use crate::gpu::contract::{self, ray, view, Unit};
use crate::gpu::gl::PixelRect;
use crate::gpu::gl::{
    bind_window, compile_program, read_window as read_back_buffer, single_file_line_map, state,
    FullscreenQuad, Program, RenderTarget, SavedState, Texture,
};
use crate::gpu::render::{Advance, Snapshot};
use crate::gpu::shader::RayState;
use crate::gpu::GlContext;
use crate::{Error, Result};

/// The presenter's fragment program (GLSL 1.20) and the contract's names it declares
/// (`gpu::contract::view`, generated). `u_view_mode`: 0 shows `u_view_img` as it is (display
/// values already encoded), 1 scales linear radiance by `u_view_scale` and encodes it as
/// sRGB, 2 writes the scaled linear radiance unencoded (to keep the average of finished
/// samples). With `u_view_wave` on, rays of `u_view_state` that are still traversing or
/// testing are tinted.
fn fragment_source() -> (String, Vec<&'static str>) {
    let mut declared = Vec::new();
    let decls = contract::declarations_for(contract::VIEW, false, &mut declared);
    let src = format!(
        "#version 120
{decls}varying vec2 v_uv;
float srgb(float v) {{
    v = clamp(v, 0.0, 1.0);
    return v <= 0.0031308 ? 12.92 * v : 1.055 * pow(v, 1.0 / 2.4) - 0.055;
}}
void main() {{
    vec3 c = texture2D(u_view_img, v_uv).rgb;
    if (u_view_mode > 0.5) c *= u_view_scale;
    if (u_view_mode > 0.5 && u_view_mode < 1.5) c = vec3(srgb(c.r), srgb(c.g), srgb(c.b));
    if (u_view_wave > 0.5) {{
        float s = texture2D(u_view_state, v_uv).{state};
        if (abs(s - {traversing:.1}) < 0.25 || abs(s - {testing:.1}) < 0.25)
            c = mix(c, vec3(1.0, 0.55, 0.1), 0.65);
    }}
    gl_FragColor = vec4(c, 1.0);
}}
",
        state = ray::STATE.swizzle(),
        traversing = RayState::Traversing.code(),
        testing = RayState::Testing.code(),
    );
    (src, declared)
}

/// The units the presenter's two textures are bound to (the contract's `u_view_img` and
/// `u_view_state`).
const VIEW_IMG: Unit = Unit::Tri;
const VIEW_STATE: Unit = Unit::Mat;

/// The presenter's GL objects.
pub(super) struct Presenter {
    program: Program,
    quad: FullscreenQuad,
    /// The last finished picture, display values (`w` x `h`).
    picture: Option<Texture>,
    /// The average of the finished samples of the render in flight (linear).
    still: Option<RenderTarget>,
    /// Samples in `still`.
    still_samples: u32,
}

/// How one draw samples its inputs.
struct DrawCall<'t> {
    img: &'t Texture,
    state: Option<&'t Texture>,
    mode: f32,
    scale: f32,
}

impl Presenter {
    /// Compiles the program and makes the quad.
    pub(super) fn new(ctx: &GlContext) -> Result<Presenter> {
        let (src, declared) = fragment_source();
        let program = compile_program(
            ctx,
            "present",
            crate::gpu::gl::QUAD_VERTEX_SHADER,
            &src,
            &single_file_line_map("<present>"),
        )?
        .declaring(declared);
        program.bind_samplers(ctx.gl());
        Ok(Presenter {
            program,
            quad: FullscreenQuad::new(ctx)?,
            picture: None,
            still: None,
            still_samples: 0,
        })
    }

    /// Keeps `rgb8` (8-bit sRGB RGB, top row first, `w` x `h`) as the picture to show.
    pub(super) fn set_picture(
        &mut self,
        ctx: &GlContext,
        w: u32,
        h: u32,
        rgb8: &[u8],
    ) -> Result<()> {
        // As floats k/255, which the 8-bit window stores back as exactly k.
        let mut data = Vec::with_capacity(w as usize * h as usize * 4);
        for row in (0..h as usize).rev() {
            let line = &rgb8[row * w as usize * 3..(row + 1) * w as usize * 3];
            for px in line.chunks_exact(3) {
                data.extend(px.iter().map(|&b| b as f32 / 255.0));
                data.push(1.0);
            }
        }
        self.picture = Some(Texture::new_f32(ctx, w, h, Some(&data))?);
        Ok(())
    }

    /// Whether there is a finished picture to show.
    pub(super) fn has_picture(&self) -> bool {
        self.picture.is_some()
    }

    /// Draws the finished picture into the window's back buffer (`w` x `h`).
    pub(super) fn draw_picture(&self, ctx: &GlContext, w: u32, h: u32) -> Result<()> {
        if let Some(img) = &self.picture {
            self.draw_into(
                ctx,
                None,
                (w, h),
                &DrawCall {
                    img,
                    state: None,
                    mode: 0.0,
                    scale: 1.0,
                },
            )?;
        }
        Ok(())
    }

    /// Forgets the average of finished samples (a new render starts).
    pub(super) fn start_render(&mut self) {
        self.still_samples = 0;
    }

    /// Draws a render in progress into the window's back buffer (`w` x `h`): before its
    /// first sample is finished, the colour so far (the first sample growing term by term
    /// and bounce by bounce); after, the average of the finished samples. Rays of the wave
    /// in flight are tinted either way. With `tiles`, the rectangles the last traversal
    /// pass drew are outlined over it.
    pub(super) fn draw_live(
        &mut self,
        ctx: &GlContext,
        snap: &Snapshot,
        w: u32,
        h: u32,
        tiles: Option<&Advance>,
    ) -> Result<()> {
        let saved = SavedState::save(ctx.gl());
        let r = self.draw_live_inner(ctx, snap, w, h);
        if let (Ok(()), Some(a)) = (&r, tiles) {
            let size = (snap.radiance.width(), snap.radiance.height());
            state::clear_rects(ctx.gl(), &outlines(a.rects, size, (w, h)), TILE_OUTLINE);
        }
        saved.restore(ctx.gl());
        r
    }

    fn draw_live_inner(&mut self, ctx: &GlContext, snap: &Snapshot, w: u32, h: u32) -> Result<()> {
        let (rw, rh) = (snap.radiance.width(), snap.radiance.height());
        if snap.samples_done > self.still_samples && snap.samples_done > 0 {
            if self.still.as_ref().map(|t| (t.width(), t.height())) != Some((rw, rh)) {
                self.still = Some(RenderTarget::new(ctx, rw, rh, 1)?);
            }
            let target = self.still.as_ref().expect("just made");
            let call = DrawCall {
                img: snap.radiance,
                state: None,
                mode: 2.0,
                scale: snap.samples as f32 / snap.samples_done as f32,
            };
            self.draw_into(ctx, Some(target), (rw, rh), &call)?;
            self.still_samples = snap.samples_done;
        }
        let state = snap.state.first();
        let call = match (&self.still, self.still_samples) {
            (Some(t), n) if n > 0 => DrawCall {
                img: t.texture(0),
                state,
                mode: 1.0,
                scale: 1.0,
            },
            _ => DrawCall {
                img: snap.radiance,
                state,
                mode: 1.0,
                scale: snap.samples as f32,
            },
        };
        self.draw_into(ctx, None, (w, h), &call)
    }

    /// Draws the quad into `target` (the window when `None`), state saved by the caller
    /// where it matters.
    fn draw_into(
        &self,
        ctx: &GlContext,
        target: Option<&RenderTarget>,
        size: (u32, u32),
        call: &DrawCall,
    ) -> Result<()> {
        let gl = ctx.gl();
        match target {
            Some(t) => t.bind(gl),
            None => bind_window(gl, size.0, size.1),
        }
        state::mask_test(gl, None);
        state::bind_texture(gl, VIEW_IMG.index(), Some(call.img));
        state::bind_texture(gl, VIEW_STATE.index(), call.state);
        let wave = if call.state.is_some() { 1.0 } else { 0.0 };
        self.program.set(gl, view::MODE, call.mode)?;
        self.program.set(gl, view::SCALE, call.scale)?;
        self.program.set(gl, view::WAVE, wave)?;
        self.quad.draw(gl, &self.program);
        Ok(())
    }
}

/// The colour of the tiles' outlines: cyan, apart from the orange tint of the wave.
pub(super) const TILE_OUTLINE: [f32; 4] = [0.1, 0.9, 1.0, 1.0];

/// The one-pixel edges of `rects` of a `from` image, scaled onto a `to` window.
fn outlines(rects: &[PixelRect], from: (u32, u32), to: (u32, u32)) -> Vec<PixelRect> {
    let sx = |x: u32| (x as u64 * to.0 as u64 / from.0.max(1) as u64) as u32;
    let sy = |y: u32| (y as u64 * to.1 as u64 / from.1.max(1) as u64) as u32;
    let mut out = Vec::with_capacity(rects.len() * 4);
    for r in rects {
        let (x0, y0, x1, y1) = (sx(r.x0), sy(r.y0), sx(r.x1), sy(r.y1));
        if x1 <= x0 || y1 <= y0 {
            continue;
        }
        let edge = |x0, y0, x1, y1| PixelRect { x0, y0, x1, y1 };
        out.extend([
            edge(x0, y0, x1, y0 + 1),
            edge(x0, y1 - 1, x1, y1),
            edge(x0, y0, x0 + 1, y1),
            edge(x1 - 1, y0, x1, y1),
        ]);
    }
    out
}

/// Reads the window's back buffer (`w` x `h`) as 8-bit RGB, top row first.
pub(super) fn read_window(ctx: &GlContext, w: u32, h: u32) -> Result<Vec<u8>> {
    let rgba = read_back_buffer(ctx.gl(), w, h).map_err(|e| Error::Internal(e.to_string()))?;
    let mut rgb = Vec::with_capacity(w as usize * h as usize * 3);
    for row in (0..h as usize).rev() {
        for px in rgba[row * w as usize * 4..(row + 1) * w as usize * 4].chunks_exact(4) {
            rgb.extend_from_slice(&px[..3]);
        }
    }
    Ok(rgb)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::context::with_test_context;

    /// Presenting between two passes leaves every piece of GL state it touches as it was
    /// (the renderer today re-binds what it uses before each pass, so only this test notices
    /// a presenter that does not restore).
    #[test]
    fn draw_live_restores_the_renderers_gl_state() {
        with_test_context(|ctx| {
            let gl = ctx.gl();
            let mut p = Presenter::new(ctx).unwrap();
            let radiance = Texture::new_f32(ctx, 8, 4, None).unwrap();
            let state: Vec<Texture> = (0..4)
                .map(|_| Texture::new_f32(ctx, 8, 4, None).unwrap())
                .collect();
            let target = RenderTarget::new(ctx, 5, 3, 1).unwrap();
            let other = Texture::new_f32(ctx, 2, 2, None).unwrap();
            // A renderer's state in the middle of an early-z traversal.
            target.bind(gl);
            state::bind_texture(gl, 1, Some(&other));
            state::depth_test_on_with_active_unit(gl, 5);
            let before = SavedState::save(gl);
            for samples_done in [0, 1] {
                // Without a window the default framebuffer is incomplete: drawing into it
                // is an error the driver records (cleared here), not a presenter failure.
                state::clear_errors(gl);
                let snap = Snapshot {
                    radiance: &radiance,
                    state: &state,
                    samples_done,
                    samples: 2,
                    passes: 10,
                    pass: "traverse_step",
                    aov: None,
                    advance: None,
                };
                let rects = [PixelRect {
                    x0: 0,
                    y0: 0,
                    x1: 4,
                    y1: 2,
                }];
                let tiles = Advance {
                    rects: &rects,
                    pixels: 8,
                    active: 3,
                };
                p.draw_live(ctx, &snap, 8, 4, Some(&tiles)).unwrap();
                let after = SavedState::save(gl);
                assert_eq!(after.framebuffer, before.framebuffer);
                assert_eq!(after.viewport, [0, 0, 5, 3]);
                assert_eq!(after.program, before.program);
                assert_eq!(after.active_unit, glow::TEXTURE0 + 5);
                assert_eq!(after.units, before.units);
                assert!(after.depth_test && !after.stencil_test);
            }
            state::clear_errors(gl);
        });
    }
}
