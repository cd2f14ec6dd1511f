// texture.glsl: texture lookups and ray cones. CPU twin: src/cpu/texture.rs (conventions
// and the papers there). Textured scenes only: the layout (src/gpu/layout/) appends this
// file to its generated text, after fetch_tex, so an untextured program has none of it.
// Reads: the `tex` texture through fetch_tex: per triangle TEX_REC texels
//        (u0, v0, u1, v1), (u2, v2, lod_bias, curvature); from TEX_COLORS three vertex
//        colours per triangle (HAS_VERTEX_COLORS); a texture's header
//        (levels, wrap u, wrap v, 0) followed by one texel per level (base, w, h, 0); the
//        texels, row by row from the bottom.
// Writes: nothing (functions only).

// Integer texel index i wrapped into 0..n-1 by mode (0 repeat, 1 clamp, 2 mirror); the
// quotient corrected by one step either way (CPU twin: wrap_index).
float wrap_index(float i, float n, float mode) {
    if (mode > 0.5 && mode < 1.5) return clamp(i, 0.0, n - 1.0);
    float p = mode > 1.5 ? n + n : n;
    float r = i - p * floor(i / p);
    if (r >= p) r = r - p;
    if (r < 0.0) r = r + p;
    if (mode > 1.5 && r >= n) r = n + n - 1.0 - r;
    return r;
}

// Level of detail bias + log2|w| - log2|cos| (CPU twin: lod).
float tex_lod(float bias, float width, float cos_nd) {
    return bias + log2(max(abs(width), LOD_TINY)) - log2(max(abs(cos_nd), LOD_TINY));
}

vec3 tex_texel(vec4 level, float x, float y) {
    return fetch_tex(level.x + y * level.y + x).xyz;
}

// The bilinear lookup of the texture whose header is at hdr, at uv, in the mip level lod
// selects (CPU twins: level_of, bilinear).
vec3 tex_bilinear(float hdr, vec2 uv, float lod) {
    vec4 h = fetch_tex(hdr);
    float l = floor(lod + 0.5);
    l = l > 0.0 ? min(l, h.x - 1.0) : 0.0;
    vec4 lv = fetch_tex(hdr + 1.0 + l);
    float x = uv.x * lv.y - 0.5;
    float y = uv.y * lv.z - 0.5;
    float x0 = floor(x);
    float y0 = floor(y);
    float fx = x - x0;
    float fy = y - y0;
    float xa = wrap_index(x0, lv.y, h.y);
    float xb = wrap_index(x0 + 1.0, lv.y, h.y);
    float ya = wrap_index(y0, lv.z, h.z);
    float yb = wrap_index(y0 + 1.0, lv.z, h.z);
    vec3 t00 = tex_texel(lv, xa, ya);
    vec3 t10 = tex_texel(lv, xb, ya);
    vec3 t01 = tex_texel(lv, xa, yb);
    vec3 t11 = tex_texel(lv, xb, yb);
    vec3 bottom = t00 + (t10 - t00) * fx;
    vec3 top = t01 + (t11 - t01) * fx;
    return bottom + (top - bottom) * fy;
}

// The cone of a child of a hit of curvature k as the ray sees it, whose cone there is
// (width, spread): reflected, or refracted with eta = n1/n2 (CPU twin: child_cone).
vec2 child_cone(vec2 cone, float k, bool refracted, float eta) {
    float kw = k * cone.x;
    float spread = refracted ? eta * cone.y + (eta - 1.0) * kw : cone.y + (kw + kw);
    return vec2(cone.x, spread);
}
