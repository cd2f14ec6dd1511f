// instance.glsl: the compute kernel's walk of an instanced scene's two levels (GLSL 4.30;
// compiled in with INSTANCED only). CPU twin: src/cpu/traverse_instances.rs (the same
// top tree, the same tie rule; the CPU walks each mesh's BVH, this each mesh's uniform
// grid). The levels: accel/grid_instances.rs.
// Reads: inst_data (gpu/contract/instancing.rs: placements, meshes' grids, the top tree)
//        and, through trace (compute.glsl), the scene textures, in which every mesh's
//        triangles and grid cells follow the scene's own.
// Writes: the ray state of the walk (s0, s3: the closest hit's t and primitive id
//         `first + triangle`, as a float: exact below 2^24), g_hit_id (the id exactly),
//         g_hit_rec and g_shade_inst (the packed triangle hit and its instance, or -1 for
//         the scene's own, for surface() in shade.glsl).
// Needs compute.glsl (trace, new_ray) and traverse.glsl (own_grid, the per-walk grid).
#ifdef INSTANCED

// The hit surface() shades: its packed triangle, and its instance (-1: the scene's own);
// and its primitive id (render.comp writes its bits to the AOV: exact to 2^32).
float g_hit_rec;
int g_shade_inst = -1;
uint g_hit_id;

uint inst_bits(float f) {
    return floatBitsToUint(f);
}

// First texel of instance k.
uint inst_at(int k) {
    return 1u + uint(k) * INST_TEXELS;
}

// Sets the walk's grid to mesh m's (object space).
void mesh_grid(uint m) {
    uint at = inst_bits(inst_data[0].y) + m * MESH_TEXELS;
    vec4 a = inst_data[at];
    vec4 b = inst_data[at + 1u];
    g_grid_min = a.xyz;
    g_cell_base = float(inst_bits(a.w));
    g_grid_max = b.xyz;
    g_cell_size = inst_data[at + 2u].xyz;
    g_grid_res = inst_data[at + 3u].xyz;
}

// Row-vector product of the three rows from texel `at` on with p.
vec3 rows_times(uint at, vec3 p) {
    return vec3(dot(inst_data[at].xyz, p), dot(inst_data[at + 1u].xyz, p),
                dot(inst_data[at + 2u].xyz, p));
}

// The placed (local-space) triangle of the instance being shaded, in f32 (the host places
// in f64 and rounds once: Instance::point): vertices by the linear part and translation,
// the winding reversed for a mirroring placement, as Scene::flattened stores it.
void place_triangle(inout vec4 t0, inout vec4 t1, inout vec4 t2) {
    if (g_shade_inst < 0) return;
    uint at = inst_at(g_shade_inst);
    vec3 tr = inst_data[at + 3u].xyz;
    t0.xyz = rows_times(at + 4u, t0.xyz) + tr;
    vec3 p1 = rows_times(at + 4u, t1.xyz) + tr;
    vec3 p2 = rows_times(at + 4u, t2.xyz) + tr;
    bool mirror = inst_data[at + 2u].w > 0.5;
    t1.xyz = mirror ? p2 : p1;
    t2.xyz = mirror ? p1 : p2;
}

// The placed vertex normals (the normal matrix, renormalised: Instance::normal), in the
// order place_triangle put the vertices.
void place_normals(inout vec3 n0, inout vec3 n1, inout vec3 n2) {
    if (g_shade_inst < 0) return;
    uint at = inst_at(g_shade_inst);
    n0 = normalize(rows_times(at + 7u, n0));
    vec3 m1 = normalize(rows_times(at + 7u, n1));
    vec3 m2 = normalize(rows_times(at + 7u, n2));
    bool mirror = inst_data[at + 2u].w > 0.5;
    n1 = mirror ? m2 : m1;
    n2 = mirror ? m1 : m2;
}

// Whether the ray meets the box lo..hi within [0, t1] (the slab test, its far end widened
// by the rounding of its three operations: the boxes are padded, but a ray along a face
// must not lose the instance behind it).
bool box_hit(vec3 o, vec3 d, vec3 lo, vec3 hi, float t1) {
    float a = 0.0;
    float b = t1;
    for (int k = 0; k < 3; k++) {
        if (d[k] == 0.0) {
            if (o[k] < lo[k] || o[k] > hi[k]) return false;
        } else {
            float n = (lo[k] - o[k]) / d[k];
            float f = (hi[k] - o[k]) / d[k];
            a = max(a, min(n, f));
            b = min(b, max(n, f));
        }
    }
    return a <= b * (1.0 + 2.0 * gamma_n(3.0));
}

// The ray in s0..s3 (state INITIAL) traced through both levels: the scene's own grid, then
// the top tree's instances whose boxes it meets, each mesh's grid walked with the ray in
// its object space (the direction not renormalised, so t is the same in both spaces) up
// to the tie rule's bound. The tie rule (CPU twin: Closest::takes): a later id replaces
// the held hit when closer by more than TIE_EPS relative; an earlier one unless the held
// hit is closer by more than that. A shadow ray (any_hit) ends at its first hit.
void trace_scene(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3, const bool any_hit) {
    vec3 o = s0.S0_ORIGIN;
    vec3 d = s1.S1_DIR;
    float t_max = s1.S1_T_MAX;
    own_grid();
    trace(s0, s1, s2, s3, any_hit);
    bool held = in_state(s0.S0_STATE, ST_SHADING);
    if (any_hit && held) return;
    float steps = s3.S3_STEPS;
    float t_b = s3.S3_T_BEST;
    uint id_b = held ? uint(s3.S3_TRI_BEST) : 0u;
    float rec_b = s3.S3_TRI_BEST;
    int inst_b = -1;
    // The closest t seen: the bound of every later walk (Closest::bound).
    float t_low = held ? t_b : t_max;
    uint node_base = inst_bits(inst_data[0].z);
    uint ref_base = inst_bits(inst_data[0].w);
    uint stack[TOP_STACK];
    int sp = 0;
    stack[sp++] = 0u;
    if (inst_bits(inst_data[0].x) == 0u) sp = 0;
    while (sp > 0) {
        uint at = node_base + stack[--sp] * NODE_TEXELS;
        vec4 lx = inst_data[at];
        vec4 ly = inst_data[at + 1u];
        vec4 lz = inst_data[at + 2u];
        vec4 hx = inst_data[at + 3u];
        vec4 hy = inst_data[at + 4u];
        vec4 hz = inst_data[at + 5u];
        uvec4 child = floatBitsToUint(inst_data[at + 6u]);
        uvec4 count = floatBitsToUint(inst_data[at + 7u]);
        for (int i = 0; i < 4; i++) {
            if (count[i] == 0u && lx[i] > hx[i]) continue; // an empty slot
            float bound = held ? t_low + abs(t_low) * (2.0 * TIE_EPS) : t_max;
            if (!box_hit(o, d, vec3(lx[i], ly[i], lz[i]), vec3(hx[i], hy[i], hz[i]), bound)) {
                continue;
            }
            if (count[i] == 0u) {
                if (sp < TOP_STACK) {
                    stack[sp++] = child[i];
                } else {
                    n_count[C_UNFINISHED] += 1u;
                }
                continue;
            }
            for (uint r = child[i]; r < child[i] + count[i]; r++) {
                int k = int(inst_bits(inst_data[ref_base + r / 4u][r % 4u]));
                uint ia = inst_at(k);
                uint mesh = inst_bits(inst_data[ia].w);
                uint first = inst_bits(inst_data[ia + 1u].w);
                vec3 tr = inst_data[ia + 3u].xyz;
                vec3 oo = rows_times(ia, o - tr);
                vec3 od = rows_times(ia, d);
                mesh_grid(mesh);
                float lim = held ? t_low + abs(t_low) * (2.0 * TIE_EPS) : t_max;
                vec4 q0;
                vec4 q1;
                vec4 q2;
                vec4 q3;
                new_ray(oo, od, lim, q0, q1, q2, q3);
                trace(q0, q1, q2, q3, any_hit);
                steps += q3.S3_STEPS;
                if (!in_state(q0.S0_STATE, ST_SHADING)) continue;
                if (any_hit) {
                    s0.S0_STATE = ST_SHADING;
                    s3.S3_STEPS = steps;
                    return;
                }
                float t = q3.S3_T_BEST;
                float rec = q3.S3_TRI_BEST;
                uint tri_base = inst_bits(inst_data[inst_bits(inst_data[0].y) + mesh * MESH_TEXELS
                                                     + 1u].w);
                uint id = first + (uint(rec) - tri_base);
                bool take = !held
                    || (id > id_b ? t < t_b - abs(t_b) * TIE_EPS
                                  : !(t_b < t - abs(t) * TIE_EPS));
                t_low = min(t_low, t);
                if (take) {
                    held = true;
                    t_b = t;
                    id_b = id;
                    rec_b = rec;
                    inst_b = k;
                }
            }
        }
    }
    s3.S3_STEPS = steps;
    if (any_hit) return;
    g_hit_rec = rec_b;
    g_shade_inst = inst_b;
    g_hit_id = id_b;
    if (held) {
        s0.S0_STATE = ST_SHADING;
        s3.S3_HIT = vec2(t_b, float(id_b));
    }
}
#endif
