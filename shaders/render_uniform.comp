// render_uniform.comp: the render kernel with the scene's frame in a
// uniform buffer and its arrays in rgba32ui storage images of at most
// IMAGE_ROWS rows of IMAGE_WIDTH texels (scene_buffers.glsl, SCENE_UNIFORM),
// for scenes that fit (all but flat ones of millions of primitives). Same body
// (render_main.glsl), same pixels; several times faster on lavapipe, whose
// storage-buffer loads go lane by lane with a bounds check each, uniform
// loads a 32-bit word per lane and image loads a 128-bit texel per lane
// (docs/scale.md#shaped-for-lavapipe).
#version 460
#extension GL_GOOGLE_include_directive : require
#define SCENE_UNIFORM 1

#include "render_main.glsl"
