// srgb8.frag: the finished image as 8-bit sRGB, on the GPU, so the host reads back 3 bytes
// a pixel for a PNG instead of 16. CPU twin: src/image_io.rs (`srgb8`), through its
// thresholds (`srgb8_thresholds`), comparisons only, as srgb8.comp does for the compute
// kernel: every byte equals the host conversion's.
// Reads: u_acc (the accumulated linear colour, GL rows from the bottom), u_srgb (256 x 1:
//        entry c in .r is the smallest value whose code is at least c + 1; entry 255 is
//        +inf).
// Writes: gl_FragData[0] = (code + 0.25) / 255 per channel into an RGBA8 target, rows
//         flipped so that glReadPixels returns the image's rows from the top ((code + 0.25)
//         / 255 stores `code` whether the driver rounds or truncates to 8 bits); alpha 0
//         where the colour is not finite (NaN or infinite: the render is refused), else 1.

// The 8-bit code of linear value v: thresholds at or below v, by binary search (NaN and
// negative values give 0; values above 1 give 255).
float srgb8(float v) {
    if (!(v >= 0.0)) return 0.0;
    v = min(v, 1.0);
    float n = 0.0;
    for (int k = 7; k >= 0; k--) {
        float step = exp2(float(k));
        if (texture2D(u_srgb, vec2((n + step - 0.5) / 256.0, 0.5)).r <= v) n += step;
    }
    return n;
}

// Whether v is finite. GLSL 1.20 has no isnan/isinf: a NaN fails both comparisons of v
// itself, an infinity one of them. Written per channel, without abs() or all(): llvmpipe's
// compiler folds `abs(v) <= MAX`, and all() of vector comparisons, as if no value were NaN,
// and counted NaN pixels as finite (found by the full-range test in
// src/gpu/fragment/readback.rs).
bool finite1(float v) {
    return v >= -3.4028235e38 && v <= 3.4028235e38;
}

void main() {
    vec3 c = texture2D(u_acc, vec2(v_uv.x, 1.0 - v_uv.y)).rgb;
    vec3 code = vec3(srgb8(c.r), srgb8(c.g), srgb8(c.b));
    bool finite = finite1(c.r) && finite1(c.g) && finite1(c.b);
    gl_FragData[0] = vec4((code + 0.25) / 255.0, finite ? 1.0 : 0.0);
}
