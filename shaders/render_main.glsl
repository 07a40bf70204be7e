// render_main.glsl: the render kernel's body, included by render.comp (the
// scene in storage buffers) and render_uniform.comp (its arrays in
// storage images: scene_buffers.glsl, SCENE_UNIFORM). One invocation per
// pixel, 8x8 workgroups, one sample of every pixel per dispatch. Binds the
// scene buffers and writes each pixel's colour (or normal AOV), t, hit id,
// normal and rays. All the work is in raycast.glsl, shared with the CPU
// build.
//
// A picture whose pixels do not fit one storage buffer is drawn in bands of
// rows (frame.row_offset), each with buffers of its own.
//
// The host dispatches the kernel frame.spp times over the same buffers:
// the running sums (`sums`, zeroed by the host) say which sample is next.
// Computed this way, the pixel is bit for bit render_pixel's (sample 0
// starts the sum, later samples add to it in order, the sum over spp is
// stored), and each invocation does one sample's work: Mesa's lavapipe
// gives an invocation 65535 loop iterations in all (sampling.glsl
// loop_budget_ok), which several samples of a deep scene exceed.
//
// Under FLAG_COURSE_SAMPLING (--supersample course) the host dispatches it
// COURSE_MAX_SAMPLES times: each pixel takes the next sample its adaptive
// scheme asks for (course_sampling.glsl; the state in `course_sums`, zeroed
// by the host) until it is done, the steps render_course_pixel takes.
#include "layout.h"

layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE, local_size_z = 1) in;

#include "scene_buffers.glsl"
layout(std430, binding = BINDING_PIXELS) writeonly buffer PixelBlock { PixelOut pixels[]; };
layout(std430, binding = BINDING_SAMPLE_SUMS) buffer SampleSumBlock { SampleSum sums[]; };
layout(std430, binding = BINDING_COURSE_SUMS) buffer CourseSumBlock { CourseSum course_sums[]; };

#include "raycast.glsl"

void main() {
    // The pixel in the band the dispatch draws, from frame.row_offset on
    // (every band but the last a whole number of tiles high).
    uvec2 pixel = tile_pixel(gl_WorkGroupID.xy, gl_LocalInvocationIndex);
    uint j = pixel.x;
    uint i = frame.row_offset + pixel.y;
    if (j >= frame.width || i >= frame.height) {
        return;
    }
    uint index = pixel.y * frame.width + j;
    if (HAS_COURSE_SAMPLING && (frame.flags & FLAG_COURSE_SAMPLING) != 0u) {
        CourseSum st = course_sums[index];
        if (course_done(st)) {
            return;
        }
        bool first = st.samples == 0u;
        PixelSample c = sample_pixel(j, i, course_offset(st), sample_dims(st.samples, 1u));
        st = course_add(st, c.color);
        st.rays = st.rays + c.rays;
        if (!loop_budget_ok()) {
            st.rays = st.rays | RAYS_CUT_SHORT;
        }
        if (first) {
            // t, id and normal are the first sample's.
            pixels[index] = pixel_out(c.hit, vec3(0.0f, 0.0f, 0.0f), st.rays);
        }
        if (course_done(st)) {
            pixels[index].rgba = pack_rgba8(course_color(st));
            pixels[index].rays = st.rays;
        }
        course_sums[index] = st;
        return;
    }
    uint n = max(frame.spp, 1u);
    uint s = sums[index].samples;
    if (s >= n) {
        return;
    }
    PixelSample x = sample_pixel(j, i, sample_offset(s, n), sample_dims(s, n));
    precise vec3 sum = x.color;
    uint rays = x.rays;
    if (s > 0u) {
        sum = xyz(sums[index].color) + x.color;
        rays = sums[index].rays + x.rays;
    }
    if (!loop_budget_ok()) {
        rays = rays | RAYS_CUT_SHORT;
    }
    if (s == 0u) {
        // t, id and normal are the first sample's.
        pixels[index] = pixel_out(x.hit, sample_average(sum, n), rays);
    } else if (s + 1u == n) {
        pixels[index].rgba = pack_rgba8(sample_average(sum, n));
        pixels[index].rays = rays;
    }
    sums[index].color = vec4(sum, 0.0f);
    sums[index].samples = s + 1u;
    sums[index].rays = rays;
}
