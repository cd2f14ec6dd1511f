// raygen.frag: primary ray generation (pass 1 of the thesis).
// Reads: uniforms u_eye, u_bl, u_br, u_tl, u_tr (window corners on the projection plane,
//        relative to the eye: computed in f64 on the host, so that a far eye does not round
//        the directions to the f32 spacing at its coordinates),
//        u_size (W, H), u_offset (sub-pixel sample position), grid uniforms.
// Writes: s0 = (eye, INITIAL or INVALID when the ray misses the grid box),
//         s1 = (direction, BIG), s2 = 0, s3 = (BIG, TRI_NONE, 0, 0).
#include "traverse.glsl"

uniform vec3 u_eye;
uniform vec3 u_bl;
uniform vec3 u_br;
uniform vec3 u_tl;
uniform vec3 u_tr;
uniform vec2 u_size;
uniform vec2 u_offset;

void main() {
    // gl_FragCoord is the pixel centre (i + 0.5, row + 0.5) with row 0 at the bottom;
    // image row j = H - 1 - row, and the sample sits at (i + ox, j + oy).
    float x = (gl_FragCoord.x - 0.5 + u_offset.x) / u_size.x;
    float y = (gl_FragCoord.y + 0.5 - u_offset.y) / u_size.y;
    vec3 p = mix(mix(u_bl, u_br, x), mix(u_tl, u_tr, x), y);
    vec3 d = normalize(p);
    vec2 span = clip_grid(u_eye, d, 0.0, BIG);
    float state = span.x > span.y ? ST_INVALID : ST_INITIAL;
    gl_FragData[0] = S0_TEXEL(u_eye, state);
    gl_FragData[1] = S1_TEXEL(d, BIG);
    gl_FragData[2] = S2_TEXEL(vec3(0.0), 0.0);
    gl_FragData[3] = S3_TEXEL(BIG, TRI_NONE, 0.0, 0.0);
}
