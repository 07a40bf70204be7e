// walk_keys.hpp: what the CPU build's lean copy keeps beside the walk's
// stack to walk in order (shaders/traversal.glsl, ORDERED_WALK; shared.hpp
// includes this before the GLSL, records_meet.hpp fills the keys).
//
// The ordered walk: a leaf's met instances go on the stack in order of
// their bounds' closest approach, nearest on top for the nearest hit
// (camera and mirror rays) and farthest on top for any hit (shadow rays:
// they leave from a surface deep inside the bounds around it, which seldom
// hold what blocks the light; at recursive-spheres depth 10 the warm frame
// took 10% less time than with the nearest on top, 6% less than in the
// device's order). An entry taken off the stack is tested again against
// the reach the walk has come to since it was pushed, skipped when it lies
// past it. The picture cannot change: the walk's answer does not depend
// on the order it meets hits in (the tie rule, docs/scene-format.md#ties),
// and the test again is the bound's own test at the smaller reach
// (sphere_hit's last condition, in its operations and order; box_hit's,
// whose interval only the reach narrows), so nothing it skips holds a hit
// that counts. Only the passes differ, which the lean copy does not count
// (it has no AOVs): the whole copy, which draws the AOVs, keeps the
// device's order, and `raycast check` compares its passes.
#pragma once

// One leaf's records as records_meet tested them (count at most 32):
// sphere_hit's tc and rr for a sphere, a box's entry t and -1 (past its
// entry every reach skips it), and the ray's dot3(d, d).
struct WalkKeys {
    float tc[32];
    float rr[32];
    float dd;
    // Which items of the placed group's root leaf the look-ahead found the
    // ray may meet (bit j for item j; all where it has none): the walk
    // tests only those of its primitives (records_meet.hpp, fill_lookahead).
    uint ahead[32];
};

// Whether a bound records_meet met (tc, rr, dd: its keys) lies past reach:
// sphere_hit's `(past <= 0.0f || past * past * dd <= rr)` false.
inline bool bound_passed_by(float tc, float rr, float dd, float reach) {
    float past = tc - reach;
    return !(past <= 0.0f || past * past * dd <= rr);
}

// The keys of the walk's stack entries: tc and rr slot by slot, dd level by
// level (the entries of a level were all pushed with the level's one ray).
struct KeyStack {
    float tc[STACK_SIZE];
    float rr[STACK_SIZE];
    float dd[MAX_LEVELS] = {};
    uint ahead[STACK_SIZE];

    // Slot `at` holds an entry taken at any reach (the root, a node's children).
    void any(int at) {
        tc[at] = -INFINITY;
        rr[at] = 0.0f;
        ahead[at] = ~0u;
    }

    // Whether the entry `word` at `at` lies past reach (bound_passed_by).
    bool passed_by(int at, uint word, float reach) const {
        return bound_passed_by(tc[at], rr[at], dd[(word >> STACK_LEVEL_SHIFT) & (MAX_LEVELS - 1u)], reach);
    }

    // Pushes `word` (of `level`), record n of `keys` (taken at any reach
    // unless `keyed`), among the entries first .. top - 1 pushed from its
    // leaf so far: the least tc nearest the top (the greatest with
    // far_first), ties in the order pushed.
    void push_in_order(uint* stack, int& top, int first, uint word, uint level, bool keyed, const WalkKeys& keys, uint n,
                       bool far_first) {
        float key = keyed ? keys.tc[n] : -INFINITY;
        int at = top;
        for (; at > first && (far_first ? tc[at - 1] > key : tc[at - 1] < key); at--) {
            stack[at] = stack[at - 1];
            tc[at] = tc[at - 1];
            rr[at] = rr[at - 1];
            ahead[at] = ahead[at - 1];
        }
        stack[at] = word;
        tc[at] = key;
        rr[at] = keyed ? keys.rr[n] : 0.0f;
        ahead[at] = keyed ? keys.ahead[n] : ~0u;
        dd[level] = keyed ? keys.dd : 0.0f;
        top = top + 1;
    }
};
