// record.frag: stores the finished trace of one ray-tree node in its level's hit record.
// Reads: s0 (origin, state), s1 (direction), s3 (t_best, tri_best).
// Writes: r0 = (origin, tri) with tri = hit triangle, -1 for a miss, -2 for no ray;
//         r1 = (direction, t).
void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    float tri = in_state(s0.w, ST_SHADING) ? s3.y : (s3.y < -1.5 ? -2.0 : -1.0);
    gl_FragData[0] = vec4(s0.xyz, tri);
    gl_FragData[1] = vec4(s1.xyz, s3.x);
}
