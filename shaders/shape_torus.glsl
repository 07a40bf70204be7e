// shape_torus.glsl: the torus about the y axis, ring radius 0.375 (the
// tube's centre line), tube radius 0.125: outer radius 0.5 and y in
// [-0.125, 0.125], inside the unit box (included by shapes.glsl;
// docs/scene-format.md#torus).
//
// Its surface is F(p) = (|p|^2 + R^2 - r^2)^2 - 4 R^2 (x^2 + z^2) = 0,
// R^2 - r^2 = 0.125 and 4 R^2 = 0.5625, a quartic along a ray. It is
// solved without a closed formula (Ferrari's loses every digit on grazing
// rays), from + - * / and sqrt alone, the same steps in every build:
//   1. the ray is moved to its closest approach c to the centre and its
//      direction made unit (e), so that p(s) = c + s e stays within the
//      torus's size and F keeps its digits for rays from far off; s is
//      clipped to the bounding sphere (radius 0.5), the slab |y| <= 0.125
//      and t > 0;
//   2. F''(s) is a quadratic: its roots cut the interval into at most
//      three pieces on each of which F' is monotone, so F' has at most one
//      root there (a critical point of F), found by safeguarded Newton;
//   3. F is then monotone between consecutive critical points: the first
//      piece whose ends differ in sign holds the nearest hit, refined by
//      the same safeguarded Newton.
// Newton's steps stay inside a bracket that shrinks with every step (a
// bisection where a step would leave it), and stop when a step no longer
// moves the point, or after TORUS_STEPS steps.

const float TORUS_RING = 0.375f;
const int TORUS_STEPS = 40;

// F at p (k == 0), or F' along e (k == 1), and its own derivative along
// e, as (value, slope); |e| = 1.
//   F   = q^2 - 0.5625 w,                 q = |p|^2 + 0.125, w = x^2 + z^2
//   F'  = 4 q (p.e) - 1.125 (x ex + z ez)
//   F'' = 8 (p.e)^2 + 4 q - 1.125 (ex^2 + ez^2)
precise vec2 torus_f(vec3 p, vec3 e, int k) {
    precise float q = dot3(p, p) + 0.125f;
    precise float pe = dot3(p, e);
    precise float we = p.x * e.x + p.z * e.z;
    precise float f1 = 4.0f * (q * pe) - 1.125f * we;
    if (k == 0) {
        precise float w = p.x * p.x + p.z * p.z;
        return vec2(q * q - 0.5625f * w, f1);
    }
    precise float f2 = (8.0f * (pe * pe) + 4.0f * q) - 1.125f * (e.x * e.x + e.z * e.z);
    return vec2(f1, f2);
}

// The root in [lo, hi] of F (k == 0) or F' (k == 1) along c + s e, whose
// values at the ends, f_lo and f_hi, differ in sign and between which it
// is monotone: Newton from the secant's point, each step kept inside the
// bracket (its midpoint instead where a step would leave it), the bracket
// narrowed by the sign at every point.
precise float torus_root(vec3 c, vec3 e, int k, float lo, float hi, float f_lo, float f_hi) {
    bool lo_negative = f_lo < 0.0f;
    precise float s = lo - f_lo * div_rn(hi - lo, f_hi - f_lo);
    if (!(s > lo && s < hi)) {
        s = 0.5f * (lo + hi);
    }
    for (int i = 0; i < TORUS_STEPS; i++) {
        precise vec2 g = torus_f(c + s * e, e, k);
        if (g.x == 0.0f) {
            break;
        }
        if ((g.x < 0.0f) == lo_negative) {
            lo = s;
        } else {
            hi = s;
        }
        precise float next = s - div_rn(g.x, g.y);
        if (!(next > lo && next < hi)) {
            next = 0.5f * (lo + hi);
        }
        if (next == s) {
            break;
        }
        s = next;
    }
    return s;
}

// Torus: the nearest hit with t > 0, normal p - R (x, 0, z) / |(x, 0, z)|
// (from the nearest point of the ring to p: length r on the surface).
ShapeHit intersect_torus(Ray r) {
    precise float tc = closest_t(r, vec3(0.0f, 0.0f, 0.0f));
    precise vec3 c = r.origin + tc * r.direction;
    precise float len = sqrt_rn(dot3(r.direction, r.direction));
    precise vec3 e = div_rn(r.direction, len);
    // The bounding sphere and the slab, each 2^-10 larger: a miss of both
    // is a miss of the torus, and F > 0 at their sides.
    precise float disc = 0.250488281f - dot3(c, c);
    if (!(disc >= 0.0f)) {
        return no_hit();
    }
    precise float half_chord = sqrt_rn(disc);
    precise float lo = max_f(-half_chord, -(tc * len));
    precise float hi = half_chord;
    if (e.y != 0.0f) {
        precise float y0 = div_rn(-0.125122070f - c.y, e.y);
        precise float y1 = div_rn(0.125122070f - c.y, e.y);
        lo = max_f(lo, min_f(y0, y1));
        hi = min_f(hi, max_f(y0, y1));
    } else if (abs(c.y) > 0.125122070f) {
        return no_hit();
    }
    if (!(lo < hi)) {
        return no_hit();
    }
    // The pieces on which F' is monotone: ends at F'''s roots, the
    // roots of F'' = 12 s^2 + 24 b s + (8 b^2 + 4 (|c|^2 + 0.125) - 1.125
    // (ex^2 + ez^2)), b = c.e (0 but for rounding).
    precise float b = dot3(c, e);
    precise vec2 inflections = quadratic_roots(12.0f, 24.0f * b, (8.0f * (b * b) + 4.0f * (dot3(c, c) + 0.125f)) - 1.125f * (e.x * e.x + e.z * e.z));
    precise vec4 ends = vec4(lo, min_f(max_f(inflections.x, lo), hi), min_f(max_f(inflections.y, lo), hi), hi);
    precise float a = lo;
    precise vec2 fa = torus_f(c + a * e, e, 0);
    bool found = false;
    precise float s = 0.0f;
    for (int k = 1; k < 4; k++) {
        precise float z = ends[k];
        if (found || !(z > a)) {
            continue;
        }
        // F' monotone on [a, z]: F falls, then rises (or the reverse),
        // about its one critical point m, if any.
        precise vec2 fz = torus_f(c + z * e, e, 0);
        precise float m = z;
        precise vec2 fm = fz;
        if ((fa.y < 0.0f) != (fz.y < 0.0f)) {
            m = torus_root(c, e, 1, a, z, fa.y, fz.y);
            fm = torus_f(c + m * e, e, 0);
        }
        if ((fa.x < 0.0f) != (fm.x < 0.0f)) {
            s = torus_root(c, e, 0, a, m, fa.x, fm.x);
            found = true;
        } else if ((fm.x < 0.0f) != (fz.x < 0.0f)) {
            s = torus_root(c, e, 0, m, z, fm.x, fz.x);
            found = true;
        }
        a = z;
        fa = fz;
    }
    if (!found) {
        return no_hit();
    }
    precise vec3 p = c + s * e;
    precise float rho = sqrt_rn(p.x * p.x + p.z * p.z);
    precise float k = div_rn(rho - TORUS_RING, rho);
    ShapeHit h = no_hit();
    return nearer(h, tc + div_rn(s, len), vec3(k * p.x, p.y, k * p.z));
}

// (u, v): u around y; v around the tube, from its inner equator (v = 0)
// over the top (1/4) and the outer equator (1/2) to the bottom (3/4).
precise vec2 torus_uv(vec3 p) {
    precise float rho = sqrt_rn(p.x * p.x + p.z * p.z);
    return vec2(around_y(p), 0.5f - atan2_portable(p.y, rho - 0.375f) * 0.159154937f);
}
