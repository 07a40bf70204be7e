// render.comp: the render kernel with the scene in storage buffers (any
// size). The body is render_main.glsl.
#version 460
#extension GL_GOOGLE_include_directive : require

#include "render_main.glsl"
