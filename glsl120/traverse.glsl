// traverse.glsl: 3D-DDA helpers after Amanatides & Woo.
// CPU twin: src/cpu/traverse.rs (`GridWalker::clip`, `start_cell`, `boundary`).
//
// The boundary parameter of an axis is recomputed from the cell index rather than
// accumulated with tDelta, which would drift by an ulp per step (see the CPU twin).

uniform vec3 u_grid_min;
uniform vec3 u_grid_max;
uniform vec3 u_cell_size;
uniform vec3 u_grid_res;

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
    return c.x + u_grid_res.x * (c.y + u_grid_res.y * c.z);
}

// Slack of the in-cell acceptance test, as in the CPU twin.
float exit_limit(float t_exit) {
    return t_exit + abs(t_exit) * gamma_n(8.0);
}
