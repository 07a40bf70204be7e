// scene_buffers.glsl: the scene's storage buffers as every kernel that
// includes raycast.glsl declares them (GLSL only; the C++ build declares its
// own in host/cpu/shared.hpp). Include after layout.h, before raycast.glsl.
#ifndef RAYCAST_SCENE_BUFFERS_GLSL
#define RAYCAST_SCENE_BUFFERS_GLSL

#ifdef SCENE_UNIFORM
// The small arrays as uniform buffers (render_uniform.comp). std140 lays
// these structs out as std430 does: vec4 / mat4 / 4-byte members, every
// struct a multiple of 16 bytes.
layout(std140, binding = BINDING_FRAME) uniform FrameBlock { Frame frame; };
layout(std140, binding = BINDING_PRIMITIVES) uniform PrimitiveBlock { Primitive primitives[UNIFORM_PRIMITIVES]; };
layout(std140, binding = BINDING_MATERIALS) uniform MaterialBlock { Material materials[UNIFORM_MATERIALS]; };
layout(std140, binding = BINDING_LIGHTS) uniform LightBlock { Light lights[UNIFORM_LIGHTS]; };
layout(std140, binding = BINDING_NODES) uniform NodeBlock { BvhNode nodes[UNIFORM_NODES]; };
layout(std140, binding = BINDING_INSTANCES) uniform InstanceBlock { Instance instances[UNIFORM_INSTANCES]; };
layout(std140, binding = BINDING_LEAF_ITEMS) uniform LeafItemBlock { LeafItemQuad leaf_item_quads[UNIFORM_LEAF_QUADS]; };
#else
layout(std430, binding = BINDING_FRAME) readonly buffer FrameBlock { Frame frame; };
layout(std430, binding = BINDING_PRIMITIVES) readonly buffer PrimitiveBlock { Primitive primitives[]; };
layout(std430, binding = BINDING_MATERIALS) readonly buffer MaterialBlock { Material materials[]; };
layout(std430, binding = BINDING_LIGHTS) readonly buffer LightBlock { Light lights[]; };
layout(std430, binding = BINDING_NODES) readonly buffer NodeBlock { BvhNode nodes[]; };
layout(std430, binding = BINDING_INSTANCES) readonly buffer InstanceBlock { Instance instances[]; };
layout(std430, binding = BINDING_LEAF_ITEMS) readonly buffer LeafItemBlock { LeafItem leaf_items[]; };
#endif

// Leaf item i (LeafItem.item), from either form of the block.
uint leaf_item(uint i) {
#ifdef SCENE_UNIFORM
    return leaf_item_quads[i >> 2u].items[i & 3u];
#else
    return leaf_items[i].item;
#endif
}
// What the kernel may leave out (layout.h, SPEC_*): true unless the host
// specialises the kernel for a scene. Only ever used as `HAS_X && runtime
// condition` or `if (HAS_X)`: an expression of constants alone would be an
// OpSpecConstantOp, which naga does not read.
layout(constant_id = SPEC_CUBES) const bool HAS_CUBES = true;
layout(constant_id = SPEC_CONES) const bool HAS_CONES = true;
layout(constant_id = SPEC_CYLINDERS) const bool HAS_CYLINDERS = true;
layout(constant_id = SPEC_SPHERES) const bool HAS_SPHERES = true;
layout(constant_id = SPEC_INSTANCES) const bool HAS_INSTANCES = true;
layout(constant_id = SPEC_POSITIONED_LIGHTS) const bool HAS_POSITIONED_LIGHTS = true;
layout(constant_id = SPEC_SPOT_LIGHTS) const bool HAS_SPOT_LIGHTS = true;
layout(constant_id = SPEC_TEXTURES) const bool HAS_TEXTURES = true;
layout(constant_id = SPEC_BILINEAR) const bool HAS_BILINEAR = true;
layout(constant_id = SPEC_SPECULAR) const bool HAS_SPECULAR = true;
layout(constant_id = SPEC_SHADOWS) const bool HAS_SHADOWS = true;
layout(constant_id = SPEC_REFLECTIONS) const bool HAS_REFLECTIONS = true;

// Arrays of one uint would take 16 bytes an element in std140: always storage.
layout(std430, binding = BINDING_TEXTURES) readonly buffer TextureBlock { Texture textures[]; };
layout(std430, binding = BINDING_TEXELS) readonly buffer TexelBlock { Texel texels[]; };

#endif
