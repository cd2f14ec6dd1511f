// render.comp: `--kernel compute`, the whole Whitted ray tree of every pixel and every
// sample in one dispatch. The one GLSL 4.30 file: everything it computes is the GLSL 1.20
// the fragment kernels run (traverse_setup, traverse_step and intersect_test of step.glsl;
// surface, shadow_ray, light_term, secondary of shade.glsl), walked in the same order
// (gpu/render/tree.rs): per sample the primary ray, then at each node ambient, the lights in
// order, the reflected subtree, the refracted subtree, depth first. A small per-invocation
// stack holds the pending children (at most one per level: STACK_SIZE = max depth + 1).
// Reads: the scene textures through the generated texelFetch fetch functions, grid
//        uniforms, with INSTANCED the instancing data (instance.glsl, instance_walk.glsl: the
//        walk of an instanced scene's two levels), u_eye, u_ambient, u_background, u_sample_weight, the camera buffer (the
//        up vector and the host's f64 tables of each column's and row's terms: primary
//        directions by the camera's formula in f64, rounded to f32, as the host computes
//        them for the fragment kernels) and the lights
//        buffer (position, radiance).
// Writes: radiance (linear RGB summed over samples) and, with WRITE_AOV, aov_out (first
//         sample's primary ray: t_best, tri_best or TRI_NONE, steps, state), both in image
//         order (with INSTANCED the id's bits in its tri channel); the render's 64-bit
//         counter sums (rays by kind, cells entered, triangle
//         tests, rays cut off by MAX_ITERATIONS, primary-ray steps, non-finite pixels).
#include "camera.glsl"
#include "intersect.glsl"
#include "traverse.glsl"
#include "step.glsl"
#include "shade.glsl"
#include "compute.glsl"
#include "instance.glsl"
#include "instance_walk.glsl"

// Declared by the host from gpu/contract (bindings.rs, compute.rs): the buffers `cam`
// (CAM_* slots: the up vector, then per sample the columns' f + a r and the rows' b), `lights`
// (LIGHT_POS(k), LIGHT_RAD(k)), `counters` (COUNTERS slots per work group), and the
// outputs for the band's rows in image order (rows from the top), so the host reads them
// straight into its image: `radiance` (RGB per pixel) and `aov_out` (A0_TEXEL per pixel);
// the uniforms u_eye, u_ambient, u_background, u_sample_weight, u_size and u_band (the band
// of GL rows this dispatch renders: first row, row count).
layout(local_size_x = LOCAL_X, local_size_y = LOCAL_Y) in;

shared uint g_count[COUNTERS];

// The primary direction of sample k through the pixel in column c and row r of the pixels
// rendered (rows from the top): Camera::direction_at in f64, operation for operation
// (precise: no fused multiply-adds), rounded to f32 (unit_f32, camera.glsl). The host's
// tables hold each column's f + a r and each row's b (camera_buffer, computed as
// Frame::direction_at computes them), so a pixel adds b u and normalises.
vec3 primary_dir(int k, int c, int r) {
    int col = CAM_COLUMNS + 3 * (k * u_size.x + c);
    int row = CAM_COLUMNS + 3 * SAMPLES * u_size.x + k * u_size.y + r;
    dvec3 fa = dvec3(cam[col], cam[col + 1], cam[col + 2]);
    dvec3 u = dvec3(cam[CAM_U], cam[CAM_U + 1], cam[CAM_U + 2]);
    double b = cam[row];
    precise dvec3 v = fa + b * u;
    precise double len2 = v.x * v.x + v.y * v.y + v.z * v.z;
    return unit_f32(v, len2);
}

// One pending node of the ray tree: its ray and its weight.
struct Node {
    vec3 o;
    vec3 d;
    vec3 w;
    int level;
};
#ifdef HAS_TEXTURES
// Beside the stack: each pending node's cone at its origin (width, spread).
vec2 g_cones[STACK_SIZE];
#endif

// Adds the radiance of the ray tree rooted at the primary ray (eye, d0) with weight w0 to
// `colour`; with `first`, stores the primary ray's AOV texel in `aov`.
// One loop traces one ray an iteration, a node's ray or one of its shadow rays, through the
// one call of `trace`: the driver inlines that walk once, not once for the closest hit and
// again for the shadow rays (on the H200 the second copy made the cold compile about
// twice as long; issue 52). The operations and their order are the same as a loop over the
// lights inside the node's iteration: ambient, the lights in order, then the children.
void shade_tree(vec3 d0, float w0, bool first, inout vec3 colour, inout vec4 aov) {
    Node stack[STACK_SIZE];
    stack[0] = Node(u_eye, d0, vec3(w0), 0);
#ifdef HAS_TEXTURES
    g_cones[0] = vec2(0.0, u_root_cone.y);
#endif
    int top = 1;
    // The node being shaded (`open`: it was hit and its children are not pushed yet), its
    // surface and albedo, and the light whose shadow ray comes next.
    Node n;
    Surface s;
    vec3 alb;
#ifdef HAS_TEXTURES
    vec2 hit_cone;
#endif
    bool open = false;
    int light = LIGHTS;
    while (true) {
        vec4 s0;
        vec4 s1;
        vec4 s2;
        vec4 s3;
        vec3 l;
        bool shadow = light < LIGHTS;
        if (shadow) {
            vec3 o;
            float dist;
            if (!shadow_ray(s, LIGHT_POS(light), o, l, dist)) {
                light++;
                continue;
            }
            n_count[C_SHADOW] += 1u;
            new_ray(o, l, dist, s0, s1, s2, s3);
        } else {
#ifdef HAS_SECONDARY
            if (open && n.level < MAX_DEPTH) {
                vec3 kr;
                vec3 kt;
                vec3 refl;
                vec3 refr;
                secondary(s.mat, s, n.d, kr, kt, refl, refr);
                // Refracted below reflected: the reflected subtree is walked first.
                if (child_exists(kt)) {
                    n_count[C_REFRACTED] += 1u;
#ifdef HAS_TEXTURES
                    g_cones[top] = child_cone_at(s, hit_cone, true);
#endif
                    stack[top++] = Node(offset_origin(s, refr), refr, n.w * kt, n.level + 1);
                }
                if (child_exists(kr)) {
                    n_count[C_REFLECTED] += 1u;
#ifdef HAS_TEXTURES
                    g_cones[top] = child_cone_at(s, hit_cone, false);
#endif
                    stack[top++] = Node(offset_origin(s, refl), refl, n.w * kr, n.level + 1);
                }
            }
#endif
            open = false;
            if (top == 0) break;
            n = stack[--top];
            new_ray(n.o, n.d, BIG, s0, s1, s2, s3);
        }
#ifdef INSTANCED
        trace_scene(s0, s1, s2, s3, shadow);
#else
        trace(s0, s1, s2, s3, shadow);
#endif
        if (shadow) {
            if (!in_state(s0.S0_STATE, ST_SHADING)) {
                vec3 c = light_term(s.mat, alb, s, l, -n.d);
                colour += contribution(n.w, c, LIGHT_RAD(light));
            }
            light++;
            continue;
        }
        bool hit = in_state(s0.S0_STATE, ST_SHADING);
        if (first && n.level == 0) {
#ifdef INSTANCED
            // The id's bits (the host reads them back exactly: ids run to 2^32).
            aov = A0_TEXEL(s3.S3_T_BEST, hit ? uintBitsToFloat(g_hit_id) : TRI_NONE, s3.S3_STEPS,
                           s0.S0_STATE);
#else
            aov = A0_TEXEL(s3.S3_T_BEST, hit ? s3.S3_TRI_BEST : TRI_NONE, s3.S3_STEPS, s0.S0_STATE);
#endif
            n_count[C_PRIMARY_STEPS] += uint(s3.S3_STEPS);
        }
        if (!hit) {
            colour += n.w * u_background;
            continue;
        }
#ifdef INSTANCED
        // The packed triangle hit (its id is the instance's first plus its index).
        s = surface(n.o, n.d, g_hit_rec);
#else
        s = surface(n.o, n.d, s3.S3_TRI_BEST);
#endif
#ifdef HAS_TEXTURES
        hit_cone = cone_at(g_cones[top], s3.S3_T_BEST);
        alb = albedo_tex(s, hit_cone.x, n.d);
        colour += contribution(n.w, ambient_with(s, alb), u_ambient);
#else
        alb = albedo_at(s.mat, s.p);
        colour += contribution(n.w, ambient_term(s), u_ambient);
#endif
        open = true;
        light = 0;
    }
    // Work left: the loop was ended from outside (llvmpipe ends every loop of an invocation
    // once 65535 iterations of them all have run); the tree is incomplete.
    if (top > 0 || open) n_count[C_UNFINISHED] += 1u;
}

// Radiance and AOV of pixel px (GL rows from the bottom of the pixels rendered, u_size)
// into the output buffers, which hold this band's rows in image order. The pixels rendered
// may be a region of the image: the primary ray is the whole image's (the host's tables
// are the region's columns and rows of the whole image).
void render_pixel(ivec2 px) {
    vec3 colour = vec3(0.0);
    vec4 aov = vec4(0.0);
    // GL rows run from the bottom, camera rows from the top.
    int row = u_size.y - 1 - px.y;
    for (int k = 0; k < SAMPLES; k++) {
        vec3 d = primary_dir(k, px.x, row);
        n_count[C_PRIMARY] += 1u;
        shade_tree(d, u_sample_weight, k == 0, colour, aov);
    }
    uint k = uint(u_band.x + u_band.y - 1 - px.y) * uint(u_size.x) + uint(px.x);
    radiance[3u * k] = colour.r;
    radiance[3u * k + 1u] = colour.g;
    radiance[3u * k + 2u] = colour.b;
    if (any(isnan(colour)) || any(isinf(colour))) n_count[C_NONFINITE] += 1u;
#ifdef WRITE_AOV
    aov_out[k] = aov;
#endif
}

void main() {
    for (int k = 0; k < COUNTERS; k++) n_count[k] = 0u;
    if (gl_LocalInvocationIndex == 0u) {
        for (int k = 0; k < COUNTERS; k++) g_count[k] = 0u;
    }
    barrier();
    ivec2 px = ivec2(gl_GlobalInvocationID.xy) + ivec2(0, u_band.x);
    if (px.x < u_size.x && px.y < u_band.x + u_band.y) render_pixel(px);
    for (int k = 0; k < COUNTERS; k++) {
        if (n_count[k] != 0u) atomicAdd(g_count[k], n_count[k]);
    }
    barrier();
    // The group's totals into the render's 64-bit sums (low word, high word per counter):
    // a carry out of the low word is exactly an addition that wrapped. No `continue` for
    // zero totals: with one, llvmpipe kept this a real loop, its loop limit (65535
    // iterations an invocation) ended it early in groups that hit the limit, and the
    // C_UNFINISHED total that reports exactly that was lost (tests/compute_kernel.rs caught
    // it on ground.toml with the uniform grid).
    if (gl_LocalInvocationIndex == 0u) {
        for (int k = 0; k < COUNTERS; k++) {
            uint v = g_count[k];
            uint old = atomicAdd(counters[2 * k], v);
            if (old + v < old) atomicAdd(counters[2 * k + 1], 1u);
        }
    }
}
