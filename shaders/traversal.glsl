// traversal.glsl: the nearest hit of a ray over the scene: the walk through
// the hierarchy (BVH nodes, instances of groups, nested), its box and
// sphere bounds, the primitive test it keeps the nearest of, and how far
// a shadow or mirror ray starts from the surface it leaves.

// What the walk fetches, in bytes, for AOV_LANES (layout.h: a BvhNode, its
// box alone, an instance record's texel, an Instance, a Primitive, and a
// MeshTriangle with its three MeshVertex positions; host/src/render/lanes.rs
// checks them against the structs). A leaf's item
// words are left out: a kernel specialised for leaves of one primitive
// reads none where the CPU build reads one, and the two count alike.
const uint NODE_BYTES = 48u;
const uint NODE_BOX_BYTES = 32u;
const uint RECORD_BYTES = 16u;
const uint INSTANCE_BYTES = 80u;
const uint PRIMITIVE_BYTES = 80u;
const uint TRIANGLE_BYTES = 64u;

// The normal rule (exact.glsl transform_normal), or under
// FLAG_EXPLAIN_UNTRANSPOSED_NORMALS a student's mistake: the normal mapped
// as a vector is, by the inverse of object_from_world (world_from_object),
// rather than by its transpose. For `raycast explain` only: not exact.
precise vec3 explained_normal(mat4 object_from_world, vec3 n) {
    if (HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_UNTRANSPOSED_NORMALS) != 0u) {
        vec3 a = xyz(object_from_world[0]);
        vec3 b = xyz(object_from_world[1]);
        vec3 c = xyz(object_from_world[2]);
        vec3 bc = cross(b, c);
        return vec3(dot(bc, n), dot(cross(c, a), n), dot(cross(a, b), n)) / dot(a, bc);
    }
    return transform_normal(object_from_world, n);
}

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

// An instance record's box corners (lo is also a bounding sphere's
// centre): in steps of its leaf's box (layout.h, BvhNode).
precise vec3 record_lo(uvec4 record, vec4 leaf_lo, vec3 step) {
    precise vec3 q = vec3(float(record.x & 0xffffu), float(record.x >> 16u), float(record.y & 0xffffu));
    precise vec3 lo = xyz(leaf_lo) + q * step;
    return lo;
}

precise vec3 record_hi(uvec4 record, vec4 leaf_hi, vec3 step) {
    precise vec3 q = vec3(float(record.y >> 16u), float(record.z & 0xffffu), float(record.z >> 16u));
    precise vec3 hi = xyz(leaf_hi) - q * step;
    return hi;
}

#include "shape_mesh.glsl"

// Ties (docs/scene-format.md#ties). Two hits whose t are at most TIE_ULPS
// floats apart (their bit patterns, both t > 0, differ by at most
// TIE_ULPS: integer arithmetic, the same in both builds) are a tie, and the
// later-listed primitive, the higher id, wins: the course draws a cap
// placed exactly on a surface, and two coincident quadrics with different
// transforms solve to t a float or so apart. The rule: the nearest hit's
// t, t_min, then the highest id among the hits within TIE_ULPS above it:
// a chain a ~ b ~ c whose ends are further apart has one answer whatever
// order the walk meets them in, so --no-bvh gives the same bits.
const uint TIE_ULPS = 2u;

// tie_add keeps in a walk's window (rays.glsl, TieWindow) what it knows
// of the rule's answer so far: t, the least t of its hits, and ids, for it
// and each of the TIE_ULPS floats above it, 1 + the highest id of the hits
// at exactly that t (0: none; ids.x is 0 only before the first hit). A
// nearer hit moves the window down, dropping what falls out.
// The hit (t, id) added to window w: a hit only with t < t_max (a miss is
// T_FAR); within the window, or below it, it counts.
TieWindow tie_add(TieWindow w, float t, uint id, float t_max) {
    if (!(t < t_max)) {
        return w;
    }
    uint bt = floatBitsToUint(t);
    uint bm = floatBitsToUint(w.t);
    uint mark = id + 1u;
    uvec3 ids = w.ids;
    if (ids.x == 0u || bt < bm) {
        // The new least t: the slots within TIE_ULPS of it move up.
        uint shift = (ids.x == 0u) ? TIE_ULPS + 1u : bm - bt;
        w.t = t;
        w.ids = uvec3(mark, (shift == 1u) ? ids.x : 0u, (shift == 1u) ? ids.y : ((shift == 2u) ? ids.x : 0u));
        return w;
    }
    uint k = bt - bm;
    if (k == 0u && mark > ids.x) {
        w.ids.x = mark;
    } else if (k == 1u && mark > ids.y) {
        w.ids.y = mark;
    } else if (k == 2u && mark > ids.z) {
        w.ids.z = mark;
    }
    return w;
}

// The rule's answer over the hits added: the highest id in the window
// (NO_HIT when there is none: 0 - 1).
uint tie_winner(TieWindow w) {
    uvec3 ids = w.ids;
    uint m = (ids.y > ids.x) ? ids.y : ids.x;
    m = (ids.z > m) ? ids.z : m;
    return m - 1u;
}

// How far a hit can lie and still count: TIE_ULPS floats past w.t once
// there is a hit (never past t_max). The walk's box and bound tests and a
// mesh's own walk reach this far, so no box that holds a tie is passed by.
precise float tie_reach(TieWindow w, float t_max) {
    if (w.ids.x == 0u) {
        return t_max;
    }
    precise float past = uintBitsToFloat(floatBitsToUint(w.t) + TIE_ULPS);
    return min_f(past, t_max);
}

// best with the hit of ray lr (in the space of the primitive's group)
// with primitive `item` added to its tie window (tie_add) and kept when it
// is the window's winner: its t, id (first_id plus its offset), item and
// object-space point and normal. A mesh looks no further than tie_reach.
// The walk finishes the hit it keeps after its loop (the world normal,
// material and shape).
// A mesh's hit keeps its texture coordinates (u, v, 0) where the others
// keep their point (surface_uv reads them back). With any_hit (a shadow
// ray) the first hit below t_max is the answer, and the walk returns on
// it: the tie window is left alone (the same answer and passes; 4 to 5%
// off the dispatch at recursiveSpheres4 and depth 8: BENCHMARKS.md).
SceneHit primitive_hit(SceneHit best, uint item, Ray lr, uint first_id, float t_max, bool any_hit) {
    if (HAS_AOVS) {
        best.prim_bytes = best.prim_bytes + PRIMITIVE_BYTES;
    }
    Ray local = ray_through(primitive_at(item).object_from_world, lr);
    ShapeHit h;
    bool mesh = HAS_MESHES && primitive_at(item).shape == SHAPE_MESH;
    vec2 mesh_uv = vec2(0.0f, 0.0f);
    if (mesh) {
        MeshHit m = intersect_mesh(primitive_at(item).mesh, local, tie_reach(best.tie, t_max));
        h.t = m.t;
        h.normal = m.normal;
        mesh_uv = m.uv;
        if (HAS_AOVS && frame.aov == AOV_LANES) {
            // A lane that tests a mesh walks its triangles within this
            // pass: for lane use, its steps count as passes.
            best.passes = best.passes + m.steps;
            best.node_bytes = best.node_bytes + m.node_bytes;
            best.prim_bytes = best.prim_bytes + m.triangle_bytes;
        }
    } else {
        h = intersect_shape(primitive_at(item).shape, local);
    }
    uint id = first_id + primitive_at(item).id_offset;
    if (!any_hit) {
        best.tie = tie_add(best.tie, h.t, id, t_max);
    }
    if (h.t < t_max && (any_hit || id == tie_winner(best.tie))) {
        precise vec3 p_object = mesh ? vec3(mesh_uv, 0.0f) : local.origin + h.t * local.direction;
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
// one found, its t and id only): of hits that tie (TIE_ULPS above), the
// highest primitive id, so the answer does not depend on the order things
// are tested in.
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
// ray takes 3 passes on average where it took 24 (docs/scale.md#shaped-for-lavapipe). A loop inside a pass runs its body at least once
// even when no lane enters it, so a kernel keeps only the steps its scene
// has: the inner-node step (HAS_INNER_NODES), the loop over a leaf's
// primitives or a single test (HAS_SEVERAL_PRIMITIVE_LEAVES), the
// hierarchy or the flat list (HAS_HIERARCHY, HAS_FLAT_LIST).
// (The C++ build keeps it one function for trace.glsl's two calls:
// shared.hpp declares it so.)
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
    best.node_bytes = 0u;
    best.prim_bytes = 0u;
    best.tie.t = T_FAR;
    best.tie.ids = uvec3(0u, 0u, 0u);
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
    // The top entry, while `cached`, is here and not in stack[top - 1]
    // (only with RECORD_MASKS: a mask's rest and a leaf's met records go
    // here, the entry below stored only when another comes on top).
    // lavapipe stores the stack a lane at a time: 2 to 9% off the dispatch
    // at recursive-spheres depths 4 to 10 (BENCHMARKS.md, "A kernel for
    // lanes").
    uint top_word = 0u;
    bool cached = false;
#ifdef ORDERED_WALK
    // The CPU build's lean copy: each entry's bound, to test again when it
    // is taken, and its look-ahead (host/cpu/walk_keys.hpp).
    KeyStack keyed;
    WalkKeys keys;
    keyed.any(0);
#endif
    if (frame.node_count > 0u) {
        stack[0] = frame.root_node;
        top = 1;
    }
    // Without a hierarchy: primitive `next` of primitive_count, in order.
    uint next = (frame.node_count > 0u) ? frame.primitive_count : 0u;
    // How far a box may begin and still hold a hit that counts (tie_reach).
    // `best` is its tie window's winner but where
    // a nearer hit moved the window past it and left an earlier hit the
    // winner (a chain of three within 2 TIE_ULPS): then, at the end, the
    // walk goes once more, the window as it is, and keeps that one.
    float reach = t_max;
    bool again = false;
    while (true) {
        if (top == 0 && next >= frame.primitive_count) {
            if (again || tie_winner(best.tie) == best.id) {
                break;
            }
            again = true;
            best.id = NO_HIT;
            best_level = 0u;
            unsaved = 0u;
            if (frame.node_count > 0u) {
                stack[0] = frame.root_node;
                top = 1;
                cached = false;
#ifdef ORDERED_WALK
                keyed.any(0);
#endif
            } else {
                next = 0u;
            }
        }
        if (HAS_AOVS) {
            best.passes = best.passes + 1u;
        }
#ifdef ORDERED_WALK
        // The primitives the look-ahead left in (walk_keys.hpp, WalkKeys.ahead).
        uint primitives_ahead = ~0u;
#endif
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
#ifdef ORDERED_WALK
            if (keyed.passed_by(top, stack[top], reach)) {
                continue;
            }
            primitives_ahead = keyed.ahead[top];
#endif
            uint word = stack[top];
            if (cached) {
                word = top_word;
            }
            cached = false;
            uint entry = word & STACK_ENTRY_MASK;
            level = (word >> STACK_LEVEL_SHIFT) & (MAX_LEVELS - 1u);
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
                if (RECORD_MASKS) {
                    // A leaf's met records (layout.h, SPEC_RECORD_MASKS):
                    // the highest left, as the last of one entry a record
                    // would be, or with RECORD_LOW_FIRST the lowest; the
                    // rest stay on the stack.
                    uint met = k & 0xffu;
                    uint n = ((k & RECORD_LOW_FIRST) != 0u) ? uint(findLSB(met)) : uint(findMSB(met));
                    met = met & ~(1u << n);
                    if (met != 0u) {
                        top_word = (word & ~0xffu) | met;
                        cached = true;
                        top = top + 1;
                    }
                    k = leaf_record((k >> RECORD_MASK_SHIFT) + n).w & (ITEM_INSTANCE - 1u) & ~RECORD_SPHERE;
                }
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
                if (HAS_AOVS) {
                    best.node_bytes = best.node_bytes + INSTANCE_BYTES;
                }
            }
            BvhNode node = node_at(entry);
            if (HAS_AOVS) {
                best.node_bytes = best.node_bytes + NODE_BYTES;
            }
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
                if (cached) {
                    stack[top - 1] = top_word;
                    cached = false;
                }
                vec4 lo0 = node_at(c0).lo;
                vec4 hi0 = node_at(c0).hi;
                vec4 lo1 = node_at(c1).lo;
                vec4 hi1 = node_at(c1).hi;
                if (HAS_AOVS) {
                    best.node_bytes = best.node_bytes + 2u * NODE_BOX_BYTES;
                }
                if (!use_boxes || box_hit(lr, lo0, hi0, reach)) {
                    stack[top] = stack_word(c0, level);
#ifdef ORDERED_WALK
                    keyed.any(top);
#endif
                    top = top + 1;
                    pushed = c0;
                }
                if (!use_boxes || box_hit(lr, lo1, hi1, reach)) {
                    stack[top] = stack_word(c1, level);
#ifdef ORDERED_WALK
                    keyed.any(top);
#endif
                    top = top + 1;
                    pushed = c1;
                }
                if (pushed == NO_HIT) {
                    continue;
                }
                // Its box is one of the two just read (its instances' boxes are relative to it).
                node = node_at(pushed);
                if (HAS_AOVS) {
                    best.node_bytes = best.node_bytes + NODE_BYTES - NODE_BOX_BYTES;
                }
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
#ifdef ORDERED_WALK
                if (n < 32u && ((primitives_ahead >> n) & 1u) == 0u) {
                    continue;
                }
#endif
                best = primitive_hit(best, direct ? first_item : leaf_item(first_item + n), lr, first_id, t_max, any_hit);
            }
        } else if (prim_count > 0u) {
            // At most one: an `if`, not a loop (12% of recursiveSpheres4's
            // dispatch: a lavapipe loop costs far more than its body).
            best = primitive_hit(best, direct ? first_item : first_primitive, lr, first_id, t_max, any_hit);
        }
        reach = tie_reach(best.tie, t_max);
        if (best.id != best_before) {
            // A new winner in this leaf (ids are unique, so it has another
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
            uint records = (first_item + prim_count + 3u) >> 2u;
#ifdef RECORDS_MEET
            // The CPU build's form (host/cpu/records_meet.hpp): the same
            // tests, a leaf's spheres several at a time, then the met pushed
            // in the loop's order (the lean copy in its own, walk_keys.hpp).
            if (HAS_AOVS) {
                best.node_bytes = best.node_bytes + RECORD_BYTES * (item_count - prim_count);
            }
            for (uint base = 0u; base < item_count - prim_count; base += 32u) {
                uint count = min(item_count - prim_count - base, 32u);
#ifdef ORDERED_WALK
                // The lean copy's: in order of their bounds (the nearest on
                // top, the farthest for any hit), each with its keys.
                uint met = use_boxes ? records_meet(lr, leaf_lo, leaf_hi, records + base, count, reach, &keys) : (0xffffffffu >> (32u - count));
                int first_pushed = top;
                for (; met != 0u; met = met & (met - 1u)) {
                    uint n = uint(findLSB(met));
                    uint word = stack_word(leaf_record(records + base + n).w & ~RECORD_SPHERE, level);
                    keyed.push_in_order(stack, top, first_pushed, word, level, use_boxes, keys, n, any_hit);
                }
#else
                uint met = use_boxes ? records_meet(lr, leaf_lo, leaf_hi, records + base, count, reach, nullptr) : (0xffffffffu >> (32u - count));
                for (; met != 0u; met = met & (met - 1u)) {
                    uint record_w = leaf_record(records + base + uint(findLSB(met))).w;
                    stack[top] = stack_word(record_w & ~RECORD_SPHERE, level);
                    top = top + 1;
                }
#endif
            }
#else
            precise vec3 step = div_rn(xyz(leaf_hi) - xyz(leaf_lo), float(BOX_STEPS));
            if (HAS_AOVS) {
                best.node_bytes = best.node_bytes + RECORD_BYTES * (item_count - prim_count);
            }
            // With RECORD_MASKS, the met records as one entry: a store to
            // the stack a leaf, not a record (lavapipe stores lane by
            // lane): 5% off the dispatch at recursive-spheres depths 8
            // and 10 (BENCHMARKS.md, "A kernel for lanes"). In colour
            // (no AOVs: the passes are not counted), taken from the end of
            // the mask whose record lies nearer along the ray (its bound's
            // centre, or its box's lo; for a shadow ray, farther): a
            // nearer hit first culls more of the rest (8 to 11% off at
            // depth 10). The answer does not depend on the order (the tie
            // rule); the AOVs keep the order of one entry a record, which
            // the CPU build counts.
            uint met_mask = 0u;
            bool ordered = true;
            if (HAS_AOVS) {
                ordered = false;
            }
            float first_key = 0.0f;
            float last_key = 0.0f;
            for (uint n = prim_count; n < item_count; n++) {
                // Pushed only when the ray meets the instance's bound: a
                // missed instance costs no pass. The bound is a box or a
                // sphere (RECORD_SPHERE; a scene's kernel keeps the tests
                // its records need), whose centre is where a box's lo is.
                uvec4 record = leaf_record(records + (n - prim_count));
                precise vec3 lo = record_lo(record, leaf_lo, step);
                bool sphere = HAS_SPHERE_RECORDS && (HAS_BOX_RECORDS ? (record.w & RECORD_SPHERE) != 0u : true);
                bool meets = !use_boxes;
                if (sphere) {
                    meets = meets || sphere_hit(lr, lo, uintBitsToFloat(record.z), reach);
                } else if (HAS_BOX_RECORDS) {
                    meets = meets || box_hit(lr, vec4(lo, 0.0f), vec4(record_hi(record, leaf_hi, step), 0.0f), reach);
                }
                if (meets) {
                    if (RECORD_MASKS) {
                        if (ordered) {
                            float key = dot3(lo - lr.origin, lr.direction);
                            first_key = (met_mask == 0u) ? key : first_key;
                            last_key = key;
                        }
                        met_mask = met_mask | (1u << (n - prim_count));
                    } else {
                        stack[top] = stack_word(record.w & ~RECORD_SPHERE, level);
                        top = top + 1;
                    }
                }
            }
            if (RECORD_MASKS && met_mask != 0u) {
                if (cached) {
                    stack[top - 1] = top_word;
                }
                // A shadow ray's farthest end first: it leaves from deep
                // inside the bounds around its own surface, and what blocks
                // it lies further out (as the CPU build's lean copy orders).
                uint low_first = (ordered && (any_hit ? first_key > last_key : first_key < last_key)) ? RECORD_LOW_FIRST : 0u;
                top_word = stack_word(ITEM_INSTANCE | (records << RECORD_MASK_SHIFT) | low_first | met_mask, level);
                cached = true;
                top = top + 1;
            }
#endif
        }
    }
    if (best.id != NO_HIT) {
        // The normal in the world: in the primitive's group, then by the
        // normal rule level by level back up (unit at the end).
        Primitive hit_primitive = primitive_at(best.item);
        // FLAG_EXPLAIN_LONG_NORMALS: a student's mistake, the object's
        // normal made unit length and the world's not.
        bool long_normals = HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_LONG_NORMALS) != 0u;
        precise vec3 n_object = long_normals ? unit(best.n_object) : best.n_object;
        precise vec3 n_world = explained_normal(hit_primitive.object_from_world, n_object);
        if (HAS_INSTANCES) {
            if (LEVELS_IN_REGISTERS) {
                // The same order, deepest first, over the scene's levels.
                for (uint i = 1u; i < REGISTER_LEVELS; i++) {
                    uint l = REGISTER_LEVELS - i;
                    if (l <= best_level) {
                        uint placed = (((unsaved >> l) & 1u) != 0u) ? level_instance[l] : best_instance[l];
                        n_world = explained_normal(instance_at(placed).object_from_parent, n_world);
                    }
                }
            } else {
                for (uint l = best_level; l > 0u; l--) {
                    uint placed = (((unsaved >> l) & 1u) != 0u) ? level_instance[l] : best_instance[l];
                    n_world = explained_normal(instance_at(placed).object_from_parent, n_world);
                }
            }
        }
        best.normal = long_normals ? n_world : unit(n_world);
        if (HAS_EXPLAIN && (frame.flags & FLAG_EXPLAIN_FLIP_NORMALS) != 0u) {
            best.normal = -best.normal;
        }
        best.material = hit_primitive.material;
        best.shape = hit_primitive.shape;
    } else {
        best.t = T_FAR;
    }
    // A copy: `best` then stays the walk's own (the CPU build keeps it in
    // registers, where as the return slot itself every hit kept was a copy
    // through memory).
    SceneHit found = best;
    return found;
}

// The nearest hit of ray r with t > 0 (T_FAR and NO_HIT on a miss).
SceneHit trace(Ray r) {
    return walk(r, T_FAR, false);
}
