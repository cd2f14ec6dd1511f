// compute.glsl: what the compute kernels (render.comp, wave.comp; GLSL 4.30) add to the
// step chunk: tracing one ray to its end in a loop, with this invocation's counts.
// CPU twin of the loop: src/cpu/traverse.rs (closest_hit, any_hit) and
// src/cpu/traverse_irregular.rs; it counts cells and tests the way their `Work` does.
// Needs step.glsl.

// This invocation's counts (C_* slots).
uint n_count[COUNTERS];

// Traces the ray in s0..s3 (state INITIAL) to its end, counting cells entered and triangle
// tests apart: the looped kernel's loop with no pass to end it, written "while-while"
// (Aila and Laine 2009): step while traversing, then test while testing, so an invocation
// runs one kind of work at a stretch. On the H200 this took 21% off the default scene's
// dispatch and 5% off the bunny's against one step and one test per iteration
// (docs/performance.md). MAX_ITERATIONS bounds all of it.
void trace(inout vec4 s0, vec4 s1, inout vec4 s2, inout vec4 s3, const bool any_hit) {
    traverse_setup(s0, s1, s2, s3);
    if (ray_active(s0)) n_count[C_CELLS] += 1u;
    int it = 0;
    while (it < MAX_ITERATIONS && ray_active(s0)) {
        while (it < MAX_ITERATIONS && in_state(s0.S0_STATE, ST_TRAVERSING)) {
            traverse_step(s0, s1, s2, s3);
            if (ray_active(s0)) n_count[C_CELLS] += 1u;
            it++;
        }
        while (it < MAX_ITERATIONS && in_state(s0.S0_STATE, ST_TESTING)) {
            n_count[C_TESTS] += 1u;
            intersect_test(s0, s1, s2, s3, any_hit);
            it++;
        }
    }
    if (ray_active(s0)) n_count[C_UNFINISHED] += 1u;
}

// A fresh ray from o along d up to t_max, in state INITIAL.
void new_ray(vec3 o, vec3 d, float t_max, out vec4 s0, out vec4 s1, out vec4 s2, out vec4 s3) {
    s0 = S0_TEXEL(o, ST_INITIAL);
    s1 = S1_TEXEL(d, t_max);
    s2 = S2_TEXEL(vec3(0.0), 0.0);
    s3 = S3_TEXEL(t_max, TRI_NONE, 0.0, 0.0);
}

