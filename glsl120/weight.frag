// weight.frag: weight of a child node of the Whitted ray tree, from its parent's record.
// Reads: u_p0, u_p1, u_p2 (the parent level's records), u_branch (0 = reflect,
//        1 = refract), the triangle and material textures.
// Writes: c2 = (parent weight * kr or kt, 1) when the child ray exists, else (0, 0); with
//         HAS_TEXTURES also c3 = the child's cone (width at its origin, spread), from the
//         parent's (u_root_cone at the root, else u_p3).
#include "intersect.glsl"
#include "shade.glsl"
#include "instance.glsl"


#ifdef HAS_TEXTURES
// The cone record of the level shaded: with INSTANCED beside the instance in ri (record.frag;
// both on s2's unit, the one unit a textured scene leaves them), else u_p3.
vec2 level_cone() {
#ifdef INSTANCED
    return texture2D(u_ri, v_uv).yz;
#else
    return texture2D(u_p3, v_uv).xy;
#endif
}
#endif

void main() {
#ifdef INSTANCED
    // The instance of this level's (the parent's) hit, which surface() places.
    g_shade_inst = texture2D(u_ri, v_uv).x;
#endif
    vec4 p0 = texture2D(u_p0, v_uv);
    vec4 p2 = texture2D(u_p2, v_uv);
    vec4 outw = R2_TEXEL(vec3(0.0), 0.0);
#ifdef HAS_TEXTURES
    vec4 outc = vec4(0.0);
#endif
    if (p2.R2_EXISTS > 0.5 && p0.R0_TRI >= 0.0) {
        vec4 p1 = texture2D(u_p1, v_uv);
        Surface s = surface(p0.R0_ORIGIN, p1.R1_DIR, p0.R0_TRI);
        vec3 kr;
        vec3 kt;
        vec3 refl;
        vec3 refr;
        secondary(s.mat, s, p1.R1_DIR, kr, kt, refl, refr);
        vec3 k = u_branch < 0.5 ? kr : kt;
        if (child_exists(k)) {
            outw = R2_TEXEL(p2.R2_WEIGHT * k, 1.0);
#ifdef HAS_TEXTURES
            vec2 pc = u_root_cone.x > 0.5 ? vec2(0.0, u_root_cone.y) : level_cone();
            outc = vec4(child_cone_at(s, cone_at(pc, p1.R1_T), u_branch > 0.5), 0.0, 0.0);
#endif
        }
    }
    gl_FragData[0] = outw;
#ifdef HAS_TEXTURES
    gl_FragData[1] = outc;
#endif
}
