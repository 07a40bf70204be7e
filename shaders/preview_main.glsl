// preview_main.glsl: the preview kernel's body, included by preview.comp
// (the scene in storage buffers) and preview_uniform.comp (its arrays
// in storage images, as render_uniform.comp). One sample per pixel per
// frame for the preview window.
// Sample 0 is the ray through the pixel centre, so the first frame is
// byte-identical to render.comp; later samples are jittered (the host picks
// the offsets), their colours summed in `accum`, and the quantised average
// written to the pixel buffer and to the display image.
#include "layout.h"
#include "preview.h"

layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE, local_size_z = 1) in;

#include "scene_buffers.glsl"
layout(std430, binding = BINDING_PIXELS) writeonly buffer PixelBlock { PixelOut pixels[]; };
layout(std430, binding = BINDING_PREVIEW) readonly buffer PreviewBlock { PreviewFrame preview; };
layout(std430, binding = BINDING_ACCUM) buffer AccumBlock { AccumPixel accum[]; };
layout(binding = BINDING_DISPLAY, rgba8) writeonly uniform image2D display;
layout(std430, binding = BINDING_STATUS) buffer StatusBlock { PreviewStatus status; };

#include "raycast.glsl"

// Grey by distance along the ray: white at depth_range.x, black at .y and beyond.
vec3 depth_color(Ray r, SceneHit hit) {
    if (hit.id == NO_HIT) {
        return vec3(0.0f, 0.0f, 0.0f);
    }
    precise float dist = hit.t * sqrt(dot3(r.direction, r.direction));
    precise float span = max_f(preview.depth_range.y - preview.depth_range.x, 1e-6f);
    precise float g = 1.0f - clamp01((dist - preview.depth_range.x) / span);
    return vec3(g, g, g);
}

// A colour per primitive index: its bits scrambled into three bytes, kept
// away from black (which is a miss).
vec3 id_color(SceneHit hit) {
    if (hit.id == NO_HIT) {
        return vec3(0.0f, 0.0f, 0.0f);
    }
    uint h = (hit.id + 1u) * 2654435761u;
    h = h ^ (h >> 15u);
    vec3 c = vec3(float(h & 255u), float((h >> 8u) & 255u), float((h >> 16u) & 255u)) / 255.0f;
    return c * 0.75f + 0.25f;
}

void main() {
    uvec2 pixel = tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationIndex);
    uint j = pixel.x;
    uint i = pixel.y + preview.row_offset;
    if (j >= frame.width || i >= frame.height) {
        return;
    }
    uint index = i * frame.width + j;
    vec2 offset = (preview.sample_index == 0u) ? vec2(0.0f, 0.0f) : vec2(preview.jitter.x, preview.jitter.y);

    // Every mode goes through sample_pixel, so the kernel holds one copy of
    // the walk (lavapipe compiles and runs every copy); for the depth and
    // id modes the host asks for the first hit only (AOV_NORMAL).
    PixelSample s = sample_pixel(j, i, offset);
    SceneHit hit = s.hit;
    vec3 color = s.color;
    uint rays = s.rays;
    if (preview.mode == PREVIEW_DEPTH) {
        color = depth_color(camera_ray(j, i, offset), hit);
    } else if (preview.mode == PREVIEW_ID) {
        color = id_color(hit);
    }

    // Sum the samples; sample 0 divides by exactly 1, so it quantises as render.comp.
    precise vec3 sum = color;
    if (preview.sample_index > 0u) {
        sum = xyz(accum[index].sum) + color;
    }
    accum[index].sum = vec4(sum, 0.0f);
    precise vec3 average = sum / float(preview.sample_index + 1u);

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
