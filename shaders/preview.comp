// preview.comp: the preview kernel with the scene in storage buffers (any
// size). The body is preview_main.glsl.
#version 460
#extension GL_GOOGLE_include_directive : require

#include "preview_main.glsl"
