// raycast_trace.cpp: the trace of one pixel's sample (`raycast trace`),
// in a translation unit of its own: here the shared GLSL's TRACE lines
// record layout.h TraceSteps; in raycast_cpu.cpp, as in a kernel, TRACE is
// nothing, so rendering pays nothing for them (it cost the CPU build 3-8%
// as a check of a thread-local pointer at every step).
#include "raycast_cpu.h"

namespace raycast_cpu {
struct TraceStep;
}

namespace {
// Where the steps go while a trace runs: up to trace_capacity of them; all
// counted.
thread_local raycast_cpu::TraceStep* trace_steps = nullptr;
thread_local uint32_t trace_capacity = 0;
thread_local uint32_t trace_count = 0;
} // namespace

#define TRACE(kind_, level_, light_, id_, passes_, origin_, direction_, value_, extra_)                              \
    do {                                                                                                          \
        if (trace_count < trace_capacity) {                                                                       \
            trace_steps[trace_count] =                                                                            \
                TraceStep{origin_, direction_, value_, extra_, kind_, level_, light_, id_, passes_, 0u, 0u, 0u};  \
        }                                                                                                         \
        trace_count++;                                                                                            \
    } while (false)

#include "shared.hpp"

using namespace raycast_cpu;

extern "C" uint32_t raycast_cpu_trace_sample(const void* const* buffers, uint32_t x, uint32_t y, uint32_t sample,
                                             void* out, uint32_t capacity) {
    Scene s = bind_buffers(buffers);
    trace_steps = static_cast<TraceStep*>(out);
    trace_capacity = capacity;
    trace_count = 0;
    if ((s.frame.flags & FLAG_COURSE_SAMPLING) != 0u) {
        // The course's scheme: its samples before this one decide where it
        // lies; they are taken without recording their steps.
        CourseSum st = course_start();
        trace_capacity = 0;
        while (st.samples < sample && !course_done(st)) {
            st = course_add(st, sample_pixel(x, y, course_offset(st), sample_dims(st.samples, 1u)).color);
        }
        trace_capacity = capacity;
        trace_count = 0;
        sample_pixel(x, y, course_offset(st), sample_dims(st.samples, 1u));
    } else {
        uint32_t n = max(s.frame.spp, 1u);
        sample_pixel(x, y, sample_offset(sample, n), sample_dims(sample, n));
    }
    trace_steps = nullptr;
    trace_capacity = 0;
    return trace_count;
}

extern "C" uint32_t raycast_cpu_course_samples(const void* const* buffers, uint32_t x, uint32_t y, float* out) {
    Scene s = bind_buffers(buffers);
    (void)s;
    trace_steps = nullptr;
    trace_capacity = 0;
    CourseSum st = course_start();
    uint32_t k = 0;
    while (!course_done(st) && k < uint32_t(COURSE_MAX_SAMPLES)) {
        vec2 offset = course_offset(st);
        uint32_t level = (st.state >> COURSE_LEVEL_SHIFT) & 3u;
        PixelSample p = sample_pixel(x, y, offset, sample_dims(st.samples, 1u));
        float* o = out + 6 * k;
        o[0] = offset.x;
        o[1] = offset.y;
        o[2] = float(level);
        o[3] = p.color.x;
        o[4] = p.color.y;
        o[5] = p.color.z;
        st = course_add(st, p.color);
        k++;
    }
    return k;
}
