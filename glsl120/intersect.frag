// intersect.frag: one ray-triangle test (pass 4 of the thesis) for rays in state TESTING.
// Reads: s0..s3, grid uniforms, the triangle list (fetch_list) and triangles (fetch_tri).
// Writes: s2.w = next list index; s3 = (t_best, tri_best, list end, steps + 1); when the
//         cell's list is exhausted, s0 state -> SHADING (closest hit found) or TRAVERSING.
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
        vec4 h = intersect_tri(s0.xyz, P, S, p0, p1, p2, 0.0, s3.x);
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
            // Accept only inside the current cell: a closer hit may lie in the next one.
            vec3 tn = boundaries(s0.xyz, s1.xyz, s2.xyz);
            if (h.x <= exit_limit(min(min(tn.x, tn.y), tn.z))) {
                s3.xy = vec2(h.x, tri);
            }
        }
        if (s2.w >= s3.z) {
            s0.w = s3.y >= 0.0 ? ST_SHADING : ST_TRAVERSING;
        }
#endif
    }
    gl_FragData[0] = s0;
    gl_FragData[1] = s1;
    gl_FragData[2] = s2;
    gl_FragData[3] = s3;
}
