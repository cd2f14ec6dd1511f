// unrolled.frag: UNROLL traversal iterations (a step then a test, the same chunk the
// faithful passes run one at a time) as straight-line code, for `--kernel unrolled:K`
// (no loops: still period hardware) and, with LOOPED, a bounded loop for
// `--kernel looped` (Shader Model 3 era).
// Reads: s0..s3, grid uniforms, cell table (and voxel map), triangle list, triangles.
// Writes: s0..s3 advanced by up to UNROLL (or LOOP_MAX) iterations; with INSTANCED, of the
//         two-level walk (instance_walk.glsl) in its packed state.
#include "intersect.glsl"
#include "traverse.glsl"
#include "step.glsl"
#include "instance.glsl"
#include "instance_walk.glsl"

void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s2 = texture2D(u_s2, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
#ifdef INSTANCED
    // The two-level walk (instance_walk.glsl): unpacked once, its iterations (a step half
    // then a test half), packed once.
    if (lv_packed_active(s0)) {
        Levels L;
        vec4 q0;
        vec4 q1;
        vec4 q2;
        vec4 q3;
        lv_unpack(s0, s1, s2, s3, L, q0, q1, q2, q3);
#ifdef LOOPED
        for (int i = 0; i < LOOP_MAX; i++) {
            if (!lv_active(L)) break;
            lv_step(L, q0, q1, q2, q3);
            lv_test(L, q0, q1, q2, q3, QUERY_ANY);
        }
#else
        UNROLLED_LEVELS
#endif
        lv_pack(L, q0, q2, q3, s0, s1, s2, s3);
    }
#elif defined(LOOPED)
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
