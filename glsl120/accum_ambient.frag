// accum_ambient.frag: adds the ambient term at this level's hits and the background for
// this level's rays that left the scene.
// Reads: u_r0, u_r1, u_r2 (this level's records), u_acc, u_ambient, u_background,
//        triangle and material textures.
// Writes: colour = u_acc + weight * (ka A albedo) on hits, + weight * background on misses.
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
    vec4 r2 = texture2D(u_r2, v_uv);
    if (r2.R2_EXISTS > 0.5) {
        vec4 r0 = texture2D(u_r0, v_uv);
        if (r0.R0_TRI >= 0.0) {
            vec4 r1 = texture2D(u_r1, v_uv);
            Surface s = surface(r0.R0_ORIGIN, r1.R1_DIR, r0.R0_TRI);
#ifdef HAS_TEXTURES
            // This level's cone: the root's from u_root_cone, else its record r3.
            vec2 cone = u_root_cone.x > 0.5 ? vec2(0.0, u_root_cone.y) : level_cone();
            vec3 alb = albedo_tex(s, cone_at(cone, r1.R1_T).x, r1.R1_DIR);
            acc.xyz += contribution(r2.R2_WEIGHT, ambient_with(s, alb), u_ambient);
#else
            acc.xyz += contribution(r2.R2_WEIGHT, ambient_term(s), u_ambient);
#endif
        } else if (r0.R0_TRI > -1.5) {
            acc.xyz += r2.R2_WEIGHT * u_background;
        }
    }
    gl_FragData[0] = acc;
}
