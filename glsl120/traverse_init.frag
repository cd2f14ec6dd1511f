// traverse_init.frag: traversal set-up (pass 2 of the thesis) for rays in state INITIAL.
// Reads: s0..s3, grid uniforms, the cell table (fetch_cell) and, with ACCEL_IRREGULAR, the
//        voxel map (irr_lookup).
// Writes: s0 state -> INVALID (misses the grid), TESTING (start cell has triangles) or
//         TRAVERSING; s2 = (start cell, or (cell id, t_enter, 0) with ACCEL_IRREGULAR, first
//         list index); s3 = (t_max, TRI_NONE, list end, steps + 1). Rays in other states are copied through unchanged.
#include "traverse.glsl"

void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s2 = texture2D(u_s2, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    if (in_state(s0.S0_STATE, ST_INITIAL)) {
        vec2 span = clip_grid(s0.S0_ORIGIN, s1.S1_DIR, 0.0, s1.S1_T_MAX);
        if (span.x > span.y) {
            s0.S0_STATE = ST_INVALID;
        } else {
            vec3 c = start_cell(s0.S0_ORIGIN, s1.S1_DIR, span.x);
#ifdef ACCEL_IRREGULAR
            // The cell holding the virtual cell of the entry point.
            float id = irr_lookup(c);
            vec4 cell = vec4(irr_lo(id).w, irr_hi(id).w, 0.0, 0.0);
            c = vec3(id, span.x, 0.0);
#else
            vec4 cell = fetch_cell(cell_linear(c));
#endif
            s2 = S2_TEXEL(c, cell.x);
            s3 = S3_TEXEL(s1.S1_T_MAX, TRI_NONE, cell.x + cell.y, s3.S3_STEPS + 1.0);
            s0.S0_STATE = cell.y > 0.0 ? ST_TESTING : ST_TRAVERSING;
        }
    }
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
