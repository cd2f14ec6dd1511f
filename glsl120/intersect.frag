// intersect.frag: one ray-triangle test (pass 4 of the thesis) for rays in state TESTING.
// Reads: s0..s3, grid uniforms, the triangle list (fetch_list) and triangles (fetch_tri).
// Writes: s2.w = next list index; s3 = (t_best, tri_best, list end, steps + 1) with the
//         cell's closest hit so far; when the cell's list is exhausted, s0 state ->
//         SHADING (that hit lies inside the cell) or TRAVERSING (hit forgotten).
//         With ANY_HIT (shadow rays) the first hit in (0, t_max) ends the ray as SHADING,
//         meaning "occluded". Other rays are copied through.
#include "intersect.glsl"
#include "traverse.glsl"

void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s2 = texture2D(u_s2, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    if (in_state(s0.w, ST_TESTING)) {
        float k = s2.w;
        float texel = floor(k * (1.0 / LIST_PER_TEXEL));
        float comp = k - texel * LIST_PER_TEXEL;
        float tri = dot(fetch_list(texel), vec4(equal(vec4(comp), vec4(0.0, 1.0, 2.0, 3.0))));
        vec3 p0 = fetch_tri(tri * TRI_TEXELS).xyz;
        vec3 p1 = fetch_tri(tri * TRI_TEXELS + 1.0).xyz;
        vec3 p2 = fetch_tri(tri * TRI_TEXELS + 2.0).xyz;
        mat3 P;
        vec3 S;
        shear_setup(s1.xyz, P, S);
#ifdef ANY_HIT
        float t_hi = s3.x;
#else
        // Ties: once a hit is held, a later (higher-index) triangle must be closer by more
        // than TIE_EPS relative, as in the CPU twin (cpu/traverse.rs, tie_limit).
        float t_hi = s3.y >= 0.0 ? s3.x - abs(s3.x) * TIE_EPS : s3.x;
#endif
        vec4 h = intersect_tri(s0.xyz, P, S, p0, p1, p2, 0.0, t_hi);
        s2.w = k + 1.0;
        s3.w += 1.0;
#ifdef ANY_HIT
        if (h.x > 0.0) {
            s3.xy = vec2(h.x, tri);
            s0.w = ST_SHADING;
        } else if (s2.w >= s3.z) {
            s0.w = ST_TRAVERSING;
        }
#else
        if (h.x > 0.0) {
            s3.xy = vec2(h.x, tri);
        }
        if (s2.w >= s3.z) {
            // The cell's closest hit counts only inside the cell: a closer hit may lie in
            // the next one, where this triangle is binned too (CPU twin: closest_hit).
            vec3 tn = boundaries(s0.xyz, s1.xyz, s2.xyz);
            if (s3.y >= 0.0 && s3.x <= exit_limit(min(min(tn.x, tn.y), tn.z))) {
                s0.w = ST_SHADING;
            } else {
                s3.xy = vec2(s1.w, -1.0);
                s0.w = ST_TRAVERSING;
            }
        }
#endif
    }
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
