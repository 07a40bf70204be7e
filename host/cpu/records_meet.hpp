// records_meet.hpp: the CPU build's form of the walk's instance-record loop
// (shaders/traversal.glsl calls it, with RECORDS_MEET, in place of the
// loop's bound tests; shared.hpp includes it after the GLSL): which of a
// leaf's instance records the ray meets, as a mask, the bounding spheres
// four at a time in SIMD lanes. Each lane does sphere_hit's
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
// four records load at once. Without them (the shader-test harness) the
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

// box_hit's interval over the box [lo, hi]: the ray meets it where
// !(span.x > span.y), entering at span.x.
inline vec2 box_span(Ray r, vec4 lo, vec4 hi, float t_max) {
    vec2 span = vec2(0.0f, t_max);
    span = slab(r.origin.x, r.direction.x, lo.x, hi.x, span);
    span = slab(r.origin.y, r.direction.y, lo.y, hi.y, span);
    span = slab(r.origin.z, r.direction.z, lo.z, hi.z, span);
    return span;
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
            __builtin_memcpy(&cx, at, sizeof(cx));
            __builtin_memcpy(&cy, at + record_column_stride, sizeof(cy));
            __builtin_memcpy(&cz, at + 2u * record_column_stride, sizeof(cz));
            __builtin_memcpy(&z, at + 3u * record_column_stride, sizeof(z));
            __builtin_memcpy(&w, at + 4u * record_column_stride, sizeof(w));
        } else {
            // Decoded here, as fill_record_columns does (zeros past count).
            uint words[RECORD_COLUMNS][LANES] = {};
            vec3 step = record_step(leaf_lo, leaf_hi);
            for (uint k = 0u; k < LANES && g + k < count; k++) {
                record_column_words(records + g + k, leaf_lo, step, &words[0][k], LANES);
            }
            __builtin_memcpy(&cx, words[0], sizeof(cx));
            __builtin_memcpy(&cy, words[1], sizeof(cy));
            __builtin_memcpy(&cz, words[2], sizeof(cz));
            __builtin_memcpy(&z, words[3], sizeof(z));
            __builtin_memcpy(&w, words[4], sizeof(w));
        }
        // sphere_hit(lr, centre, radius, reach).
        fv ocx = cx - o.x;
        fv ocy = cy - o.y;
        fv ocz = cz - o.z;
        fv radius;
        __builtin_memcpy(&radius, &z, sizeof(radius));
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
        iv meets = (p2 <= rr) & ((tc >= 0.0f) | ((tc * tc) * dd <= rr)) & ((past <= 0.0f) | ((past * past) * dd <= rr));
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
        if (HAS_SPHERE_RECORDS && lane_bits(valid & ~spheres) == 0u) {
            met |= lane_bits(meets & valid) << g;
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
