// preview_main.glsl: the preview kernel's body, included by preview.comp
// (the scene in storage buffers) and preview_uniform.comp (its arrays
// in storage images, as render_uniform.comp). One sample per pixel per
// frame for the preview window.
// Sample 0 is the ray through the pixel centre, so the first frame is
// byte-identical to render.comp; later samples are jittered (the host picks
// the offsets), their colours summed in `accum`, and the quantised average
// written to the pixel buffer and to the display image. With HOST_PIXELS
// the host has drawn them (the CPU build's raycast_cpu_preview_rows, the
// same steps in C++) and the kernel shows the pixel buffer's colours.
#include "layout.h"
#include "preview.h"

layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE, local_size_z = 1) in;

#include "scene_buffers.glsl"
layout(std430, binding = BINDING_PIXELS) buffer PixelBlock { PixelOut pixels[]; };
layout(std430, binding = BINDING_PREVIEW) readonly buffer PreviewBlock { PreviewFrame preview; };
layout(std430, binding = BINDING_ACCUM) buffer AccumBlock { AccumPixel accum[]; };
layout(binding = BINDING_DISPLAY, rgba8) writeonly uniform image2D display;
layout(std430, binding = BINDING_STATUS) buffer StatusBlock { PreviewStatus status; };

#include "raycast.glsl"

layout(constant_id = SPEC_HOST_PIXELS) const bool HOST_PIXELS = false;

void main() {
    uvec2 pixel = tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationIndex);
    uint j = pixel.x;
    uint i = pixel.y + preview.row_offset;
    if (j >= frame.width || i >= frame.height) {
        return;
    }
    uint index = i * frame.width + j;
    if (HOST_PIXELS) {
        imageStore(display, ivec2(int(j), int(i)), unpackUnorm4x8(pixels[index].rgba));
        return;
    }
    vec2 offset = (preview.sample_index == 0u) ? vec2(0.0f, 0.0f) : vec2(preview.jitter.x, preview.jitter.y);

    // Every mode is a Frame.aov of sample_pixel, as in render.comp.
    // Its lens point and area-light rotation: sample_index of a sequence without end (n = 1).
    PixelSample s = sample_pixel(j, i, offset, sample_dims(preview.sample_index, 1u));
    SceneHit hit = s.hit;
    vec3 color = s.color;
    uint rays = s.rays;

    // Sum the samples; sample 0 divides by exactly 1, so it quantises as render.comp.
    precise vec3 sum = color;
    if (preview.sample_index > 0u) {
        sum = xyz(accum[index].sum) + color;
    }
    accum[index].sum = vec4(sum, 0.0f);
    precise vec3 average = sample_average(sum, preview.sample_index + 1u);

    // Sample 0's hit (the pixel centre's) stays in the pixel buffer for picking.
    uint rgba = pack_rgba8(average);
    bool cut_short = !loop_budget_ok();
    if (cut_short) {
        rays = rays | RAYS_CUT_SHORT;
        atomicAdd(status.cut_short, 1u);
    }
    if (preview.sample_index == 0u) {
        pixels[index] = pixel_out(hit, average, rays);
    } else {
        pixels[index].rgba = rgba;
        if (cut_short) {
            pixels[index].rays = rays;
        }
    }
    imageStore(display, ivec2(int(j), int(i)), unpackUnorm4x8(rgba));
}
