// traverse.glsl: 3D-DDA helpers after Amanatides & Woo.
// CPU twin: src/cpu/traverse.rs (`GridWalker::clip`, `start_cell`, `boundary`).
//
// The boundary parameter of an axis is recomputed from the cell index rather than
// accumulated with tDelta, which would drift by an ulp per step (see the CPU twin).
// Reads the grid uniforms u_grid_min, u_grid_max, u_cell_size, u_grid_res (declared by the
// host from gpu/contract); with INSTANCED, the grid of the walk in progress instead.

#ifdef INSTANCED
// The grid a walk reads (instance.glsl): the scene's own, from the uniforms (own_grid), or
// an instanced mesh's in its object space (mesh_grid), whose cells follow the own grid's in
// the cell texture from g_cell_base on. Compiled in for instanced scenes only, so the
// programs of other scenes read the uniforms as before.
vec3 g_grid_min;
vec3 g_grid_max;
vec3 g_cell_size;
vec3 g_grid_res;
float g_cell_base;
void own_grid() {
    g_grid_min = u_grid_min;
    g_grid_max = u_grid_max;
    g_cell_size = u_cell_size;
    g_grid_res = u_grid_res;
    g_cell_base = 0.0;
}
#define u_grid_min g_grid_min
#define u_grid_max g_grid_max
#define u_cell_size g_cell_size
#define u_grid_res g_grid_res
#endif

// Slab clip of the ray against the grid box within [t0, t1]: (t_enter, t_exit); a miss
// when t_enter > t_exit. A +-0 direction component leaves the slab unbounded when the
// origin is inside it (d == 0.0 is true for -0.0 too).
vec2 clip_grid(vec3 o, vec3 d, float t0, float t1) {
    vec2 r = vec2(t0, t1);
    if (d.x == 0.0) {
        if (o.x < u_grid_min.x || o.x > u_grid_max.x) return vec2(1.0, -1.0);
    } else {
        float n = (u_grid_min.x - o.x) / d.x;
        float f = (u_grid_max.x - o.x) / d.x;
        r = vec2(max(r.x, min(n, f)), min(r.y, max(n, f)));
    }
    if (d.y == 0.0) {
        if (o.y < u_grid_min.y || o.y > u_grid_max.y) return vec2(1.0, -1.0);
    } else {
        float n = (u_grid_min.y - o.y) / d.y;
        float f = (u_grid_max.y - o.y) / d.y;
        r = vec2(max(r.x, min(n, f)), min(r.y, max(n, f)));
    }
    if (d.z == 0.0) {
        if (o.z < u_grid_min.z || o.z > u_grid_max.z) return vec2(1.0, -1.0);
    } else {
        float n = (u_grid_min.z - o.z) / d.z;
        float f = (u_grid_max.z - o.z) / d.z;
        r = vec2(max(r.x, min(n, f)), min(r.y, max(n, f)));
    }
    return r;
}

// Cell containing o + d t, clamped into the grid.
vec3 start_cell(vec3 o, vec3 d, float t) {
    vec3 p = o + d * t;
    return clamp(floor((p - u_grid_min) / u_cell_size), vec3(0.0), u_grid_res - 1.0);
}

float boundary1(float o, float d, float mn, float cs, float c) {
    if (d == 0.0) return BIG;
    float k = d > 0.0 ? c + 1.0 : c;
    return (mn + k * cs - o) / d;
}

// Parameters at which the ray leaves cell c through each axis's far face.
vec3 boundaries(vec3 o, vec3 d, vec3 c) {
    return vec3(boundary1(o.x, d.x, u_grid_min.x, u_cell_size.x, c.x),
                boundary1(o.y, d.y, u_grid_min.y, u_cell_size.y, c.y),
                boundary1(o.z, d.z, u_grid_min.z, u_cell_size.z, c.z));
}

// Linear cell index, x fastest (exact: below 2^24).
float cell_linear(vec3 c) {
#ifdef INSTANCED
    return g_cell_base + (c.x + u_grid_res.x * (c.y + u_grid_res.y * c.z));
#else
    return c.x + u_grid_res.x * (c.y + u_grid_res.y * c.z);
#endif
}

// Slack of the in-cell acceptance test, as in the CPU twin.
float exit_limit(float t_exit) {
    return t_exit + abs(t_exit) * gamma_n(8.0);
}

#ifdef ACCEL_IRREGULAR
// Irregular grid: one cell per step, leaving each through its exit box. CPU twin:
// src/cpu/traverse_irregular.rs (`exit`, `lateral`, `walk`). u_cell_size and u_grid_res
// are the virtual grid's; irr_lookup (the voxel-map descent) is generated with the layout.

#ifdef DENSE_GRID
// The compute kernel's integer layout (gpu/layout/dense.rs): a cell id is the cell's index
// in the uvec4 buffers dense_cell_lo (exit box lower corner, first reference) and
// dense_cell_hi (exit box upper corner, count); the first reference is kept apart
// (g_cell_first), the cursor counting from it. CELL_ID is a cell id's type, NO_CELL none.
#define CELL_ID uint
#define NO_CELL 4294967295u
vec4 irr_lo(uint id) { return vec4(vec3(dense_cell_lo[id].xyz), 0.0); }
vec4 irr_hi(uint id) {
    uvec4 h = dense_cell_hi[id];
    return vec4(vec3(h.xyz), float(h.w));
}
#else
// Cell texels: (exit box lower corner, list offset) and (exit box upper corner, count);
// with SPLIT_INDEX the offset is its lo part and a third texel holds (hi, 0, 0, 0). A cell
// id is its float slot.
#define CELL_ID float
#define NO_CELL -1.0
vec4 irr_lo(float id) { return fetch_cell_at(id, CELL_TEXELS, 0.0); }
vec4 irr_hi(float id) { return fetch_cell_at(id, CELL_TEXELS, 1.0); }
#endif

#ifdef KERNEL_COMPUTE
// The compute kernels trace one ray to its end in a loop, so the texels of the cell a ray
// is in stay in registers from the step that entered it (irr_enter) instead of being
// fetched again by the next step and by the closest-hit test's cell exit: two of a step's
// five fetches. The fragment kernels fetch them again (their ray state lives in textures
// between passes). Same values either way, so the same images.
vec4 g_cell_lo;
vec4 g_cell_hi;
#ifdef DENSE_GRID
uint g_cell_first;
#endif
void irr_enter(CELL_ID id, vec4 lo, vec4 hi) {
    g_cell_lo = lo;
    g_cell_hi = hi;
#ifdef DENSE_GRID
    g_cell_first = dense_cell_lo[id].w;
#endif
}
vec4 irr_cur_lo(vec4 s2) { return g_cell_lo; }
vec4 irr_cur_hi(vec4 s2) { return g_cell_hi; }
#else
void irr_enter(float id, vec4 lo, vec4 hi) {}
vec4 irr_cur_lo(vec4 s2) { return irr_lo(s2.S2_CELL.x); }
vec4 irr_cur_hi(vec4 s2) { return irr_hi(s2.S2_CELL.x); }
#endif

// Parameter at which the ray crosses virtual boundary k of one axis (d != 0): the
// expression of boundary1 above.
float irr_crossing(float o, float d, float mn, float cs, float k) {
    float f = mn + k * cs;
#ifdef SKEW_FACES
    // Tests only (GpuScene::with_skewed_faces): every face moved by about an ulp, up for
    // even k and down for odd, as NVIDIA's fused multiply-add rounds mn + k * cs one way
    // where the CPU rounds it another, so that llvmpipe shows what that does to the walk.
    f += (mod(k, 2.0) < 1.0 ? 1.0 : -1.0) * abs(f) * 1.1920929e-7;
#endif
    return (f - o) / d;
}

// Crossing of one axis's far face: BIG where the ray does not move along the axis, and
// t_prev where the face lies before the previous exit (exits never go back in t: see the
// CPU twin; the ray is already past that face, so the walk leaves through it at once).
float irr_far(float o, float d, float mn, float cs, float lo, float hi, float t_prev) {
    if (d == 0.0) return BIG;
    float t = irr_crossing(o, d, mn, cs, d > 0.0 ? hi : lo);
    return max(t, t_prev);
}

// (t_exit, axis) of the box lo..hi after the previous exit t_prev; ties go to the lower axis.
vec2 irr_exit(vec3 o, vec3 d, vec3 lo, vec3 hi, float t_prev) {
    vec3 tn = vec3(irr_far(o.x, d.x, u_grid_min.x, u_cell_size.x, lo.x, hi.x, t_prev),
                   irr_far(o.y, d.y, u_grid_min.y, u_cell_size.y, lo.y, hi.y, t_prev),
                   irr_far(o.z, d.z, u_grid_min.z, u_cell_size.z, lo.z, hi.z, t_prev));
    if (tn.x <= tn.y && tn.x <= tn.z) return vec2(tn.x, 0.0);
    if (tn.y <= tn.z) return vec2(tn.y, 1.0);
    return vec2(tn.z, 2.0);
}

// Virtual cell on a lateral axis at the exit parameter t, within lo..hi (inclusive): the
// exit point's cell, then moved (at most two cells each way) until its own crossings
// bracket t. The CPU twin's `lateral` makes two backward then two forward corrections;
// here each crossing is computed once, with the same choices: a correction that does not
// move k would not move it when repeated, and after a backward move the forward test reads
// the crossing just found to lie after t, so it fails. The common case (no move) costs two
// crossings instead of four.
float irr_lateral(float o, float d, float t, float mn, float cs, float lo, float hi) {
    float k = clamp(floor((o + d * t - mn) / cs), lo, hi);
    if (d == 0.0) return k;
    // Entering boundary of cell k: its lower face when d > 0, else its upper one.
    float enter = d > 0.0 ? 0.0 : 1.0;
    float back = d > 0.0 ? -1.0 : 1.0;
    if ((d > 0.0 ? k > lo : k < hi) && irr_crossing(o, d, mn, cs, k + enter) > t) {
        k += back;
        if ((d > 0.0 ? k > lo : k < hi) && irr_crossing(o, d, mn, cs, k + enter) > t) k += back;
        return k;
    }
    if ((d > 0.0 ? k < hi : k > lo) && irr_crossing(o, d, mn, cs, k + 1.0 - enter) <= t) {
        k -= back;
        if ((d > 0.0 ? k < hi : k > lo) && irr_crossing(o, d, mn, cs, k + 1.0 - enter) <= t) k -= back;
    }
    return k;
}

// Virtual cell on the exit axis: the first one beyond the face.
float irr_beyond(float d, float lo, float hi) {
    return d > 0.0 ? hi : lo - 1.0;
}

// The cell after leaving box lo..hi at ex = (t_exit, axis): its id, or NO_CELL when the ray
// leaves the grid.
CELL_ID irr_next(vec3 o, vec3 d, vec2 ex, vec3 lo, vec3 hi) {
    float t = ex.x;
    vec3 k = vec3(
        ex.y == 0.0 ? irr_beyond(d.x, lo.x, hi.x)
                    : irr_lateral(o.x, d.x, t, u_grid_min.x, u_cell_size.x, lo.x, hi.x - 1.0),
        ex.y == 1.0 ? irr_beyond(d.y, lo.y, hi.y)
                    : irr_lateral(o.y, d.y, t, u_grid_min.y, u_cell_size.y, lo.y, hi.y - 1.0),
        ex.y == 2.0 ? irr_beyond(d.z, lo.z, hi.z)
                    : irr_lateral(o.z, d.z, t, u_grid_min.z, u_cell_size.z, lo.z, hi.z - 1.0));
    if (any(lessThan(k, vec3(0.0))) || any(greaterThanEqual(k, u_grid_res))) return NO_CELL;
    return irr_lookup(k);
}
#endif

// Entry k of the current cell's list (s2): the cursor counts from the list's start, or
// with SPLIT_INDEX from the cell's first reference, whose offset hi * 2^24 + lo is fetched
// again from the cell (the ray state has no channel left for it).
float cell_entry(vec4 s2, float k) {
#ifdef DENSE_GRID
    // The triangle's index from the dense list, carried as its float id.
    return tri_slot(dense_refs[g_cell_first + uint(k)]);
#elif defined(SPLIT_INDEX)
#ifdef ACCEL_IRREGULAR
    return entry_list_split(fetch_cell_at(s2.S2_CELL.x, CELL_TEXELS, 2.0).x, irr_cur_lo(s2).w, k);
#else
    vec4 cell = fetch_cell(cell_linear(s2.S2_CELL));
    return entry_list_split(cell.z, cell.x, k);
#endif
#else
    return entry_list(k);
#endif
}

// Exit parameter of the ray's current cell (s2): the DDA cell's far faces, or the
// irregular cell's exit box.
float cell_exit(vec3 o, vec3 d, vec4 s2) {
#ifdef ACCEL_IRREGULAR
    return irr_exit(o, d, irr_cur_lo(s2).xyz, irr_cur_hi(s2).xyz, s2.S2_CELL.y).x;
#else
    vec3 tn = boundaries(o, d, s2.S2_CELL);
    return min(min(tn.x, tn.y), tn.z);
#endif
}
