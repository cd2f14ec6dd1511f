// accum_light.frag: adds one light's direct term at this level's hits whose shadow ray
// reached the light.
// Reads: u_r0, u_r1, u_r2 (this level's records), s0 (shadow ray state: SHADING means
//        occluded), s1 (unit direction to the light), s3 (tri_best = TRI_NO_RAY: no shadow ray),
//        u_acc (colour so far), u_light_rad (I_l), triangle/normal/material textures.
// Writes: colour = u_acc + weight * I_l * (kd albedo n.l + ks (r.v)^ns) where visible.
#include "intersect.glsl"
#include "shade.glsl"
#include "instance.glsl"


#ifdef HAS_TEXTURES
// The cone record of the level shaded: with INSTANCED beside the instance in ri (record.frag;
// both on s2's unit, the one unit a textured scene leaves them), else u_r3.
vec2 level_cone() {
#ifdef INSTANCED
    return texture2D(u_ri, v_uv).yz;
#else
    return texture2D(u_r3, v_uv).xy;
#endif
}
#endif

void main() {
#ifdef INSTANCED
    // The instance of this level's (the parent's) hit, which surface() places.
    g_shade_inst = texture2D(u_ri, v_uv).x;
#endif
    vec4 acc = texture2D(u_acc, v_uv);
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    if (s3.S3_TRI_BEST > -1.5 && !in_state(s0.S0_STATE, ST_SHADING)) {
        vec4 r0 = texture2D(u_r0, v_uv);
        vec4 r1 = texture2D(u_r1, v_uv);
        vec4 r2 = texture2D(u_r2, v_uv);
        Surface s = surface(r0.R0_ORIGIN, r1.R1_DIR, r0.R0_TRI);
        vec3 l = texture2D(u_s1, v_uv).S1_DIR;
#ifdef HAS_TEXTURES
        vec2 cone = u_root_cone.x > 0.5 ? vec2(0.0, u_root_cone.y) : level_cone();
        vec3 alb = albedo_tex(s, cone_at(cone, r1.R1_T).x, r1.R1_DIR);
#else
        vec3 alb = albedo_at(s.mat, s.p);
#endif
        vec3 c = light_term(s.mat, alb, s, l, -r1.R1_DIR);
        acc.xyz += contribution(r2.R2_WEIGHT, c, u_light_rad);
    }
    gl_FragData[0] = acc;
}
