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
    uint32_t n = max(s.frame.spp, 1u);
    sample_pixel(x, y, sample_offset(sample, n), sample_dims(sample, n));
    trace_steps = nullptr;
    trace_capacity = 0;
    return trace_count;
}
