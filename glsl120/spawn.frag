// spawn.frag: generates the rays of one child node of the Whitted ray tree.
// Reads: u_p0, u_p1 (parent level's records), u_c2 (this node's weight record),
//        u_branch (0 = reflect, 1 = refract), triangle and material textures.
// Writes: s0..s3 = a new ray in state INITIAL from the offset hit point, or state DONE
//         with tri_best = -2 ("no ray") where the node does not exist.
#include "intersect.glsl"
#include "shade.glsl"

uniform sampler2D u_p0;
uniform sampler2D u_p1;
uniform sampler2D u_c2;
uniform float u_branch;

void main() {
    vec4 c2 = texture2D(u_c2, v_uv);
    if (c2.w > 0.5) {
        vec4 p0 = texture2D(u_p0, v_uv);
        vec4 p1 = texture2D(u_p1, v_uv);
        Surface s = surface(p0.xyz, p1.xyz, p0.w);
        vec3 kr;
        vec3 kt;
        vec3 refl;
        vec3 refr;
        secondary(s.mat, s, p1.xyz, kr, kt, refl, refr);
        vec3 dir = u_branch < 0.5 ? refl : refr;
        gl_FragData[0] = vec4(offset_origin(s, dir), ST_INITIAL);
        gl_FragData[1] = vec4(dir, BIG);
    } else {
        gl_FragData[0] = vec4(0.0, 0.0, 0.0, ST_DONE);
        gl_FragData[1] = vec4(0.0, 0.0, 1.0, BIG);
    }
    gl_FragData[2] = vec4(0.0);
    gl_FragData[3] = vec4(BIG, c2.w > 0.5 ? -1.0 : -2.0, 0.0, 0.0);
}
