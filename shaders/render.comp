// render.comp: one invocation per pixel, 8x8 workgroups. Binds the scene
// buffers and writes each pixel's colour (or normal AOV), t, hit id and
// normal. All the work is in raycast.glsl, shared with the CPU build.
#version 460
#extension GL_GOOGLE_include_directive : require

#include "layout.h"

layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE, local_size_z = 1) in;

#include "scene_buffers.glsl"
layout(std430, binding = BINDING_PIXELS) writeonly buffer PixelBlock { PixelOut pixels[]; };

#include "raycast.glsl"

void main() {
    uint j = gl_GlobalInvocationID.x;
    uint i = gl_GlobalInvocationID.y;
    if (j >= frame.width || i >= frame.height) {
        return;
    }
    pixels[i * frame.width + j] = render_pixel(j, i);
}
