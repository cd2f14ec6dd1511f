// count.frag: termination and pruning test, run under an occlusion query: fragments that
// are not discarded are counted by GL_SAMPLES_PASSED. Colour writes are masked off.
// Reads: COUNT_RAYS: s0 (counts rays still INITIAL, TRAVERSING or TESTING);
//        COUNT_NODES: u_c2 (counts pixels where a ray-tree node exists).
// Writes: nothing.

void main() {
#ifdef COUNT_RAYS
    float st = texture2D(u_s0, v_uv).S0_STATE;
    if (!(in_state(st, ST_INITIAL) || in_state(st, ST_TRAVERSING) || in_state(st, ST_TESTING))) {
        discard;
    }
#else
    if (texture2D(u_c2, v_uv).R2_EXISTS < 0.5) {
        discard;
    }
#endif
    gl_FragData[0] = vec4(0.0);
}
