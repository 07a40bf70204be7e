// records_meet.hpp: the CPU build's form of the walk's instance-record loop
// (shaders/traversal.glsl calls it, with RECORDS_MEET, in place of the
// loop's bound tests; shared.hpp includes it after the GLSL): which of a
// leaf's instance records the ray meets, as a mask, the bounding spheres
// LANES at a time in SIMD lanes. Each lane does sphere_hit's
// arithmetic, operation for operation in the same order (no FMA: the
// library is built with -ffp-contract=off), so each answer is the scalar
// test's (host/cpu/intersect_test.cpp, RecordsMeet, compares them); box
// records take box_hit itself. The whole copy's walk then pushes the met
// instances in order, as the loop does, so the stack, the passes and the
// bits are the device's; the lean copy's in its own order (walk_keys.hpp).
//
// The lanes read the records' centres from columns made once a frame
// (raycast_cpu_record_columns): each centre decoded from its leaf's box as
// record_lo decodes it, the same floats, one column per coordinate so
// a group of records loads at once. Without them (the shader-test harness) the
// lanes decode the records themselves.
//
// Why (docs/scale.md#shaped-for-lavapipe, "in SIMD lanes"): at
// recursive-spheres depth 10 a leaf holds five instance records, and their
// scalar tests were a third of the CPU build's instructions, each with
// branches the predictor misses; decoding them took a third of what was
// left of it.
//
// GCC's vector extensions (GCC is the CPU build's compiler: Debian's g++);
// they compile to SSE on x86-64 and to NEON on arm64.
#pragma once

namespace record_lanes {
// Lanes a group: eight where the compiler may use AVX (raycast_cpu_lean_avx2.cpp),
// else four (SSE, NEON). The leaves of the course's recursive scenes hold
// five records: one group of eight, two of four.
#ifdef __AVX__
const uint LANES = 8u;
#else
const uint LANES = 4u;
#endif
typedef float fv __attribute__((vector_size(4 * LANES)));
typedef int iv __attribute__((vector_size(4 * LANES)));
typedef uint uv __attribute__((vector_size(4 * LANES)));

// abs in each lane, as shared.hpp's abs: the sign bit cleared.
inline fv abs_lanes(fv v) {
    uv bits;
    __builtin_memcpy(&bits, &v, sizeof(bits));
    bits &= 0x7fffffffu;
    __builtin_memcpy(&v, &bits, sizeof(v));
    return v;
}

// Bit k for each lane k that is true (all ones).
inline uint lane_bits(iv v) {
#if defined(__AVX__)
    return uint(__builtin_ia32_movmskps256(fv(v)));
#elif defined(__SSE__)
    return uint(__builtin_ia32_movmskps(fv(v)));
#else
    uint bits = 0u;
    for (uint k = 0u; k < LANES; k++) {
        bits |= (v[k] != 0) ? (1u << k) : 0u;
    }
    return bits;
#endif
}

// The LANES words from `at` on, as a vector of lanes.
template <class V>
inline V lanes_at(const void* at) {
    V v;
    __builtin_memcpy(&v, at, sizeof(v));
    return v;
}
} // namespace record_lanes

// Columns of the record columns: x, y, z, the radius word, the w word.
const uint RECORD_COLUMNS = 5u;

// Record slots a leaf's records span: the columns' length, less their padding.
inline uint record_column_slots() {
    uint slots = 0u;
    for (uint n = 0u; n < frame.node_count; n++) {
        BvhNode node = node_at(n);
        if (node.count > node.primitives) {
            uint records = (node.first + node.primitives + 3u) >> 2u;
            slots = max(slots, records + node.count - node.primitives);
        }
    }
    return slots;
}

// Words past the columns' last slot: a group of lanes loads from its
// leaf's last record on.
const uint RECORD_COLUMN_PADDING = 8u;

// A record's box step in its leaf's box [leaf_lo, leaf_hi], as the walk's
// loop computes it (layout.h, BvhNode).
inline vec3 record_step(vec4 leaf_lo, vec4 leaf_hi) {
    return div_rn(xyz(leaf_hi) - xyz(leaf_lo), float(BOX_STEPS));
}

// Record t's words in columns `stride` words apart from out[0]: x, y and z
// of its centre (as record_lo decodes it from its leaf's box, leaf_lo and
// step), its radius word and its w word.
inline void record_column_words(uint t, vec4 leaf_lo, vec3 step, uint* out, uint stride) {
    uvec4 record = leaf_record(t);
    vec3 lo = record_lo(record, leaf_lo, step);
    out[0] = floatBitsToUint(lo.x);
    out[stride] = floatBitsToUint(lo.y);
    out[2u * stride] = floatBitsToUint(lo.z);
    out[3u * stride] = record.z;
    out[4u * stride] = record.w;
}

// Writes the columns of records records .. records + count - 1 of a leaf
// whose box is [leaf_lo, leaf_hi].
inline void fill_record_columns(uint* out, uint stride, vec4 leaf_lo, vec4 leaf_hi, uint records, uint count) {
    vec3 step = record_step(leaf_lo, leaf_hi);
    for (uint t = records; t < records + count; t++) {
        record_column_words(t, leaf_lo, step, out + t, stride);
    }
}

// The look-ahead (the lean copy's, records_meet with keys): for each
// record, up to LOOKAHEAD spheres in its leaf's space that hold all that
// the placed group's root leaf holds, its primitives and its own records'
// bounds. A ray that meets the record's bound but none of these would
// enter the instance, miss its primitives and push none of its records:
// the walk leaves it out. A record whose group's root is not a leaf of at
// most LOOKAHEAD items, or holds a torus or a mesh, gets infinite spheres
// (never left out, every item tested). Sphere j bounds item j: the
// primitives first, as the leaf holds them, then the records.
const uint LOOKAHEAD = 8u;

// The most a linear map l stretches a vector, from above: the square root
// of the largest row sum of |lᵀl| (at least its largest eigenvalue; exact
// for a rotation and a uniform scale).
inline double stretch_bound(const dmat4& m) {
    dmat3 l(m);
    dmat3 g = transpose(l) * l;
    double most = 0.0;
    for (int r = 0; r < 3; r++) {
        most = std::max(most, std::fabs(g[0][r]) + std::fabs(g[1][r]) + std::fabs(g[2][r]));
    }
    return std::sqrt(most);
}

// The radius about its origin of a canonical shape (docs/scene-format.md),
// or 0 for one the look-ahead does not bound (a torus, a mesh).
inline double canonical_radius(uint shape) {
    switch (shape) {
    case SHAPE_SPHERE:
        return 0.5;
    case SHAPE_CUBE:
        return 0.8660254037844387; // sqrt(3) / 2
    case SHAPE_CONE:
    case SHAPE_CYLINDER:
        return 0.7071067811865476; // sqrt(2) / 2
    default:
        return 0.0;
    }
}

// Writes record t's look-ahead (LOOKAHEAD floats of x, then y, z and the
// radius) to out, in double and then rounded outward: each sphere grown
// by 2^-10 of its radius and 2^-20 of its centre's size, far more than
// the rounding of the walk's own tests in the placed group.
inline void fill_lookahead(uint t, float* out) {
    // Every sphere at the origin with this radius.
    auto every = [out](float radius) {
        for (uint i = 0u; i < LOOKAHEAD; i++) {
            out[i] = 0.0f;
            out[LOOKAHEAD + i] = 0.0f;
            out[2u * LOOKAHEAD + i] = 0.0f;
            out[3u * LOOKAHEAD + i] = radius;
        }
    };
    every(std::nanf("")); // meets nothing
    uvec4 record = leaf_record(t);
    Instance placed = instance_at(record.w & (ITEM_INSTANCE - 1u) & ~RECORD_SPHERE);
    BvhNode root = node_at(placed.root);
    dmat4 parent_from_child = inverse(dmat4(placed.object_from_parent));
    uint n = 0u;
    bool bounded = root.count > 0u && root.count <= LOOKAHEAD;
    auto put = [&](dvec3 centre, double radius) {
        double size = std::max(std::max(std::fabs(centre.x), std::fabs(centre.y)), std::fabs(centre.z));
        double grown = radius * (1.0 + 0x1p-10) + size * 0x1p-20;
        vec3 c = vec3(centre);
        grown += length(dvec3(c) - centre);
        float r = float(grown);
        out[n] = c.x;
        out[LOOKAHEAD + n] = c.y;
        out[2u * LOOKAHEAD + n] = c.z;
        out[3u * LOOKAHEAD + n] = (double(r) < grown) ? std::nextafter(r, INFINITY) : r;
        n++;
    };
    for (uint j = 0u; bounded && j < root.primitives; j++) {
        Primitive p = primitive_at(leaf_item(root.first + j));
        double radius = canonical_radius(p.shape);
        bounded = radius > 0.0;
        dmat4 parent_from_object = parent_from_child * inverse(dmat4(p.object_from_world));
        put(dvec3(parent_from_object[3]), radius * stretch_bound(parent_from_object));
    }
    uint records = (root.first + root.primitives + 3u) >> 2u;
    vec3 step = record_step(root.lo, root.hi);
    double stretch = stretch_bound(parent_from_child);
    for (uint j = 0u; bounded && j < root.count - root.primitives; j++) {
        uvec4 inner = leaf_record(records + j);
        dvec3 lo = dvec3(record_lo(inner, root.lo, step));
        dvec3 centre = lo;
        double radius = double(uintBitsToFloat(inner.z));
        if ((inner.w & RECORD_SPHERE) == 0u) {
            dvec3 hi = dvec3(record_hi(inner, root.hi, step));
            centre = (lo + hi) * 0.5;
            radius = length(hi - lo) * 0.5;
        }
        bounded = std::isfinite(radius);
        put(dvec3(parent_from_child * dvec4(centre, 1.0)), radius * stretch);
    }
    if (!bounded) {
        every(INFINITY); // meets every ray
    }
}

// box_hit's interval over the box [lo, hi]: the ray meets it where
// !(span.x > span.y), entering at span.x.
inline vec2 box_span(Ray r, vec4 lo, vec4 hi, float t_max) {
    vec2 span = vec2(0.0f, t_max);
    span = slab(r.origin.x, r.direction.x, lo.x, hi.x, span);
    span = slab(r.origin.y, r.direction.y, lo.y, hi.y, span);
    span = slab(r.origin.z, r.direction.z, lo.z, hi.z, span);
    return span;
}

// sphere_hit in each lane, for spheres whose centres lie (ocx, ocy, ocz)
// from the ray's origin: the same operations in the same order. dd is
// dot3(d, d). Its tc and rr to *tc_out and *rr_out where given.
inline record_lanes::iv spheres_meet(record_lanes::fv ocx, record_lanes::fv ocy, record_lanes::fv ocz, record_lanes::fv radius,
                                     vec3 d, float dd, float reach, record_lanes::fv* tc_out, record_lanes::fv* rr_out) {
    using namespace record_lanes;
    fv tc = ((ocx * d.x + ocy * d.y) + ocz * d.z) / dd;
    fv px = ocx - tc * d.x;
    fv py = ocy - tc * d.y;
    fv pz = ocz - tc * d.z;
    // max_abs3(oc): abs (shared.hpp: the sign bit cleared), then max_f's (a < b) ? b : a.
    fv ax = abs_lanes(ocx);
    fv ay = abs_lanes(ocy);
    fv az = abs_lanes(ocz);
    fv m = ax < ay ? ay : ax;
    m = m < az ? az : m;
    fv span = radius + m * 1.52587891e-5f;
    fv rr = span * span;
    fv past = tc - reach;
    fv p2 = (px * px + py * py) + pz * pz;
    if (tc_out != nullptr) {
        *tc_out = tc;
        *rr_out = rr;
    }
    return (p2 <= rr) & ((tc >= 0.0f) | ((tc * tc) * dd <= rr)) & ((past <= 0.0f) | ((past * past) * dd <= rr));
}

// The records records .. records + count - 1 (count at most 32) the ray lr
// meets within reach: bit n for record n. The leaf's box [leaf_lo,
// leaf_hi] places their centres and boxes (layout.h, BvhNode). (With
// FLAG_NO_BVH the walk does not call it: every record meets.)
uint records_meet(Ray lr, vec4 leaf_lo, vec4 leaf_hi, uint records, uint count, float reach, WalkKeys* keys) {
    using namespace record_lanes;
    const vec3 o = lr.origin;
    const vec3 d = lr.direction;
    // dot3(d, d), once: the same value sphere_hit computes for each record.
    const float dd = dot3(d, d);
    if (keys != nullptr) {
        keys->dd = dd;
    }
    uint met = 0u;
    for (uint g = 0u; g < count; g += LANES) {
        // A group's centres, radius words and w words.
        fv cx, cy, cz;
        uv z, w;
        if (record_columns != nullptr) {
            // Past count: the columns' next words (their padding at the end).
            const uint* at = record_columns + records + g;
            cx = lanes_at<fv>(at);
            cy = lanes_at<fv>(at + record_column_stride);
            cz = lanes_at<fv>(at + 2u * record_column_stride);
            z = lanes_at<uv>(at + 3u * record_column_stride);
            w = lanes_at<uv>(at + 4u * record_column_stride);
        } else {
            // Decoded here, as fill_record_columns does (zeros past count).
            uint words[RECORD_COLUMNS][LANES] = {};
            vec3 step = record_step(leaf_lo, leaf_hi);
            for (uint k = 0u; k < LANES && g + k < count; k++) {
                record_column_words(records + g + k, leaf_lo, step, &words[0][k], LANES);
            }
            cx = lanes_at<fv>(words[0]);
            cy = lanes_at<fv>(words[1]);
            cz = lanes_at<fv>(words[2]);
            z = lanes_at<uv>(words[3]);
            w = lanes_at<uv>(words[4]);
        }
        // sphere_hit(lr, centre, radius, reach).
        fv radius = lanes_at<fv>(&z);
        fv tc, rr;
        iv meets = spheres_meet(cx - o.x, cy - o.y, cz - o.z, radius, d, dd, reach, &tc, &rr);
        if (keys != nullptr) {
            __builtin_memcpy(&keys->tc[g], &tc, sizeof(tc));
            __builtin_memcpy(&keys->rr[g], &rr, sizeof(rr));
        }
        // Lanes past count are left out; where every record is a sphere
        // (the usual case), the mask is the lanes' answers as they are.
        iv lane;
        for (uint k = 0u; k < LANES; k++) {
            lane[k] = int(k);
        }
        iv valid = lane < int(count - g);
        iv spheres = HAS_BOX_RECORDS ? iv((w & RECORD_SPHERE) != 0u) : (valid | ~valid);
        if (keys != nullptr) {
            for (uint k = 0u; k < LANES; k++) {
                keys->ahead[g + k] = ~0u;
            }
        }
        if (HAS_SPHERE_RECORDS && lane_bits(valid & ~spheres) == 0u) {
            uint bits = lane_bits(meets & valid);
            if (keys != nullptr && record_lookahead != nullptr) {
                // The lean copy's look-ahead: a met record none of whose
                // spheres the ray meets is left out (fill_lookahead).
                for (uint left = bits; left != 0u; left &= left - 1u) {
                    uint k = uint(__builtin_ctz(left));
                    const float* ahead = record_lookahead + size_t(records + g + k) * 4u * LOOKAHEAD;
                    // Bit j: the ray meets sphere j (item j of the group's root leaf).
                    uint any = 0u;
                    for (uint h = 0u; h < LOOKAHEAD; h += LANES) {
                        fv hx = lanes_at<fv>(ahead + h) - o.x;
                        fv hy = lanes_at<fv>(ahead + LOOKAHEAD + h) - o.y;
                        fv hz = lanes_at<fv>(ahead + 2u * LOOKAHEAD + h) - o.z;
                        fv hr = lanes_at<fv>(ahead + 3u * LOOKAHEAD + h);
                        any |= lane_bits(spheres_meet(hx, hy, hz, hr, d, dd, reach, nullptr, nullptr)) << h;
                    }
                    // All eight met: an unbounded group's (or every item): test them all.
                    keys->ahead[g + k] = (any == (1u << LOOKAHEAD) - 1u) ? ~0u : any;
                    bits &= (any != 0u) ? ~0u : ~(1u << k);
                }
            }
            met |= bits << g;
            continue;
        }
        for (uint k = 0u; k < LANES && g + k < count; k++) {
            bool sphere = HAS_SPHERE_RECORDS && (HAS_BOX_RECORDS ? (w[k] & RECORD_SPHERE) != 0u : true);
            bool hit;
            if (sphere) {
                hit = meets[k] != 0;
            } else {
                uvec4 record = leaf_record(records + g + k);
                vec3 step = record_step(leaf_lo, leaf_hi);
                vec4 lo = vec4(record_lo(record, leaf_lo, step), 0.0f);
                vec4 hi = vec4(record_hi(record, leaf_hi, step), 0.0f);
                if (keys != nullptr) {
                    vec2 span = box_span(lr, lo, hi, reach);
                    hit = !(span.x > span.y);
                    keys->tc[g + k] = span.x;
                    keys->rr[g + k] = -1.0f;
                } else {
                    hit = box_hit(lr, lo, hi, reach);
                }
            }
            met |= hit ? (1u << (g + k)) : 0u;
        }
    }
    return met;
}
