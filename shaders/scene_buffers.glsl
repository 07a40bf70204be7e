// scene_buffers.glsl: the scene's storage buffers as every kernel that
// includes raycast.glsl declares them (GLSL only; the C++ build declares its
// own in host/cpu/shared.hpp). Include after layout.h, before raycast.glsl.
#ifndef RAYCAST_SCENE_BUFFERS_GLSL
#define RAYCAST_SCENE_BUFFERS_GLSL

// Kernels read primitives, materials, lights, nodes and instances through
// primitive_at(i), material_at(i), light_at(i), node_at(i) and
// instance_at(i) (macros:
// glslang 11 runs out of memory on this shader when they are functions
// returning the structs).
// The frame: in the uniform kernels (render_uniform.comp and
// preview_uniform.comp) a uniform block (std140 lays it out as std430
// does), a storage buffer in the others.
#ifdef SCENE_UNIFORM
layout(std140, binding = BINDING_FRAME) uniform FrameBlock { Frame frame; };
#else
layout(std430, binding = BINDING_FRAME) readonly buffer FrameBlock { Frame frame; };
#endif

// Lavapipe 22.3 folds the uniform-block words that a branch or a loop's
// end depends on alone into the kernel, and so builds the kernel again
// at every dispatch (its "inlined uniforms": ~8 ms a dispatch at
// recursiveSpheres4, where the specialization constants have already
// taken out what the folding would; BENCHMARKS.md, "A kernel for lanes").
// So on a CPU device (the kernels compiled without CORRECT_DIVISION or
// FAST_MATH: glslang_args.rs, Division::AsGiven) the kernel first copies
// the frame into frame_copy (frame_unfolded), each uint min'ed with
// ~gl_LocalInvocationIndex: the same value (never as large as 2^32 - 64:
// fits_uniform keeps such a frame off these kernels), but none the driver
// can fold, and loop_budget_ok's loop keeps a trip
// count it does not know. Everything after reads the copy (`frame`
// names it). GPU kernels read the block. A test in host/src/layout.rs
// checks that frame_unfolded covers every uint of Frame; the C++ build's
// (host/cpu/shared.hpp) returns the frame.
Frame frame_unfolded() {
    Frame f = frame;
    uint open = ~gl_LocalInvocationIndex;
    f.width = min(f.width, open);
    f.height = min(f.height, open);
    f.primitive_count = min(f.primitive_count, open);
    f.light_count = min(f.light_count, open);
    f.aov = min(f.aov, open);
    f.flags = min(f.flags, open);
    f.max_depth = min(f.max_depth, open);
    f.spp = min(f.spp, open);
    f.texture_filter = min(f.texture_filter, open);
    f.root_node = min(f.root_node, open);
    f.node_count = min(f.node_count, open);
    f.loop_canary = min(f.loop_canary, open);
    f.row_offset = min(f.row_offset, open);
    f.light_samples = min(f.light_samples, open);
    return f;
}
#if defined(SCENE_UNIFORM) && !defined(CORRECT_DIVISION) && !defined(FAST_MATH)
// (A global's initializer runs at the start of main, before any read.)
Frame frame_copy = frame_unfolded();
#define frame frame_copy
#endif

#ifdef SCENE_UNIFORM
// The uniform kernels: the arrays as rgba32ui storage images of the same
// bytes (layout.h, IMAGE_WIDTH), but primitives and instances packed
// (below).
layout(binding = BINDING_PRIMITIVES, rgba32ui) readonly uniform uimage2D primitive_texels;
layout(binding = BINDING_MATERIALS, rgba32ui) readonly uniform uimage2D material_texels;
layout(binding = BINDING_NODES, rgba32ui) readonly uniform uimage2D node_texels;
layout(binding = BINDING_INSTANCES, rgba32ui) readonly uniform uimage2D instance_texels;
layout(binding = BINDING_LEAF_ITEMS, rgba32ui) readonly uniform uimage2D leaf_item_texels;
// Texel t of an image, row by row.
#define SCENE_TEXEL_AT(image, t) imageLoad(image, ivec2(int((t) & uint(IMAGE_WIDTH - 1)), int((t) >> IMAGE_WIDTH_SHIFT)))
#define SCENE_TEXEL(image, n, i, k) SCENE_TEXEL_AT(image, (i) * (n) + (k))
#define SCENE_VEC4(image, n, i, k) uintBitsToFloat(SCENE_TEXEL(image, n, i, k))
// A Primitive or an Instance takes 4 texels, not 5: its matrix's columns,
// each with one of the four words that follow the matrix in its w
// (layout::padded_for_uniform packs them; the kernels read only a
// column's xyz, exact.glsl transform_point and the rest). A fetch fewer
// each for the walk's instance and primitive.
#define SCENE_PACKED_COLUMN(image, i, k) SCENE_TEXEL_AT(image, (i) * PACKED_TEXELS + (k))
#define SCENE_PACKED_MAT4(image, i) \
    mat4(vec4(uintBitsToFloat(SCENE_PACKED_COLUMN(image, i, 0u).xyz), 0.0f), \
         vec4(uintBitsToFloat(SCENE_PACKED_COLUMN(image, i, 1u).xyz), 0.0f), \
         vec4(uintBitsToFloat(SCENE_PACKED_COLUMN(image, i, 2u).xyz), 0.0f), \
         vec4(uintBitsToFloat(SCENE_PACKED_COLUMN(image, i, 3u).xyz), 1.0f))
#define SCENE_PACKED_WORDS(image, i) \
    SCENE_PACKED_COLUMN(image, i, 0u).w, SCENE_PACKED_COLUMN(image, i, 1u).w, SCENE_PACKED_COLUMN(image, i, 2u).w, \
        SCENE_PACKED_COLUMN(image, i, 3u).w
#define primitive_at(i) Primitive(SCENE_PACKED_MAT4(primitive_texels, i), SCENE_PACKED_WORDS(primitive_texels, i))
#define material_at(i) \
    Material(SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 0u), SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 1u), \
             SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 2u), SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 3u), \
             SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 4u), SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 5u), \
             SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 6u).x, SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 6u).y, \
             SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 6u).z, int(SCENE_TEXEL(material_texels, MATERIAL_TEXELS, i, 6u).w), \
             SCENE_VEC4(material_texels, MATERIAL_TEXELS, i, 7u))
#define light_at(i) \
    Light(SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 0u), SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 1u), \
          SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 2u), SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 3u), \
          SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 4u), SCENE_TEXEL(light_texels, LIGHT_TEXELS, i, 5u).x, \
          SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 5u).y, SCENE_VEC4(light_texels, LIGHT_TEXELS, i, 5u).z, \
          SCENE_TEXEL(light_texels, LIGHT_TEXELS, i, 5u).w)
#define node_at(i) \
    BvhNode(SCENE_VEC4(node_texels, NODE_TEXELS, i, 0u), SCENE_VEC4(node_texels, NODE_TEXELS, i, 1u), \
            SCENE_TEXEL(node_texels, NODE_TEXELS, i, 2u).x, SCENE_TEXEL(node_texels, NODE_TEXELS, i, 2u).y, \
            SCENE_TEXEL(node_texels, NODE_TEXELS, i, 2u).z, SCENE_TEXEL(node_texels, NODE_TEXELS, i, 2u).w)
#define instance_at(i) Instance(SCENE_PACKED_MAT4(instance_texels, i), SCENE_PACKED_WORDS(instance_texels, i))
layout(binding = BINDING_LIGHTS, rgba32ui) readonly uniform uimage2D light_texels;
#else
layout(std430, binding = BINDING_PRIMITIVES) readonly buffer PrimitiveBlock { Primitive primitives[]; };
layout(std430, binding = BINDING_MATERIALS) readonly buffer MaterialBlock { Material materials[]; };
layout(std430, binding = BINDING_LIGHTS) readonly buffer LightBlock { Light lights[]; };
layout(std430, binding = BINDING_NODES) readonly buffer NodeBlock { BvhNode nodes[]; };
layout(std430, binding = BINDING_INSTANCES) readonly buffer InstanceBlock { Instance instances[]; };
layout(std430, binding = BINDING_LEAF_ITEMS) readonly buffer LeafItemBlock { LeafItem leaf_items[]; };
#define primitive_at(i) primitives[i]
#define material_at(i) materials[i]
#define light_at(i) lights[i]
#define node_at(i) nodes[i]
#define instance_at(i) instances[i]
#endif

// Leaf item i (LeafItem.item), from either form of the block.
uint leaf_item(uint i) {
#ifdef SCENE_UNIFORM
    return SCENE_TEXEL_AT(leaf_item_texels, i >> 2u)[i & 3u];
#else
    return leaf_items[i].item;
#endif
}

// The instance record at leaf items 4 t .. 4 t + 3 (layout.h, BvhNode):
// one texel of the image.
uvec4 leaf_record(uint t) {
#ifdef SCENE_UNIFORM
    return SCENE_TEXEL_AT(leaf_item_texels, t);
#else
    uint i = t * 4u;
    return uvec4(leaf_item(i), leaf_item(i + 1u), leaf_item(i + 2u), leaf_item(i + 3u));
#endif
}
// What the kernel may leave out (layout.h, SPEC_*): true unless the host
// specialises the kernel for a scene. Only ever used as `HAS_X && runtime
// condition` or `if (HAS_X)`: an expression of constants alone would be an
// OpSpecConstantOp, which naga does not read.
// A shape's (shapes.glsl) is declared where the shape is registered:
#define SHAPE_SPEC(id, name) layout(constant_id = id) const bool name = true
layout(constant_id = SPEC_INSTANCES) const bool HAS_INSTANCES = true;
layout(constant_id = SPEC_POSITIONED_LIGHTS) const bool HAS_POSITIONED_LIGHTS = true;
layout(constant_id = SPEC_SPOT_LIGHTS) const bool HAS_SPOT_LIGHTS = true;
layout(constant_id = SPEC_TEXTURES) const bool HAS_TEXTURES = true;
layout(constant_id = SPEC_BILINEAR) const bool HAS_BILINEAR = true;
layout(constant_id = SPEC_SPECULAR) const bool HAS_SPECULAR = true;
layout(constant_id = SPEC_SHADOWS) const bool HAS_SHADOWS = true;
layout(constant_id = SPEC_REFLECTIONS) const bool HAS_REFLECTIONS = true;
layout(constant_id = SPEC_INNER_NODES) const bool HAS_INNER_NODES = true;
layout(constant_id = SPEC_SEVERAL_PRIMITIVE_LEAVES) const bool HAS_SEVERAL_PRIMITIVE_LEAVES = true;
layout(constant_id = SPEC_HIERARCHY) const bool HAS_HIERARCHY = true;
layout(constant_id = SPEC_FLAT_LIST) const bool HAS_FLAT_LIST = true;
layout(constant_id = SPEC_BOX_RECORDS) const bool HAS_BOX_RECORDS = true;
layout(constant_id = SPEC_SPHERE_RECORDS) const bool HAS_SPHERE_RECORDS = true;
layout(constant_id = SPEC_AOVS) const bool HAS_AOVS = true;
layout(constant_id = SPEC_COURSE_SAMPLING) const bool HAS_COURSE_SAMPLING = true;
layout(constant_id = SPEC_AREA_LIGHTS) const bool HAS_AREA_LIGHTS = true;
layout(constant_id = SPEC_DOF) const bool HAS_DOF = true;
layout(constant_id = SPEC_EXPLAIN) const bool HAS_EXPLAIN = true;
// The walk's form (layout.h): its levels in arrays unless LEVELS_IN_REGISTERS,
// then REGISTER_LEVELS of them in registers (used only in comparisons with
// a variable, for naga's sake as above).
layout(constant_id = SPEC_LEVELS_IN_REGISTERS) const bool LEVELS_IN_REGISTERS = false;
layout(constant_id = SPEC_REGISTER_LEVELS) const uint REGISTER_LEVELS = 1u;
layout(constant_id = SPEC_RECORD_MASKS) const bool RECORD_MASKS = false;
layout(constant_id = SPEC_REFRACTION) const bool HAS_REFRACTION = true;

// Arrays of one uint would take 16 bytes an element in std140: always storage.
layout(std430, binding = BINDING_TEXTURES) readonly buffer TextureBlock { Texture textures[]; };
layout(std430, binding = BINDING_TEXELS) readonly buffer TexelBlock { Texel texels[]; };
// Triangle meshes: storage buffers in every kernel (a mesh can outgrow the
// images, and lavapipe's branch per lane is paid only inside a mesh).
layout(std430, binding = BINDING_MESH_NODES) readonly buffer MeshNodeBlock { BvhNode mesh_nodes[]; };
layout(std430, binding = BINDING_MESH_TRIANGLES) readonly buffer MeshTriangleBlock { MeshTriangle mesh_triangles[]; };
layout(std430, binding = BINDING_MESH_VERTICES) readonly buffer MeshVertexBlock { MeshVertex mesh_vertices[]; };

#endif
