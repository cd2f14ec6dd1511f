// traverse_step.frag: one 3D-DDA step (pass 3 of the thesis), or one irregular-grid step
// with ACCEL_IRREGULAR, for rays in state TRAVERSING.
// Reads: s0..s3, grid uniforms, the cell table (and the voxel map with ACCEL_IRREGULAR).
// Writes: s0 state -> DONE (left the grid or its interval: a miss), TESTING (the new cell
//         has triangles) or TRAVERSING; s2 = (new cell, first list index);
//         s3 = (t_best, tri_best, list end, steps + 1). Other rays are copied through.
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
    // A grid step, or a top-level step of the two-level walk (instance_walk.glsl).
    lv_pass_step(s0, s1, s2, s3);
#else
    traverse_step(s0, s1, s2, s3);
#endif
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
