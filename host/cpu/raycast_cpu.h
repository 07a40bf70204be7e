/* raycast_cpu.h: the C ABI of the CPU build of the shared GLSL. The structs
 * are those of shaders/layout.h; the Rust host passes its mirrors
 * (host/src/layout.rs), whose sizes and offsets it checks against
 * raycast_cpu_field_offset at start-up. */
#ifndef RAYCAST_CPU_H
#define RAYCAST_CPU_H

#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

/* Renders rows [row_begin, row_end) of the frame into out (width pixels a
 * row, out[0] is the first pixel of row_begin). buffers[b] is the buffer the
 * kernel binds at binding b (layout.h BINDING_*, up to BINDING_COUNT; the
 * pixel binding is unused), and buffers[BINDING_COUNT] the record columns
 * (raycast_cpu_record_columns) or NULL. Safe to call from many threads at
 * once. */
void raycast_cpu_render_rows(const void* const* buffers, uint32_t row_begin, uint32_t row_end, void* out);

/* One sample of the preview window (shaders/preview_main.glsl, the same
 * steps): sample `sample_index` of rows [row_begin, row_end), through each
 * pixel's centre for sample 0, else (jitter_x, jitter_y) pixels off it,
 * added to accum (preview.h AccumPixel, the sum of the earlier samples);
 * writes the pixels (sample 0: the whole PixelOut; later samples: the
 * average's rgba). accum and pixels hold the rows' pixels, accum[0] and
 * pixels[0] the first of row_begin. Safe to call from many threads at once. */
void raycast_cpu_preview_rows(const void* const* buffers, uint32_t row_begin, uint32_t row_end, uint32_t sample_index,
                              float jitter_x, float jitter_y, void* accum, void* pixels);

/* The two above, compiled with meshes, tori, the AOVs other than colour,
 * the course's sampling, area lights and refraction left out
 * (raycast_cpu_lean.cpp): for frames that reach none of them, the same bits. */
void raycast_cpu_render_rows_lean(const void* const* buffers, uint32_t row_begin, uint32_t row_end, void* out);
void raycast_cpu_preview_rows_lean(const void* const* buffers, uint32_t row_begin, uint32_t row_end,
                                   uint32_t sample_index, float jitter_x, float jitter_y, void* accum_out, void* out);

/* The lean two compiled for x86-64 with AVX2 (raycast_cpu_lean_avx2.cpp;
 * only in x86-64 builds, to be called only where the CPU has AVX2). */
void raycast_cpu_render_rows_lean_avx2(const void* const* buffers, uint32_t row_begin, uint32_t row_end, void* out);
void raycast_cpu_preview_rows_lean_avx2(const void* const* buffers, uint32_t row_begin, uint32_t row_end,
                                        uint32_t sample_index, float jitter_x, float jitter_y, void* accum_out,
                                        void* out);

/* Traces sample `sample` of pixel (x, y) as raycast_cpu_render_rows renders
 * it: writes its steps (layout.h TraceStep), up to `capacity`, to out and
 * returns how many there are. Safe to call from many threads at once. */
uint32_t raycast_cpu_trace_sample(const void* const* buffers, uint32_t x, uint32_t y, uint32_t sample, void* out,
                                  uint32_t capacity);

/* Under FLAG_COURSE_SAMPLING: the samples the course's adaptive scheme takes
 * at pixel (x, y), in the order it takes them (course_sampling.glsl). For
 * each, 6 floats to out: its offset from the pixel centre (x, y), its
 * square's level, its colour (r, g, b). out holds COURSE_MAX_SAMPLES of
 * them; returns how many there are. */
uint32_t raycast_cpu_course_samples(const void* const* buffers, uint32_t x, uint32_t y, float* out);

/* The scene's instance records by column, as the walk's SIMD lanes read
 * them (records_meet.hpp): the words they take (0: the scene has none),
 * written to out when capacity (in words) holds them. buffers as
 * raycast_cpu_render_rows takes them, the columns' own entry unread. */
uint64_t raycast_cpu_record_columns(const void* const* buffers, uint32_t* out, uint64_t capacity);

/* The C++ layout of struct `type` (e.g. "Material"): its size when member is
 * NULL, else the member's offset; -1 when unknown. */
int64_t raycast_cpu_field_offset(const char* type, const char* member);

#ifdef __cplusplus
}
#endif

#endif
