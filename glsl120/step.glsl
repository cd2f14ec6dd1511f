// step.glsl: one traversal step and one triangle test as functions on a ray's state
// (s0..s3, see common.glsl). The faithful passes run one of them per pass; the unrolled
// kernel repeats the pair as straight-line code; the looped kernel runs them in a bounded
// loop. CPU twins: src/cpu/traverse.rs (walk, closest_hit, any_hit) and, with
// ACCEL_IRREGULAR, src/cpu/traverse_irregular.rs.
// Needs intersect.glsl and traverse.glsl.

#ifdef KERNEL_COMPUTE
// The compute kernels trace one ray to its end in a loop, so the ray's shear (watertight
// test) is set up once, by traverse_setup, and kept in registers for its triangle tests;
// the fragment kernels set it up per test (the ray state has no room for it). Same values.
mat3 g_shear_p;
vec3 g_shear_s;
void ray_shear_setup(vec3 d) {
#ifdef INTERSECT_WATERTIGHT
    shear_setup(d, g_shear_p, g_shear_s);
#endif
}
void ray_shear(vec3 d, out mat3 P, out vec3 S) {
    P = g_shear_p;
    S = g_shear_s;
}
#else
void ray_shear_setup(vec3 d) {}
void ray_shear(vec3 d, out mat3 P, out vec3 S) {
    shear_setup(d, P, S);
}
#endif

// Traversal set-up for a ray in state INITIAL (else nothing): the start cell, or INVALID
// when the ray misses the grid's box (pass 2 of the thesis; traverse_init.frag runs it).
void traverse_setup(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3) {
    if (!in_state(s0.S0_STATE, ST_INITIAL)) return;
    ray_shear_setup(s1.S1_DIR);
    vec2 span = clip_grid(s0.S0_ORIGIN, s1.S1_DIR, 0.0, s1.S1_T_MAX);
    if (span.x > span.y) {
        s0.S0_STATE = ST_INVALID;
        return;
    }
#ifdef ACCEL_IRREGULAR
    // The cell holding the virtual cell whose crossings bracket the entry parameter, chosen
    // as after an exit (irr_lateral): the entry point's own cell can be one off where the
    // ray starts on a face, and then its far face would lie behind the ray.
    vec3 o = s0.S0_ORIGIN;
    vec3 d = s1.S1_DIR;
    vec3 top = u_grid_res - 1.0;
    vec3 c = vec3(irr_lateral(o.x, d.x, span.x, u_grid_min.x, u_cell_size.x, 0.0, top.x),
                  irr_lateral(o.y, d.y, span.x, u_grid_min.y, u_cell_size.y, 0.0, top.y),
                  irr_lateral(o.z, d.z, span.x, u_grid_min.z, u_cell_size.z, 0.0, top.z));
    CELL_ID id = irr_lookup(c);
    vec4 lo = irr_lo(id);
    vec4 hi = irr_hi(id);
    irr_enter(id, lo, hi);
    vec4 cell = vec4(lo.w, hi.w, 0.0, 0.0);
    // (cell id, previous exit t, where the ray leaves the grid's box): the box exit is
    // kept so that steps need not clip the ray against the box again. The dense grid's
    // id stays in registers (irr_enter); its channel holds the id as a float, unread.
    c = vec3(float(id), span.x, span.y);
#else
    vec3 c = start_cell(s0.S0_ORIGIN, s1.S1_DIR, span.x);
    vec4 cell = fetch_cell(cell_linear(c));
#endif
    s2 = S2_TEXEL(c, CURSOR_FIRST(cell.x));
    s3 = S3_TEXEL(s1.S1_T_MAX, TRI_NONE, CURSOR_END_OF(cell.x, cell.y), s3.S3_STEPS + 1.0);
    s0.S0_STATE = cell.y > 0.0 ? ST_TESTING : ST_TRAVERSING;
}

// One 3D-DDA step for a ray in state TRAVERSING (else nothing).
void traverse_step(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3) {
    if (!in_state(s0.S0_STATE, ST_TRAVERSING)) return;
#ifdef ACCEL_IRREGULAR
    // One irregular-grid step (CPU twin: cpu/traverse_irregular.rs, walk).
    vec3 o = s0.S0_ORIGIN;
    vec3 d = s1.S1_DIR;
    vec3 lo = irr_cur_lo(s2).xyz;
    vec3 hi = irr_cur_hi(s2).xyz;
    vec2 ex = irr_exit(o, d, lo, hi, s2.S2_CELL.y);
    float t_leave = s2.S2_CELL.z; // clip_grid(o, d, 0.0, t_max).y, from traverse_setup
    CELL_ID next = ex.x >= t_leave ? NO_CELL : irr_next(o, d, ex, lo, hi);
    if (next == NO_CELL) {
        s0.S0_STATE = ST_DONE;
        return;
    }
    vec4 nlo = irr_lo(next);
    vec4 nhi = irr_hi(next);
    irr_enter(next, nlo, nhi);
    s2 = S2_TEXEL(vec3(float(next), ex.x, t_leave), CURSOR_FIRST(nlo.w));
    s3.S3_CURSOR_END = CURSOR_END_OF(nlo.w, nhi.w);
    s3.S3_STEPS += 1.0;
    s0.S0_STATE = nhi.w > 0.0 ? ST_TESTING : ST_TRAVERSING;
#else
    vec3 o = s0.S0_ORIGIN;
    vec3 d = s1.S1_DIR;
    vec3 c = s2.S2_CELL;
    vec3 tn = boundaries(o, d, c);
    float t_exit = min(min(tn.x, tn.y), tn.z);
    float t_leave = clip_grid(o, d, 0.0, s1.S1_T_MAX).y;
    if (t_exit >= t_leave) {
        s0.S0_STATE = ST_DONE;
        return;
    }
    // Smallest boundary; ties go to the lower axis, as in the CPU twin.
    vec3 axis = (tn.x <= tn.y && tn.x <= tn.z) ? vec3(1.0, 0.0, 0.0)
              : (tn.y <= tn.z ? vec3(0.0, 1.0, 0.0) : vec3(0.0, 0.0, 1.0));
    c += axis * sign(d);
    if (any(lessThan(c, vec3(0.0))) || any(greaterThanEqual(c, u_grid_res))) {
        s0.S0_STATE = ST_DONE;
        return;
    }
    vec4 cell = fetch_cell(cell_linear(c));
    s2 = S2_TEXEL(c, CURSOR_FIRST(cell.x));
    s3.S3_CURSOR_END = CURSOR_END_OF(cell.x, cell.y);
    s3.S3_STEPS += 1.0;
    s0.S0_STATE = cell.y > 0.0 ? ST_TESTING : ST_TRAVERSING;
#endif
}

// One ray-triangle test for a ray in state TESTING (else nothing); any_hit: a shadow ray's
// query (the first hit below t_max ends it), else the closest hit. A constant at every call,
// so compilers fold the branch away: the fragment passes get it from ANY_HIT
// (intersect_step), the compute kernel traces both kinds with one program.
void intersect_test(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3, const bool any_hit) {
    if (!in_state(s0.S0_STATE, ST_TESTING)) return;
    float k = s2.S2_CURSOR;
    float tri = cell_entry(s2, k);
    vec3 p0 = fetch_tri_at(tri, TRI_TEXELS, 0.0).xyz;
    vec3 p1 = fetch_tri_at(tri, TRI_TEXELS, 1.0).xyz;
    vec3 p2 = fetch_tri_at(tri, TRI_TEXELS, 2.0).xyz;
    mat3 P = mat3(1.0);
    vec3 S = vec3(1.0);
#ifdef INTERSECT_WATERTIGHT
    ray_shear(s1.S1_DIR, P, S);
#endif
    // Ties (closest hit): once a hit is held, a later (higher-index) triangle must be closer
    // by more than TIE_EPS relative, as in the CPU twin (cpu/traverse.rs, tie_limit).
    float t_hi = (!any_hit && s3.S3_TRI_BEST >= 0.0) ? s3.S3_T_BEST - abs(s3.S3_T_BEST) * TIE_EPS
                                                     : s3.S3_T_BEST;
    vec4 h = intersect_tri(s0.S0_ORIGIN, s1.S1_DIR, P, S, p0, p1, p2, 0.0, t_hi);
    s2.S2_CURSOR = k + 1.0;
    s3.S3_STEPS += 1.0;
    if (any_hit) {
        if (h.x > 0.0) {
            s3.S3_HIT = vec2(h.x, tri);
            s0.S0_STATE = ST_SHADING;
        } else if (s2.S2_CURSOR >= s3.S3_CURSOR_END) {
            s0.S0_STATE = ST_TRAVERSING;
        }
        return;
    }
    if (h.x > 0.0) {
        s3.S3_HIT = vec2(h.x, tri);
    }
    if (s2.S2_CURSOR >= s3.S3_CURSOR_END) {
        // The cell's closest hit counts only inside the cell: a closer hit may lie in the
        // next one, where this triangle is binned too (CPU twin: closest_hit). The exit is
        // computed only when a hit is held (&& evaluates its right side only then).
        if (s3.S3_TRI_BEST >= 0.0
            && s3.S3_T_BEST <= exit_limit(cell_exit(s0.S0_ORIGIN, s1.S1_DIR, s2))) {
            s0.S0_STATE = ST_SHADING;
        } else {
            s3.S3_HIT = vec2(s1.S1_T_MAX, TRI_NONE);
            s0.S0_STATE = ST_TRAVERSING;
        }
    }
}

#ifdef ANY_HIT
#define QUERY_ANY true
#else
#define QUERY_ANY false
#endif

// intersect_test for the fragment passes, whose query is fixed at assembly (ANY_HIT).
void intersect_step(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3) {
    intersect_test(s0, s1, s2, s3, QUERY_ANY);
}

// True while the ray still needs traversal or intersection work.
bool ray_active(vec4 s0) {
    return in_state(s0.S0_STATE, ST_TRAVERSING) || in_state(s0.S0_STATE, ST_TESTING);
}
