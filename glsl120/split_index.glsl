// split_index.glsl: the exact address arithmetic of SPLIT_INDEX, the layout of scenes whose
// texels or references pass 2^24 (what one float counts exactly). Generated fetches
// (fetch_<name>_at, entry_<name>_split, src/gpu/layout/) call these; every value formed
// stays an integer below 2^24, or one times a power of two. CPU twins: rec_coord and
// split_coord in src/gpu/split_index.rs, which the tests compare against this file on the
// driver.

// (column, row) of texel k of record `item` (below 2^24) of `per` texels, in rows w wide (a
// power of two, inv_w its exact reciprocal): item = a w + b, so the texel is per a w + per b
// + k, whose row is per a + floor((per b + k) / w), without forming per * item.
vec2 rec_coord(float item, float per, float k, float w, float inv_w) {
    float a = floor(item * inv_w);
    float c = per * (item - a * w) + k;
    float r = floor(c * inv_w);
    return vec2(c - r * w, per * a + r);
}

// (texel column, row, component) of list entry hi * SPLIT_BASE + lo + j, in rows of w texels
// of four entries: lo's row and column first, then j added to the column (lo, j below 2^24
// less a row), then hi's rows, SPLIT_BASE / (4 w) each.
vec3 split_coord(float hi, float lo, float j, float w, float inv_w) {
    float r = 4.0 * w;
    float inv_r = 0.25 * inv_w;
    float lr = floor(lo * inv_r);
    float c = lo - lr * r + j;
    float cr = floor(c * inv_r);
    float e = c - cr * r;
    float x = floor(e * 0.25);
    return vec3(x, hi * (SPLIT_BASE * inv_r) + lr + cr, e - x * 4.0);
}
