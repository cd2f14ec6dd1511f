// intersect.frag: one ray-triangle test (pass 4 of the thesis) for rays in state TESTING.
// Reads: s0..s3, grid uniforms, the triangle list (fetch_list) and triangles (fetch_tri).
// Writes: s2 cursor = next list index; s3 = (t_best, tri_best, list end, steps + 1) with the
//         cell's closest hit so far; when the cell's list is exhausted, s0 state ->
//         SHADING (that hit lies inside the cell) or TRAVERSING (hit forgotten).
//         With ANY_HIT (shadow rays) the first hit in (0, t_max) ends the ray as SHADING,
//         meaning "occluded". Other rays are copied through.
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
    lv_pass_test(s0, s1, s2, s3, QUERY_ANY);
#else
    intersect_step(s0, s1, s2, s3);
#endif
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
