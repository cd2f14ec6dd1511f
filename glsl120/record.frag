// record.frag: stores the finished trace of one ray-tree node in its level's hit record.
// Reads: s0 (origin, state), s1 (direction), s3 (t_best, tri_best).
// Writes: r0 = (origin, tri) with tri = hit triangle, TRI_NONE for a miss, TRI_NO_RAY
//         for no ray; r1 = (direction, t); with INSTANCED ri = (the hit's instance, -1 for
//         the scene's own triangles), which the passes that shade read as u_ri; with
//         HAS_TEXTURES too, ri.yz = the level's cone (u_root_cone at the root, else its
//         record u_r3, bound on s2's unit, which this pass does not read): the passes that
//         shade then read the cone and the instance from the one unit they have.
void main() {
    vec4 s0 = texture2D(u_s0, v_uv);
    vec4 s1 = texture2D(u_s1, v_uv);
    vec4 s3 = texture2D(u_s3, v_uv);
    float tri = in_state(s0.S0_STATE, ST_SHADING) ? s3.S3_TRI_BEST
              : (s3.S3_TRI_BEST < -1.5 ? TRI_NO_RAY : TRI_NONE);
    gl_FragData[0] = R0_TEXEL(s0.S0_ORIGIN, tri);
    gl_FragData[1] = R1_TEXEL(s1.S1_DIR, s3.S3_T_BEST);
#ifdef INSTANCED
    // The hit's instance (instance_walk.glsl's finished state: s3's third channel).
#ifdef HAS_TEXTURES
    vec2 cone = u_root_cone.x > 0.5 ? vec2(0.0, u_root_cone.y) : texture2D(u_r3, v_uv).xy;
    gl_FragData[2] = vec4(s3.z, cone, 0.0);
#else
    gl_FragData[2] = vec4(s3.z, 0.0, 0.0, 0.0);
#endif
#endif
}
