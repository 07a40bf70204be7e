// fma_probe.comp: fma(a, b, c) for each case, as this device computes it.
// The host compares the results with a once-rounded fma (f32::mul_add) and
// where every one agrees runs kernels whose division correction takes its
// residuals from fma() (exact.glsl FUSED_FMA; host/src/gpu/fma_probe.rs).
// The cases come from a buffer, so no compiler can fold them.
#version 460
#extension GL_GOOGLE_include_directive : require

#include "layout.h"

layout(local_size_x = 64) in;

layout(std430, binding = BINDING_FMA_CASES) readonly buffer FmaCases {
    FmaCase fma_cases[];
};
layout(std430, binding = BINDING_FMA_RESULTS) writeonly buffer FmaResults {
    FmaCase fma_results[];
};

void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i < uint(fma_cases.length())) {
        FmaCase c = fma_cases[i];
        c.r = fma(c.a, c.b, c.c);
        fma_results[i] = c;
    }
}
