// preview_uniform.comp: the preview kernel with the scene's arrays in
// storage images, for scenes that fit, and its frame in a uniform block,
// as render_uniform.comp. The body is preview_main.glsl.
#version 460
#extension GL_GOOGLE_include_directive : require
#define SCENE_UNIFORM 1

#include "preview_main.glsl"
