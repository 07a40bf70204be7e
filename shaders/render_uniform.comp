// render_uniform.comp: the render kernel with the scene's small arrays
// (frame, primitives, materials, lights, nodes, instances) in uniform
// buffers of at most UNIFORM_BLOCK_BYTES each, for scenes that fit (every
// instanced scene does). Same body (render_main.glsl), same pixels; about
// 1.4 times faster on lavapipe, whose storage-buffer loads go lane by lane
// with a bounds check each (BENCHMARKS.md, "Why lavapipe is slow here").
#version 460
#extension GL_GOOGLE_include_directive : require
#define SCENE_UNIFORM 1

#include "render_main.glsl"
