// raygen.frag: primary ray generation (pass 1 of the thesis).
// Reads: u_dir (the unit primary direction of each pixel for this sample, computed by the
//        host in f64 with the camera's formula and rounded to f32: the same direction the
//        f32 CPU traces, relative to the eye, so a far eye rounds nothing), u_eye, u_size,
//        grid uniforms.
// Writes: s0 = (eye, INITIAL or INVALID when the ray misses the grid box),
//         s1 = (direction, BIG), s2 = 0, s3 = (BIG, TRI_NONE, 0, 0).
#include "traverse.glsl"


void main() {
    // gl_FragCoord is the pixel centre, so it samples texel (i, row) exactly.
    vec3 d = texture2D(u_dir, gl_FragCoord.xy / vec2(u_size)).xyz;
    vec2 span = clip_grid(u_eye, d, 0.0, BIG);
#ifdef INSTANCED
    // The instances lie outside the own grid's box too: every ray walks the top level.
    float state = ST_INITIAL;
#else
    float state = span.x > span.y ? ST_INVALID : ST_INITIAL;
#endif
    gl_FragData[0] = S0_TEXEL(u_eye, state);
    gl_FragData[1] = S1_TEXEL(d, BIG);
    gl_FragData[2] = S2_TEXEL(vec3(0.0), 0.0);
    gl_FragData[3] = S3_TEXEL(BIG, TRI_NONE, 0.0, 0.0);
}
