// exact.glsl: the portable arithmetic every other file computes with, the
// same bits in every build (docs/exactness.md#the-recipe): fixed-order dot products and
// transforms, NaN-safe min / max / clamp, division and square root rounded
// to nearest (div_rn, sqrt_rn, corrected on GPUs), and log2, exp2, pow,
// acos, asin, atan and atan2 built from + - * / and sqrt.

// FAST_MATH (the fast kernel, `_fast` SPIR-V; docs/exactness.md "The fast
// kernel"): the device's own division, square root and transcendentals
// (pow, acos, asin, atan), and no `precise`, so the GPU's compiler may
// contract a * b + c into one fma and reorder. Not the CPU build's bits:
// the host runs it on GPUs only (never for `check`), and the C++ build is
// never compiled with it. glslang takes `precise` as a macro name.
#ifdef FAST_MATH
#define precise
#endif

const float PI = 3.14159265f;
const float DEGREES_PER_RADIAN = 57.2957795f;

vec3 xyz(vec4 v) {
    return vec3(v.x, v.y, v.z);
}

precise float dot3(vec3 a, vec3 b) {
    precise float r = (a.x * b.x + a.y * b.y) + a.z * b.z;
    return r;
}

// (b < a) ? b : a, GLM's operand order: with a NaN operand both builds
// return the same one.
precise float min_f(float a, float b) {
    return (b < a) ? b : a;
}

precise float max_f(float a, float b) {
    return (a < b) ? b : a;
}

// x clamped to [0, 1], NaN to 0: a colour that came to inf - inf (colours
// near the floats' limit, 3e38) is black in both builds, where converting
// a NaN to an integer is each compiler's own (lavapipe gave white, the C++
// build black).
precise float clamp01(float x) {
    return (x > 0.0f) ? min_f(x, 1.0f) : 0.0f;
}

// a / b and sqrt(x) rounded to nearest, as IEEE 754 has them: the same
// bits on every device. lavapipe and the C++ build round these two
// operations correctly, and then they are the plain operation; a device
// that does not (the Vulkan specification allows 2.5 ULP division and
// 3 ULP square roots; NVIDIA's driver uses them) runs the kernels compiled
// with CORRECT_DIVISION defined (the `_gpu` SPIR-V, which the host picks
// for any device that is not a CPU), which correct the operation's result.
// A preprocessor switch, not a specialization constant: lavapipe inlines
// every function before it drops dead code, so the corrections' code at
// every division doubled its pipeline build even when switched off.
// Every division and square root of the shared GLSL goes through them.
// The floats next to a finite nonzero x, toward zero and away from it.
float toward_zero(float x) {
    return intBitsToFloat(floatBitsToInt(x) - 1);
}

float away_from_zero(float x) {
    return intBitsToFloat(floatBitsToInt(x) + 1);
}

// The residuals below are exact without fma(): the Vulkan specification
// does not promise that fma() is fused (lavapipe's is not; NVIDIA's is),
// and an unfused one rounds the product first, which is the error the
// correction measures. Instead the operands are scaled by powers of two
// (exact) so that they lie in [1, 2), and the product is split into two
// floats by Dekker's method, every step of which is exact in IEEE
// arithmetic without contraction (`precise`, the C++ build's
// -ffp-contract=off). So the correction gives IEEE's bits on every device
// whose +, - and * are IEEE's, fused fma or not. Where the host has seen
// the device's fma() round once (shaders/fma_probe.comp), it runs kernels
// compiled with FUSED_FMA as well, whose residual is that one fma: the
// same value, where Dekker's product takes seventeen operations.

// 2^k as a float, for k in [-126, 127].
float pow2(int k) {
    return intBitsToFloat((k + 127) << 23);
}

// The exponent of a normal float x: x = m 2^e with 1 <= |m| < 2.
int exponent_of(float x) {
    return ((floatBitsToInt(x) >> 23) & 0xff) - 127;
}

// x split into hi + lo, each of at most 12 significant bits (Veltkamp's
// split, for |x| well inside the float range).
precise vec2 split(float x) {
    precise float t = 4097.0f * x;
    precise float hi = t - (t - x);
    return vec2(hi, x - hi);
}

// a - b c rounded once (what a fused fma(-b, c, a) gives), for b and c of
// moderate size (here within [0.5, 4)) and a within a factor of two of
// b c: Dekker's product b c = p + e exactly, a - p exact (Sterbenz's
// lemma), so (a - p) - e is the one rounding.
precise float residual(float a, float b, float c) {
#ifdef FUSED_FMA
    return fma(-b, c, a);
#else
    precise float p = b * c;
    precise vec2 bs = split(b);
    precise vec2 cs = split(c);
    precise float e = ((bs.x * cs.x - p) + bs.x * cs.y + bs.y * cs.x) + bs.y * cs.y;
    return (a - p) - e;
#endif
}

// The float nearest a / b from c at most 1 ULP off it: c or a neighbour,
// judged by |a - c b| = |b| |a / b - c| (a quotient of floats is never
// halfway between two, so there is no tie). a, b and c are scaled by
// 2^-(ec + eb), 2^-eb and 2^-ec first (correct_quotient's ranges keep
// them and their neighbours normal), which scales the three residuals
// alike.
precise float nearest_quotient(float a, float b, float c) {
    int ec = exponent_of(c);
    int eb = exponent_of(b);
    precise float sa = (a * pow2(-eb)) * pow2(-ec);
    precise float sb = b * pow2(-eb);
    precise float lo = toward_zero(c);
    precise float hi = away_from_zero(c);
    precise float rc = abs(residual(sa, c * pow2(-ec), sb));
    precise float rl = abs(residual(sa, lo * pow2(-ec), sb));
    precise float rh = abs(residual(sa, hi * pow2(-ec), sb));
    if (rl < rc) {
        c = lo;
    } else if (rh < rc) {
        c = hi;
    }
    return c;
}

// The float nearest a / b, from q a few ULP off it (div_rn): a Newton step
// with the residual a - q b (scaled as in nearest_quotient) brings it
// within 1 ULP, then nearest_quotient. Zero, infinite, NaN, subnormal and
// huge quotients, and b zero, subnormal, infinite or from 2^126 up, come
// back as given.
precise float correct_quotient(float a, float b, float q) {
    if (!(abs(q) > 1.17549435e-38f) || abs(q) > 1.0e38f || !(abs(b) >= 1.17549435e-38f) || abs(b) >= 8.50705917e37f) {
        return q;
    }
    int eq = exponent_of(q);
    int eb = exponent_of(b);
    precise float sb = b * pow2(-eb);
    precise float sq = q * pow2(-eq);
    precise float r = residual((a * pow2(-eb)) * pow2(-eq), sq, sb);
    precise float c = (sq + r * (1.0f / sb)) * pow2(eq);
    return nearest_quotient(a, b, c);
}

// The float nearest sqrt(x) from c > 0 at most 1 ULP off it: Tuckerman's
// test with the exact sign of a residual: c is the nearest unless
// x <= lo c (below the midpoint with its lower neighbour lo) or x > c hi
// (above the one with hi). Scaled by 2^-ec each and x by 2^-2ec.
precise float nearest_root(float x, float c) {
    int ec = exponent_of(c);
    precise float sx = (x * pow2(-ec)) * pow2(-ec);
    precise float sc = c * pow2(-ec);
    precise float lo = toward_zero(c);
    precise float hi = away_from_zero(c);
    if (residual(sx, lo * pow2(-ec), sc) <= 0.0f) {
        c = lo;
    } else if (residual(sx, sc, hi * pow2(-ec)) > 0.0f) {
        c = hi;
    }
    return c;
}

// The float nearest sqrt(x), from s a few ULP off it (sqrt_rn): a Newton
// step brings it within 1 ULP, then nearest_root. x zero, negative,
// subnormal, huge, infinite or NaN comes back as given.
precise float correct_root(float x, float s) {
    if (!(x > 1.17549435e-38f) || x > 1.0e38f || !(s > 0.0f)) {
        return s;
    }
    int es = exponent_of(s);
    precise float ss = s * pow2(-es);
    precise float r = residual((x * pow2(-es)) * pow2(-es), ss, ss);
    precise float c = (ss + r * (0.5f / ss)) * pow2(es);
    return nearest_root(x, c);
}

precise float div_rn(float a, float b) {
    precise float q = a / b;
#ifdef CORRECT_DIVISION
    q = correct_quotient(a, b, q);
#endif
    return q;
}

precise vec3 div_rn(vec3 v, float b) {
    return vec3(div_rn(v.x, b), div_rn(v.y, b), div_rn(v.z, b));
}

precise float sqrt_rn(float x) {
    precise float r = sqrt(x);
#ifdef CORRECT_DIVISION
    r = correct_root(x, r);
#endif
    return r;
}

precise vec3 unit(vec3 v) {
#ifdef FAST_MATH
    return v * inversesqrt(dot3(v, v));
#else
    precise float len = sqrt_rn(dot3(v, v));
    precise vec3 r = div_rn(v, len);
    return r;
#endif
}

// m * (p, 1), summed in one fixed order.
precise vec3 transform_point(mat4 m, vec3 p) {
    precise vec3 r = ((xyz(m[0]) * p.x + xyz(m[1]) * p.y) + xyz(m[2]) * p.z) + xyz(m[3]);
    return r;
}

// m * (v, 0), summed in one fixed order.
precise vec3 transform_vector(mat4 m, vec3 v) {
    precise vec3 r = (xyz(m[0]) * v.x + xyz(m[1]) * v.y) + xyz(m[2]) * v.z;
    return r;
}

// transpose(m) * (n, 0): the normal rule, applied with object_from_world.
// Row i of the transpose is column i of m.
precise vec3 transform_normal(mat4 object_from_world, vec3 n) {
    precise vec3 r = vec3(dot3(xyz(object_from_world[0]), n),
                          dot3(xyz(object_from_world[1]), n),
                          dot3(xyz(object_from_world[2]), n));
    return r;
}

// log2(x) for x > 0: exponent from the bits, mantissa m in [sqrt(1/2),
// sqrt(2)) through the atanh series: log2(m) = 2/ln2 * atanh((m-1)/(m+1)).
// Absolute error below 1e-7 for normal x; x below the normal range gives
// -127 (pow then returns 0, which is what such an x to any n > 0 rounds to).
precise float log2_portable(float x) {
    if (x < 1.17549435e-38f) {
        return -127.0f;
    }
    int bits = floatBitsToInt(x);
    int e = ((bits >> 23) & 255) - 127;
    precise float m = intBitsToFloat((bits & 8388607) | 1065353216);
    if (m > 1.41421354f) {
        m = m * 0.5f;
        e = e + 1;
    }
    precise float s = div_rn(m - 1.0f, m + 1.0f);
    precise float s2 = s * s;
    precise float p = ((((s2 * 0.0909090936f + 0.111111112f) * s2 + 0.142857149f) * s2 + 0.200000003f) * s2 + 0.333333343f) * s2 + 1.0f;
    precise float r = float(e) + (s * p) * 2.88539004f; // 2 / ln 2
    return r;
}

// 2^y: the nearest integer k into the exponent bits, the rest f = y - k in
// [-1/2, 1/2] through e^z = sum z^k/k! with z = f ln 2 (degree 7: error
// below 6e-9 before rounding). 2^0 is exactly 1. 0 below 2^-126, clamped
// at 2^128 - ulp above.
precise float exp2_portable(float y) {
    if (y < -126.0f) {
        return 0.0f;
    }
    if (y > 127.499992f) {
        y = 127.499992f;
    }
    precise float k = floor(y + 0.5f);
    precise float z = (y - k) * 0.693147182f;
    precise float p = 1.0f + z * (1.0f + z * 0.5f * (1.0f + z * 0.333333343f * (1.0f + z * 0.25f * (1.0f + z * 0.200000003f * (1.0f + z * 0.166666672f * (1.0f + z * 0.142857149f))))));
    precise float scale = intBitsToFloat((int(k) + 127) << 23);
    precise float r = p * scale;
    return r;
}

// x^n for x >= 0, n > 0 (specular highlights).
precise float pow_portable(float x, float n) {
    if (x <= 0.0f) {
        return 0.0f;
    }
#ifdef FAST_MATH
    return pow(x, n);
#else
    precise float r = exp2_portable(n * log2_portable(x));
    return r;
#endif
}

// acos(x) in radians, Abramowitz & Stegun 4.4.46: |error| <= 2e-8 on [0, 1],
// acos(-x) = pi - acos(x). x is clamped to [-1, 1].
precise float acos_portable(float x) {
    precise float c = min_f(max_f(x, -1.0f), 1.0f);
#ifdef FAST_MATH
    return acos(c);
#else
    precise float a = abs(c);
    precise float p = ((((((-0.0012624911f * a + 0.0066700901f) * a - 0.0170881256f) * a + 0.0308918810f) * a - 0.0501743046f) * a + 0.0889789874f) * a - 0.2145988016f) * a + 1.57079630f;
    precise float r = sqrt_rn(1.0f - a) * p;
    if (c < 0.0f) {
        // pi - r with pi in two parts: the float nearest pi is 8.7e-8 too big.
        r = (3.14159274f - r) - 8.74227766e-8f;
    }
    return r;
#endif
}

// asin(x) = pi/2 - acos(x), radians.
precise float asin_portable(float x) {
#ifdef FAST_MATH
    return asin(min_f(max_f(x, -1.0f), 1.0f));
#else
    precise float r = 1.57079637f - acos_portable(x);
    return r;
#endif
}

// atan(x) in radians: |x| > 1 through pi/2 - atan(1/x); |x| > tan(pi/12)
// through atan(x) = pi/6 + atan((x sqrt(3) - 1) / (x + sqrt(3))); then the
// odd series to x^11 on |x| <= 0.268 (error below 3e-9 before rounding).
precise float atan_portable(float x) {
#ifdef FAST_MATH
    return atan(x);
#else
    precise float a = abs(x);
    bool invert = a > 1.0f;
    if (invert) {
        a = div_rn(1.0f, a);
    }
    precise float offset = 0.0f;
    if (a > 0.267949194f) {
        a = div_rn(a * 1.73205078f - 1.0f, a + 1.73205078f);
        offset = 0.523598776f;
    }
    precise float s = a * a;
    precise float p = a * (1.0f + s * (-0.333333343f + s * (0.200000003f + s * (-0.142857149f + s * (0.111111112f + s * -0.0909090936f)))));
    precise float r = offset + p;
    if (invert) {
        r = 1.57079637f - r;
    }
    return (x < 0.0f) ? -r : r;
#endif
}

// atan2(y, x) in (-pi, pi], radians; atan2(0, 0) = 0.
precise float atan2_portable(float y, float x) {
#ifdef FAST_MATH
    // atan(y, x) is undefined at (0, 0), which stays 0 below.
    if (x != 0.0f || y != 0.0f) {
        return atan(y, x);
    }
#endif
    if (x > 0.0f) {
        return atan_portable(div_rn(y, x));
    }
    if (x < 0.0f) {
        precise float r = atan_portable(div_rn(y, x));
        return (y < 0.0f) ? r - PI : r + PI;
    }
    if (y > 0.0f) {
        return 1.57079637f;
    }
    if (y < 0.0f) {
        return -1.57079637f;
    }
    return 0.0f;
}
