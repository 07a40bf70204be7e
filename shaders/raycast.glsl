// raycast.glsl: everything computed per pixel — camera rays, the four
// canonical primitive tests, nearest hit, normals, local lighting and
// quantisation. Written once; it runs as GLSL in the compute kernels and
// compiles unchanged as C++ with GLM (the CPU build, see cpu/prelude.hpp).
//
// Exactness rules (../shared/docs/EXACTNESS.md), which every line obeys so
// that lavapipe and the CPU build agree bit for bit:
//   - no normalize(), no mat*vec, no built-in dot: fixed-order sums instead;
//   - `precise` on every float temporary and float-returning function;
//   - min / max / clamp as ternaries in GLM's operand order;
//   - no fma(), no transcendental built-ins: pow and acos are built here
//     from + - * / and sqrt;
//   - literals with the f suffix, at most 9 significant digits;
//   - no swizzles on the left of =, no out/inout, no struct constructors.
//
// The includer declares, before including this file, the scene buffers:
// scene_buffers.glsl in GLSL, host/cpu/shared.hpp in C++.

#ifndef RAYCAST_GLSL
#define RAYCAST_GLSL

const float PI = 3.14159265f;
const float DEGREES_PER_RADIAN = 57.2957795f;
// Larger than any t a ray can produce; a miss.
const float T_FAR = 3.40282347e38f;

// ---------------------------------------------------------------------------
// Portable arithmetic

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
// Every division and square root of this file goes through them.
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
    precise float len = sqrt_rn(dot3(v, v));
    precise vec3 r = div_rn(v, len);
    return r;
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
    precise float r = exp2_portable(n * log2_portable(x));
    return r;
}

// acos(x) in radians, Abramowitz & Stegun 4.4.46: |error| <= 2e-8 on [0, 1],
// acos(-x) = pi - acos(x). x is clamped to [-1, 1].
precise float acos_portable(float x) {
    precise float c = min_f(max_f(x, -1.0f), 1.0f);
    precise float a = abs(c);
    precise float p = ((((((-0.0012624911f * a + 0.0066700901f) * a - 0.0170881256f) * a + 0.0308918810f) * a - 0.0501743046f) * a + 0.0889789874f) * a - 0.2145988016f) * a + 1.57079630f;
    precise float r = sqrt_rn(1.0f - a) * p;
    if (c < 0.0f) {
        // pi - r with pi in two parts: the float nearest pi is 8.7e-8 too big.
        r = (3.14159274f - r) - 8.74227766e-8f;
    }
    return r;
}

// asin(x) = pi/2 - acos(x), radians.
precise float asin_portable(float x) {
    precise float r = 1.57079637f - acos_portable(x);
    return r;
}

// atan(x) in radians: |x| > 1 through pi/2 - atan(1/x); |x| > tan(pi/12)
// through atan(x) = pi/6 + atan((x sqrt(3) - 1) / (x + sqrt(3))); then the
// odd series to x^11 on |x| <= 0.268 (error below 3e-9 before rounding).
precise float atan_portable(float x) {
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
}

// atan2(y, x) in (-pi, pi], radians; atan2(0, 0) = 0.
precise float atan2_portable(float y, float x) {
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

// ---------------------------------------------------------------------------
// Rays and hits

struct Ray {
    vec3 origin;
    vec3 direction; // not unit: t is measured in multiples of it
};

// A hit on one canonical shape, in object space. t <= 0 (or T_FAR) is a miss.
struct ShapeHit {
    float t;
    vec3 normal; // object-space, not unit
};

// Nearest hit over the scene.
struct SceneHit {
    float t;       // T_FAR on a miss
    uint id;       // primitive index, NO_HIT on a miss
    vec3 normal;   // world-space unit normal
    vec3 p_object; // the hit point in the primitive's object space
    vec3 n_object; // its object-space normal as the shape test gave it (not unit)
    uint material; // the hit primitive's material and shape
    uint shape;
    uint item;     // the hit primitive's index in `primitives`
    uint passes;   // the walk's passes (AOV_COST; 0 in a kernel without HAS_AOVS)
};

ShapeHit no_hit() {
    ShapeHit h;
    h.t = T_FAR;
    h.normal = vec3(0.0f, 0.0f, 0.0f);
    return h;
}

// The primary ray through pixel (column j, row i; row 0 at the top), at
// `offset` pixels from its centre (0, 0 for the centre). The film point
// (x, y, -1) has x, y in [-1, 1]; world_from_film maps it to world space, so
// its linear part maps it to the ray direction.
Ray camera_ray(uint j, uint i, vec2 offset) {
    precise float x = div_rn((float(j) + 0.5f) + offset.x, float(frame.width)) * 2.0f - 1.0f;
    precise float y = 1.0f - div_rn((float(i) + 0.5f) + offset.y, float(frame.height)) * 2.0f;
    Ray r;
    r.origin = xyz(frame.eye);
    r.direction = transform_vector(frame.world_from_film, vec3(x, y, -1.0f));
    return r;
}

// ---------------------------------------------------------------------------
// Canonical shapes, object space (see docs/SCENE_FORMAT.md):
//   cube [-0.5, 0.5]^3, sphere r 0.5, cylinder r 0.5 with y in [-0.5, 0.5]
//   and both caps, cone with base r 0.5 at y = -0.5, apex at y = 0.5 and a
//   base cap.

// The ray parameter where the ray meets the plane {p[axis] = s}. A ray
// parallel to the plane gives +-inf or NaN, which every caller's `t > 0 &&
// t < best` rejects.
precise float plane_t(Ray r, int axis, float s) {
    precise float t = div_rn(s - r.origin[axis], r.direction[axis]);
    return t;
}

// Keeps `best` unless (t, normal) is a nearer hit with t > 0.
ShapeHit nearer(ShapeHit best, float t, vec3 normal) {
    if (t > 0.0f && t < best.t) {
        ShapeHit h;
        h.t = t;
        h.normal = normal;
        return h;
    }
    return best;
}

// Cube: each of the six face planes x, y, z = +-0.5, the hit point's other
// two coordinates within [-0.5, 0.5].
ShapeHit intersect_cube(Ray r) {
    ShapeHit best = no_hit();
    for (int axis = 0; axis < 3; axis++) {
        int a1 = (axis + 1) % 3;
        int a2 = (axis + 2) % 3;
        for (int side = 0; side < 2; side++) {
            float s = (side == 0) ? 0.5f : -0.5f;
            precise float t = plane_t(r, axis, s);
            precise float p1 = r.origin[a1] + t * r.direction[a1];
            precise float p2 = r.origin[a2] + t * r.direction[a2];
            if (abs(p1) <= 0.5f && abs(p2) <= 0.5f) {
                vec3 n = vec3(0.0f, 0.0f, 0.0f);
                n[axis] = s; // a component, not a swizzle
                best = nearer(best, t, n);
            }
        }
    }
    return best;
}

// The smaller and larger roots of a t^2 + b t + c = 0 as (t0, t1), or
// (T_FAR, T_FAR) when there is none. a == 0 gives the one root of the line.
precise vec2 quadratic_roots(float a, float b, float c) {
    if (a == 0.0f) {
        if (b == 0.0f) {
            return vec2(T_FAR, T_FAR);
        }
        precise float t = div_rn(-c, b);
        return vec2(t, t);
    }
    precise float disc = b * b - 4.0f * a * c;
    if (disc < 0.0f) {
        return vec2(T_FAR, T_FAR);
    }
    // q = -(b + sign(b) root) / 2 adds like signs, so neither root loses
    // digits to -b + root when a is small (a cone's a = dx^2 + dz^2 -
    // dy^2/4 for rays along its side): the roots are q / a and c / q.
    precise float root = sqrt_rn(disc);
    precise float q = -0.5f * (b + ((b < 0.0f) ? -root : root));
    if (q == 0.0f) {
        return vec2(0.0f, 0.0f); // b = disc = 0, so c = 0: a double root at 0
    }
    precise float q0 = div_rn(q, a);
    precise float q1 = div_rn(c, q);
    return (q1 < q0) ? vec2(q1, q0) : vec2(q0, q1);
}

// The t at which ray r passes closest to the point c. The quadrics and
// the bounding spheres solve from there rather than from the ray's origin,
// so that a ray from far off keeps their size (intersect_sphere).
precise float closest_t(Ray r, vec3 c) {
    precise float t = div_rn(dot3(c - r.origin, r.direction), dot3(r.direction, r.direction));
    return t;
}

// Sphere: |o + t d|^2 = 0.25; normal = the hit point. Solved from the
// ray's closest approach to the centre, not the quadratic's b^2 - 4ac,
// which loses the 0.25 against |o|^2 once the ray starts far off in object
// units: a sphere 3,000 radii away (the tips of recursive-spheres depth 8
// seen from the camera) has |o|^2 ~ 1e7, whose f32 step is 1, so it drew
// noise up to twice its size. This errs by a few f32 steps of |o|, so a
// bounding sphere with a small slack holds every hit (sphere_hit).
ShapeHit intersect_sphere(Ray r) {
    precise float a = dot3(r.direction, r.direction);
    precise float tc = closest_t(r, vec3(0.0f, 0.0f, 0.0f));
    precise vec3 closest = r.origin + tc * r.direction;
    precise float disc = 0.25f - dot3(closest, closest);
    precise float half_chord = sqrt_rn(div_rn(max_f(disc, 0.0f), a));
    precise vec2 ts = (disc < 0.0f) ? vec2(T_FAR, T_FAR) : vec2(tc - half_chord, tc + half_chord);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        best = nearer(best, t, p);
    }
    return best;
}

// Flat cap {y = s, x^2 + z^2 <= 0.25} with normal (0, ny, 0).
ShapeHit cap(ShapeHit best, Ray r, float s, float ny) {
    precise float t = plane_t(r, 1, s);
    precise float x = r.origin.x + t * r.direction.x;
    precise float z = r.origin.z + t * r.direction.z;
    precise float rr = x * x + z * z;
    if (rr <= 0.25f) {
        best = nearer(best, t, vec3(0.0f, ny, 0.0f));
    }
    return best;
}

// Cylinder: body x^2 + z^2 = 0.25 for y in [-0.5, 0.5], normal (x, 0, z);
// caps y = +-0.5. The body, as the sphere, from the ray's closest approach
// to the axis (in x and z), which keeps the 0.25 for rays from far off; a
// ray parallel to the axis (a = 0) meets the body nowhere or everywhere,
// and the caps decide.
ShapeHit intersect_cylinder(Ray r) {
    precise float a = r.direction.x * r.direction.x + r.direction.z * r.direction.z;
    precise float tc = div_rn(-(r.origin.x * r.direction.x + r.origin.z * r.direction.z), a);
    precise float cx = r.origin.x + tc * r.direction.x;
    precise float cz = r.origin.z + tc * r.direction.z;
    precise float disc = 0.25f - (cx * cx + cz * cz);
    precise float half_chord = sqrt_rn(div_rn(max_f(disc, 0.0f), a));
    precise vec2 ts = (a == 0.0f || disc < 0.0f) ? vec2(T_FAR, T_FAR) : vec2(tc - half_chord, tc + half_chord);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        if (abs(p.y) <= 0.5f) {
            best = nearer(best, t, vec3(p.x, 0.0f, p.z));
        }
    }
    best = cap(best, r, 0.5f, 1.0f);
    best = cap(best, r, -0.5f, -1.0f);
    return best;
}

// Cone body x^2 + z^2 = ((0.5 - y) / 2)^2 as a t^2 + b t + c = 0 for the
// points o + t d of ray r, with h = 0.5 - o.y:
//   a = dx^2 + dz^2 - dy^2 / 4
//   b = 2 (ox dx + oz dz) + h dy / 2
//   c = ox^2 + oz^2 - h^2 / 4
// Returned as (a, b, c).
precise vec3 cone_quadratic(Ray r) {
    precise float h = 0.5f - r.origin.y;
    precise float a = (r.direction.x * r.direction.x + r.direction.z * r.direction.z) - 0.25f * (r.direction.y * r.direction.y);
    precise float b = 2.0f * (r.origin.x * r.direction.x + r.origin.z * r.direction.z) + 0.5f * (h * r.direction.y);
    precise float c = (r.origin.x * r.origin.x + r.origin.z * r.origin.z) - 0.25f * (h * h);
    return vec3(a, b, c);
}

// Cone: the body for y in [-0.5, 0.5] with normal the gradient
// (2x, (0.5 - y) / 2, 2z), and the base cap y = -0.5. The quadratic is
// solved for the ray moved to its closest approach to the centre (t0), as
// the sphere, so that its c keeps the cone's size for rays from far off.
ShapeHit intersect_cone(Ray r) {
    precise float t0 = closest_t(r, vec3(0.0f, 0.0f, 0.0f));
    Ray near_centre;
    near_centre.origin = r.origin + t0 * r.direction;
    near_centre.direction = r.direction;
    precise vec3 q = cone_quadratic(near_centre);
    precise vec2 ss = quadratic_roots(q.x, q.y, q.z);
    precise vec2 ts = (ss.x == T_FAR) ? ss : vec2(t0 + ss.x, t0 + ss.y);
    ShapeHit best = no_hit();
    for (int k = 0; k < 2; k++) {
        precise float t = ts[k];
        precise vec3 p = r.origin + t * r.direction;
        if (abs(p.y) <= 0.5f) {
            best = nearer(best, t, vec3(2.0f * p.x, 0.5f * (0.5f - p.y), 2.0f * p.z));
        }
    }
    best = cap(best, r, -0.5f, -1.0f);
    return best;
}

// The test of shape `shape`; the HAS_* constants leave out the shapes a
// specialised kernel's scene does not have.
ShapeHit intersect_shape(uint shape, Ray r) {
    if (HAS_CUBES && shape == SHAPE_CUBE) {
        return intersect_cube(r);
    }
    if (HAS_CONES && shape == SHAPE_CONE) {
        return intersect_cone(r);
    }
    if (HAS_CYLINDERS && shape == SHAPE_CYLINDER) {
        return intersect_cylinder(r);
    }
    if (HAS_SPHERES) {
        return intersect_sphere(r);
    }
    return no_hit();
}

// ---------------------------------------------------------------------------
// Nearest hit and shadow rays

precise float max_abs3(vec3 v) {
    return max_f(max_f(abs(v.x), abs(v.y)), abs(v.z));
}

// How far a shadow or mirror ray starts from the surface point p, hit by a
// ray from `origin`: the course's 0.001, or 2^-14 of the largest coordinate
// of p and origin when that is larger. p = origin + t d is rounded at the
// scale of both; beyond 16 units a fixed 0.001 is only a few float steps,
// less than that rounding, and the ray would hit the surface it leaves.
// Scenes within 16 units of the origin are unaffected.
precise float ray_offset(vec3 p, vec3 origin) {
    precise float scaled = max_f(max_abs3(p), max_abs3(origin)) * 6.10351562e-5f;
    return max_f(0.001f, scaled);
}

// The ray in the object space of a primitive whose matrix is m.
Ray ray_through(mat4 m, Ray r) {
    Ray local;
    local.origin = transform_point(m, r.origin);
    local.direction = transform_vector(m, r.direction);
    return local;
}

// One axis of box_hit: the t interval `span` narrowed to where the ray is
// between that axis's planes lo and hi. A ray parallel to them is between
// them everywhere or nowhere (decided by the origin alone, so no 0/0 or inf
// arises); nowhere gives the empty (1, -1), which every later axis keeps
// empty. min/max are the NaN-safe ternaries.
precise vec2 slab(float o, float d, float lo, float hi, vec2 span) {
    if (d == 0.0f) {
        return (o < lo || o > hi) ? vec2(1.0f, -1.0f) : span;
    }
    precise float t0 = div_rn(lo - o, d);
    precise float t1 = div_rn(hi - o, d);
    return vec2(max_f(span.x, min_f(t0, t1)), min_f(span.y, max_f(t0, t1)));
}

// Whether ray r meets the box [lo, hi] at some t in [0, t_max]. The three
// axes one after the other, not a loop: lavapipe runs a loop with early
// exits pass by pass, and this test runs for every child and instance box
// (12% off recursiveSpheres4's dispatch). The interval only ever narrows,
// so testing it once at the end says what a test after each axis would.
bool box_hit(Ray r, vec4 lo, vec4 hi, float t_max) {
    precise vec2 span = vec2(0.0f, t_max);
    span = slab(r.origin.x, r.direction.x, lo.x, hi.x, span);
    span = slab(r.origin.y, r.direction.y, lo.y, hi.y, span);
    span = slab(r.origin.z, r.direction.z, lo.z, hi.z, span);
    return !(span.x > span.y);
}

// Whether ray r may meet the sphere (c, radius) at some t in [0, t_max]:
// the line passes within the radius of c, and the sphere reaches past
// t = 0 and back before t_max. An instance record's bound (layout.h,
// BvhNode) where frame.rs chose it over a box (its surface under twice the
// box's): one division where the box test has six, and around a round
// master it culls what the corners of a box would let through.
// Conservative: the radius grows by 2^-16 of c's offset from the origin,
// far more than the rounding of the closest approach here or of any
// shape's hit (each errs by a few f32 steps of the ray's offset).
bool sphere_hit(Ray r, vec3 c, float radius, float t_max) {
    precise vec3 oc = c - r.origin;
    precise float dd = dot3(r.direction, r.direction);
    precise float tc = closest_t(r, c);
    precise vec3 perp = oc - tc * r.direction;
    precise float reach = radius + max_abs3(oc) * 1.52587891e-5f;
    precise float rr = reach * reach;
    precise float past = tc - t_max;
    return dot3(perp, perp) <= rr && (tc >= 0.0f || tc * tc * dd <= rr) && (past <= 0.0f || past * past * dd <= rr);
}

// best, or the hit of ray lr (in the space of the primitive's group) with
// primitive `item` when it is nearer (on equal t, when its id, first_id
// plus its offset, is lower): its t, id, item and object-space point and
// normal. The walk finishes the hit it keeps after its loop (the world
// normal, material and shape).
SceneHit primitive_hit(SceneHit best, uint item, Ray lr, uint first_id) {
    Ray local = ray_through(primitive_at(item).object_from_world, lr);
    ShapeHit h = intersect_shape(primitive_at(item).shape, local);
    uint id = first_id + primitive_at(item).id_offset;
    if (h.t < best.t || (h.t == best.t && best.id != NO_HIT && id < best.id)) {
        precise vec3 p_object = local.origin + h.t * local.direction;
        best.t = h.t;
        best.id = id;
        best.item = item;
        best.n_object = h.normal;
        best.p_object = p_object;
    }
    return best;
}

// A traversal stack entry: the instance flag and index (or a node index) in
// the low bits, the level whose ray it uses above them.
uint stack_word(uint entry, uint level) {
    return entry | (level << STACK_LEVEL_SHIFT);
}

// The nearest hit of ray r with 0 < t < t_max (or, with any_hit, the first
// one found, its t and id only): on equal t the lowest primitive id, so the
// answer does not depend on the order things are tested in.
//
// The scene is a two-level (in general, nested) hierarchy: each group (the
// root tree, each master tree) has a BVH over its primitives and its
// instances of other groups; entering an instance maps the ray into the
// placed group's space, one matrix per level. Ids number primitives depth
// first in file order (as the host flattens them). Stack entries pair a
// node or an instance with the level whose ray it uses; deeper levels only
// ever sit above shallower ones, so each level keeps one ray. With
// FLAG_NO_BVH the boxes are ignored: every primitive is tested, through the
// same matrices, so the answer is bit for bit the same. frame.node_count 0
// means no hierarchy: primitives in order, each in world space.
//
// Shaped for lavapipe, which runs every branch of the loop body on every
// pass (masked, not skipped) and only ends the loop when every lane of its
// 8-wide vector is done: a pass costs the whole body, so each pass does as
// much as it can. Entering an instance goes straight on to its root node in
// the same pass; an inner node tests both children's boxes and pushes only
// those the ray meets, so a missed box costs no pass of its own; when the
// child left on top is a leaf, its items are tested in the same pass too.
// A leaf pushes an instance only when the ray meets the instance's box
// (so roots need no test of their own: the scene's root is entered whole,
// an instance's root lies inside the instance's box), and holds up to 8
// items when at most 4 are primitives (host/src/bvh.rs). On recursiveSpheres4 a camera
// ray takes 3 passes on average where it took 24 (BENCHMARKS.md, "What
// made lavapipe faster"). A loop inside a pass runs its body at least once
// even when no lane enters it, so a kernel keeps only the steps its scene
// has: the inner-node step (HAS_INNER_NODES), the loop over a leaf's
// primitives or a single test (HAS_SEVERAL_PRIMITIVE_LEAVES), the
// hierarchy or the flat list (HAS_HIERARCHY, HAS_FLAT_LIST).
SceneHit walk(Ray r, float t_max, bool any_hit) {
    SceneHit best;
    best.t = t_max;
    best.id = NO_HIT;
    best.normal = vec3(0.0f, 0.0f, 0.0f);
    best.p_object = vec3(0.0f, 0.0f, 0.0f);
    best.n_object = vec3(0.0f, 0.0f, 0.0f);
    best.material = 0u;
    best.shape = 0u;
    best.item = 0u;
    best.passes = 0u;
    bool use_boxes = (frame.flags & FLAG_NO_BVH) == 0u;
    vec3 level_origin[MAX_LEVELS];
    vec3 level_direction[MAX_LEVELS];
    uint level_first_id[MAX_LEVELS];
    uint level_instance[MAX_LEVELS];
    // The level of the nearest hit so far and the instances it lies in:
    // level_instance[l] while bit l of `unsaved` is set, else
    // best_instance[l] (kept there before the walk overwrote it).
    uint best_level = 0u;
    uint unsaved = 0u;
    uint best_instance[MAX_LEVELS];
    level_origin[0] = r.origin;
    level_direction[0] = r.direction;
    level_first_id[0] = 0u;
    level_instance[0] = 0u;
    uint stack[STACK_SIZE];
    int top = 0;
    if (frame.node_count > 0u) {
        stack[0] = frame.root_node;
        top = 1;
    }
    // Without a hierarchy: primitive `next` of primitive_count, in order.
    uint next = (frame.node_count > 0u) ? frame.primitive_count : 0u;
    while (top > 0 || next < frame.primitive_count) {
        if (HAS_AOVS) {
            best.passes = best.passes + 1u;
        }
        uint first_item = 0u;
        uint item_count = 0u;
        uint prim_count = 0u; // the leaf's primitives come first
        uint first_primitive = 0u; // the leaf's first primitive (BvhNode.axis)
        vec4 leaf_lo = vec4(0.0f); // the leaf's box: its instances' boxes are in steps of it
        vec4 leaf_hi = vec4(0.0f);
        uint level = 0u;
        uint level_first = 0u; // level_first_id[level]
        Ray lr = r;
        // A primitive index, not a leaf's item range. A scene has one kind
        // of walk or the other (frame.node_count), and its kernel keeps
        // only that one's code.
        bool direct = HAS_FLAT_LIST && (HAS_HIERARCHY ? top == 0 : true);
        if (direct) {
            first_item = next;
            item_count = 1u;
            prim_count = 1u;
            next = next + 1u;
        } else {
            top = top - 1;
            uint entry = stack[top] & STACK_ENTRY_MASK;
            level = (stack[top] >> STACK_LEVEL_SHIFT) & (MAX_LEVELS - 1u);
            if (LEVELS_IN_REGISTERS) {
                // A select over the scene's levels: once the loop unrolls,
                // every index is a constant and the arrays are registers
                // (layout.h, SPEC_LEVELS_IN_REGISTERS). The two forms are
                // written apart on purpose: one loop for both, its bounds
                // a select on the constant, did not unroll on lavapipe and
                // ran 1.17 to 1.26 times as long.
                lr.origin = level_origin[0];
                lr.direction = level_direction[0];
                level_first = level_first_id[0];
                for (uint l = 1u; l < REGISTER_LEVELS; l++) {
                    if (level == l) {
                        lr.origin = level_origin[l];
                        lr.direction = level_direction[l];
                        level_first = level_first_id[l];
                    }
                }
            } else {
                lr.origin = level_origin[level];
                lr.direction = level_direction[level];
                level_first = level_first_id[level];
            }
            if (HAS_INSTANCES && (entry & ITEM_INSTANCE) != 0u) {
                // Enter the instance: its group's ray one level down.
                uint k = entry & (ITEM_INSTANCE - 1u);
                Ray inner = ray_through(instance_at(k).object_from_parent, lr);
                uint child = level + 1u;
                uint child_first = level_first + instance_at(k).id_offset;
                if (LEVELS_IN_REGISTERS) {
                    for (uint l = 1u; l < REGISTER_LEVELS; l++) {
                        if (child == l) {
                            if (((unsaved >> l) & 1u) != 0u) {
                                best_instance[l] = level_instance[l];
                            }
                            level_origin[l] = inner.origin;
                            level_direction[l] = inner.direction;
                            level_first_id[l] = child_first;
                            level_instance[l] = k;
                        }
                    }
                } else {
                    if (((unsaved >> child) & 1u) != 0u) {
                        best_instance[child] = level_instance[child];
                    }
                    level_origin[child] = inner.origin;
                    level_direction[child] = inner.direction;
                    level_first_id[child] = child_first;
                    level_instance[child] = k;
                }
                unsaved = unsaved & ~(1u << child);
                level = child;
                level_first = child_first;
                lr = inner;
                entry = instance_at(k).root;
            }
            BvhNode node = node_at(entry);
            // Scenes whose every group fits one leaf (the recursive
            // spheres: a sphere and its child instances) have no inner
            // node, and their kernel leaves this block out (17% of
            // recursiveSpheres4's dispatch: lavapipe runs it on every pass).
            if (HAS_INNER_NODES && node.count == 0u) {
                // Children whose boxes the ray meets; the nearer (by the ray's sign on the split axis) on top.
                bool left_first = lr.direction[node.axis] >= 0.0f;
                uint c0 = left_first ? node.first + 1u : node.first;
                uint c1 = left_first ? node.first : node.first + 1u;
                uint pushed = NO_HIT;
                vec4 lo0 = node_at(c0).lo;
                vec4 hi0 = node_at(c0).hi;
                vec4 lo1 = node_at(c1).lo;
                vec4 hi1 = node_at(c1).hi;
                if (!use_boxes || box_hit(lr, lo0, hi0, best.t)) {
                    stack[top] = stack_word(c0, level);
                    top = top + 1;
                    pushed = c0;
                }
                if (!use_boxes || box_hit(lr, lo1, hi1, best.t)) {
                    stack[top] = stack_word(c1, level);
                    top = top + 1;
                    pushed = c1;
                }
                if (pushed == NO_HIT) {
                    continue;
                }
                // Its box is one of the two just read (its instances' boxes are relative to it).
                node = node_at(pushed);
                node.lo = (pushed == c1) ? lo1 : lo0;
                node.hi = (pushed == c1) ? hi1 : hi0;
                if (node.count == 0u) {
                    continue;
                }
                top = top - 1;
            }
            first_item = node.first;
            item_count = node.count;
            prim_count = HAS_INSTANCES ? node.primitives : node.count;
            first_primitive = node.axis;
            leaf_lo = node.lo;
            leaf_hi = node.hi;
        }
        uint first_id = level_first;
        uint best_before = best.id;
        if (HAS_SEVERAL_PRIMITIVE_LEAVES) {
            for (uint n = 0u; n < prim_count; n++) {
                best = primitive_hit(best, direct ? first_item : leaf_item(first_item + n), lr, first_id);
            }
        } else if (prim_count > 0u) {
            // At most one: an `if`, not a loop (12% of recursiveSpheres4's
            // dispatch: a lavapipe loop costs far more than its body).
            best = primitive_hit(best, direct ? first_item : first_primitive, lr, first_id);
        }
        if (best.id != best_before) {
            // A nearer hit in this leaf (ids are unique, so it has another
            // one): its normal is mapped to the world after the walk,
            // through the instances of levels 1 to `level`, which are
            // kept as the walk moves on (entering an instance above).
            // Mapping it here took a loop over the levels, and lavapipe
            // runs a loop's body at least once on every pass (15% of the
            // camera rays' time at recursive-spheres depth 8).
            if (HAS_INSTANCES) {
                best_level = level;
                unsaved = (2u << level) - 2u;
            }
            if (any_hit) {
                return best;
            }
        }
        // Then the leaf's instances (after its primitives, whose hits cull
        // their boxes). Each kind has a loop of its own: lavapipe runs the
        // whole body of a loop on every pass, so one loop over both would
        // run the primitive test for every instance and the box test for
        // every primitive.
        if (HAS_INSTANCES) {
            // Their records follow the primitives from the next multiple
            // of 4, each box in steps of the leaf's (layout.h, BvhNode).
            precise vec3 step = div_rn(xyz(leaf_hi) - xyz(leaf_lo), float(BOX_STEPS));
            uint records = (first_item + prim_count + 3u) >> 2u;
            for (uint n = prim_count; n < item_count; n++) {
                // Pushed only when the ray meets the instance's bound: a
                // missed instance costs no pass. The bound is a box or a
                // sphere (RECORD_SPHERE; a scene's kernel keeps the tests
                // its records need), whose centre is where a box's lo is.
                uvec4 record = leaf_record(records + (n - prim_count));
                precise vec3 q_lo = vec3(float(record.x & 0xffffu), float(record.x >> 16u), float(record.y & 0xffffu));
                precise vec3 lo = xyz(leaf_lo) + q_lo * step;
                bool sphere = HAS_SPHERE_RECORDS && (HAS_BOX_RECORDS ? (record.w & RECORD_SPHERE) != 0u : true);
                bool meets = !use_boxes;
                if (sphere) {
                    meets = meets || sphere_hit(lr, lo, uintBitsToFloat(record.z), best.t);
                } else if (HAS_BOX_RECORDS) {
                    precise vec3 q_hi = vec3(float(record.y >> 16u), float(record.z & 0xffffu), float(record.z >> 16u));
                    precise vec3 hi = xyz(leaf_hi) - q_hi * step;
                    meets = meets || box_hit(lr, vec4(lo, 0.0f), vec4(hi, 0.0f), best.t);
                }
                if (meets) {
                    stack[top] = stack_word(record.w & ~RECORD_SPHERE, level);
                    top = top + 1;
                }
            }
        }
    }
    if (best.id != NO_HIT) {
        // The normal in the world: in the primitive's group, then by the
        // normal rule level by level back up (unit at the end).
        Primitive hit_primitive = primitive_at(best.item);
        precise vec3 n_world = transform_normal(hit_primitive.object_from_world, best.n_object);
        if (HAS_INSTANCES) {
            if (LEVELS_IN_REGISTERS) {
                // The same order, deepest first, over the scene's levels.
                for (uint i = 1u; i < REGISTER_LEVELS; i++) {
                    uint l = REGISTER_LEVELS - i;
                    if (l <= best_level) {
                        uint placed = (((unsaved >> l) & 1u) != 0u) ? level_instance[l] : best_instance[l];
                        n_world = transform_normal(instance_at(placed).object_from_parent, n_world);
                    }
                }
            } else {
                for (uint l = best_level; l > 0u; l--) {
                    uint placed = (((unsaved >> l) & 1u) != 0u) ? level_instance[l] : best_instance[l];
                    n_world = transform_normal(instance_at(placed).object_from_parent, n_world);
                }
            }
        }
        best.normal = unit(n_world);
        best.material = hit_primitive.material;
        best.shape = hit_primitive.shape;
    } else {
        best.t = T_FAR;
    }
    return best;
}

// The nearest hit of ray r with t > 0 (T_FAR and NO_HIT on a miss).
SceneHit trace(Ray r) {
    return walk(r, T_FAR, false);
}

// ---------------------------------------------------------------------------
// Texture mapping (docs/SCENE_FORMAT.md: UV per shape, v = 0 at the top row)

// u in [0, 1) around the y axis: (-atan2(z, x) / 2 pi) mod 1.
precise float around_y(vec3 p) {
    precise float u = -atan2_portable(p.z, p.x) * 0.159154937f;
    if (u < 0.0f) {
        u = u + 1.0f;
    }
    return u;
}

// (u, v) of an object-space hit point p with the shape test's normal n.
precise vec2 surface_uv(uint shape, vec3 p, vec3 n) {
    if (HAS_CUBES && shape == SHAPE_CUBE) {
        if (n.x > 0.0f) {
            return vec2(0.5f - p.z, 0.5f - p.y);
        }
        if (n.x < 0.0f) {
            return vec2(p.z + 0.5f, 0.5f - p.y);
        }
        if (n.y > 0.0f) {
            return vec2(p.x + 0.5f, p.z + 0.5f);
        }
        if (n.y < 0.0f) {
            return vec2(p.x + 0.5f, 0.5f - p.z);
        }
        if (n.z > 0.0f) {
            return vec2(p.x + 0.5f, 0.5f - p.y);
        }
        return vec2(0.5f - p.x, 0.5f - p.y);
    }
    if (HAS_SPHERES && shape == SHAPE_SPHERE) {
        return vec2(around_y(p), 0.5f - asin_portable(2.0f * p.y) * 0.318309873f);
    }
    // Cylinder and cone: caps have the normal (0, +-1, 0), bodies n.y >= 0
    // for the cone and 0 for the cylinder.
    if (n.y < 0.0f && n.x == 0.0f && n.z == 0.0f) {
        return vec2(p.x + 0.5f, 0.5f - p.z);
    }
    if (n.y > 0.0f && n.x == 0.0f && n.z == 0.0f && shape == SHAPE_CYLINDER) {
        return vec2(p.x + 0.5f, p.z + 0.5f);
    }
    return vec2(around_y(p), 0.5f - p.y);
}

// Texel (column, row) of texture tex as RGB in [0, 1].
precise vec3 texel_rgb(Texture tex, uint column, uint row) {
    uint v = texels[tex.offset + row * tex.width + column].rgba;
    precise vec3 c = div_rn(vec3(float(v & 255u), float((v >> 8u) & 255u), float((v >> 16u) & 255u)), 255.0f);
    return c;
}

// Wraps a texel coordinate x into [0, size): floor(x) mod size, the
// modulus of arithmetic (never negative), so a negative repeat count tiles
// the texture as a positive one does, the other way (the spec's rule;
// until 2026-11-27 x was held at 0 and such a texture was one texel).
// Beyond 1e9 texels either way x is held there (a repeat count that large
// has no picture to show).
uint wrap(float x, uint size) {
    precise float f = floor(max_f(min_f(x, 1.0e9f), -1.0e9f));
    if (f < 0.0f) {
        uint r = uint(-f) % size;
        return (r == 0u) ? 0u : size - r;
    }
    return uint(f) % size;
}

// The bilinear filter of sample_texture at texel coordinates (x, y).
precise vec3 bilinear(Texture tex, float x, float y) {
    precise float bx = x - 0.5f;
    precise float by = y - 0.5f;
    precise float fx = bx - floor(bx);
    precise float fy = by - floor(by);
    uint c0 = wrap(bx, tex.width);
    uint c1 = (c0 + 1u) % tex.width;
    uint r0 = wrap(by, tex.height);
    uint r1 = (r0 + 1u) % tex.height;
    precise vec3 top = texel_rgb(tex, c0, r0) * (1.0f - fx) + texel_rgb(tex, c1, r0) * fx;
    precise vec3 bottom = texel_rgb(tex, c0, r1) * (1.0f - fx) + texel_rgb(tex, c1, r1) * fx;
    precise vec3 c = top * (1.0f - fy) + bottom * fy;
    return c;
}

// T(u, v): u, v clamped to [0, 1], scaled by the repeat counts. Nearest:
// column floor(u r_u W) mod W, row floor(v r_v H) mod H. Bilinear: the four
// texels around (u r_u W - 1/2, v r_v H - 1/2), wrapped, weighted in a fixed order.
precise vec3 sample_texture(Material m, vec2 uv) {
    Texture tex = textures[uint(m.texture)];
    precise float x = (clamp01(uv.x) * m.texture_repeat.x) * float(tex.width);
    precise float y = (clamp01(uv.y) * m.texture_repeat.y) * float(tex.height);
    if (HAS_BILINEAR && frame.texture_filter != FILTER_NEAREST) {
        return bilinear(tex, x, y);
    }
    return texel_rgb(tex, wrap(x, tex.width), wrap(y, tex.height));
}

// ---------------------------------------------------------------------------
// Local lighting (docs/SCENE_FORMAT.md, "Lighting model of the official renders")

// light_intensity of a point or spot light of colour `color`.
precise vec3 positioned_light_intensity(Light l, vec3 color, vec3 to_light, float dist) {
    precise float falloff = (l.attenuation.x + l.attenuation.y * dist) + l.attenuation.z * (dist * dist);
    precise float att = min_f(1.0f, div_rn(1.0f, falloff));
    precise vec3 intensity = color * att;
    if (HAS_SPOT_LIGHTS && l.kind == LIGHT_SPOT) {
        // Angle between the spot axis and (p - position) = -to_light.
        precise float cos_theta = -dot3(xyz(l.spot_axis), to_light);
        precise float theta = acos_portable(cos_theta) * DEGREES_PER_RADIAN;
        precise float inner = l.angle_deg - l.penumbra_deg;
        if (theta > l.angle_deg) {
            return vec3(0.0f, 0.0f, 0.0f);
        }
        if (theta > inner) {
            precise float x = div_rn(theta - inner, l.penumbra_deg);
            precise float smooth_step = (3.0f * (x * x)) - 2.0f * ((x * x) * x);
            intensity = intensity * (1.0f - smooth_step);
        }
    }
    return intensity;
}

// The intensity of light `l` arriving along unit `to_light` (pointing at the
// light) from `dist` away, before shadows: colour, distance attenuation and
// spot falloff.
precise vec3 light_intensity(Light l, vec3 to_light, float dist) {
    precise vec3 intensity = xyz(l.color);
    if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
        return positioned_light_intensity(l, intensity, to_light, dist);
    }
    return intensity;
}

// The shading of one hit, a light at a time (sample_pixel): Phong at the
// hit point p with unit normal n, seen from v (toward the viewer), of a
// surface whose diffuse colour is already blended with its texel.
struct Surface {
    vec3 p;
    vec3 n;
    vec3 v;
    vec3 base;     // ambient + emissive: the colour before any light
    vec3 diffuse;
    vec3 specular;
    float shininess;
    vec3 mirror;   // the mirror ray's weight k_s O_r
};

// The surface at `hit`, seen along ray r: everything its shading reads of
// its material, read once.
Surface surface_at(Ray r, SceneHit hit) {
    Material m = material_at(hit.material);
    Surface s;
    precise vec3 p = r.origin + hit.t * r.direction;
    s.p = p;
    s.n = hit.normal;
    precise vec3 v = -unit(r.direction);
    s.v = v;
    precise vec3 base = frame.k.x * xyz(m.ambient) + xyz(m.emissive);
    s.base = base;
    precise vec3 diffuse = frame.k.y * xyz(m.diffuse);
    if (HAS_TEXTURES && m.texture >= 0 && (frame.flags & FLAG_TEXTURES) != 0u) {
        precise vec3 texel = sample_texture(m, surface_uv(hit.shape, hit.p_object, hit.n_object));
        diffuse = (1.0f - m.blend) * diffuse + m.blend * texel;
    }
    s.diffuse = diffuse;
    precise vec3 specular = frame.k.z * xyz(m.specular);
    s.specular = specular;
    s.shininess = m.shininess;
    precise vec3 mirror = frame.k.z * xyz(m.reflective);
    s.mirror = mirror;
    return s;
}

// What light l adds at surface s when nothing shadows it: diffuse and
// specular times its intensity. to_light is the unit vector toward it.
precise vec3 light_term(Surface s, Light l, vec3 to_light, float dist) {
    precise vec3 intensity = light_intensity(l, to_light, dist);
    precise float n_dot_l = dot3(s.n, to_light);
    precise vec3 term = s.diffuse * max_f(0.0f, n_dot_l);
    if (HAS_SPECULAR && s.shininess > 0.0f) {
        precise vec3 reflected = (2.0f * n_dot_l) * s.n - to_light;
        precise float highlight = pow_portable(max_f(0.0f, dot3(reflected, s.v)), s.shininess);
        term = term + s.specular * highlight;
    }
    precise vec3 lit = intensity * term;
    return lit;
}

// Whether every channel of c is 0 or subnormal (below 2^-126 in size). A
// light term or mirror weight that small changes no pixel (the colours it
// would add are below 2^-126, far under a step of 1/255), and a GPU may
// flush it to 0 where the CPU build keeps it (NVIDIA promises no
// subnormals), so both builds treat it as nothing: no shadow or mirror ray.
bool negligible(vec3 c) {
    return abs(c.x) < 1.17549435e-38f && abs(c.y) < 1.17549435e-38f && abs(c.z) < 1.17549435e-38f;
}

precise vec3 clamp3(vec3 c) {
    return vec3(clamp01(c.x), clamp01(c.y), clamp01(c.z));
}

// ---------------------------------------------------------------------------
// Output

// floor(255 c) per channel (truncation, as the official renders), alpha 255.
uint pack_rgba8(vec3 c) {
    precise float r = floor(255.0f * c.x);
    precise float g = floor(255.0f * c.y);
    precise float b = floor(255.0f * c.z);
    return (uint(r) | (uint(g) << 8u)) | ((uint(b) << 16u) | (255u << 24u));
}

// ---------------------------------------------------------------------------
// The AOVs other than colour (layout.h AOV_*): what the first hit shows.

// Grey by distance: white at `near`, black at `far` and beyond.
precise float depth_grey(float dist, float near, float far) {
    precise float span = max_f(far - near, 1e-6f);
    return 1.0f - clamp01(div_rn(dist - near, span));
}

// A colour per primitive id: its bits scrambled into three bytes, kept
// away from black (which is a miss).
precise vec3 id_color(uint id) {
    uint h = (id + 1u) * 2654435761u;
    h = h ^ (h >> 15u);
    precise vec3 bytes = vec3(float(h & 255u), float((h >> 8u) & 255u), float((h >> 16u) & 255u));
    precise vec3 c = div_rn(bytes, 255.0f) * 0.75f;
    return c + 0.25f;
}

// x in [0, 1] (clamped) on a heat scale: dark blue, blue, cyan, green,
// yellow, red, dark red ("jet").
precise vec3 heat_color(float x) {
    precise float s = 4.0f * clamp01(x);
    return vec3(clamp01(1.5f - abs(s - 3.0f)), clamp01(1.5f - abs(s - 2.0f)), clamp01(1.5f - abs(s - 1.0f)));
}

// What AOV `aov` (not AOV_COLOR) shows of hit h (a miss only for
// AOV_COST) of camera ray r.
precise vec3 aov_color(uint aov, Ray r, SceneHit h) {
    if (aov == AOV_NORMAL) {
        precise vec3 c = (h.normal + 1.0f) * 0.5f;
        return clamp3(c);
    }
    if (aov == AOV_DEPTH) {
        precise float dist = h.t * sqrt_rn(dot3(r.direction, r.direction));
        precise float g = depth_grey(dist, frame.aov_scale.x, frame.aov_scale.y);
        return vec3(g, g, g);
    }
    if (aov == AOV_COST) {
        return heat_color(div_rn(float(h.passes), frame.aov_scale.z));
    }
    return id_color(h.id);
}

// One sample of a pixel: the primary ray's nearest hit and the colour it
// gives (the shaded colour with reflections, or an AOV's), each
// channel in [0, 1], and every ray traced for it, the camera ray included.
struct PixelSample {
    SceneHit hit;
    vec3 color;
    uint rays;
};

// The camera ray through (j, i) at `offset` and color(ray, depth) of the
// lighting model without recursion: trace the ray and its mirror path,
// keeping each level's local colour and mirror weight k_s O_r, then fold
// from the deepest level up, clamping at every level:
//   c_k = clamp(local_k + weight_k c_(k+1)).
// A level's local colour is Phong: ambient + emissive, then for each light
// in order that would add something (a light facing away or outside its
// spot adds +-0, and a subnormal term (`negligible`) less than any step
// of a stored colour: neither is added, so neither needs a shadow ray)
// and that no shadow ray finds blocked, its diffuse (textured: blended
// with the texel) and specular term. Not clamped until the fold.
//
// Every ray, camera, shadow or mirror, goes through the one walk call at
// the top of the loop: each pass traces the pixel's next ray, then goes on
// from its answer to the next ray, the next light's shadow ray or the
// level's mirror ray. Lavapipe turns every copy of the walk into code on
// every pipeline build (a copy for shadow rays took a third of
// recursiveSpheres4's), and runs a vector's lanes through a copy together:
// with one, a lane's mirror ray goes beside a neighbour's shadow ray, not
// after it. (Keeping the lanes in step, one pass per light whether its
// shadow ray is needed or not, was 4-8% slower.) With another AOV than
// colour, the first hit only (aov_color).
//
// Each step is also a TRACE (layout.h TraceStep): the CPU build records
// them for `raycast trace`; in a kernel TRACE is nothing.
#ifndef TRACE
#define TRACE(kind, level, light, id, passes, origin, direction, value, extra)
#endif
PixelSample sample_pixel(uint j, uint i, vec2 offset) {
    Ray ray = camera_ray(j, i, offset); // the level's ray: the camera's, then the mirror's
    PixelSample s;
    s.color = vec3(0.0f, 0.0f, 0.0f);
    s.rays = 0u;
    vec3 local_at[MAX_DEPTH + 1];
    vec3 weight_at[MAX_DEPTH + 1];
    uint depth = min(frame.max_depth, uint(MAX_DEPTH));
    bool reflections = HAS_REFLECTIONS && (frame.flags & FLAG_REFLECTIONS) != 0u;
    bool shadows = HAS_SHADOWS && (frame.flags & FLAG_SHADOWS) != 0u;
    uint levels = 0u;
    uint level = 0u;
    // The ray traced next: the level's ray, or (shadow) the shadow ray of
    // light li, whose term `pending` is added unless something blocks it.
    Ray next = ray;
    float next_t_max = T_FAR;
    bool shadow = false;
    Surface surface;
    precise vec3 color = vec3(0.0f, 0.0f, 0.0f);
    precise vec3 pending = vec3(0.0f, 0.0f, 0.0f);
    uint li = 0u;
    uint passes = 0u; // every walk's, for AOV_COST_ALL
    // Whether s.hit holds the camera ray's hit. Not `level == 0u`: with
    // that test Mesa 22.3's lavapipe stored 0 as the normal of a lane that
    // left the loop while a neighbour went on tracing mirror rays, its t,
    // id and colour right. By every sign it ran the assignment again in the
    // neighbour's later pass, with that pass's walk of the lane's camera ray
    // (the same t and id), whose normal, computed under a branch the lane
    // was masked out of, stayed 0; one invocation alone (check --pixel) was
    // right. Kept by a flag, it is right (found by fuzzing `check`;
    // mirror_depth.xml at 160x120 --no-shadows: 636 pixels; Mesa 25.0 did
    // not). tests/check.rs, "160x120 --no-shadows", over
    // tests/scenes/stress/mirrors_beside_matte.xml.
    bool first_kept = false;
    while (true) {
        SceneHit h = walk(next, next_t_max, shadow);
        s.rays = s.rays + 1u;
        TRACE(shadow ? TRACE_SHADOW : (level == 0u ? TRACE_CAMERA : TRACE_MIRROR), level, li, h.id, h.passes,
              vec4(next.origin, 0.0f), vec4(next.direction, next_t_max), vec4(h.normal, h.t), vec4(0.0f));
        if (HAS_AOVS) {
            passes = passes + h.passes;
        }
        if (shadow) {
            if (h.id == NO_HIT) {
                color = color + pending;
            }
            li = li + 1u;
        } else {
            if (!first_kept) {
                s.hit = h;
                first_kept = true;
            }
            // The AOVs other than colour: the first hit's, black on a miss
            // but for the cost, which a miss has too. AOV_COST_ALL goes on
            // as colour does, its picture made at the end.
            if (HAS_AOVS && frame.aov != AOV_COLOR && frame.aov != AOV_COST_ALL && (h.id != NO_HIT || frame.aov == AOV_COST)) {
                s.color = aov_color(frame.aov, ray, h);
                break;
            }
            if (h.id == NO_HIT) {
                break;
            }
            surface = surface_at(ray, h);
            color = surface.base;
            TRACE(TRACE_SURFACE, level, 0u, h.id, 0u, vec4(surface.p, 1.0f), vec4(0.0f), vec4(surface.base, 0.0f),
                  vec4(surface.diffuse, 0.0f));
            li = 0u;
        }
        // The lights from li on: each adds its term, up to the first that
        // needs a shadow ray.
        shadow = false;
        while (li < frame.light_count) {
            Light l = light_at(li);
            precise vec3 to_light = xyz(l.direction_to_light);
            precise float dist = 0.0f;
            if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
                precise vec3 d = xyz(l.position) - surface.p;
                dist = sqrt_rn(dot3(d, d));
                to_light = div_rn(d, dist);
            }
            precise vec3 lit = light_term(surface, l, to_light, dist);
            if (negligible(lit)) {
                TRACE(TRACE_LIGHT, level, li, TRACE_LIGHT_NOTHING, 0u, vec4(0.0f), vec4(to_light, dist), vec4(lit, 0.0f), vec4(0.0f));
                li = li + 1u;
                continue;
            }
            TRACE(TRACE_LIGHT, level, li, shadows ? TRACE_LIGHT_SHADOW : TRACE_LIGHT_ADDED, 0u, vec4(0.0f),
                  vec4(to_light, dist), vec4(lit, 0.0f), vec4(0.0f));
            if (shadows) {
                // From 0.001 (ray_offset) along L toward the light: blocked
                // by anything closer than the light (anything at all for a
                // directional light).
                precise vec3 shadow_origin = surface.p + ray_offset(surface.p, ray.origin) * to_light;
                next.origin = shadow_origin;
                next.direction = to_light;
                precise float t_max = T_FAR;
                if (HAS_POSITIONED_LIGHTS && l.kind != LIGHT_DIRECTIONAL) {
                    precise vec3 rest = xyz(l.position) - shadow_origin;
                    t_max = sqrt_rn(dot3(rest, rest));
                }
                next_t_max = t_max;
                pending = lit;
                shadow = true;
                break;
            }
            color = color + lit;
            li = li + 1u;
        }
        if (shadow) {
            continue;
        }
        local_at[level] = color;
        levels = level + 1u;
        precise vec3 w = surface.mirror;
        weight_at[level] = w;
        TRACE(TRACE_LEVEL, level, 0u, 0u, 0u, vec4(0.0f), vec4(0.0f), vec4(color, 0.0f), vec4(w, 0.0f));
        if (!reflections || level == depth || negligible(w)) {
            break;
        }
        // Mirror direction of the unit ray direction about N, from 0.001
        // (ray_offset) along it.
        precise vec3 d = -surface.v;
        precise vec3 mirror = d - (2.0f * dot3(surface.n, d)) * surface.n;
        precise vec3 mirror_origin = surface.p + ray_offset(surface.p, ray.origin) * mirror;
        ray.origin = mirror_origin;
        ray.direction = mirror;
        next = ray;
        next_t_max = T_FAR;
        level = level + 1u;
    }
    if (levels > 0u) {
        precise vec3 c = vec3(0.0f, 0.0f, 0.0f);
        for (uint k = levels; k > 0u; k--) {
            if (k == levels) {
                c = clamp3(local_at[k - 1u]);
            } else {
                c = clamp3(local_at[k - 1u] + weight_at[k - 1u] * c);
            }
        }
        s.color = c;
    }
    if (HAS_AOVS && frame.aov == AOV_COST_ALL) {
        // Every ray's walk, on the cost's scale; PixelOut.normal's w gets the
        // same sum (pixel_out writes the hit's passes).
        s.color = heat_color(div_rn(float(passes), frame.aov_scale.z));
        s.hit.passes = passes;
    }
    TRACE(TRACE_PIXEL, levels, 0u, pack_rgba8(s.color), passes, vec4(0.0f), vec4(0.0f), vec4(s.color, 0.0f), vec4(0.0f));
    return s;
}

// The radical inverse of s in base 2 (van der Corput): its bits mirrored
// about the binary point. Exact in float for s < 2^24.
precise float radical_inverse(uint s) {
    precise float r = 0.0f;
    precise float f = 0.5f;
    for (uint k = s; k != 0u; k = k >> 1u) {
        if ((k & 1u) != 0u) {
            r = r + f;
        }
        f = f * 0.5f;
    }
    return r;
}

// Supersampling pattern: sample s of n is at ((s + 1/2) / n, frac(vdc(s) +
// 1/(2n))) in the pixel (a Hammersley set shifted by half a stratum), as an
// offset from the pixel centre. n = 1 gives the centre; n = 4 gives
// (+-1/8 or +-3/8) in both axes, one sample per row and column stratum.
vec2 sample_offset(uint s, uint n) {
    precise float x = div_rn(float(s) + 0.5f, float(n)) - 0.5f;
    precise float y = radical_inverse(s) + div_rn(0.5f, float(n));
    if (y >= 1.0f) {
        y = y - 1.0f;
    }
    precise float y_offset = y - 0.5f;
    return vec2(x, y_offset);
}

// What a pixel stores: the hit's t, id and normal (0, NO_HIT and 0 on a
// miss), `color` quantised and the number of rays traced for it.
PixelOut pixel_out(SceneHit hit, vec3 color, uint rays) {
    PixelOut o;
    o.rays = rays;
    o.rgba = pack_rgba8(color);
    // w: the walk's passes, hit or miss, in an AOV other than colour (a
    // colour kernel leaves their count out; the CPU build counts them anyway).
    precise float passes = (frame.aov != AOV_COLOR) ? float(hit.passes) : 0.0f;
    if (hit.id == NO_HIT) {
        o.normal = vec4(0.0f, 0.0f, 0.0f, passes);
        o.t = 0.0f;
        o.id = NO_HIT;
    } else {
        o.normal = vec4(hit.normal, passes);
        o.t = hit.t;
        o.id = hit.id;
    }
    return o;
}

// The pixel of invocation k (gl_LocalInvocationIndex) of workgroup `group`
// in the kernels' 8x8 tiles (WORKGROUP_SIZE; the bit layout assumes 8).
// Lavapipe runs invocations 8n .. 8n+7 as one 8-wide vector, so these are
// a 4x2 block of pixels rather than a row of 8: rays closer together take
// more alike paths through the hierarchy, and the vector's loops end sooner
// (9% on recursiveSpheres4). Every pixel of the tile is still one
// invocation's; GPUs with 32-wide subgroups still get 8x4 blocks.
uvec2 tile_pixel(uvec2 group, uint k) {
    uint x = (k & 3u) | (((k >> 3u) & 1u) << 2u);
    uint y = ((k >> 2u) & 1u) | ((k >> 4u) << 1u);
    return uvec2(group.x * uint(WORKGROUP_SIZE) + x, group.y * uint(WORKGROUP_SIZE) + y);
}

// Whether the device ran every loop of this invocation to its end.
// Mesa's llvmpipe (lavapipe) gives each shader invocation 65535 loop
// iterations in all, counted over every loop it runs
// (LP_MAX_TGSI_LOOP_ITERATIONS), then ends each loop after its first pass
// without a word: a pixel that needs more comes out wrong. Run last, this
// loop of frame.loop_canary passes (LOOP_CANARY, 2, unknown to the
// compiler, so it is not unrolled) finds out: cut short, it runs once. The
// CPU build always runs it to the end; a frame with loop_canary 0 (the
// harness's zeroed default) asks nothing.
bool loop_budget_ok() {
    uint passes = 0u;
    for (uint k = 0u; k < frame.loop_canary; k++) {
        passes = passes + 1u;
    }
    return passes == frame.loop_canary;
}

// The colour a pixel stores: its n samples' colour sum over n.
precise vec3 sample_average(vec3 sum, uint n) {
    precise vec3 average = div_rn(sum, float(n));
    return average;
}

// Everything one pixel computes (the CPU build's and the harness's way;
// render.comp computes the same one sample per dispatch): frame.spp samples in the fixed pattern,
// their colours summed in sample order and divided by the count; t, id and
// normal from the first sample (the pixel centre when spp = 1); the rays of
// every sample.
PixelOut render_pixel(uint j, uint i) {
    uint n = max(frame.spp, 1u);
    PixelSample first = sample_pixel(j, i, sample_offset(0u, n));
    precise vec3 sum = first.color;
    uint rays = first.rays;
    for (uint s = 1u; s < n; s++) {
        PixelSample next = sample_pixel(j, i, sample_offset(s, n));
        sum = sum + next.color;
        rays = rays + next.rays;
    }
    PixelOut o = pixel_out(first.hit, sample_average(sum, n), rays);
    if (!loop_budget_ok()) {
        o.rays = o.rays | RAYS_CUT_SHORT;
    }
    return o;
}

#endif
