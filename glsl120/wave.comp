// wave.comp: `--kernel compute` for a wave of given rays (gpu::render::trace_rays: how the
// tests put hand-made rays through the kernel): each invocation traces one ray to its end
// with compute.glsl's loop, the query fixed by ANY_HIT as in the fragment passes.
// Reads and writes: u_w0..u_w3, the ray state s0..s3 of every ray (state INITIAL in, final
//                   state out), grid uniforms, the scene textures; u_size.
#include "intersect.glsl"
#include "traverse.glsl"
#include "step.glsl"
#include "compute.glsl"

layout(local_size_x = LOCAL_X, local_size_y = LOCAL_Y) in;

void main() {
    ivec2 px = ivec2(gl_GlobalInvocationID.xy);
    if (!all(lessThan(px, u_size))) return;
    for (int k = 0; k < COUNTERS; k++) n_count[k] = 0u;
    vec4 s0 = imageLoad(u_w0, px);
    vec4 s1 = imageLoad(u_w1, px);
    vec4 s2 = imageLoad(u_w2, px);
    vec4 s3 = imageLoad(u_w3, px);
    trace(s0, s1, s2, s3, QUERY_ANY);
    imageStore(u_w0, px, s0);
    imageStore(u_w2, px, s2);
    imageStore(u_w3, px, s3);
}
