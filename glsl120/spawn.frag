// spawn.frag: generates the rays of one child node of the Whitted ray tree.
// Reads: u_p0, u_p1 (parent level's records), u_c2 (this node's weight record),
//        u_branch (0 = reflect, 1 = refract), triangle and material textures.
// Writes: s0..s3 = a new ray in state INITIAL from the offset hit point, or state DONE
//         with tri_best = TRI_NO_RAY where the node does not exist.
#include "intersect.glsl"
#include "shade.glsl"
#include "instance.glsl"


void main() {
#ifdef INSTANCED
    // The instance of this level's (the parent's) hit, which surface() places.
    g_shade_inst = texture2D(u_ri, v_uv).x;
#endif
    vec4 c2 = texture2D(u_c2, v_uv);
    if (c2.R2_EXISTS > 0.5) {
        vec4 p0 = texture2D(u_p0, v_uv);
        vec4 p1 = texture2D(u_p1, v_uv);
        Surface s = surface(p0.R0_ORIGIN, p1.R1_DIR, p0.R0_TRI);
        vec3 kr;
        vec3 kt;
        vec3 refl;
        vec3 refr;
        secondary(s.mat, s, p1.R1_DIR, kr, kt, refl, refr);
        vec3 dir = u_branch < 0.5 ? refl : refr;
        gl_FragData[0] = S0_TEXEL(offset_origin(s, dir), ST_INITIAL);
        gl_FragData[1] = S1_TEXEL(dir, BIG);
    } else {
        gl_FragData[0] = S0_TEXEL(vec3(0.0), ST_DONE);
        gl_FragData[1] = S1_TEXEL(vec3(0.0, 0.0, 1.0), BIG);
    }
    gl_FragData[2] = S2_TEXEL(vec3(0.0), 0.0);
    gl_FragData[3] = S3_TEXEL(BIG, c2.R2_EXISTS > 0.5 ? TRI_NONE : TRI_NO_RAY, 0.0, 0.0);
}
