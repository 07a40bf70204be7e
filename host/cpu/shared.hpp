// shared.hpp: the shared GLSL (shaders/layout.h + shaders/raycast.glsl),
// included unchanged as C++ with GLM. This prelude supplies what GLSL has
// built in: the vector types and functions (GLM), the `precise` qualifier
// (nothing to do: the library is built with -ffp-contract=off and never
// -ffast-math), and the scene buffers that the kernel declares as storage
// buffers — here thread-local pointers, set for each render call so that
// any number of threads can render at once.
#pragma once

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <cstring>
#include <glm/glm.hpp>

namespace raycast_cpu {
using namespace glm;
#define precise

#include "layout.h"
#include "preview.h"

#ifdef RAYCAST_CHECKED_BUFFERS
// The shader-test harness's build (its generated source defines this as
// the exit status of a run that reads past an array: host/src/harness/cpu.rs
// BUFFER_OVERRUN_EXIT): every element read is checked against the buffer
// the case gave, so a scene whose index points past an array (a node's
// first leaf item, a material) ends the run with what was read on stderr,
// not with SIGSEGV or a value from beyond. The check steers no arithmetic:
// the results are the unchecked build's bits.
[[noreturn]] inline void buffer_overrun(const char* name, uint i, uint count) {
    std::fprintf(stderr, "read %s[%u], past its %u element%s\n", name, i, count, count == 1u ? "" : "s");
    std::fflush(stderr);
    std::_Exit(RAYCAST_CHECKED_BUFFERS);
}
template <class T>
struct CheckedArray {
    const T* data = nullptr;
    uint count = 0u;
    const char* name = "";
    const T& operator[](uint i) const {
        if (i >= count) {
            buffer_overrun(name, i, count);
        }
        return data[i];
    }
};
#define RAYCAST_SCENE_ARRAY(T) CheckedArray<T>
#else
#define RAYCAST_SCENE_ARRAY(T) const T*
#endif

// The names the shared GLSL reads: `frame.width`, `primitives[i]`, …
inline thread_local Frame frame;
inline thread_local RAYCAST_SCENE_ARRAY(Primitive) primitives;
inline thread_local RAYCAST_SCENE_ARRAY(Material) materials;
inline thread_local RAYCAST_SCENE_ARRAY(Light) lights;
inline thread_local RAYCAST_SCENE_ARRAY(Texture) textures;
inline thread_local RAYCAST_SCENE_ARRAY(Texel) texels;
inline thread_local RAYCAST_SCENE_ARRAY(BvhNode) nodes;
inline thread_local RAYCAST_SCENE_ARRAY(LeafItem) leaf_items;
inline thread_local RAYCAST_SCENE_ARRAY(Instance) instances;
inline thread_local RAYCAST_SCENE_ARRAY(BvhNode) mesh_nodes;
inline thread_local RAYCAST_SCENE_ARRAY(MeshTriangle) mesh_triangles;
inline thread_local RAYCAST_SCENE_ARRAY(MeshVertex) mesh_vertices;
#undef RAYCAST_SCENE_ARRAY
// The CPU build's own: the record columns of the scene (records_meet.hpp,
// raycast_cpu_record_columns), or null (records_meet decodes the records):
// RECORD_COLUMNS columns of `record_column_stride` words each.
inline thread_local const uint* record_columns = nullptr;
inline thread_local uint record_column_stride = 0u;
// And the records' look-ahead (records_meet.hpp, fill_lookahead), or null.
inline thread_local const float* record_lookahead = nullptr;

// Element i of primitives, nodes and instances, as scene_buffers.glsl reads them.
#define primitive_at(i) primitives[i]
#define material_at(i) materials[i]
#define light_at(i) lights[i]
#define node_at(i) nodes[i]
#define instance_at(i) instances[i]

// Leaf item i, as scene_buffers.glsl reads it.
inline uint leaf_item(uint i) {
    return leaf_items[i].item;
}

// The frame as scene_buffers.glsl's frame_unfolded gives it to a CPU
// device's kernels: the same values (there each uint is hidden from the
// driver's folding).
inline Frame frame_unfolded() {
    return frame;
}

// The instance record at leaf items 4 t .. 4 t + 3, as scene_buffers.glsl reads it.
inline uvec4 leaf_record(uint t) {
    uint i = t * 4u;
    return uvec4(leaf_item(i), leaf_item(i + 1u), leaf_item(i + 2u), leaf_item(i + 3u));
}

#ifndef RAYCAST_CHECKED_BUFFERS
struct Scene {
    Frame frame;
    const Primitive* primitives;
    const Material* materials;
    const Light* lights;
    const Texture* textures;
    const Texel* texels;
    const BvhNode* nodes;
    const LeafItem* leaf_items;
    const Instance* instances;
    const BvhNode* mesh_nodes;
    const MeshTriangle* mesh_triangles;
    const MeshVertex* mesh_vertices;
    const uint* record_columns;
    uint record_column_stride;
    const float* record_lookahead;
};

inline void bind_scene(const Scene& s) {
    frame = s.frame;
    primitives = s.primitives;
    materials = s.materials;
    lights = s.lights;
    textures = s.textures;
    texels = s.texels;
    nodes = s.nodes;
    leaf_items = s.leaf_items;
    instances = s.instances;
    mesh_nodes = s.mesh_nodes;
    mesh_triangles = s.mesh_triangles;
    mesh_vertices = s.mesh_vertices;
    record_columns = s.record_columns;
    record_column_stride = s.record_column_stride;
    record_lookahead = s.record_lookahead;
}

// Binds the kernel's buffers (buffers[b] at binding b, layout.h BINDING_*,
// and the record columns at BINDING_COUNT, as raycast_cpu.h takes them)
// for this thread.
inline Scene bind_buffers(const void* const* buffers) {
    Scene s;
    std::memcpy(&s.frame, buffers[BINDING_FRAME], sizeof(Frame));
    s.primitives = static_cast<const Primitive*>(buffers[BINDING_PRIMITIVES]);
    s.materials = static_cast<const Material*>(buffers[BINDING_MATERIALS]);
    s.lights = static_cast<const Light*>(buffers[BINDING_LIGHTS]);
    s.textures = static_cast<const Texture*>(buffers[BINDING_TEXTURES]);
    s.texels = static_cast<const Texel*>(buffers[BINDING_TEXELS]);
    s.nodes = static_cast<const BvhNode*>(buffers[BINDING_NODES]);
    s.leaf_items = static_cast<const LeafItem*>(buffers[BINDING_LEAF_ITEMS]);
    s.instances = static_cast<const Instance*>(buffers[BINDING_INSTANCES]);
    s.mesh_nodes = static_cast<const BvhNode*>(buffers[BINDING_MESH_NODES]);
    s.mesh_triangles = static_cast<const MeshTriangle*>(buffers[BINDING_MESH_TRIANGLES]);
    s.mesh_vertices = static_cast<const MeshVertex*>(buffers[BINDING_MESH_VERTICES]);
    // The columns' first word is their stride, the second where the
    // look-ahead begins (0: none); they begin 4 words on.
    const uint* columns = static_cast<const uint*>(buffers[BINDING_COUNT]);
    s.record_columns = (columns == nullptr) ? nullptr : columns + 4;
    s.record_column_stride = (columns == nullptr) ? 0u : columns[0];
    s.record_lookahead = (columns == nullptr || columns[1] == 0u) ? nullptr : reinterpret_cast<const float*>(columns + 4 + columns[1]);
    bind_scene(s);
    return s;
}
#endif

// The kernels' specialization constants (scene_buffers.glsl). The CPU
// build runs every path the shaders have, but for its lean copy
// (raycast_cpu_lean.cpp, RAYCAST_CPU_LEAN): that leaves out meshes, tori
// (every shape but the course's four), the AOVs other than colour, the
// course's sampling, area lights and refraction, and the host runs it only
// where the frame's specialization leaves them out too (cpu.rs,
// Specialization::cpu_lean): the same bits with less code in the walk (11%
// fewer instructions at recursive-spheres depth 10).
#ifdef RAYCAST_CPU_LEAN
#define RAYCAST_CPU_ALL false
#else
#define RAYCAST_CPU_ALL true
#endif
// A shape's HAS_* (shapes.glsl registers it): the lean copy keeps those
// with ids below SHAPE_LEAN_IDS.
#define SHAPE_SPEC(id, name) const bool name = RAYCAST_CPU_ALL || (id) < SPEC_SHAPES + SHAPE_LEAN_IDS
const bool HAS_INSTANCES = true;
const bool HAS_POSITIONED_LIGHTS = true;
const bool HAS_SPOT_LIGHTS = true;
const bool HAS_TEXTURES = true;
const bool HAS_BILINEAR = true;
const bool HAS_SPECULAR = true;
const bool HAS_SHADOWS = true;
const bool HAS_REFLECTIONS = true;
const bool HAS_INNER_NODES = true;
const bool HAS_SEVERAL_PRIMITIVE_LEAVES = true;
const bool HAS_HIERARCHY = true;
const bool HAS_FLAT_LIST = true;
const bool HAS_BOX_RECORDS = true;
const bool HAS_SPHERE_RECORDS = true;
const bool HAS_AOVS = RAYCAST_CPU_ALL;
const bool HAS_COURSE_SAMPLING = RAYCAST_CPU_ALL;
const bool HAS_AREA_LIGHTS = RAYCAST_CPU_ALL;
const bool HAS_DOF = true;
const bool HAS_EXPLAIN = RAYCAST_CPU_ALL;
// The walk's levels in arrays (layout.h, SPEC_LEVELS_IN_REGISTERS): the
// CPU build is compiled once for every scene, so it cannot hold a scene's
// count of levels; the device's register form computes the same bits
// (`raycast check`).
const bool LEVELS_IN_REGISTERS = false;
const uint REGISTER_LEVELS = 1u;
// One stack entry a met record (layout.h, SPEC_RECORD_MASKS): records_meet
// pushes them one by one, in the order the device's masks give back.
const bool RECORD_MASKS = false;
const bool HAS_REFRACTION = RAYCAST_CPU_ALL;

// GLSL's abs: the sign bit cleared, without a branch. GLM's is
// x >= 0 ? x : -x, which GCC keeps as a branch that the walk's bound tests
// (max_abs3) mispredict, and which gives -0 for -0 where the device gives 0.
inline float abs(float x) {
    return std::fabs(x);
}

// GLSL's findLSB for a uint: one instruction where GLM's counts bits.
inline int findLSB(uint v) {
    return (v == 0u) ? -1 : __builtin_ctz(v);
}

// The walk's instance-record loop in SIMD lanes (records_meet.hpp,
// defined after the GLSL, whose box_hit and record_lo it uses), and in the
// lean copy the ordered walk (walk_keys.hpp).
#define RECORDS_MEET
#ifdef RAYCAST_CPU_LEAN
#define ORDERED_WALK
#endif
#include "walk_keys.hpp"
namespace {
struct Ray;
struct SceneHit;
uint records_meet(Ray lr, vec4 leaf_lo, vec4 leaf_hi, uint records, uint count, float reach, WalkKeys* keys);
// traversal.glsl's walk: one function, neither inlined at trace.glsl's
// two calls nor cloned for their any_hit (GCC's noclone): either way GCC
// stopped inlining the record tests into it, and the frame took 10 to 25%
// longer. (Kernels inline every call.)
#if defined(__clang__)
__attribute__((noinline))
#else
__attribute__((noinline, noclone))
#endif
SceneHit walk(Ray r, float t_max, bool any_hit);
} // namespace

// Internal linkage: each translation unit has its own copy, so GCC may
// inline a function called once (sphere_hit in walk) without keeping an
// outside copy's worth of growth against it; each unit uses only some.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wunused-function"
// A variable only TRACE reads (trace.glsl), where TRACE is nothing.
#pragma GCC diagnostic ignored "-Wunused-but-set-variable"
namespace {
#include "raycast.glsl"
#include "records_meet.hpp"
} // namespace
#pragma GCC diagnostic pop

#undef precise
} // namespace raycast_cpu
