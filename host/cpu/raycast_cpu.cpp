// raycast_cpu.cpp: the C ABI over the C++ build of the shared GLSL.
#include "raycast_cpu.h"

#include <cstddef>
#include <cstring>

#include "shared.hpp"

using namespace raycast_cpu;

// The lean copy's entry points end in _lean (raycast_cpu_lean.cpp), its
// AVX2 build's in _lean_avx2 (raycast_cpu_lean_avx2.cpp).
#if defined(RAYCAST_CPU_LEAN) && defined(RAYCAST_CPU_AVX2)
#define RAYCAST_CPU_ENTRY(name) name##_lean_avx2
#elif defined(RAYCAST_CPU_LEAN)
#define RAYCAST_CPU_ENTRY(name) name##_lean
#else
#define RAYCAST_CPU_ENTRY(name) name
#endif

extern "C" void RAYCAST_CPU_ENTRY(raycast_cpu_render_rows)(const void* const* buffers, uint32_t row_begin, uint32_t row_end,
                                        void* out) {
    Scene s = bind_buffers(buffers);
    PixelOut* pixels = static_cast<PixelOut*>(out);
    for (uint32_t i = row_begin; i < row_end; i++) {
        for (uint32_t j = 0; j < s.frame.width; j++) {
            pixels[size_t(i - row_begin) * s.frame.width + j] = render_pixel(j, i);
        }
    }
}

extern "C" void RAYCAST_CPU_ENTRY(raycast_cpu_preview_rows)(const void* const* buffers, uint32_t row_begin, uint32_t row_end,
                                         uint32_t sample_index, float jitter_x, float jitter_y, void* accum_out,
                                         void* out) {
    Scene s = bind_buffers(buffers);
    AccumPixel* accum = static_cast<AccumPixel*>(accum_out);
    PixelOut* pixels = static_cast<PixelOut*>(out);
    vec2 offset = (sample_index == 0u) ? vec2(0.0f, 0.0f) : vec2(jitter_x, jitter_y);
    for (uint32_t i = row_begin; i < row_end; i++) {
        for (uint32_t j = 0; j < s.frame.width; j++) {
            size_t index = size_t(i - row_begin) * s.frame.width + j;
            // preview_main.glsl's steps, but the canary (the CPU build has no loop budget).
            PixelSample x = sample_pixel(j, i, offset, sample_dims(sample_index, 1u));
            vec3 sum = x.color;
            if (sample_index > 0u) {
                sum = xyz(accum[index].sum) + x.color;
            }
            accum[index].sum = vec4(sum, 0.0f);
            vec3 average = sample_average(sum, sample_index + 1u);
            if (sample_index == 0u) {
                pixels[index] = pixel_out(x.hit, average, x.rays);
            } else {
                pixels[index].rgba = pack_rgba8(average);
            }
        }
    }
}

#ifndef RAYCAST_CPU_LEAN
extern "C" uint64_t raycast_cpu_record_columns(const void* const* buffers, uint32_t* out, uint64_t capacity) {
    Scene s = bind_buffers(buffers);
    uint slots = record_column_slots();
    if (slots == 0u) {
        return 0u;
    }
    uint stride = slots + RECORD_COLUMN_PADDING;
    // The columns, then each slot's look-ahead.
    uint64_t ahead = uint64_t(RECORD_COLUMNS) * stride;
    uint64_t words = 4u + ahead + uint64_t(slots) * 4u * LOOKAHEAD;
    if (out == nullptr || capacity < words) {
        return words;
    }
    std::memset(out, 0, words * sizeof(uint32_t));
    out[0] = stride;
    out[1] = uint32_t(ahead);
    float* lookahead = reinterpret_cast<float*>(out + 4 + ahead);
    for (uint n = 0u; n < s.frame.node_count; n++) {
        BvhNode node = node_at(n);
        if (node.count > node.primitives) {
            uint records = (node.first + node.primitives + 3u) >> 2u;
            fill_record_columns(out + 4, stride, node.lo, node.hi, records, node.count - node.primitives);
            for (uint t = records; t < records + node.count - node.primitives; t++) {
                fill_lookahead(t, lookahead + size_t(t) * 4u * LOOKAHEAD);
            }
        }
    }
    return words;
}

namespace {
struct Field {
    const char* type;
    const char* member; // nullptr: the struct's size
    int64_t value;
};

#define SIZE(T) {#T, nullptr, int64_t(sizeof(T))}
#define AT(T, m) {#T, #m, int64_t(offsetof(T, m))}
const Field fields[] = {
    SIZE(Frame), AT(Frame, world_from_film), AT(Frame, eye), AT(Frame, k), AT(Frame, aov_scale), AT(Frame, width),
    AT(Frame, height), AT(Frame, primitive_count), AT(Frame, light_count), AT(Frame, aov),
    AT(Frame, flags), AT(Frame, max_depth), AT(Frame, spp), AT(Frame, texture_filter),
    AT(Frame, root_node), AT(Frame, node_count), AT(Frame, loop_canary),
    AT(Frame, row_offset), AT(Frame, lens_radius), AT(Frame, focal_distance), AT(Frame, light_samples),
    SIZE(BvhNode), AT(BvhNode, lo), AT(BvhNode, hi), AT(BvhNode, first), AT(BvhNode, count),
    AT(BvhNode, axis), AT(BvhNode, primitives),
    SIZE(LeafItem), AT(LeafItem, item),
    SIZE(Instance), AT(Instance, object_from_parent), AT(Instance, root), AT(Instance, id_offset),
    AT(Instance, pad0), AT(Instance, pad1),
    SIZE(Texture), AT(Texture, offset), AT(Texture, width), AT(Texture, height), AT(Texture, pad0),
    SIZE(Texel), AT(Texel, rgba),
    SIZE(Primitive), AT(Primitive, object_from_world), AT(Primitive, shape), AT(Primitive, material),
    AT(Primitive, id_offset), AT(Primitive, mesh),
    SIZE(MeshTriangle), AT(MeshTriangle, a), AT(MeshTriangle, b), AT(MeshTriangle, c), AT(MeshTriangle, flags),
    SIZE(MeshVertex), AT(MeshVertex, position), AT(MeshVertex, normal),
    SIZE(Material), AT(Material, diffuse), AT(Material, ambient), AT(Material, specular),
    AT(Material, reflective), AT(Material, transparent), AT(Material, emissive),
    AT(Material, shininess), AT(Material, blend), AT(Material, ior), AT(Material, texture),
    AT(Material, texture_repeat),
    SIZE(Light), AT(Light, color), AT(Light, position), AT(Light, direction_to_light),
    AT(Light, spot_axis), AT(Light, attenuation), AT(Light, kind), AT(Light, angle_deg),
    AT(Light, penumbra_deg), AT(Light, pad0),
    SIZE(PixelOut), AT(PixelOut, normal), AT(PixelOut, t), AT(PixelOut, id), AT(PixelOut, rgba),
    AT(PixelOut, rays),
    SIZE(AccumPixel), AT(AccumPixel, sum),
    SIZE(TraceStep), AT(TraceStep, origin), AT(TraceStep, direction), AT(TraceStep, value), AT(TraceStep, extra),
    AT(TraceStep, kind), AT(TraceStep, level), AT(TraceStep, light), AT(TraceStep, id), AT(TraceStep, passes),
    AT(TraceStep, pad0), AT(TraceStep, pad1), AT(TraceStep, pad2),
};
#undef SIZE
#undef AT
} // namespace

extern "C" int64_t raycast_cpu_field_offset(const char* type, const char* member) {
    for (const Field& f : fields) {
        if (std::strcmp(f.type, type) != 0) continue;
        if (member == nullptr && f.member == nullptr) return f.value;
        if (member != nullptr && f.member != nullptr && std::strcmp(f.member, member) == 0) return f.value;
    }
    return -1;
}
#endif
