// traverse_init.frag: traversal set-up (pass 2 of the thesis) for rays in state INITIAL.
// Reads: s0..s3, grid uniforms, the cell table (fetch_cell) and, with ACCEL_IRREGULAR, the
//        voxel map (irr_lookup).
// Writes: s0 state -> INVALID (misses the grid), TESTING (start cell has triangles) or
//         TRAVERSING; s2 = (start cell, or (cell id, t_enter, t_leave) with ACCEL_IRREGULAR, first
//         list index); s3 = (t_max, TRI_NONE, list end, steps + 1). Rays in other states are
//         copied through unchanged. The set-up itself is step.glsl's traverse_setup.
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
    // The own grid's set-up, in the two-level walk's packed state.
    lv_pass_step(s0, s1, s2, s3);
#else
    traverse_setup(s0, s1, s2, s3);
#endif
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
