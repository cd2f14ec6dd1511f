// instance.glsl: an instanced scene's data (GLSL 1.20, every kernel: the fragment passes
// and render.comp) and the placement of the instance being shaded; compiled in with
// INSTANCED only. The walk of the two levels is instance_walk.glsl's. CPU twin of the
// placement: Instance::point and Instance::normal (src/scene/instance.rs), as
// Scene::flattened stores a placed triangle.
// Reads: fetch_inst (the layout's texture `inst`, gpu/contract/instancing.rs: placements,
//        meshes' grids, the threaded top tree; INST_TEXELS, MESH_TEXELS, ENTRY_TEXELS and
//        ID_SPLIT generated there).
#ifdef INSTANCED

// The instance being shaded (-1: the scene's own triangles): set by the fragment passes
// that shade from the level's record u_ri (record.frag), by the walk in render.comp.
float g_shade_inst = -1.0;

// Texel k of the instancing data.
vec4 inst_texel(float k) {
    return fetch_inst(k);
}

// First texel of instance k (after the header).
float inst_at(float k) {
    return 1.0 + k * INST_TEXELS;
}

// Row-vector product of the three rows from texel `at` on with p.
vec3 rows_times(float at, vec3 p) {
    return vec3(dot(inst_texel(at).xyz, p), dot(inst_texel(at + 1.0).xyz, p),
                dot(inst_texel(at + 2.0).xyz, p));
}

// The placed (local-space) triangle of the instance being shaded, in f32 (the host places
// in f64 and rounds once: Instance::point): vertices by the linear part and translation,
// the winding reversed for a mirroring placement, as Scene::flattened stores it.
void place_triangle(inout vec4 t0, inout vec4 t1, inout vec4 t2) {
    if (g_shade_inst < 0.0) return;
    float at = inst_at(g_shade_inst);
    vec3 tr = inst_texel(at + 3.0).xyz;
    t0.xyz = rows_times(at + 4.0, t0.xyz) + tr;
    vec3 p1 = rows_times(at + 4.0, t1.xyz) + tr;
    vec3 p2 = rows_times(at + 4.0, t2.xyz) + tr;
    bool mirror = inst_texel(at + 2.0).w > 0.5;
    t1.xyz = mirror ? p2 : p1;
    t2.xyz = mirror ? p1 : p2;
}

// The placed vertex normals (the normal matrix, renormalised: Instance::normal), in the
// order place_triangle put the vertices.
void place_normals(inout vec3 n0, inout vec3 n1, inout vec3 n2) {
    if (g_shade_inst < 0.0) return;
    float at = inst_at(g_shade_inst);
    n0 = normalize(rows_times(at + 7.0, n0));
    vec3 m1 = normalize(rows_times(at + 7.0, n1));
    vec3 m2 = normalize(rows_times(at + 7.0, n2));
    bool mirror = inst_texel(at + 2.0).w > 0.5;
    n1 = mirror ? m2 : m1;
    n2 = mirror ? m1 : m2;
}
#ifdef HAS_TEXTURES
// True when the instance being shaded mirrors (its winding reversed when placed).
bool shade_mirrors() {
    return g_shade_inst >= 0.0 && inst_texel(inst_at(g_shade_inst) + 2.0).w > 0.5;
}

// The packed (object-space) record r0, r1 of triangle tri made the placed triangle's: the
// corners' uvs in the placed winding, the level-of-detail bias moved by half the log2 of
// the object-space area over the placed area (the bias is 0.5 log2(texel area / area):
// TriTex::of on the placed triangle, up to f32 rounding here).
void place_tex(float tri, inout vec4 r0, inout vec4 r1) {
    if (g_shade_inst < 0.0) return;
    vec4 t0 = fetch_tri_at(tri, TRI_TEXELS, 0.0);
    vec4 t1 = fetch_tri_at(tri, TRI_TEXELS, 1.0);
    vec4 t2 = fetch_tri_at(tri, TRI_TEXELS, 2.0);
    float a_obj = length(cross(t1.xyz - t0.xyz, t2.xyz - t0.xyz));
    place_triangle(t0, t1, t2);
    float a_placed = length(cross(t1.xyz - t0.xyz, t2.xyz - t0.xyz));
    if (a_obj > 0.0 && a_placed > 0.0) r1.z += 0.5 * log2(a_obj / a_placed);
    if (shade_mirrors()) {
        vec2 u1 = r0.zw;
        r0.zw = r1.xy;
        r1.xy = u1;
    }
}

// The packed triangle's corner colours c1, c2 in the placed winding (Scene::placed_colors).
void place_colors(inout vec3 c1, inout vec3 c2) {
    if (!shade_mirrors()) return;
    vec3 c = c1;
    c1 = c2;
    c2 = c;
}

// The curvature of triangle tri as placed (k: the packed record's, the scene's own
// triangles'): worked out on the placed vertices and normals (CPU twin: curvature in
// src/scene/texture.rs, on the flattened triangle), since a scale changes it.
float placed_curvature(float tri, float k) {
    if (g_shade_inst < 0.0) return k;
#ifdef HAS_SMOOTH_NORMALS
    vec4 t0 = fetch_tri_at(tri, TRI_TEXELS, 0.0);
    vec4 t1 = fetch_tri_at(tri, TRI_TEXELS, 1.0);
    vec4 t2 = fetch_tri_at(tri, TRI_TEXELS, 2.0);
    if (t1.w <= 0.5) return 0.0;
    vec3 n0 = fetch_nrm_at(tri, TRI_TEXELS, 0.0).xyz;
    vec3 n1 = fetch_nrm_at(tri, TRI_TEXELS, 1.0).xyz;
    vec3 n2 = fetch_nrm_at(tri, TRI_TEXELS, 2.0).xyz;
    place_triangle(t0, t1, t2);
    place_normals(n0, n1, n2);
    float sum = 0.0;
    vec3 dp = t1.xyz - t0.xyz;
    float l2 = dot(dp, dp);
    if (l2 > 0.0) sum += dot(n1 - n0, dp) / l2;
    dp = t2.xyz - t1.xyz;
    l2 = dot(dp, dp);
    if (l2 > 0.0) sum += dot(n2 - n1, dp) / l2;
    dp = t0.xyz - t2.xyz;
    l2 = dot(dp, dp);
    if (l2 > 0.0) sum += dot(n0 - n2, dp) / l2;
    return sum / 3.0;
#else
    return 0.0;
#endif
}
#endif
#endif
