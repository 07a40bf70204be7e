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
#else
layout(std430, binding = BINDING_FRAME) readonly buffer FrameBlock { Frame frame; };
layout(std430, binding = BINDING_PRIMITIVES) readonly buffer PrimitiveBlock { Primitive primitives[]; };
layout(std430, binding = BINDING_MATERIALS) readonly buffer MaterialBlock { Material materials[]; };
layout(std430, binding = BINDING_LIGHTS) readonly buffer LightBlock { Light lights[]; };
layout(std430, binding = BINDING_NODES) readonly buffer NodeBlock { BvhNode nodes[]; };
layout(std430, binding = BINDING_INSTANCES) readonly buffer InstanceBlock { Instance instances[]; };
#endif
// Arrays of one uint would take 16 bytes an element in std140: always storage.
layout(std430, binding = BINDING_TEXTURES) readonly buffer TextureBlock { Texture textures[]; };
layout(std430, binding = BINDING_TEXELS) readonly buffer TexelBlock { Texel texels[]; };
layout(std430, binding = BINDING_LEAF_ITEMS) readonly buffer LeafItemBlock { LeafItem leaf_items[]; };

#endif
