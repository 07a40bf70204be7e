// preview.h: the structs and binding numbers the preview kernel
// (preview.comp) adds to those of layout.h, written once. Same rules as
// layout.h: vec4 / mat4 / float / int / uint members, vec4 before scalars,
// every struct a multiple of 16 bytes. The Rust mirror is
// host/src/preview/layout.rs, checked against naga's reflection at start-up;
// the #defines become Rust constants through host/build.rs.
#ifndef RAYCAST_PREVIEW_H
#define RAYCAST_PREVIEW_H

// Descriptor set 0 bindings, after layout.h's 0..4 (BINDING_PIXELS holds
// the first sample's hit and the quantised average colour).
#define BINDING_PREVIEW 5 // PreviewFrame (one)
#define BINDING_ACCUM 6   // AccumPixel[], one per pixel, read and written
#define BINDING_DISPLAY 7 // rgba8 storage image, copied to the window
#define BINDING_STATUS 19 // PreviewStatus (one), read and written (after the meshes' 14 to 16)

// The preview kernel's specialization constant after the render kernel's
// (SPEC_COUNT, shapes.glsl): set, the host has drawn the pixels (`raycast preview
// --backend cpu`: the CPU build, raycast_cpu_preview_rows) and the kernel
// only shows their colours in the display image.
#define SPEC_HOST_PIXELS SPEC_COUNT

struct PreviewFrame {
    // xy: this sample's offset from the pixel centre, in pixels (0, 0 for
    // sample 0); zw unused.
    vec4 jitter;
    uint sample_index; // 0 starts the sum over again
    uint row_offset;   // the dispatch covers rows from this one (a band of a sample)
    uint pad0;
    uint pad1;
};

// What the host reads back after every frame (and zeroes before the next).
struct PreviewStatus {
    uint cut_short; // pixels whose loops the device cut short (RAYS_CUT_SHORT)
    uint pad0;
    uint pad1;
    uint pad2;
};

struct AccumPixel {
    vec4 sum; // xyz: the sum of the samples' colours so far; w unused
};

#endif
