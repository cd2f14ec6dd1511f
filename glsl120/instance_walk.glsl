// instance_walk.glsl: the walk of an instanced scene's two levels (GLSL 1.20, every kernel:
// the fragment kernels one iteration at a time, their state packed into s0..s3 between
// passes; render.comp to the end in registers); compiled in with INSTANCED only. CPU twin:
// src/cpu/traverse_instances.rs (the same top tree and tie rule; the CPU walks each mesh's
// BVH, this each mesh's uniform grid). The levels: accel/grid_instances.rs; the data and
// the threaded top tree: gpu/contract/instancing.rs.
//
// The walk: the scene's own grid with the world ray, then the top tree's entries in order
// (threaded: a box met goes on to the next entry, a box missed to its skip), each
// instance's mesh grid walked with the ray in its object space (the direction not
// renormalised, so t is the same in both spaces) up to the tie rule's bound, which is
// recomputed from what is held, so the object ray need not be kept. Each grid walk is
// step.glsl's (traverse_setup, traverse_step, intersect_test) on the grid walk's own state
// q0..q3; what the walk holds besides is a Levels. The tie rule (CPU twin: Closest::takes):
// a later hit (instance, then triangle: the primitive id's order) replaces the held one
// when closer by more than TIE_EPS relative; an earlier one unless the held hit is closer
// by more than that. A shadow ray (any_hit) ends at its first hit.
// Reads: instance.glsl's data, and through step.glsl the scene textures, in which every
// mesh's triangles and grid cells follow the scene's own.
// Needs instance.glsl, traverse.glsl (own_grid, the per-walk grid) and step.glsl.
#ifdef INSTANCED

// What the two-level walk holds beside the grid walk in progress.
struct Levels {
    vec3 o;       // the world ray
    vec3 d;
    float t_low;  // the closest t of any hit seen (Closest::t_low): the ray's t_max before any
    float node;   // -1: the own grid's walk; else the top-level entry (END: finished)
    float t_b;    // the hit held: t, packed triangle (TRI_NONE: none) and instance (-1: own)
    float rec_b;
    float inst_b;
};

// Top-level entries: past the last, the walk is finished.
float lv_end() {
    return inst_texel(0.0).x;
}

// First texel of entry e.
float lv_entry(float e) {
    return inst_texel(0.0).y + e * ENTRY_TEXELS;
}

// The instance whose mesh entry e walks (-1: the own grid, or an inner entry).
float lv_instance(float e) {
    return e < 0.0 ? -1.0 : inst_texel(lv_entry(e) + 1.0).w;
}

// Upper bound on the t of any hit the rule could still take (Closest::bound): 2 TIE_EPS
// past the closest seen once a hit is held, the ray's t_max before.
float lv_bound(Levels L) {
    return L.rec_b >= 0.0 ? L.t_low + abs(L.t_low) * (2.0 * TIE_EPS) : L.t_low;
}

// Sets the walk's grid to mesh m's (object space).
void mesh_grid(float m) {
    float at = inst_texel(0.0).z + m * MESH_TEXELS;
    vec4 a = inst_texel(at);
    vec4 b = inst_texel(at + 1.0);
    g_grid_min = a.xyz;
    g_cell_base = a.w;
    g_grid_max = b.xyz;
    g_cell_size = inst_texel(at + 2.0).xyz;
    g_grid_res = inst_texel(at + 3.0).xyz;
}

// The grid of instance k's walk (k < 0: the own grid) and the ray in its space, in state
// `state`, its interval ending at the bound: (q0, q1). Recomputed the same way each time.
void lv_ray(Levels L, float k, float state, out vec4 q0, out vec4 q1) {
    if (k < 0.0) {
        own_grid();
        q0 = S0_TEXEL(L.o, state);
        q1 = S1_TEXEL(L.d, L.t_low);
        return;
    }
    float at = inst_at(k);
    mesh_grid(inst_texel(at).w);
    vec3 tr = inst_texel(at + 3.0).xyz;
    q0 = S0_TEXEL(rows_times(at, L.o - tr), state);
    q1 = S1_TEXEL(rows_times(at, L.d), lv_bound(L));
}

// Whether the ray meets the box lo..hi within [0, t1] (the slab test, its far end widened
// by the rounding of its three operations: the boxes are padded, but a ray along a face
// must not lose the instance behind it). One axis.
vec2 lv_slab(float o, float d, float lo, float hi, vec2 ab) {
    if (d == 0.0) return (o < lo || o > hi) ? vec2(1.0, -1.0) : ab;
    float n = (lo - o) / d;
    float f = (hi - o) / d;
    return vec2(max(ab.x, min(n, f)), min(ab.y, max(n, f)));
}
bool box_hit(vec3 o, vec3 d, vec3 lo, vec3 hi, float t1) {
    vec2 ab = vec2(0.0, t1);
    ab = lv_slab(o.x, d.x, lo.x, hi.x, ab);
    ab = lv_slab(o.y, d.y, lo.y, hi.y, ab);
    ab = lv_slab(o.z, d.z, lo.z, hi.z, ab);
    return ab.x <= ab.y * (1.0 + 2.0 * gamma_n(3.0));
}

// The walk's end: the held hit as the ray's result (q0's state SHADING, q3's hit), or none.
void lv_finish(inout Levels L, inout vec4 q0, inout vec4 q3) {
    L.node = lv_end();
    bool held = L.rec_b >= 0.0;
    q0.S0_STATE = held ? ST_SHADING : ST_DONE;
    q3.S3_HIT = held ? vec2(L.t_b, L.rec_b) : vec2(L.t_low, TRI_NONE);
}

// One top-level step at entry L.node (no grid walk in progress, q0 in state INITIAL): its
// box tested up to the bound; missed, the walk skips its subtree; met, an inner entry goes
// on to its first child and an instance's entry starts its mesh walk (set up at once:
// q0..q3 TRAVERSING, TESTING, or INVALID where the ray misses the mesh's grid).
void lv_top_step(inout Levels L, inout vec4 q0, inout vec4 q1, inout vec4 q2, inout vec4 q3) {
    float at = lv_entry(L.node);
    vec4 a = inst_texel(at);
    vec4 b = inst_texel(at + 1.0);
    if (!box_hit(L.o, L.d, a.xyz, b.xyz, lv_bound(L))) {
        L.node = a.w;
    } else if (b.w < 0.0) {
        L.node += 1.0;
    } else {
        float steps = q3.S3_STEPS;
        lv_ray(L, b.w, ST_INITIAL, q0, q1);
        q2 = S2_TEXEL(vec3(0.0), 0.0);
        q3 = S3_TEXEL(q1.S1_T_MAX, TRI_NONE, 0.0, steps);
        traverse_setup(q0, q1, q2, q3);
        return;
    }
    if (L.node >= lv_end()) lv_finish(L, q0, q3);
}

// After a grid walk's step or test: a walk that ended (SHADING, DONE, INVALID) hands its
// hit to the top level (taken or not by the tie rule; a shadow ray's ends the whole walk)
// and the walk goes on at the next entry (q0 INITIAL), or finishes. Else nothing.
void lv_settle(inout Levels L, inout vec4 q0, inout vec4 q1, inout vec4 q2, inout vec4 q3,
               const bool any_hit) {
    float st = q0.S0_STATE;
    if (L.node >= lv_end() || in_state(st, ST_INITIAL) || in_state(st, ST_TRAVERSING)
        || in_state(st, ST_TESTING)) {
        return;
    }
    if (in_state(st, ST_SHADING)) {
        if (any_hit) {
            L.node = lv_end();
            return;
        }
        float t = q3.S3_T_BEST;
        float rec = q3.S3_TRI_BEST;
        float inst = lv_instance(L.node);
        bool held = L.rec_b >= 0.0;
        bool take = !held || (inst > L.inst_b ? t < L.t_b - abs(L.t_b) * TIE_EPS
                                              : !(L.t_b < t - abs(t) * TIE_EPS));
        L.t_low = min(L.t_low, t);
        if (take) {
            L.t_b = t;
            L.rec_b = rec;
            L.inst_b = inst;
        }
    }
    // An instance's entry is a leaf: the next entry is its skip.
    L.node = L.node < 0.0 ? 0.0 : L.node + 1.0;
    q0.S0_STATE = ST_INITIAL;
    if (L.node >= lv_end()) lv_finish(L, q0, q3);
}

// The first half of a fragment kernel's iteration (the multipass kernel's step pass): the
// own grid's set-up or a top-level step (INITIAL), or a grid step (TRAVERSING). None of
// them ends a grid walk with a hit, so the query does not matter here.
void lv_step(inout Levels L, inout vec4 q0, inout vec4 q1, inout vec4 q2, inout vec4 q3) {
    if (in_state(q0.S0_STATE, ST_INITIAL)) {
        if (L.node < 0.0) {
            traverse_setup(q0, q1, q2, q3);
        } else {
            lv_top_step(L, q0, q1, q2, q3);
        }
    } else {
        traverse_step(q0, q1, q2, q3);
    }
    lv_settle(L, q0, q1, q2, q3, false);
}

// The second half (the multipass kernel's test pass): a triangle test (TESTING).
void lv_test(inout Levels L, inout vec4 q0, inout vec4 q1, inout vec4 q2, inout vec4 q3,
             const bool any_hit) {
    intersect_test(q0, q1, q2, q3, any_hit);
    lv_settle(L, q0, q1, q2, q3, any_hit);
}

// Whether the two-level walk still has work (its grid walk's, or the top level's).
bool lv_active(Levels L) {
    return L.node < lv_end();
}

// A fresh walk of the ray (o, d) up to t_max.
Levels lv_new(vec3 o, vec3 d, float t_max) {
    return Levels(o, d, t_max, -1.0, t_max, TRI_NONE, -1.0);
}

#ifndef KERNEL_COMPUTE
// The walk's state in the ray-state texels between passes (GL 2.1's four draw buffers):
//   s0 = (world origin, state + 8 (node + 1)), s1 = (world direction, t_low),
//   s2 = (grid walk's cell as a linear index, its list cursor, held t, held triangle),
//   s3 = (grid walk's t_best, tri_best, held instance, steps).
// The object-space ray and its bound are recomputed (lv_ray), the cell's list end is
// fetched again from its cell. A finished ray's texels are the flat walk's (s0's state
// alone, s3 = (t, triangle, instance, steps)), which the passes after the walk read.
// Every index is an integer below 2^24, exact in a float.

// Cell index l (x fastest) of the walk's grid as (x, y, z), exactly: each quotient's
// rounding corrected by one product.
vec3 lv_cell(float l) {
    float rxy = g_grid_res.x * g_grid_res.y;
    float z = floor(l / rxy);
    z = z * rxy > l ? z - 1.0 : ((z + 1.0) * rxy <= l ? z + 1.0 : z);
    float r = l - z * rxy;
    float y = floor(r / g_grid_res.x);
    y = y * g_grid_res.x > r ? y - 1.0 : ((y + 1.0) * g_grid_res.x <= r ? y + 1.0 : y);
    return vec3(r - y * g_grid_res.x, y, z);
}

// Whether the packed state s0 holds a ray the walk still works on.
bool lv_packed_active(vec4 s0) {
    float st = s0.S0_STATE - 8.0 * floor(s0.S0_STATE * 0.125);
    return in_state(st, ST_INITIAL) || in_state(st, ST_TRAVERSING) || in_state(st, ST_TESTING);
}

// Unpacks an active ray's texels (lv_packed_active) into the walk and its grid walk.
void lv_unpack(vec4 s0, vec4 s1, vec4 s2, vec4 s3, out Levels L, out vec4 q0, out vec4 q1,
               out vec4 q2, out vec4 q3) {
    float tag = floor(s0.S0_STATE * 0.125);
    float st = s0.S0_STATE - 8.0 * tag;
    // The own walk holds nothing yet (a ray spawned INITIAL carries zeros there).
    bool own = tag < 0.5;
    L = Levels(s0.S0_ORIGIN, s1.S1_DIR, s1.S1_T_MAX, tag - 1.0, own ? s1.S1_T_MAX : s2.z,
               own ? TRI_NONE : s2.w, own ? -1.0 : s3.z);
    bool walking = !in_state(st, ST_INITIAL);
    if (walking || own) {
        lv_ray(L, lv_instance(L.node), st, q0, q1);
    } else {
        own_grid();
        q0 = S0_TEXEL(L.o, st);
        q1 = S1_TEXEL(L.d, L.t_low);
    }
    vec3 c = walking ? lv_cell(s2.x) : vec3(0.0);
    q2 = S2_TEXEL(c, s2.y);
    float end = 0.0;
    if (in_state(st, ST_TESTING)) {
        vec4 cell = fetch_cell(cell_linear(c));
        end = CURSOR_END_OF(cell.x, cell.y);
    }
    q3 = S3_TEXEL(s3.x, s3.y, end, s3.w);
}

// Packs the walk back into the ray-state texels.
void lv_pack(Levels L, vec4 q0, vec4 q2, vec4 q3, out vec4 s0, out vec4 s1, out vec4 s2,
             out vec4 s3) {
    bool done = !lv_active(L);
    float tag = done ? 0.0 : L.node + 1.0;
    s0 = S0_TEXEL(L.o, q0.S0_STATE + 8.0 * tag);
    s1 = S1_TEXEL(L.d, L.t_low);
    vec3 c = q2.S2_CELL;
    float l = c.x + g_grid_res.x * (c.y + g_grid_res.y * c.z);
    s2 = vec4(l, q2.S2_CURSOR, L.t_b, L.rec_b);
    s3 = vec4(q3.S3_T_BEST, q3.S3_TRI_BEST, L.inst_b, q3.S3_STEPS);
}

// The multipass kernel's passes on this fragment's packed state: the step half
// (traverse_init.frag and traverse_step.frag) and the test half (intersect.frag). A ray the
// walk is not working on is left as it is.
void lv_pass_step(inout vec4 s0, inout vec4 s1, inout vec4 s2, inout vec4 s3) {
    if (!lv_packed_active(s0)) return;
    Levels L;
    vec4 q0;
    vec4 q1;
    vec4 q2;
    vec4 q3;
    lv_unpack(s0, s1, s2, s3, L, q0, q1, q2, q3);
    lv_step(L, q0, q1, q2, q3);
    lv_pack(L, q0, q2, q3, s0, s1, s2, s3);
}
void lv_pass_test(inout vec4 s0, inout vec4 s1, inout vec4 s2, inout vec4 s3,
                  const bool any_hit) {
    if (!lv_packed_active(s0)) return;
    Levels L;
    vec4 q0;
    vec4 q1;
    vec4 q2;
    vec4 q3;
    lv_unpack(s0, s1, s2, s3, L, q0, q1, q2, q3);
    lv_test(L, q0, q1, q2, q3, any_hit);
    lv_pack(L, q0, q2, q3, s0, s1, s2, s3);
}

#else
// The hit render.comp shades: its packed triangle (g_shade_inst is its instance, -1 for
// the scene's own); and its primitive id (render.comp writes its bits to the AOV: exact to
// 2^32), the instance's first id (split over two floats) plus the triangle's index in its
// mesh.
float g_hit_rec;
uint g_hit_id;

// The ray in s0..s3 (state INITIAL) traced through both levels to the end: each grid walk
// by compute.glsl's trace, the top level between them. The result as trace leaves it (s0's
// state, s3's t_best and steps) with the globals above.
void trace_scene(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3, const bool any_hit) {
    Levels L = lv_new(s0.S0_ORIGIN, s1.S1_DIR, s1.S1_T_MAX);
    vec4 q0 = s0;
    vec4 q1 = s1;
    vec4 q2 = s2;
    vec4 q3 = s3;
    own_grid();
    trace(q0, q1, q2, q3, any_hit);
    lv_settle(L, q0, q1, q2, q3, any_hit);
    // At the top level (a walk cut short by MAX_ITERATIONS stays active and ends here).
    while (in_state(q0.S0_STATE, ST_INITIAL)) {
        lv_top_step(L, q0, q1, q2, q3);
        if (ray_active(q0)) trace(q0, q1, q2, q3, any_hit);
        lv_settle(L, q0, q1, q2, q3, any_hit);
    }
    s0.S0_STATE = q0.S0_STATE;
    s2 = q2;
    s3 = q3;
    if (any_hit) return;
    g_hit_rec = L.rec_b;
    g_shade_inst = L.inst_b;
    if (L.inst_b < 0.0) {
        g_hit_id = uint(L.rec_b);
    } else {
        float at = inst_at(L.inst_b);
        float mesh = inst_texel(at).w;
        float tri_base = inst_texel(inst_texel(0.0).z + mesh * MESH_TEXELS + 1.0).w;
        g_hit_id = uint(inst_texel(at + 3.0).w) * uint(ID_SPLIT) + uint(inst_texel(at + 1.0).w)
                 + (uint(L.rec_b) - uint(tri_base));
    }
}
#endif
#endif
