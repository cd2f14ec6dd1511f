// shade.glsl: the Whitted shading model. CPU twin: src/cpu/shade.rs (conventions there).
// Needs intersect.glsl (tri_bary) and the generated fetch_tri / fetch_mat / fetch_nrm.

// A hit re-derived from the recorded ray (o, d) and triangle index.
struct Surface {
    vec3 p;      // barycentric hit point
    vec3 p_err;  // its absolute error bound
    vec3 ng;     // unit geometric normal from the winding
    vec3 nf;     // ng facing the incoming ray
    vec3 ns;     // shading normal facing the incoming ray
    bool entering;
    float mat;   // material index
    float gap;   // with TERMINATOR_SMOOTH: how far p lies from the smooth surface along
    float reach; // nf, and the most a shadow ray skips (cpu/shade.rs: gap, reach)
#ifdef HAS_TEXTURES
    vec3 b;        // barycentrics of p (texture coordinates, vertex colours)
    float tri;     // the triangle hit
    bool flipped;  // the vertex normals face away from the ray (cpu/shade.rs: flipped)
#endif
};

#ifdef TERMINATOR_SMOOTH
// Vertex v's share of the terminator gap of p (CPU twin terminator_gap): b times p's
// distance from v's tangent plane, along n.
vec3 terminator_gap(vec3 p, vec3 v, vec3 n, float b) {
    return n * (b * abs(dot(p - v, n)));
}
#endif

#ifdef INSTANCED
// The instance being shaded places its triangle and normals (instance.glsl, included later).
void place_triangle(inout vec4 t0, inout vec4 t1, inout vec4 t2);
void place_normals(inout vec3 n0, inout vec3 n1, inout vec3 n2);
#ifdef HAS_TEXTURES
// And its texture record, corner colours and curvature.
void place_tex(float tri, inout vec4 r0, inout vec4 r1);
void place_colors(inout vec3 c1, inout vec3 c2);
float placed_curvature(float tri, float k);
#endif
#endif

Surface surface(vec3 o, vec3 d, float tri) {
    Surface s;
    vec4 t0 = fetch_tri_at(tri, TRI_TEXELS, 0.0);
    vec4 t1 = fetch_tri_at(tri, TRI_TEXELS, 1.0);
    vec4 t2 = fetch_tri_at(tri, TRI_TEXELS, 2.0);
#ifdef INSTANCED
    // An instance's hit shades on its placed (world) triangle (instance.glsl).
    place_triangle(t0, t1, t2);
#endif
    vec3 b = tri_bary(o, d, t0.xyz, t1.xyz, t2.xyz);
    s.p = t0.xyz * b.x + t1.xyz * b.y + t2.xyz * b.z;
    s.p_err = (abs(t0.xyz * b.x) + abs(t1.xyz * b.y) + abs(t2.xyz * b.z)) * gamma_n(7.0);
    vec3 n_raw = cross(t1.xyz - t0.xyz, t2.xyz - t0.xyz);
    float len = length(n_raw);
    s.ng = len > 0.0 ? n_raw * (1.0 / len) : vec3(0.0, 1.0, 0.0);
    s.entering = dot(d, s.ng) < 0.0;
    s.nf = s.entering ? s.ng : -s.ng;
    s.ns = s.nf;
    s.gap = 0.0;
    s.reach = 0.0;
#ifdef HAS_TEXTURES
    s.b = b;
    s.tri = tri;
    s.flipped = false;
#endif
#ifdef HAS_SMOOTH_NORMALS
    if (t1.w > 0.5) {
        vec3 n0 = fetch_nrm_at(tri, TRI_TEXELS, 0.0).xyz;
        vec3 n1 = fetch_nrm_at(tri, TRI_TEXELS, 1.0).xyz;
        vec3 n2 = fetch_nrm_at(tri, TRI_TEXELS, 2.0).xyz;
#ifdef INSTANCED
        place_normals(n0, n1, n2);
#endif
        vec3 sn = n0 * b.x + n1 * b.y + n2 * b.z;
        float l = length(sn);
        if (l > 0.0) {
            sn = sn * (1.0 / l);
            bool flip = dot(sn, s.nf) < 0.0;
            s.ns = flip ? -sn : sn;
#ifdef HAS_TEXTURES
            s.flipped = flip;
#endif
#ifdef TERMINATOR_SMOOTH
            // Vertex normals on the side ns faces (CPU twin: surface's gap).
            if (flip) {
                n0 = -n0;
                n1 = -n1;
                n2 = -n2;
            }
            vec3 away = terminator_gap(s.p, t0.xyz, n0, b.x)
                + terminator_gap(s.p, t1.xyz, n1, b.y)
                + terminator_gap(s.p, t2.xyz, n2, b.z);
            // Only its component along nf (CPU twin: surface's gap).
            float up = dot(away, s.nf);
            if (up > 0.0) {
                s.gap = up;
                // A third of the longest edge (CPU twin: third_of_longest_edge).
                vec3 e0 = t1.xyz - t0.xyz;
                vec3 e1 = t2.xyz - t1.xyz;
                vec3 e2 = t0.xyz - t2.xyz;
                s.reach = sqrt(max(max(dot(e0, e0), dot(e1, e1)), dot(e2, e2))) * (1.0 / 3.0);
            }
#endif
        }
    }
#endif
    s.mat = t0.w;
    return s;
}

// Origin of a ray leaving point p (error bound p_err) of a surface with geometric normal
// ng in direction w (pbrt's offset, then one rounding step more); with
// OFFSET_EPSILON_FIXED, the fixed OFFSET_EPSILON along the normal instead.
vec3 offset_point(vec3 p, vec3 p_err, vec3 ng, vec3 w) {
#ifdef OFFSET_EPSILON_FIXED
    return p + ng * (dot(w, ng) < 0.0 ? -OFFSET_EPSILON : OFFSET_EPSILON);
#else
    float dist = dot(abs(ng), p_err);
    vec3 off = ng * dist;
    if (dot(w, ng) < 0.0) off = -off;
    vec3 po = p + off;
    vec3 step = abs(po) * (2.0 * UNIT_ROUNDOFF) + vec3(1.0e-30);
    return po + sign(off) * step;
#endif
}

// Origin of a reflected or refracted ray leaving s in direction w.
vec3 offset_origin(Surface s, vec3 w) {
    return offset_point(s.p, s.p_err, s.ng, w);
}

vec4 mat_texel(float mat, float k) {
    return fetch_mat(mat * MAT_TEXELS + k);
}

vec3 albedo_at(float mat, vec3 p) {
    vec3 a = mat_texel(mat, M0_SLOT).M0_ALBEDO;
#ifdef HAS_CHECKER
    vec4 ca = mat_texel(mat, M4_SLOT);
    if (ca.M4_CHECKER_SCALE > 0.0) {
        vec4 cb = mat_texel(mat, M5_SLOT);
        // axes code: 0 = xy, 1 = xz, 2 = yz
        float axes = cb.M5_CHECKER_AXES;
        vec2 uv = axes < 0.5 ? p.xy : (axes < 1.5 ? p.xz : p.yz);
        uv += mat_texel(mat, M6_SLOT).M6_CHECKER_PHASE;
        float inv = 1.0 / ca.M4_CHECKER_SCALE;
        float s = floor(uv.x * inv) + floor(uv.y * inv);
        float half_s = s * 0.5;
        a = floor(half_s) == half_s ? ca.M4_CHECKER_A : cb.M5_CHECKER_B;
    }
#endif
    return a;
}

vec3 reflect_dir(vec3 d, vec3 n) {
    return d - n * (2.0 * dot(d, n));
}

// Secondary rays: effective weights kr, kt and directions (see the CPU twin).
void secondary(float mat, Surface s, vec3 d, out vec3 kr, out vec3 kt, out vec3 refl, out vec3 refr) {
    refl = reflect_dir(d, s.ns);
    if (dot(refl, s.nf) <= 0.0) refl = reflect_dir(d, s.nf);
    float fresnel = 0.0;
#ifdef HAS_FRESNEL
    fresnel = mat_texel(mat, M6_SLOT).M6_FRESNEL;
#endif
    kr = fresnel > 0.5 ? vec3(0.0) : mat_texel(mat, M2_SLOT).M2_KR;
    vec4 kt_ior = mat_texel(mat, M3_SLOT);
    kt = fresnel > 0.5 ? vec3(0.0) : kt_ior.M3_KT;
    refr = vec3(0.0);
#ifdef HAS_REFRACTION
    vec3 kt_m = kt_ior.M3_KT;
    if (fresnel > 0.5 || max(max(kt_m.x, kt_m.y), kt_m.z) > 0.0) {
        float ior = kt_ior.M3_IOR;
        float n1 = s.entering ? 1.0 : ior;
        float n2 = s.entering ? ior : 1.0;
        float eta = n1 / n2;
        float cos_i = min(-dot(d, s.ns), 1.0);
        float k = 1.0 - eta * eta * (1.0 - cos_i * cos_i);
        if (k < 0.0) {
            kr = fresnel > 0.5 ? vec3(1.0) : kr + kt;
            kt = vec3(0.0);
        } else {
            float cos_t = sqrt(k);
            refr = normalize(d * eta + s.ns * (eta * cos_i - cos_t));
            if (dot(refr, s.nf) >= 0.0) {
                float cos_g = -dot(d, s.nf);
                float kg = 1.0 - eta * eta * (1.0 - cos_g * cos_g);
                refr = normalize(d * eta + s.nf * (eta * cos_g - sqrt(max(kg, 0.0))));
            }
            if (fresnel > 0.5) {
                float rs = (n1 * cos_i - n2 * cos_t) / (n1 * cos_i + n2 * cos_t);
                float rp = (n2 * cos_i - n1 * cos_t) / (n2 * cos_i + n1 * cos_t);
                float f = (rs * rs + rp * rp) * 0.5;
                kr = vec3(f);
                kt = vec3(1.0 - f);
            }
        }
    }
#endif
}

// Direct term of one visible light before its radiance (what `contribution` scales by
// it); l = unit direction to the light, v = to the viewer.
vec3 light_term(float mat, vec3 albedo, Surface s, vec3 l, vec3 v) {
    float ndotl = dot(s.ns, l);
    if (ndotl <= 0.0) return vec3(0.0);
    vec4 kr_kd = mat_texel(mat, M2_SLOT);
    vec3 c = albedo * (kr_kd.M2_KD * ndotl);
#ifdef HAS_SPECULAR
    vec4 ks_ns = mat_texel(mat, M1_SLOT);
    vec3 ks = ks_ns.M1_KS;
    if (max(max(ks.x, ks.y), ks.z) > 0.0) {
        vec3 r = reflect_dir(-l, s.ns);
        float rv = max(dot(r, v), 0.0);
        c += ks * (rv > 0.0 ? pow(rv, ks_ns.M1_NS) : 0.0);
    }
#endif
    return c;
}

// What a term adds to a pixel: the node's weight w times the term, then times the scene's
// factor (the ambient light, a light's radiance), in that order in every kernel. Written
// w * (term * factor), Mesa 22.3's compiler (llvmpipe) regrouped the product as
// (w * albedo) * ... in the fragment passes and kept it in the compute kernel: one f32 ulp
// apart in a few pixels of most scenes. With the factor last the two kernels render the
// same bytes on every shipped scene (tests/compute_kernel.rs; issue 52).
vec3 contribution(vec3 w, vec3 term, vec3 factor) {
    return (w * term) * factor;
}

#ifdef HAS_TEXTURES
// The cone (width, spread) at the hit at distance t of a ray whose cone at its origin is
// `cone` (cpu/render.rs: Shading::cone).
vec2 cone_at(vec2 cone, float t) {
    return vec2(cone.x + cone.y * t, cone.y);
}

// Albedo at s for a ray of direction d whose cone is `width` wide there: the material's
// colour, times its map_Kd texel, times the vertex colour (CPU twin: CpuRenderer::begin).
vec3 albedo_tex(Surface s, float width, vec3 d) {
    vec3 a = albedo_at(s.mat, s.p);
    float map = mat_texel(s.mat, M6_SLOT).M6_MAP_KD;
    if (map > 0.0) {
        vec4 r0 = fetch_tex(s.tri * TEX_REC);
        vec4 r1 = fetch_tex(s.tri * TEX_REC + 1.0);
#ifdef INSTANCED
        place_tex(s.tri, r0, r1);
#endif
        float lod = tex_lod(r1.z, width, dot(s.nf, d));
        vec2 uv = r0.xy * s.b.x + r0.zw * s.b.y + r1.xy * s.b.z;
        a = a * tex_bilinear(map - 1.0, uv, lod);
    }
#ifdef HAS_VERTEX_COLORS
    vec3 c0 = fetch_tex(TEX_COLORS + s.tri * 3.0).xyz;
    vec3 c1 = fetch_tex(TEX_COLORS + s.tri * 3.0 + 1.0).xyz;
    vec3 c2 = fetch_tex(TEX_COLORS + s.tri * 3.0 + 2.0).xyz;
#ifdef INSTANCED
    place_colors(c1, c2);
#endif
    a = a * (c0 * s.b.x + c1 * s.b.y + c2 * s.b.z);
#endif
    return a;
}

// The cone of the reflected (or refracted) child of s, whose cone there is `cone`
// (CPU twin: CpuRenderer::child_cone).
vec2 child_cone_at(Surface s, vec2 cone, bool refracted) {
    float k = fetch_tex(s.tri * TEX_REC + 1.0).w;
#ifdef INSTANCED
    k = placed_curvature(s.tri, k);
#endif
    if (s.flipped) k = -k;
    float ior = mat_texel(s.mat, M3_SLOT).M3_IOR;
    float eta = s.entering ? 1.0 / ior : ior / 1.0;
    return child_cone(cone, k, refracted, eta);
}

// Ambient term ka albedo at s with the albedo given, before the ambient light A (what
// `contribution` scales by it).
vec3 ambient_with(Surface s, vec3 albedo) {
    float ka = mat_texel(s.mat, M0_SLOT).M0_KA;
    return albedo * ka;
}
#endif

// Ambient term ka albedo at s, before the ambient light A (accum_ambient.frag; the compute
// kernel).
vec3 ambient_term(Surface s) {
    float ka = mat_texel(s.mat, M0_SLOT).M0_KA;
    return albedo_at(s.mat, s.p) * ka;
}

// The shadow ray from s towards a point light at light_pos: false where the light is below
// the geometric or shading horizon (it then contributes nothing), else the ray's origin
// (offset from p), unit direction l and length dist; with TERMINATOR_SMOOTH it starts
// further along the same line, where it has risen 2 s.gap above the triangle's plane, at
// most s.reach away (the CPU's shadow_ray and terminator_skip) (shadow_spawn.frag; the
// compute kernel).
bool shadow_ray(Surface s, vec3 light_pos, out vec3 o, out vec3 l, out float dist) {
    o = vec3(0.0);
    l = vec3(0.0, 0.0, 1.0);
    dist = 0.0;
    vec3 to_l = light_pos - s.p;
    if (!(dot(to_l, s.nf) > 0.0 && dot(s.ns, to_l) > 0.0)) return false;
    o = offset_point(s.p, s.p_err, s.ng, to_l);
    vec3 dl = light_pos - o;
    dist = length(dl);
    l = dl * (1.0 / dist);
    if (s.gap > 0.0) {
        float rise = dot(s.nf, l);
        float height = s.gap + s.gap;
        float skip = min(height < s.reach * rise ? height / rise : s.reach, dist);
        o += l * skip;
        dist -= skip;
    }
    return true;
}

// True where a child with effective weight k exists (weight.frag; the compute kernel).
bool child_exists(vec3 k) {
    return max(max(k.x, k.y), k.z) > 0.0;
}
