// unrolled.frag: UNROLL traversal iterations (a step then a test, the same chunk the
// faithful passes run one at a time) as straight-line code, for `--kernel unrolled:K`
// (no loops: still period hardware) and, with LOOPED, a bounded loop for
// `--kernel looped` (Shader Model 3 era).
// Reads: s0..s3, grid uniforms, cell table (and voxel map), triangle list, triangles.
// Writes: s0..s3 advanced by up to UNROLL (or LOOP_MAX) iterations.
#include "intersect.glsl"
#include "traverse.glsl"
#include "step.glsl"

void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s2 = texture2D(u_s2, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
#ifdef LOOPED
    for (int i = 0; i < LOOP_MAX; i++) {
        if (!ray_active(s0)) break;
        traverse_step(s0, s1, s2, s3);
        intersect_step(s0, s1, s2, s3);
    }
#else
    UNROLLED_STEPS
#endif
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
