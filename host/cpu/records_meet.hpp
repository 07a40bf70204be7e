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
typedef float f4 __attribute__((vector_size(16)));
typedef int i4 __attribute__((vector_size(16)));
typedef uint u4 __attribute__((vector_size(16)));

// abs in each lane, as shared.hpp's abs: the sign bit cleared.
inline f4 abs_lanes(f4 v) {
    u4 bits;
    __builtin_memcpy(&bits, &v, sizeof(bits));
    bits &= 0x7fffffffu;
    __builtin_memcpy(&v, &bits, sizeof(v));
    return v;
}
} // namespace record_lanes

// Instance record t (leaf_record) in one vector.
inline record_lanes::u4 record_at(uint t) {
#ifdef RAYCAST_CHECKED_BUFFERS
    uvec4 r = leaf_record(t);
    return record_lanes::u4{r.x, r.y, r.z, r.w};
#else
    record_lanes::u4 r;
    __builtin_memcpy(&r, &leaf_items[t * 4u], sizeof(r));
    return r;
#endif
}

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

// Writes the columns of records records .. records + count - 1 of a leaf
// whose box is [leaf_lo, leaf_hi]: x, y and z of the centre (as the walk
// decodes it), the radius word and the w word.
inline void fill_record_columns(uint* out, uint stride, vec4 leaf_lo, vec4 leaf_hi, uint records, uint count) {
    vec3 step = div_rn(xyz(leaf_hi) - xyz(leaf_lo), float(BOX_STEPS));
    for (uint t = records; t < records + count; t++) {
        uvec4 record = leaf_record(t);
        vec3 lo = record_lo(record, leaf_lo, step);
        out[t] = floatBitsToUint(lo.x);
        out[stride + t] = floatBitsToUint(lo.y);
        out[2u * stride + t] = floatBitsToUint(lo.z);
        out[3u * stride + t] = record.z;
        out[4u * stride + t] = record.w;
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
// meets within reach: bit n for record n. leaf_lo and step place their
// centres and boxes (layout.h, BvhNode). (With FLAG_NO_BVH the walk does
// not call it: every record meets.)
uint records_meet(Ray lr, vec4 leaf_lo, vec4 leaf_hi, vec3 step, uint records, uint count, float reach, WalkKeys* keys) {
    using namespace record_lanes;
    const vec3 o = lr.origin;
    const vec3 d = lr.direction;
    // dot3(d, d), once: the same value sphere_hit computes for each record.
    const float dd = dot3(d, d);
    if (keys != nullptr) {
        keys->dd = dd;
    }
    uint met = 0u;
    for (uint g = 0u; g < count; g += 4u) {
        // Four records' centres, radius words and w words.
        f4 cx, cy, cz;
        u4 z, w;
        if (record_columns != nullptr) {
            // Past count: the columns' next words (their padding at the end).
            const uint* at = record_columns + records + g;
            __builtin_memcpy(&cx, at, sizeof(cx));
            __builtin_memcpy(&cy, at + record_column_stride, sizeof(cy));
            __builtin_memcpy(&cz, at + 2u * record_column_stride, sizeof(cz));
            __builtin_memcpy(&z, at + 3u * record_column_stride, sizeof(z));
            __builtin_memcpy(&w, at + 4u * record_column_stride, sizeof(w));
        } else {
            // Four records (zeros past count), then one word of each to a
            // vector: x (the centre's x | y << 16), y (its z in the low
            // half), z (the radius's bits), w; the centre as record_lo
            // decodes it.
            u4 r0 = record_at(records + g);
            u4 r1 = (g + 1u < count) ? record_at(records + g + 1u) : u4{0u, 0u, 0u, 0u};
            u4 r2 = (g + 2u < count) ? record_at(records + g + 2u) : u4{0u, 0u, 0u, 0u};
            u4 r3 = (g + 3u < count) ? record_at(records + g + 3u) : u4{0u, 0u, 0u, 0u};
            u4 t0 = __builtin_shuffle(r0, r1, u4{0u, 4u, 1u, 5u});
            u4 t1 = __builtin_shuffle(r2, r3, u4{0u, 4u, 1u, 5u});
            u4 t2 = __builtin_shuffle(r0, r1, u4{2u, 6u, 3u, 7u});
            u4 t3 = __builtin_shuffle(r2, r3, u4{2u, 6u, 3u, 7u});
            u4 x = __builtin_shuffle(t0, t1, u4{0u, 1u, 4u, 5u});
            u4 y = __builtin_shuffle(t0, t1, u4{2u, 3u, 6u, 7u});
            z = __builtin_shuffle(t2, t3, u4{0u, 1u, 4u, 5u});
            w = __builtin_shuffle(t2, t3, u4{2u, 3u, 6u, 7u});
            cx = leaf_lo.x + __builtin_convertvector(i4(x & 0xffffu), f4) * step.x;
            cy = leaf_lo.y + __builtin_convertvector(i4(x >> 16u), f4) * step.y;
            cz = leaf_lo.z + __builtin_convertvector(i4(y & 0xffffu), f4) * step.z;
        }
        // sphere_hit(lr, centre, radius, reach).
        f4 ocx = cx - o.x;
        f4 ocy = cy - o.y;
        f4 ocz = cz - o.z;
        f4 radius;
        __builtin_memcpy(&radius, &z, sizeof(radius));
        f4 tc = ((ocx * d.x + ocy * d.y) + ocz * d.z) / dd;
        f4 px = ocx - tc * d.x;
        f4 py = ocy - tc * d.y;
        f4 pz = ocz - tc * d.z;
        // max_abs3(oc): abs (shared.hpp: the sign bit cleared), then max_f's (a < b) ? b : a.
        f4 ax = abs_lanes(ocx);
        f4 ay = abs_lanes(ocy);
        f4 az = abs_lanes(ocz);
        f4 m = ax < ay ? ay : ax;
        m = m < az ? az : m;
        f4 span = radius + m * 1.52587891e-5f;
        f4 rr = span * span;
        f4 past = tc - reach;
        f4 p2 = (px * px + py * py) + pz * pz;
        i4 meets = (p2 <= rr) & ((tc >= 0.0f) | ((tc * tc) * dd <= rr)) & ((past <= 0.0f) | ((past * past) * dd <= rr));
        if (keys != nullptr) {
            __builtin_memcpy(&keys->tc[g], &tc, sizeof(tc));
            __builtin_memcpy(&keys->rr[g], &rr, sizeof(rr));
        }
        // Lanes past count are left out; where every record is a sphere
        // (the usual case), the mask is the lanes' answers as they are.
        i4 valid = i4{0, 1, 2, 3} < int(count - g);
        i4 spheres = HAS_BOX_RECORDS ? i4((w & RECORD_SPHERE) != 0u) : i4{-1, -1, -1, -1};
        if (HAS_SPHERE_RECORDS && __builtin_ia32_movmskps(f4(valid & ~spheres)) == 0) {
            met |= uint(__builtin_ia32_movmskps(f4(meets & valid))) << g;
            continue;
        }
        for (uint k = 0u; k < 4u && g + k < count; k++) {
            bool sphere = HAS_SPHERE_RECORDS && (HAS_BOX_RECORDS ? (w[k] & RECORD_SPHERE) != 0u : true);
            bool hit;
            if (sphere) {
                hit = meets[k] != 0;
            } else {
                uvec4 record = leaf_record(records + g + k);
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
