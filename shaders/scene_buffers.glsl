// scene_buffers.glsl: the scene's storage buffers as every kernel that
// includes raycast.glsl declares them (GLSL only; the C++ build declares its
// own in host/cpu/shared.hpp). Include after layout.h, before raycast.glsl.
#ifndef RAYCAST_SCENE_BUFFERS_GLSL
#define RAYCAST_SCENE_BUFFERS_GLSL

layout(std430, binding = BINDING_FRAME) readonly buffer FrameBlock { Frame frame; };
layout(std430, binding = BINDING_PRIMITIVES) readonly buffer PrimitiveBlock { Primitive primitives[]; };
layout(std430, binding = BINDING_MATERIALS) readonly buffer MaterialBlock { Material materials[]; };
layout(std430, binding = BINDING_LIGHTS) readonly buffer LightBlock { Light lights[]; };
layout(std430, binding = BINDING_TEXTURES) readonly buffer TextureBlock { Texture textures[]; };
layout(std430, binding = BINDING_TEXELS) readonly buffer TexelBlock { Texel texels[]; };
layout(std430, binding = BINDING_NODES) readonly buffer NodeBlock { BvhNode nodes[]; };
layout(std430, binding = BINDING_LEAF_ITEMS) readonly buffer LeafItemBlock { LeafItem leaf_items[]; };
layout(std430, binding = BINDING_INSTANCES) readonly buffer InstanceBlock { Instance instances[]; };

#endif
