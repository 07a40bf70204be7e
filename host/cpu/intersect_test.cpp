// Unit tests of the shared GLSL's intersection code, built as C++. Expected
// values are derived by hand from the seed handout's equations (the working
// is in each comment) and chosen so that every step is exact in float: the
// rule is bit-exact equality unless a test says otherwise.
#include <gtest/gtest.h>

#include <cmath>
#include <initializer_list>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "shared.hpp"
#include "raycast_cpu.h"
#include <glm/gtc/matrix_transform.hpp>

using namespace raycast_cpu;

namespace {
Ray ray(float ox, float oy, float oz, float dx, float dy, float dz) {
    Ray r;
    r.origin = vec3(ox, oy, oz);
    r.direction = vec3(dx, dy, dz);
    return r;
}

void expect_vec3_eq(vec3 actual, vec3 expected) {
    EXPECT_EQ(actual.x, expected.x);
    EXPECT_EQ(actual.y, expected.y);
    EXPECT_EQ(actual.z, expected.z);
}
} // namespace

// Cube faces: t = (s - o[axis]) / d[axis] for the planes axis = s = +-0.5.
TEST(CubePlanes, XPlanes) {
    Ray r = ray(-3.0f, 0.1f, 0.2f, 2.0f, 0.0f, 0.0f);
    EXPECT_EQ(plane_t(r, 0, 0.5f), 1.75f);  // (0.5 + 3) / 2
    EXPECT_EQ(plane_t(r, 0, -0.5f), 1.25f); // (-0.5 + 3) / 2
}

TEST(CubePlanes, ParallelRayGivesNaNOrInfinity) {
    Ray r = ray(0.5f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f);
    EXPECT_TRUE(std::isnan(plane_t(r, 0, 0.5f)));  // 0 / 0
    EXPECT_TRUE(std::isinf(plane_t(r, 0, -0.5f))); // -1 / 0
}

TEST(Cube, NearestFaceFromOutside) {
    ShapeHit h = intersect_cube(ray(-3.0f, 0.1f, 0.2f, 2.0f, 0.0f, 0.0f));
    EXPECT_EQ(h.t, 1.25f); // the x = -0.5 face
    expect_vec3_eq(h.normal, vec3(-0.5f, 0.0f, 0.0f));
}

TEST(Cube, FromInsideOnlyTheFaceAhead) {
    ShapeHit h = intersect_cube(ray(0.0f, 0.0f, 0.0f, 1.0f, 0.0f, 0.0f));
    EXPECT_EQ(h.t, 0.5f); // x = -0.5 is at t = -0.5: behind, rejected
    expect_vec3_eq(h.normal, vec3(0.5f, 0.0f, 0.0f));
}

TEST(Cube, ParallelRayAlongAFacePlaneHitsTheEdgeOfTheFaceAhead) {
    // On the plane x = 0.5, travelling -z: x faces give NaN / inf (rejected);
    // z = 0.5 at t = 1.5 with the hit point (0.5, 0, 0.5) on the edge.
    ShapeHit h = intersect_cube(ray(0.5f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f));
    EXPECT_EQ(h.t, 1.5f);
    expect_vec3_eq(h.normal, vec3(0.0f, 0.0f, 0.5f));
}

TEST(Cube, BehindTheRayIsAMiss) {
    EXPECT_EQ(intersect_cube(ray(0.0f, 0.0f, 2.0f, 0.0f, 0.0f, 1.0f)).t, T_FAR);
}

// Cone body: a = dx^2 + dz^2 - dy^2/4, b = 2(ox dx + oz dz) + h dy/2,
// c = ox^2 + oz^2 - h^2/4 with h = 0.5 - oy.
TEST(ConeQuadratic, HorizontalRayThroughTheAxis) {
    // o = (0, 0, 2), d = (0, 0, -1): h = 0.5; a = 1; b = 2 * (2 * -1) = -4;
    // c = 4 - 0.25 * 0.25 = 3.9375.
    expect_vec3_eq(cone_quadratic(ray(0.0f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f)), vec3(1.0f, -4.0f, 3.9375f));
}

TEST(ConeQuadratic, SlopedRay) {
    // o = (1, 0.5, 0), d = (-1, -1, 0): h = 0; a = 1 - 0.25 = 0.75;
    // b = 2 * (1 * -1) = -2; c = 1.
    expect_vec3_eq(cone_quadratic(ray(1.0f, 0.5f, 0.0f, -1.0f, -1.0f, 0.0f)), vec3(0.75f, -2.0f, 1.0f));
}

TEST(Cone, BodyHitOfTheHorizontalRay) {
    // Roots of t^2 - 4t + 3.9375: (4 -+ sqrt(0.25)) / 2 = 1.75, 2.25. At
    // y = 0 the radius is (0.5 - 0) / 2 = 0.25 = 2 - 1.75. Normal: the
    // gradient (2x, (0.5 - y)/2, 2z) at (0, 0, 0.25) = (0, 0.25, 0.5).
    ShapeHit h = intersect_cone(ray(0.0f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f));
    EXPECT_EQ(h.t, 1.75f);
    expect_vec3_eq(h.normal, vec3(0.0f, 0.25f, 0.5f));
}

TEST(Cone, BodyHitOfTheSlopedRay) {
    // Roots of 0.75 t^2 - 2t + 1: (2 -+ 1) / 1.5 = 2/3, 2; at t = 2/3 the
    // point (1/3, -1/6, 0) has radius (0.5 + 1/6) / 2 = 1/3.
    ShapeHit h = intersect_cone(ray(1.0f, 0.5f, 0.0f, -1.0f, -1.0f, 0.0f));
    EXPECT_EQ(h.t, 1.0f / 1.5f);
}

TEST(Cone, BaseCapFromBelow) {
    // The cap y = -0.5 at t = (-0.5 + 2) / 1 = 1.5, x^2 + z^2 = 0.05 <= 0.25.
    ShapeHit h = intersect_cone(ray(0.1f, -2.0f, 0.2f, 0.0f, 1.0f, 0.0f));
    EXPECT_EQ(h.t, 1.5f);
    expect_vec3_eq(h.normal, vec3(0.0f, -1.0f, 0.0f));
}

TEST(Cone, MissOutsideTheCapAndBelowTheBody) {
    // x = 0.6: the cap needs x^2 <= 0.25; the body meets x = 0.6 at
    // y = 0.5 - 1.2 = -0.7, below the cone.
    EXPECT_EQ(intersect_cone(ray(0.6f, -2.0f, 0.0f, 0.0f, 1.0f, 0.0f)).t, T_FAR);
}

TEST(Sphere, AlongAnAxis) {
    // t^2 - 4t + 3.75 = 0: t = 1.5, 2.5; normal = hit point (0, 0, 0.5).
    ShapeHit h = intersect_sphere(ray(0.0f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f));
    EXPECT_EQ(h.t, 1.5f);
    expect_vec3_eq(h.normal, vec3(0.0f, 0.0f, 0.5f));
}

TEST(Cylinder, BodyAndCaps) {
    ShapeHit body = intersect_cylinder(ray(0.0f, 0.0f, 2.0f, 0.0f, 0.0f, -1.0f));
    EXPECT_EQ(body.t, 1.5f);
    expect_vec3_eq(body.normal, vec3(0.0f, 0.0f, 0.5f));
    ShapeHit top = intersect_cylinder(ray(0.0f, 2.0f, 0.0f, 0.0f, -1.0f, 0.0f));
    EXPECT_EQ(top.t, 1.5f);
    expect_vec3_eq(top.normal, vec3(0.0f, 1.0f, 0.0f));
}

// Portable transcendental functions, against the double-precision library.
// Rules: pow within 4e-6 relative (rounding y = n log2(x) to float alone
// costs up to 3e-6 at |y| = 50), 0 below the normal floats, exact at x = 0
// and x = 1; acos within 3
// ULP of the float result.
TEST(PortableMath, PowWithin4e6Relative) {
    for (float x : {1e-6f, 0.01f, 0.3f, 0.5f, 0.77f, 0.999f, 1.0f}) {
        for (float n : {0.5f, 1.0f, 2.0f, 7.5f, 25.0f, 100.0f}) {
            double expected = std::pow(double(x), double(n));
            double actual = double(pow_portable(x, n));
            if (expected < 1.17549435e-38) {
                EXPECT_EQ(actual, 0.0) << "pow(" << x << ", " << n << ") is below the normal floats: 0";
            } else {
                EXPECT_NEAR(actual, expected, 4e-6 * expected) << "pow(" << x << ", " << n << ")";
            }
        }
    }
    EXPECT_EQ(pow_portable(0.0f, 3.0f), 0.0f);
    EXPECT_EQ(pow_portable(1.0f, 3.0f), 1.0f);
    EXPECT_EQ(pow_portable(1.0f, 0.5f), 1.0f);
}

TEST(PortableMath, AcosWithin3Ulp) {
    // Worst seen on this grid: 2.4 ULP (float evaluation of the polynomial).
    double worst = 0.0;
    float worst_x = 0.0f;
    for (int k = -100000; k <= 100000; k++) {
        float x = float(k) / 100000.0f;
        double expected = std::acos(double(x));
        float e = float(expected);
        double ulp = double(std::nextafter(e, 4.0f) - e);
        double err = std::fabs(double(acos_portable(x)) - expected) / ulp;
        if (err > worst) {
            worst = err;
            worst_x = x;
        }
    }
    EXPECT_LE(worst, 3.0) << "worst at acos(" << worst_x << ")";
}

// The corrections that div_rn and sqrt_rn apply on a GPU (exact.glsl),
// which use no fma: from a start up to 3 ULP off either way
// correct_quotient and correct_root, and from 1 ULP off nearest_quotient
// and nearest_root (their last step, which the Newton step before it
// seldom leaves anything to do), must give the correctly rounded quotient
// and root, which IEEE float division and sqrtf are. Random operands over
// 2^-60 .. 2^60 and both signs, a fixed seed, then quotients and roots at
// the edges of a binade and of the ranges corrected; rule: bit-exact,
// every case.
TEST(PortableMath, QuotientAndRootCorrectionsAreIeee) {
    uint32_t state = 12345u;
    auto next = [&state]() {
        state = state * 1664525u + 1013904223u;
        return state;
    };
    auto random_float = [&]() {
        uint32_t bits = (next() >> 9) | ((67u + next() % 120u) << 23) | (next() & 0x80000000u);
        return glm::uintBitsToFloat(bits);
    };
    auto off_by = [](float x, int ulps) { return glm::intBitsToFloat(glm::floatBitsToInt(x) + ulps); };
    // Operands next to powers of two, where a neighbour of the quotient
    // or root lies in the next binade, and quotients near the smallest
    // corrected and divisors near the largest (2^126).
    std::vector<std::pair<float, float>> edges;
    for (float p : {1.0f, 0x1p-125f, 0x1p-100f, 0x1p100f, 0x1.fffffep125f, 0x1p125f}) {
        for (int da = -3; da <= 3; da++) {
            for (int db = -3; db <= 3; db++) {
                edges.push_back({off_by(p, da), off_by(1.0f, db)});
                edges.push_back({off_by(1.0f, da), off_by(p, db)});
            }
        }
    }
    int quotients = 0, roots = 0;
    const int randoms = 300000;
    for (int i = 0; i < randoms + int(edges.size()); i++) {
        float a = i < randoms ? random_float() : edges[i - randoms].first;
        float b = i < randoms ? std::fabs(random_float()) : edges[i - randoms].second;
        if (i >= randoms && (!(std::fabs(a / b) >= 0x1p-125f) || std::fabs(a / b) > 1.0e38f || b >= 0x1p126f)) {
            continue; // starts outside what the correction corrects (returned as given, below)
        }
        int ulps = i < randoms ? int(next() % 7u) - 3 : (i % 7) - 3;
        int one = ulps % 2; // -1, 0 or 1
        float q = a / b;
        for (float got : {correct_quotient(a, b, off_by(q, ulps)), nearest_quotient(a, b, off_by(q, one))}) {
            if (glm::floatBitsToUint(got) != glm::floatBitsToUint(q) && quotients++ < 5) {
                ADD_FAILURE() << std::hexfloat << a << " / " << b << " = " << q << ", corrected from " << ulps << " or " << one
                              << " ULP off: " << got;
            }
        }
        float r = std::sqrt(b);
        for (float got : {correct_root(b, off_by(r, ulps)), nearest_root(b, off_by(r, one))}) {
            if (glm::floatBitsToUint(got) != glm::floatBitsToUint(r) && roots++ < 5) {
                ADD_FAILURE() << std::hexfloat << "sqrt " << b << " = " << r << ", corrected from " << ulps << " or " << one
                              << " ULP off: " << got;
            }
        }
    }
    EXPECT_EQ(quotients, 0) << "quotients not correctly rounded";
    EXPECT_EQ(roots, 0) << "roots not correctly rounded";
    // As given: zero, infinite and NaN quotients, b = 0, x = 0.
    EXPECT_EQ(correct_quotient(0.0f, 3.0f, 0.0f), 0.0f);
    EXPECT_TRUE(std::isinf(correct_quotient(1.0f, 0.0f, 1.0f / 0.0f)));
    EXPECT_TRUE(std::isnan(correct_quotient(0.0f, 0.0f, std::nanf(""))));
    EXPECT_EQ(correct_root(0.0f, 0.0f), 0.0f);
}

TEST(Camera, CentreRayOfAnOddImageIsTheLookDirection) {
    // world_from_film = identity with the eye at the origin: the centre of
    // pixel (1, 1) of a 3x3 image is film (0, 0), direction (0, 0, -1).
    Scene s{};
    s.frame.world_from_film = mat4(1.0f);
    s.frame.eye = vec4(0.0f, 0.0f, 0.0f, 1.0f);
    s.frame.width = 3;
    s.frame.height = 3;
    bind_scene(s);
    Ray r = camera_ray(1, 1, vec2(0.0f, 0.0f));
    expect_vec3_eq(r.direction, vec3(0.0f, 0.0f, -1.0f));
    Ray corner = camera_ray(0, 0, vec2(-0.5f, -0.5f)); // top-left corner of the film
    expect_vec3_eq(corner.direction, vec3(-1.0f, 1.0f, -1.0f));
}

// The CPU build's instance-record loop (records_meet.hpp), from the
// records and from their columns, against the
// scalar tests the device runs (sphere_hit and box_hit on record_lo and
// record_hi): random leaves of one to eight records, spheres and boxes
// mixed; rays at a record's sphere, into the leaf or anywhere, with values
// at the edges (zero, NaN and infinite directions and radii, reach 0, -1,
// NaN and T_FAR); and at each random ray, the two neighbouring floats (of
// one direction component, or of the reach) between which the scalar
// answer for the aimed record flips, where any other rounding would show.
// Rule: the same mask, bit for bit, every ray; a failure prints the count
// and the first.
TEST(RecordsMeet, SameAnswersAsTheScalarTests) {
    uint32_t state = 2024u;
    auto next = [&state]() {
        state = state * 1664525u + 1013904223u;
        return state;
    };
    auto unit = [&]() { return float(next() >> 8) * 0x1p-24f; };
    auto pick = [&](std::initializer_list<float> specials, float lo, float hi) {
        if (next() % 16u == 0u) {
            return *(specials.begin() + next() % specials.size());
        }
        return lo + (hi - lo) * unit();
    };
    const float inf = std::numeric_limits<float>::infinity();
    const float nan = std::numeric_limits<float>::quiet_NaN();
    int rays = 0, differ = 0, met = 0, records = 0, boundaries = 0, key_failures = 0, retested = 0;
    std::string first;
    uint count = 0u;
    vec4 leaf_lo, leaf_hi;
    vec3 step;
    // The scalar loop's mask.
    auto expected_mask = [&](Ray r, float reach) {
        uint mask = 0u;
        for (uint n = 0u; n < count; n++) {
            uvec4 record = leaf_record(1u + n);
            vec3 lo = record_lo(record, leaf_lo, step);
            bool meets = (record.w & RECORD_SPHERE) != 0u ? sphere_hit(r, lo, glm::uintBitsToFloat(record.z), reach)
                                                          : box_hit(r, vec4(lo, 0.0f), vec4(record_hi(record, leaf_hi, step), 0.0f), reach);
            mask |= meets ? (1u << n) : 0u;
        }
        return mask;
    };
    std::vector<uint> columns;
    // The mask from the records, and from their columns (made as
    // raycast_cpu_record_columns makes them) with the walk's keys; each
    // met record's keys tested again at smaller reaches (walk_keys.hpp):
    // a sphere's answer is sphere_hit's there, a box's never skips one
    // box_hit meets.
    auto records_meet_both = [&](Ray r, float reach) {
        uint decoded = records_meet(r, leaf_lo, leaf_hi, 1u, count, reach, nullptr);
        uint stride = 1u + count + RECORD_COLUMN_PADDING;
        columns.assign(4u + RECORD_COLUMNS * stride, 0u);
        fill_record_columns(columns.data() + 4, stride, leaf_lo, leaf_hi, 1u, count);
        record_columns = columns.data() + 4;
        record_column_stride = stride;
        WalkKeys keys;
        uint from_columns = records_meet(r, leaf_lo, leaf_hi, 1u, count, reach, &keys);
        record_columns = nullptr;
        if (from_columns != decoded) {
            key_failures++;
            ADD_FAILURE() << "the columns' mask " << from_columns << ", the records' " << decoded;
        }
        for (uint met_now = decoded; met_now != 0u; met_now &= met_now - 1u) {
            uint n = uint(__builtin_ctz(met_now));
            uvec4 record = leaf_record(1u + n);
            vec3 lo = record_lo(record, leaf_lo, step);
            bool sphere = (record.w & RECORD_SPHERE) != 0u;
            for (float smaller : {reach * unit(), reach * 0.5f, 0.0f, keys.tc[n]}) {
                if (!(smaller >= 0.0f && smaller <= reach)) {
                    continue;
                }
                bool hit = sphere ? sphere_hit(r, lo, glm::uintBitsToFloat(record.z), smaller)
                                  : box_hit(r, vec4(lo, 0.0f), vec4(record_hi(record, leaf_hi, step), 0.0f), smaller);
                bool skipped = bound_passed_by(keys.tc[n], keys.rr[n], keys.dd, smaller);
                retested++;
                if ((skipped && hit) || (sphere && skipped == hit)) {
                    if (key_failures++ == 0) {
                        ADD_FAILURE() << "record " << n << (sphere ? " (sphere)" : " (box)") << " at reach " << smaller << " of "
                                      << reach << ": skipped " << skipped << ", met " << hit;
                    }
                }
            }
        }
        return decoded;
    };
    auto compare = [&](Ray r, float reach) {
        uint expected = expected_mask(r, reach);
        uint actual = records_meet_both(r, reach);
        rays++;
        records += int(count);
        met += __builtin_popcount(expected);
        if (actual != expected && differ++ == 0) {
            char text[400];
            std::snprintf(text, sizeof(text), "%u records, ray (%a %a %a) + t (%a %a %a), reach %a: mask %#x, expected %#x", count, double(r.origin.x),
                          double(r.origin.y), double(r.origin.z), double(r.direction.x), double(r.direction.y), double(r.direction.z), double(reach),
                          actual, expected);
            first = text;
        }
    };
    // Floats a and b (same sign) whose answers f(a) != f(b): narrowed to
    // neighbours, both compared.
    auto at_boundary = [&](float a, float b, auto f, auto compare_at) {
        uint lo = glm::floatBitsToUint(a);
        uint hi = glm::floatBitsToUint(b);
        bool at_lo = f(a);
        if ((lo >> 31) != (hi >> 31) || at_lo == f(b)) {
            return;
        }
        while ((lo > hi ? lo - hi : hi - lo) > 1u) {
            uint mid = lo + (hi > lo ? (hi - lo) / 2u : 0u) - (lo > hi ? (lo - hi) / 2u : 0u);
            (f(glm::uintBitsToFloat(mid)) == at_lo ? lo : hi) = mid;
        }
        boundaries++;
        compare_at(glm::uintBitsToFloat(lo));
        compare_at(glm::uintBitsToFloat(hi));
    };
    std::vector<LeafItem> items;
    for (int c = 0; c < 100000; c++) {
        count = 1u + next() % 8u;
        items.assign(4u * (count + 1u), LeafItem{0u});
        leaf_lo = vec4(pick({0.0f, -1e30f}, -50.0f, 50.0f), pick({0.0f}, -50.0f, 50.0f), pick({0.0f}, -50.0f, 50.0f), 0.0f);
        leaf_hi = leaf_lo + vec4(pick({0.0f, 1e-30f}, 0.0f, 40.0f), pick({0.0f}, 0.0f, 40.0f), pick({0.0f}, 0.0f, 40.0f), 0.0f);
        step = div_rn(xyz(leaf_hi) - xyz(leaf_lo), float(BOX_STEPS));
        float size = leaf_hi.x - leaf_lo.x + leaf_hi.y - leaf_lo.y;
        for (uint n = 0u; n < count; n++) {
            uint* w = &items[4u * (n + 1u)].item;
            bool sphere = (next() & 1u) != 0u;
            if (sphere) {
                w[0] = next();
                w[1] = next() & 0xffffu;
                w[2] = glm::floatBitsToUint(pick({0.0f, 1e-30f, inf, nan, 1e30f}, 0.0f, 0.5f * size));
            } else {
                // lo and hi steps that leave the box mostly the right way round.
                w[0] = next() & 0x7fff7fffu;
                w[1] = next() & 0x7fff7fffu;
                w[2] = next() & 0x7fff7fffu;
            }
            w[3] = ITEM_INSTANCE | (sphere ? RECORD_SPHERE : 0u) | n;
        }
        leaf_items = items.data();
        vec3 origin(pick({0.0f, nan, leaf_lo.x}, -80.0f, 80.0f), pick({0.0f, leaf_lo.y}, -80.0f, 80.0f), pick({0.0f, 1e20f}, -80.0f, 80.0f));
        uint aimed = 1u + next() % count;
        uvec4 aim = leaf_record(aimed);
        vec3 centre = record_lo(aim, leaf_lo, step);
        float radius = glm::uintBitsToFloat(aim.z);
        vec3 target = centre;
        uint how = next() % 4u;
        if (how < 2u) {
            // At the radius sphere_hit pads (by 2^-16 of the centre's offset).
            float span = radius + max_abs3(centre - origin) * 1.52587891e-5f;
            vec3 v(unit() - 0.5f, unit() - 0.5f, unit() - 0.5f);
            target = centre + v * div_rn(span, std::sqrt(dot3(v, v)));
        } else if (how == 2u) {
            target = xyz(leaf_lo) + vec3(unit(), unit(), unit()) * (xyz(leaf_hi) - xyz(leaf_lo));
        } else {
            target = vec3(unit(), unit(), unit()) * 160.0f - 80.0f;
        }
        vec3 direction = (target - origin) * pick({0.0f, nan, inf, 1e-20f}, 0.01f, 4.0f);
        if (next() % 16u == 0u) {
            direction[next() % 3u] = pick({0.0f, -inf, 1e-30f}, -4.0f, 4.0f);
        }
        Ray r = ray(origin.x, origin.y, origin.z, direction.x, direction.y, direction.z);
        float reach = pick({0.0f, T_FAR, -1.0f, nan}, 0.0f, 200.0f);
        compare(r, reach);
        if ((aim.w & RECORD_SPHERE) == 0u) {
            continue;
        }
        // The aimed sphere's boundaries: in direction.x (from the ray at
        // its centre outward) and in the reach.
        Ray at_centre = r;
        at_centre.direction = centre - origin;
        float dx = at_centre.direction.x;
        float outward = dx + (dx < 0.0f ? -1.0f : 1.0f) * 4.0f * (radius + 1.0f);
        auto with_dx = [&](float x) {
            Ray moved = at_centre;
            moved.direction.x = x;
            return moved;
        };
        at_boundary(dx, outward, [&](float x) { return sphere_hit(with_dx(x), centre, radius, T_FAR); },
                    [&](float x) { compare(with_dx(x), T_FAR); });
        at_boundary(0.0f, T_FAR, [&](float t) { return sphere_hit(at_centre, centre, radius, t); }, [&](float t) { compare(at_centre, t); });
        // And leaving it: from inside, heading away, to beyond its radius.
        vec3 across(unit() - 0.5f, unit() - 0.5f, unit() - 0.5f);
        auto from_x = [&](float x) {
            Ray away = ray(centre.x + x, centre.y + across.y, centre.z + across.z, 1.0f, across.x, across.z);
            return away;
        };
        at_boundary(0.0f, 4.0f * (radius + 1.0f), [&](float x) { return sphere_hit(from_x(x), centre, radius, T_FAR); },
                    [&](float x) { compare(from_x(x), T_FAR); });
    }
    leaf_items = nullptr;
    EXPECT_EQ(differ, 0) << differ << " of " << rays << " rays differ; the first: " << first;
    // Both answers well represented, and boundaries found, or the
    // comparison would say little.
    EXPECT_GT(met, records / 10) << met << " of " << records << " records met";
    EXPECT_LT(met, records - records / 10) << met << " of " << records << " records met";
    EXPECT_GT(boundaries, 20000) << boundaries << " boundaries found";
    EXPECT_EQ(key_failures, 0) << key_failures << " answers of the columns or the keys differ";
    EXPECT_GT(retested, 100000) << retested << " keys tested again";
}

// The lean copy's look-ahead (records_meet.hpp, fill_lookahead) against
// what it stands for: random scenes of a leaf of records, each placing
// one group (a leaf of a random canonical shape and two sphere records)
// by a random rotation, scale and translation; random rays and reaches.
// Rule: wherever the look-ahead leaves out a record the ray meets, the
// walk in the placed group finds nothing within the reach: its primitive's
// hit (through both matrices) is not nearer, and the ray meets neither of
// its records' spheres; and wherever it keeps a record but leaves out its
// group's primitive (WalkKeys.ahead), that primitive's hit is not nearer.
// Each must happen often, or the test says little.
TEST(Lookahead, LeavesOutOnlyWhatHoldsNoHit) {
    uint32_t state = 1230u;
    auto next = [&state]() {
        state = state * 1664525u + 1013904223u;
        return state;
    };
    auto unit = [&]() { return float(next() >> 8) * 0x1p-24f; };
    auto spread = [&](float lo, float hi) { return lo + (hi - lo) * unit(); };
    auto random_axis = [&]() {
        vec3 a(spread(-1.0f, 1.0f), spread(-1.0f, 1.0f), spread(-1.0f, 1.0f));
        return (dot(a, a) > 1e-4f) ? a : vec3(0.0f, 1.0f, 0.0f);
    };
    const uint records = 6u;
    const uint shapes[4] = {SHAPE_SPHERE, SHAPE_CUBE, SHAPE_CONE, SHAPE_CYLINDER};
    int left_out = 0, checked = 0, wrong = 0, primitives_left_out = 0;
    std::string first;
    for (int scene = 0; scene < 400; scene++) {
        // Nodes: 0 the parent's leaf (records at slots 0..), 1 the placed group's.
        std::vector<BvhNode> nodes(2);
        nodes[0].lo = vec4(-4.0f, -4.0f, -4.0f, 0.0f);
        nodes[0].hi = vec4(4.0f, 4.0f, 4.0f, 0.0f);
        nodes[0].first = 0u;
        nodes[0].count = records;
        nodes[0].primitives = 0u;
        uint child_first = 4u * records;
        nodes[1].lo = vec4(-1.5f, -1.5f, -1.5f, 0.0f);
        nodes[1].hi = vec4(1.5f, 1.5f, 1.5f, 0.0f);
        nodes[1].first = child_first;
        nodes[1].count = 3u;
        nodes[1].primitives = 1u;
        uint child_records = (child_first + 1u + 3u) >> 2u;
        std::vector<LeafItem> items(4u * (child_records + 2u), LeafItem{0u});
        std::vector<Instance> placed(records);
        for (uint k = 0u; k < records; k++) {
            mat4 parent_from_child = glm::translate(mat4(1.0f), vec3(spread(-3.0f, 3.0f), spread(-3.0f, 3.0f), spread(-3.0f, 3.0f)));
            parent_from_child = glm::rotate(parent_from_child, spread(0.0f, 6.28f), random_axis());
            parent_from_child = glm::scale(parent_from_child, vec3(spread(0.2f, 1.5f)));
            placed[k].object_from_parent = glm::inverse(parent_from_child);
            placed[k].root = 1u;
            uint* w = &items[4u * k].item;
            // The record's sphere: about the placed group's centre, wide enough to be met often.
            vec3 c = vec3(parent_from_child[3]);
            vec3 q = glm::round((c - vec3(-4.0f)) / (vec3(8.0f) / float(BOX_STEPS)));
            w[0] = uint(q.x) | (uint(q.y) << 16u);
            w[1] = uint(q.z);
            w[2] = glm::floatBitsToUint(4.0f);
            w[3] = ITEM_INSTANCE | RECORD_SPHERE | k;
        }
        items[child_first].item = 0u;
        for (uint j = 0u; j < 2u; j++) {
            uint* w = &items[4u * (child_records + j)].item;
            w[0] = (next() & 0xffffu) | ((next() & 0xffffu) << 16u);
            w[1] = next() & 0xffffu;
            w[2] = glm::floatBitsToUint(spread(0.05f, 0.5f));
            w[3] = ITEM_INSTANCE | RECORD_SPHERE | 0u;
        }
        Primitive shape{};
        shape.shape = shapes[next() % 4u];
        mat4 child_from_object = glm::translate(mat4(1.0f), vec3(spread(-1.0f, 1.0f), spread(-1.0f, 1.0f), spread(-1.0f, 1.0f)));
        child_from_object = glm::rotate(child_from_object, spread(0.0f, 6.28f), random_axis());
        // Half the shapes scaled alike on every axis, where the look-ahead's bound is tight.
        float alike = spread(0.2f, 1.0f);
        child_from_object = glm::scale(child_from_object, (scene % 2 == 0) ? vec3(alike)
                                                                           : vec3(spread(0.2f, 1.0f), spread(0.2f, 1.0f), spread(0.2f, 1.0f)));
        shape.object_from_world = glm::inverse(child_from_object);
        Frame f{};
        f.node_count = 2u;
        const void* buffers[BINDING_COUNT + 1] = {};
        buffers[BINDING_FRAME] = &f;
        buffers[BINDING_PRIMITIVES] = &shape;
        buffers[BINDING_NODES] = nodes.data();
        buffers[BINDING_LEAF_ITEMS] = items.data();
        buffers[BINDING_INSTANCES] = placed.data();
        std::vector<uint32_t> columns(raycast_cpu_record_columns(buffers, nullptr, 0u));
        raycast_cpu_record_columns(buffers, columns.data(), columns.size());
        buffers[BINDING_COUNT] = columns.data();
        bind_scene(bind_buffers(buffers));
        const float* lookahead = record_lookahead;
        ASSERT_NE(lookahead, nullptr);
        for (int n = 0; n < 400; n++) {
            vec3 origin(spread(-8.0f, 8.0f), spread(-8.0f, 8.0f), spread(-8.0f, 8.0f));
            uint aim = next() % records;
            vec3 target = glm::inverse(placed[aim].object_from_parent) * vec4(spread(-1.5f, 1.5f), spread(-1.5f, 1.5f), spread(-1.5f, 1.5f), 1.0f);
            vec3 d = (target - origin) * spread(0.1f, 2.0f);
            Ray r = ray(origin.x, origin.y, origin.z, d.x, d.y, d.z);
            float reach = (next() % 2u == 0u) ? T_FAR : spread(0.0f, 3.0f);
            WalkKeys keys;
            uint with = records_meet(r, nodes[0].lo, nodes[0].hi, 0u, records, reach, &keys);
            record_lookahead = nullptr;
            WalkKeys keys_without;
            uint without = records_meet(r, nodes[0].lo, nodes[0].hi, 0u, records, reach, &keys_without);
            record_lookahead = lookahead;
            ASSERT_EQ(with & ~without, 0u) << "the look-ahead added a record";
            // A kept record whose primitive the look-ahead left out: the primitive holds no hit either.
            for (uint kept = with; kept != 0u; kept &= kept - 1u) {
                uint k = uint(__builtin_ctz(kept));
                if ((keys.ahead[k] & 1u) != 0u) {
                    continue;
                }
                primitives_left_out++;
                ShapeHit h = intersect_shape(shape.shape, ray_through(shape.object_from_world, ray_through(placed[k].object_from_parent, r)));
                if (h.t < reach && wrong++ == 0) {
                    first = "a primitive left out of a kept record held a hit, scene " + std::to_string(scene);
                }
            }
            for (uint out = without & ~with; out != 0u; out &= out - 1u) {
                uint k = uint(__builtin_ctz(out));
                left_out++;
                Ray inner = ray_through(placed[k].object_from_parent, r);
                ShapeHit h = intersect_shape(shape.shape, ray_through(shape.object_from_world, inner));
                bool hit = h.t < reach;
                vec3 step = record_step(nodes[1].lo, nodes[1].hi);
                for (uint j = 0u; j < 2u; j++) {
                    uvec4 record = leaf_record(child_records + j);
                    hit = hit || sphere_hit(inner, record_lo(record, nodes[1].lo, step), glm::uintBitsToFloat(record.z), reach);
                }
                checked++;
                if (hit && wrong++ == 0) {
                    char text[300];
                    std::snprintf(text, sizeof(text), "scene %d, shape %u, record %u, ray (%a %a %a) + t (%a %a %a), reach %a, primitive t %a", scene,
                                  shape.shape, k, double(origin.x), double(origin.y), double(origin.z), double(d.x), double(d.y), double(d.z),
                                  double(reach), double(h.t));
                    first = text;
                }
            }
        }
    }
    bind_scene(Scene{});
    EXPECT_EQ(wrong, 0) << wrong << " of " << checked << " left out held a hit; the first: " << first;
    EXPECT_GT(left_out, 10000) << left_out << " records left out";
    EXPECT_GT(primitives_left_out, 5000) << primitives_left_out << " primitives of kept records left out";
}

#ifdef RAYCAST_CPU_TESTS_AVX2
// The AVX2 build's own main: Skipped (exit 77, CMakeLists.txt) on a CPU
// without AVX2, where its code cannot run.
int main(int argc, char** argv) {
    if (!__builtin_cpu_supports("avx2")) {
        std::printf("Skipped: this CPU has no AVX2\n");
        return 77;
    }
    ::testing::InitGoogleTest(&argc, argv);
    return RUN_ALL_TESTS();
}
#endif
