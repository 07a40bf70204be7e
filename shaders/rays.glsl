// rays.glsl: the ray and the hit records every stage passes along: a
// shape's hit in object space (ShapeHit) and the nearest hit over the
// scene (SceneHit), T_FAR for a miss.

// Larger than any t a ray can produce; a miss.
const float T_FAR = 3.40282347e38f;

struct Ray {
    vec3 origin;
    vec3 direction; // not unit: t is measured in multiples of it
};

// A hit on one canonical shape, in object space. t <= 0 (or T_FAR) is a miss.
struct ShapeHit {
    float t;
    vec3 normal; // object-space, not unit
};

// What a walk knows of the tie rule's answer so far (traversal.glsl,
// tie_add): the least t of its hits, and 1 + the highest id at it and at
// each of the 2 floats above it (0: none).
struct TieWindow {
    float t;
    uvec3 ids;
};

// Nearest hit over the scene.
struct SceneHit {
    float t;       // T_FAR on a miss
    uint id;       // primitive index, NO_HIT on a miss
    vec3 normal;   // world-space unit normal
    vec3 p_object; // the hit point in the primitive's object space; a mesh's (u, v, 0)
    vec3 n_object; // its object-space normal as the shape test gave it (not unit)
    uint material; // the hit primitive's material and shape
    uint shape;
    uint item;     // the hit primitive's index in `primitives`
    uint passes;   // the walk's passes (AOV_COST; 0 in a kernel without HAS_AOVS)
    uint node_bytes; // AOV_LANES: the hierarchy's bytes the walk fetched (0 without HAS_AOVS)
    uint prim_bytes; // AOV_LANES: the primitives' bytes it fetched
    TieWindow tie; // the walk's tie window (traversal.glsl, tie_add)
};

ShapeHit no_hit() {
    ShapeHit h;
    h.t = T_FAR;
    h.normal = vec3(0.0f, 0.0f, 0.0f);
    return h;
}
