// preview_uniform.comp: the preview kernel with the scene's arrays in
// storage images, for scenes that fit (as render_uniform.comp), and its
// frame in a storage buffer (scene_buffers.glsl says why). The body is
// preview_main.glsl.
#version 460
#extension GL_GOOGLE_include_directive : require
#define SCENE_UNIFORM 1
#define FRAME_IN_STORAGE 1

#include "preview_main.glsl"
