// srgb8.comp: the band's linear radiance as 8-bit sRGB, on the GPU, so the host reads back
// a quarter of the bytes for a PNG. CPU twin: src/image_io.rs (`srgb8`): the code of a value
// is the number of the host's thresholds at or below it (`srgb8_thresholds`), comparisons
// only, so every byte equals the host conversion's.
// Reads: radiance (the band's RGB floats, image order), srgb_thresholds (256 sorted
//        values, the last +inf), u_pixels (pixels in the band).
// Writes: srgb8_out: the band's RGB bytes packed four to a word (little end first), each
//         invocation one word = 4 bytes of the byte stream.

layout(local_size_x = 64) in;

// The 8-bit code of linear value v: thresholds at or below v, by binary search (NaN and
// negative values give 0; values above 1 give 255).
uint srgb8(float v) {
    if (!(v >= 0.0)) return 0u;
    v = min(v, 1.0);
    uint n = 0u;
    for (uint step = 128u; step > 0u; step >>= 1u) {
        if (srgb_thresholds[n + step - 1u] <= v) n += step;
    }
    return n;
}

void main() {
    uint word = gl_GlobalInvocationID.x;
    uint bytes = uint(u_pixels) * 3u;
    if (4u * word >= bytes) return;
    uint bits = 0u;
    for (uint b = 0u; b < 4u; b++) {
        uint at = 4u * word + b;
        if (at < bytes) bits |= srgb8(radiance[at]) << (8u * b);
    }
    srgb8_out[word] = bits;
}
