// intersect.glsl: watertight ray-triangle intersection (Woop, Benthin, Wald 2013) with
// pbrt-v3's conservative bound on the error of t.
// CPU twin: src/cpu/intersect.rs (same operations in the same order).
//
// Technique switches (generated from src/technique.rs, exactly one of each pair defined):
// INTERSECT_WATERTIGHT / INTERSECT_MOLLER_TRUMBORE (Moller-Trumbore 1997 instead, CPU twin
// intersect_moller_trumbore), T_BOUND_ON / T_BOUND_OFF (the t error bound).
//
// GLSL 1.20 has no dynamic vector indexing on period hardware, so the axis permutation
// (kx, ky, kz) is a 0/1 matrix: v * P picks components exactly (products with 0 and 1 and
// sums with 0 are exact).

// Shear of direction d: P permutes a vector to (v[kx], v[ky], v[kz]); S = (Sx, Sy, Sz).
void shear_setup(vec3 d, out mat3 P, out vec3 S) {
    vec3 a = abs(d);
    vec3 kx;
    vec3 ky;
    vec3 kz;
    // Ties resolve to the lower axis, as in the CPU twin.
    if (a.x >= a.y && a.x >= a.z) {
        kz = vec3(1.0, 0.0, 0.0); kx = vec3(0.0, 1.0, 0.0); ky = vec3(0.0, 0.0, 1.0);
    } else if (a.y >= a.z) {
        kz = vec3(0.0, 1.0, 0.0); kx = vec3(0.0, 0.0, 1.0); ky = vec3(1.0, 0.0, 0.0);
    } else {
        kz = vec3(0.0, 0.0, 1.0); kx = vec3(1.0, 0.0, 0.0); ky = vec3(0.0, 1.0, 0.0);
    }
    float dz = dot(d, kz);
    if (dz < 0.0) {
        vec3 t = kx; kx = ky; ky = t;
    }
    P = mat3(kx, ky, kz);
    S = vec3(dot(d, kx) / dz, dot(d, ky) / dz, 1.0 / dz);
}

// Vertices relative to o in the shear frame: A, B, C (z not yet scaled by Sz), and the
// edge functions (u, v, w) = (weight of p0, p1, p2) * det.
void shear_edges(vec3 o, mat3 P, vec3 S, vec3 p0, vec3 p1, vec3 p2,
                 out vec3 A, out vec3 B, out vec3 C, out vec3 uvw, out vec2 a, out vec2 b, out vec2 c) {
    A = (p0 - o) * P;
    B = (p1 - o) * P;
    C = (p2 - o) * P;
    a = vec2(A.x - S.x * A.z, A.y - S.y * A.z);
    b = vec2(B.x - S.x * B.z, B.y - S.y * B.z);
    c = vec2(C.x - S.x * C.z, C.y - S.y * C.z);
    uvw = vec3(c.x * b.y - c.y * b.x, a.x * c.y - a.y * c.x, b.x * a.y - b.y * a.x);
}

#ifdef INTERSECT_MOLLER_TRUMBORE
// |a| x |b| with a plus per component: magnitudes summed in a cross product.
vec3 abs_cross(vec3 a, vec3 b) {
    vec3 x = abs(a);
    vec3 y = abs(b);
    return vec3(x.y * y.z + x.z * y.y, x.z * y.x + x.x * y.z, x.x * y.y + x.y * y.x);
}

// Moller-Trumbore: (t, b0, b1, b2) for t in (t_min, t_max), or t = -1.0 on a miss. Same
// rules as the CPU twin: zero counts as inside, det == 0 and zero-area triangles miss.
vec4 intersect_mt(vec3 o, vec3 d, vec3 p0, vec3 p1, vec3 p2, float t_min, float t_max) {
    vec3 e1 = p1 - p0;
    vec3 e2 = p2 - p0;
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (det == 0.0) {
        return vec4(-1.0);
    }
    vec3 n_raw = cross(e1, e2);
    if (dot(n_raw, n_raw) == 0.0) {
        return vec4(-1.0);
    }
    float inv = 1.0 / det;
    vec3 sv = o - p0;
    float u = dot(sv, pv) * inv;
    if (u < 0.0 || u > 1.0) {
        return vec4(-1.0);
    }
    vec3 qv = cross(sv, e1);
    float v = dot(d, qv) * inv;
    if (v < 0.0 || u + v > 1.0) {
        return vec4(-1.0);
    }
    float t = dot(e2, qv) * inv;
    if (!(t > t_min && t < t_max)) {
        return vec4(-1.0);
    }
#ifdef T_BOUND_ON
    float num_err = gamma_n(7.0) * dot(abs(e2), abs_cross(sv, e1));
    float det_err = gamma_n(5.0) * dot(abs(e1), abs_cross(d, e2));
    if (t <= (num_err + abs(t) * det_err) / abs(det)) {
        return vec4(-1.0);
    }
#endif
    return vec4(t, 1.0 - u - v, u, v);
}
#endif

// Hit of ray (o, d; shear P S of d) with triangle (p0, p1, p2) for t in (t_min, t_max):
// returns (t, b0, b1, b2), or t = -1.0 on a miss. Under INTERSECT_MOLLER_TRUMBORE, P and S
// are not used.
vec4 intersect_tri(vec3 o, vec3 d, mat3 P, vec3 S, vec3 p0, vec3 p1, vec3 p2, float t_min, float t_max) {
#ifdef INTERSECT_MOLLER_TRUMBORE
    return intersect_mt(o, d, p0, p1, p2, t_min, t_max);
#else
    vec3 A;
    vec3 B;
    vec3 C;
    vec3 uvw;
    vec2 a2;
    vec2 b2;
    vec2 c2;
    shear_edges(o, P, S, p0, p1, p2, A, B, C, uvw, a2, b2, c2);
    float ax = a2.x;
    float ay = a2.y;
    float bx = b2.x;
    float by = b2.y;
    float cx = c2.x;
    float cy = c2.y;
    float u = uvw.x;
    float v = uvw.y;
    float w = uvw.z;
    if ((u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0)) {
        return vec4(-1.0);
    }
    float det = u + v + w;
    if (det == 0.0) {
        return vec4(-1.0);
    }
    // Zero area in f32 (collinear or repeated vertices): never hit, as in the CPU twin.
    vec3 n_raw = cross(p1 - p0, p2 - p0);
    if (dot(n_raw, n_raw) == 0.0) {
        return vec4(-1.0);
    }
    float az = S.z * A.z;
    float bz = S.z * B.z;
    float cz = S.z * C.z;
    float tt = u * az + v * bz + w * cz;
    float det_abs = abs(det);
    if (det < 0.0) {
        tt = -tt;
    }
    if (!(tt > t_min * det_abs && tt < t_max * det_abs)) {
        return vec4(-1.0);
    }
    float t = tt / det_abs;
#ifdef T_BOUND_ON
    float max_zt = max(max(abs(az), abs(bz)), abs(cz));
    float max_xt = max(max(abs(ax), abs(bx)), abs(cx));
    float max_yt = max(max(abs(ay), abs(by)), abs(cy));
    float delta_z = gamma_n(3.0) * max_zt;
    float delta_x = gamma_n(5.0) * (max_xt + max_zt);
    float delta_y = gamma_n(5.0) * (max_yt + max_zt);
    float delta_e = 2.0 * (gamma_n(2.0) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
    float max_e = max(max(abs(u), abs(v)), abs(w));
    float delta_t = 3.0 * (gamma_n(3.0) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) / det_abs;
    if (t <= delta_t) {
        return vec4(-1.0);
    }
#endif
    float inv = 1.0 / det;
    return vec4(t, u * inv, v * inv, w * inv);
#endif
}

// Barycentric weights of a hit already found (no rejection): the shading passes
// re-derive them from the recorded ray and triangle instead of storing them.
vec3 tri_bary(vec3 o, vec3 d, vec3 p0, vec3 p1, vec3 p2) {
#ifdef INTERSECT_MOLLER_TRUMBORE
    // The same operations as intersect_mt, without its rejections.
    vec3 e1 = p1 - p0;
    vec3 e2 = p2 - p0;
    vec3 pv = cross(d, e2);
    float det = dot(e1, pv);
    if (det == 0.0) {
        return vec3(1.0 / 3.0);
    }
    float inv = 1.0 / det;
    vec3 sv = o - p0;
    float u = dot(sv, pv) * inv;
    vec3 qv = cross(sv, e1);
    float v = dot(d, qv) * inv;
    return vec3(1.0 - u - v, u, v);
#else
    mat3 P;
    vec3 S;
    shear_setup(d, P, S);
    vec3 A;
    vec3 B;
    vec3 C;
    vec3 uvw;
    vec2 a2;
    vec2 b2;
    vec2 c2;
    shear_edges(o, P, S, p0, p1, p2, A, B, C, uvw, a2, b2, c2);
    float det = uvw.x + uvw.y + uvw.z;
    if (det == 0.0) {
        return vec3(1.0 / 3.0);
    }
    return uvw * (1.0 / det);
#endif
}
