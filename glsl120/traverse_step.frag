// traverse_step.frag: one 3D-DDA step (pass 3 of the thesis) for rays in state TRAVERSING.
// Reads: s0..s3, grid uniforms, the cell table.
// Writes: s0 state -> DONE (left the grid or its interval: a miss), TESTING (the new cell
//         has triangles) or TRAVERSING; s2 = (new cell, first list index);
//         s3 = (t_best, tri_best, list end, steps + 1). Other rays are copied through.
#include "traverse.glsl"

void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s2 = texture2D(u_s2, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    if (in_state(s0.w, ST_TRAVERSING)) {
        vec3 o = s0.xyz;
        vec3 d = s1.xyz;
        vec3 c = s2.xyz;
        vec3 tn = boundaries(o, d, c);
        float t_exit = min(min(tn.x, tn.y), tn.z);
        float t_leave = clip_grid(o, d, 0.0, s1.w).y;
        if (t_exit >= t_leave) {
            s0.w = ST_DONE;
        } else {
            // Smallest boundary; ties go to the lower axis, as in the CPU twin.
            vec3 axis = (tn.x <= tn.y && tn.x <= tn.z) ? vec3(1.0, 0.0, 0.0)
                      : (tn.y <= tn.z ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
            c += axis * sign(d);
            if (any(lessThan(c, vec3(0.0))) || any(greaterThanEqual(c, u_grid_res))) {
                s0.w = ST_DONE;
            } else {
                vec4 cell = fetch_cell(cell_linear(c));
                s2 = vec4(c, cell.x);
                s3.z = cell.x + cell.y;
                s3.w += 1.0;
                s0.w = cell.y > 0.0 ? ST_TESTING : ST_TRAVERSING;
            }
        }
    }
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
