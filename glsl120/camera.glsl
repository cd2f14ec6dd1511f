// camera.glsl: the compute kernel's primary directions in f64, rounded to f32 as the host
// rounds them (GLSL 4.30: doubles). CPU twin: src/scene/camera.rs (Frame::direction_at, whose
// normalisation is glam's `v * (1 / sqrt(v . v))` in IEEE f64). render.comp forms v in f64
// operation for operation; unit_f32 finishes the direction.
// Reads and writes nothing: functions of their arguments only.

// How far the fast value may lie from the exact f64 quotient, relative: 2^-36, eight times
// the bound of unit_f32's reciprocal square root after its Newton step (below 2^-39 for a
// starting value within 2^-20, wider than the single precision the GLSL spec asks of
// `inversesqrt` on doubles), with the products' roundings.
#define UNIT_MARGIN 1.4551915228366852e-11LF

// Whether every f64 value within UNIT_MARGIN |w| of w rounds to f32 as w does (to f): no f32
// rounding boundary (the midpoint between f and a neighbour, half an ulp of f away) lies that
// close. w - f is exact (Sterbenz) and small, so its distance from half an ulp is measured
// in f32, to within 2^-47 |w|. Zero is exact (its component of v is zero); f a power of two
// (its neighbours unevenly spaced), values near the f32 denormals, and NaN are not decided.
bool rounds_surely(double w, float f) {
    if (w == 0.0LF) return true;
    float af = abs(f);
    if (!(af > 1.0e-30)) return false;
    uint bits = floatBitsToUint(af);
    if ((bits & 0x7fffffu) == 0u) return false;
    float e = abs(float(w - double(f)));
    // Half an ulp of f: 2^(E - 24) for f = 1.m 2^E.
    float half_ulp = uintBitsToFloat((bits & 0x7f800000u) - (24u << 23));
    return abs(e - half_ulp) > af * float(UNIT_MARGIN);
}

// v / |v| rounded to f32, bit for bit the CPU twin's `v * (1 / sqrt(len2))` in f64 then
// rounded (len2 = v . v, computed by the caller as the twin does). The correctly rounded f64
// square root and division cost 1.7% of the H100's equal-work kernel (docs/performance.md), so
// the quotient is first taken from `inversesqrt` refined by one Newton step, and computed
// exactly only where that value could round to another f32 (about one component in 2^13).
// UNIT_DIR_SCALE (tests only) scales the fast value's reciprocal, playing a driver whose
// reciprocal square root errs; UNIT_DIR_UNCHECKED (tests only) trusts the fast value always.
vec3 unit_f32(dvec3 v, double len2) {
    double q = inversesqrt(len2);
    q = q * (1.5LF - 0.5LF * len2 * q * q);
#ifdef UNIT_DIR_SCALE
    q *= UNIT_DIR_SCALE;
#endif
    dvec3 w = v * q;
    vec3 d = vec3(w);
#ifdef UNIT_DIR_UNCHECKED
    return d;
#else
    if (rounds_surely(w.x, d.x) && rounds_surely(w.y, d.y) && rounds_surely(w.z, d.z)) {
        return d;
    }
    precise double inv = 1.0LF / sqrt(len2);
    return vec3(v * inv);
#endif
}
