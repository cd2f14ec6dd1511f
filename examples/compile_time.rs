//! How long the driver takes to compile and link GLSL sources, one at a time: the tool
//! behind issue 52's cold-start figures, for trying a change to a shader (a pragma, a
//! smaller source) on a GPU without rebuilding fragtrace.
//!
//! ```sh
//! fragtrace dump-shaders ci/peers/equal-work.toml /tmp/d --backend gl
//! cargo run --release --example compile_time -- /tmp/d/compute.comp /tmp/d/looped.frag
//! ```
//!
//! A `.comp` file is compiled as a compute shader; any other as a fragment shader linked
//! with the full-screen quad's vertex shader. Each file is compiled `RUNS` times (default 3)
//! with a distinct trailing comment so that no in-process cache answers; turn the driver's
//! disk cache off for cold figures (`__GL_SHADER_DISK_CACHE=0` on NVIDIA,
//! `MESA_SHADER_CACHE_DISABLE=true` on Mesa).
use std::time::Instant;

use fragtrace::gpu::gl::compile_compute;
use fragtrace::gpu::gl::program::{compile_program, single_file_line_map, QUAD_VERTEX_SHADER};
use fragtrace::gpu::GlContext;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let runs: usize = std::env::var("RUNS")
        .ok()
        .and_then(|r| r.parse().ok())
        .unwrap_or(3);
    let ctx = GlContext::new_unchecked()?;
    for (n, path) in std::env::args().skip(1).enumerate() {
        let src = std::fs::read_to_string(&path)?;
        let map = single_file_line_map(&path);
        let mut ms = Vec::new();
        for run in 0..runs {
            let src = format!("{src}\n// compile_time {n} {run}\n");
            let t = Instant::now();
            if path.ends_with(".comp") {
                compile_compute(&ctx, "compile_time", &src, &map)?;
            } else {
                compile_program(&ctx, "compile_time", QUAD_VERTEX_SHADER, &src, &map)?;
            }
            ms.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let shown: Vec<String> = ms.iter().map(|m| format!("{m:.1}")).collect();
        println!(
            "{path}: {} bytes, compile+link ms {}",
            src.len(),
            shown.join(" ")
        );
    }
    Ok(())
}
