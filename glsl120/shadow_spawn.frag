// shadow_spawn.frag: one shadow ray per shaded hit towards light u_light_pos, traced
// afterwards as an any-hit query limited to the light's distance.
// Reads: u_r0, u_r1 (this level's records), triangle, normal and material textures.
// Writes: s0..s3 = a ray in state INITIAL with t_max = distance to the light, or state
//         DONE with tri_best = TRI_NO_RAY when there is no hit or the light is below the geometric
//         or shading horizon (it then contributes nothing).
#include "intersect.glsl"
#include "shade.glsl"
#include "instance.glsl"


void main() {
#ifdef INSTANCED
    // The instance of this level's (the parent's) hit, which surface() places.
    g_shade_inst = texture2D(u_ri, v_uv).x;
#endif
    vec4 r0 = texture2D(u_r0, v_uv);
    bool spawned = false;
    vec3 o;
    vec3 l;
    float dist;
    if (r0.R0_TRI >= 0.0) {
        vec4 r1 = texture2D(u_r1, v_uv);
        Surface s = surface(r0.R0_ORIGIN, r1.R1_DIR, r0.R0_TRI);
        spawned = shadow_ray(s, u_light_pos, o, l, dist);
    }
    if (spawned) {
        gl_FragData[0] = S0_TEXEL(o, ST_INITIAL);
        gl_FragData[1] = S1_TEXEL(l, dist);
    } else {
        gl_FragData[0] = S0_TEXEL(vec3(0.0), ST_DONE);
        gl_FragData[1] = S1_TEXEL(vec3(0.0, 0.0, 1.0), 0.0);
    }
    gl_FragData[2] = S2_TEXEL(vec3(0.0), 0.0);
    gl_FragData[3] = S3_TEXEL(spawned ? dist : 0.0, spawned ? TRI_NONE : TRI_NO_RAY, 0.0, 0.0);
}
