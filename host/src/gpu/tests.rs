//! Tests of the gpu part on lavapipe (Mesa's software Vulkan device), with
//! the Khronos validation layer on. Kernels are small GLSL compute shaders
//! compiled here with glslangValidator.

use std::path::PathBuf;
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Duration;

use super::*;
use crate::layout::{pixel_kernel_bindings, BindingLayout, BufferShape, FieldLayout, StructLayout};

/// The device every test runs on (present wherever mesa-vulkan-drivers is).
fn lavapipe() -> Option<DeviceSelector> {
    Some(DeviceSelector::Name("llvmpipe".into()))
}

fn validated_context() -> GpuContext {
    let opts = GpuOptions { device: lavapipe(), validation: true, ..Default::default() };
    GpuContext::new(&opts).unwrap_or_else(|e| panic!("{e}"))
}

/// Compiles the GLSL compute shader `src` to SPIR-V, with shaders/ on the include path.
fn compile(name: &str, src: &str) -> Vec<u8> {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let dir = std::env::temp_dir().join(format!(
        "raycast-gpu-test-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let (comp, spv) = (dir.join(format!("{name}.comp")), dir.join(format!("{name}.spv")));
    std::fs::write(&comp, src).unwrap();
    let include = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../shaders");
    glsl_to_spirv(&comp, &include, &spv, Division::AsGiven).unwrap_or_else(|e| panic!("{name}: {e}"));
    let bytes = std::fs::read(&spv).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    bytes
}

/// Panics with every message when the validation layer said anything.
fn assert_no_messages(sink: &std::sync::Mutex<Vec<String>>, when: &str) {
    let messages = sink.lock().unwrap().clone();
    assert!(messages.is_empty(), "{} validation message(s) {when}:\n{}", messages.len(), messages.join("\n"));
}

fn field(name: &'static str, offset: u32, size: u32) -> FieldLayout {
    FieldLayout { name, offset, size }
}

fn params_layout() -> StructLayout {
    StructLayout {
        name: "Params",
        size: 16,
        fields: vec![field("count", 0, 4), field("pad0", 4, 4), field("pad1", 8, 4), field("pad2", 12, 4)],
    }
}

fn item_layout() -> StructLayout {
    StructLayout { name: "Item", size: 8, fields: vec![field("u", 0, 4), field("f", 4, 4)] }
}

const COMMON: &str = r#"
#version 450
layout(local_size_x = 64) in;
struct Params { uint count; uint pad0; uint pad1; uint pad2; };
struct Item { uint u; float f; };
layout(std430, set = 0, binding = 0) readonly buffer ParamsBuf { Params params; };
layout(std430, set = 0, binding = 2) buffer Outputs { Item results[]; };
"#;

/// results[i] = 2 * items[i] for i < params.count.
fn double_src() -> String {
    COMMON.to_string()
        + r#"
layout(std430, set = 0, binding = 1) readonly buffer Inputs { Item items[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.count) return;
    results[i].u = items[i].u * 2u;
    results[i].f = items[i].f * 2.0;
}
"#
}

fn double_bindings() -> Vec<BindingLayout> {
    vec![
        BindingLayout::single(0, params_layout()),
        BindingLayout::array(1, item_layout()),
        BindingLayout::array(2, item_layout()).writable(),
    ]
}

fn params(count: u32) -> Vec<u8> {
    bytemuck::cast_slice(&[count, 0u32, 0, 0]).to_vec()
}

/// Input items: u = 3i + 1, f = i / 2 - 7.25 (exact in f32, so doubling is exact).
fn items(n: usize) -> Vec<u8> {
    let words: Vec<u32> = (0..n).flat_map(|i| [3 * i as u32 + 1, (i as f32 * 0.5 - 7.25).to_bits()]).collect();
    bytemuck::cast_slice(&words).to_vec()
}

/// Runs the doubling kernel over `n` items with `spare` extra output items, filled with `fill`.
fn run_double(ctx: &GpuContext, kernel: &Kernel, n: usize, spare: usize, fill: u32) -> Vec<u32> {
    let (p, it) = (params(n as u32), items(n));
    let groups = [(n as u32).div_ceil(64).max(1), 1, 1];
    let (out, _) =
        ctx.run(kernel, &[(0, &p), (1, &it)], (2, (n + spare) * 8), fill, groups).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(out.len(), (n + spare) * 8);
    bytemuck::pod_collect_to_vec(&out)
}

/// Rule: bit-exact (doubling an f32 with few significant bits is exact).
fn check_doubled(words: &[u32], n: usize) {
    let mut bad = Vec::new();
    for i in 0..n {
        let (u, f) = (words[2 * i], f32::from_bits(words[2 * i + 1]));
        let (want_u, want_f) = (2 * (3 * i as u32 + 1), 2.0 * (i as f32 * 0.5 - 7.25));
        if u != want_u || f.to_bits() != want_f.to_bits() {
            bad.push(format!("item {i}: got ({u}, {f}), want ({want_u}, {want_f})"));
        }
    }
    assert!(bad.is_empty(), "{} of {n} items wrong (bit-exact rule); first: {}", bad.len(), bad[0]);
}

#[test]
fn doubles_u32_and_f32_on_lavapipe_with_no_validation_messages() {
    let spv = compile("double", &double_src());
    // Twice: a context must be creatable again after a clean teardown.
    for round in 0..2 {
        let ctx = validated_context();
        assert!(ctx.info().name.contains("llvmpipe"), "{:?}", ctx.info());
        let sink = ctx.message_sink();
        let kernel = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(kernel.workgroup_size(), [64, 1, 1]);
        // The pipeline is reused across runs; 1000 is not a multiple of the group size.
        for n in [1000, 64, 1] {
            check_doubled(&run_double(&ctx, &kernel, n, 0, 0), n);
        }
        // Zero-length input and output: 16-byte buffers behind the scenes, nothing back.
        assert!(run_double(&ctx, &kernel, 0, 0, 0).is_empty());
        assert_no_messages(&sink, &format!("during round {round}"));
        drop(kernel);
        drop(ctx);
        assert_no_messages(&sink, &format!("at device/instance destruction, round {round}"));
    }
}

/// A cleared binding reads as zeros however its memory was used before
/// (three runs that left 0xffffffff in an output of the same size first:
/// on lavapipe the allocator hands that memory back, and without the clear
/// the doubled words read 0xfffffffe), in device-only memory; and it
/// is a binding like any other: given twice, or as an image, it is refused.
/// `GpuOptions::kernel` on lavapipe, a CPU device: `auto` and `exact` run
/// the exact kernels (as given: lavapipe divides as IEEE does), `fast` the
/// FAST_MATH ones; `auto` is fast on discrete and integrated GPUs only.
/// Rule: exact.
#[test]
fn the_kernel_choice_picks_the_fast_kernels_only_where_asked_or_on_a_gpu() {
    for (kernel, division) in [
        (KernelChoice::Auto, Division::AsGiven),
        (KernelChoice::Exact, Division::AsGiven),
        (KernelChoice::Fast, Division::Fast),
    ] {
        let ctx = GpuContext::new(&GpuOptions { device: lavapipe(), kernel, ..Default::default() })
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(ctx.division(), division, "{kernel:?}");
        assert_eq!(division.exact(), kernel != KernelChoice::Fast);
        assert!(!ctx.info().fast_by_default(), "{} taken for a GPU", ctx.info().name);
    }
    let mut info = GpuContext::new(&GpuOptions { device: lavapipe(), ..Default::default() })
        .unwrap_or_else(|e| panic!("{e}"))
        .info()
        .clone();
    for (kind, fast) in [("discrete GPU", true), ("integrated GPU", true), ("virtual GPU", false), ("other", false)] {
        info.kind = kind.to_string();
        assert_eq!(KernelChoice::Auto.fast_on(&info), fast, "{kind}");
        assert!(KernelChoice::Fast.fast_on(&info) && !KernelChoice::Exact.fast_on(&info), "{kind}");
    }
}

/// The fma probe (fma_probe.rs) on lavapipe, whose fma() rounds the
/// product first: not fused, so kernels forced to correct its division
/// keep Dekker's residuals; a CPU device corrects nothing and runs no
/// probe. And the probe's cases tell the two apart: a once-rounded fma and
/// the rounded product plus c differ in most of them, so an unfused fma
/// cannot pass it by chance. Rule: exact.
#[test]
fn the_fma_probe_sees_that_lavapipes_fma_is_not_fused() {
    let ctx = validated_context();
    assert_eq!(ctx.division(), Division::AsGiven);
    assert!(!fma_rounds_once(&ctx).unwrap_or_else(|e| panic!("{e}")), "lavapipe's fma() taken for a fused one");
    assert_no_messages(&ctx.message_sink(), "running the fma probe");
    let cases = fma_probe::cases();
    let telling = cases.iter().filter(|c| c.a.mul_add(c.b, c.c).to_bits() != (c.a * c.b + c.c).to_bits()).count();
    assert!(
        telling * 4 >= cases.len() * 3,
        "only {telling} of {} cases tell a fused fma from an unfused one",
        cases.len()
    );
}

#[test]
fn cleared_buffers_read_as_zero() {
    let spv = compile("double_cleared", &double_src());
    let ctx = validated_context();
    let sink = ctx.message_sink();
    let kernel = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
    let n = 65_536;
    for _ in 0..3 {
        assert!(run_double(&ctx, &kernel, 0, n, 0xffff_ffff).iter().all(|w| *w == 0xffff_ffff));
    }
    let p = params(n as u32);
    let inputs = [(0, &p[..])];
    let buffers = RunBuffers { inputs: &inputs, cleared: &[(1, n * 8)], output: (2, n * 8), fill: 7 };
    let (out, _) = ctx.run_passes(&kernel, &buffers, [n as u32 / 64, 1, 1], 2).unwrap_or_else(|e| panic!("{e}"));
    let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out);
    let nonzero = words.iter().filter(|w| **w != 0).count();
    assert_eq!(
        nonzero,
        0,
        "rule: bit-exact zeros; {nonzero} of {} words are not (first {:?})",
        words.len(),
        words.iter().find(|w| **w != 0)
    );
    let twice = RunBuffers { inputs: &[(0, &p[..]), (1, &[0u8; 8][..])], cleared: &[(1, 8)], output: (2, 8), fill: 0 };
    let e = ctx.run_passes(&kernel, &twice, [1, 1, 1], 1).unwrap_err().to_string();
    assert!(
        e.contains("given bindings [0, 1, 1, 2] (inputs, cleared and output)") && e.contains("exactly once"),
        "{e}"
    );
    assert_no_messages(&sink, "clearing");
}

/// out[i] = texel i of an rgba32ui data image (row by row, 4096 texels a
/// row: layout.h IMAGE_WIDTH), its words reversed.
const DATA_IMAGE_SRC: &str = r#"
#version 450
layout(local_size_x = 64) in;
struct Params { uint count; uint pad0; uint pad1; uint pad2; };
struct Quad { uvec4 v; };
layout(std430, set = 0, binding = 0) readonly buffer ParamsBuf { Params params; };
layout(set = 0, binding = 1, rgba32ui) readonly uniform uimage2D data;
layout(std430, set = 0, binding = 2) writeonly buffer Outputs { Quad quads[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    if (i >= params.count) return;
    quads[i].v = imageLoad(data, ivec2(int(i & 4095u), int(i >> 12u))).wzyx;
}
"#;

#[test]
fn run_uploads_data_images_texel_for_texel() {
    let spv = compile("data_image", DATA_IMAGE_SRC);
    let ctx = validated_context();
    let sink = ctx.message_sink();
    let quad = StructLayout { name: "Quad", size: 16, fields: vec![field("v", 0, 16)] };
    let buffers = [BindingLayout::single(0, params_layout()), BindingLayout::array(2, quad).writable()];
    let image = ImageBinding { binding: 1, writable: false, format: ImageFormat::Rgba32Uint };
    let kernel = Kernel::with_images(&ctx, "data_image", &spv, &buffers, std::slice::from_ref(&image))
        .unwrap_or_else(|e| panic!("{e}"));
    // One partial row (300 texels) and three whole rows (12,288), distinct
    // words with NaN and infinity patterns among them: bits, not values.
    for n in [300usize, 3 * 4096] {
        let words: Vec<u32> = (0..4 * n as u32).map(|w| w.wrapping_mul(0x9E37_79B9) ^ 0x7FC0_0001).collect();
        let (out, _) = ctx
            .run(
                &kernel,
                &[(0, &params(n as u32)), (1, bytemuck::cast_slice(&words))],
                (2, n * 16),
                0,
                [(n as u32).div_ceil(64), 1, 1],
            )
            .unwrap_or_else(|e| panic!("{e}"));
        let got: Vec<u32> = bytemuck::pod_collect_to_vec(&out);
        let want: Vec<u32> = words.chunks(4).flat_map(|t| [t[3], t[2], t[1], t[0]]).collect();
        let differ = got.iter().zip(&want).filter(|(g, w)| g != w).count();
        let first = got.iter().zip(&want).position(|(g, w)| g != w);
        assert_eq!(
            differ,
            0,
            "rule: bit-exact; {n} texels: {differ} of {} words differ, first at {first:?}",
            want.len()
        );
    }
    // Bytes that are not whole texels, and more than a row that is not whole rows.
    let e = ctx.run(&kernel, &[(0, &params(1)), (1, &[0u8; 20][..])], (2, 16), 0, [1, 1, 1]).err().unwrap();
    assert!(e.to_string().contains("20 bytes are not whole 16-byte texels"), "{e}");
    let ragged = vec![0u8; 16 * 4097];
    let e = ctx.run(&kernel, &[(0, &params(1)), (1, &ragged)], (2, 16), 0, [1, 1, 1]).err().unwrap();
    assert!(e.to_string().contains("4097 texels are more than one row and not whole rows of 4096"), "{e}");
    let p = params(1);
    let inputs = [(0, &p[..])];
    let image_cleared = RunBuffers { inputs: &inputs, cleared: &[(1, 16)], output: (2, 16), fill: 0 };
    let e = ctx.run_passes(&kernel, &image_cleared, [1, 1, 1], 1).unwrap_err().to_string();
    assert!(e.contains("binding 1 is a read-only image; it cannot be cleared"), "{e}");
    // naga names a format mismatch.
    let rgba8 = ImageBinding { format: ImageFormat::Rgba8, ..image };
    let e = Kernel::with_images(&ctx, "data_image", &spv, &buffers, &[rgba8]).err().unwrap();
    assert!(e.to_string().contains("expected `layout(rgba8) uniform image2D`"), "{e}");
    drop(kernel);
    drop(ctx);
    assert_no_messages(&sink, "in the data image test");
}

/// A run takes the last run's resources where the kernel and the
/// bindings' lengths are the same (`dispatch::KeptRun`), and writes only
/// the inputs that changed: so inputs that change between runs of the
/// same lengths (a buffer, a data image), a sentinel that changes, and
/// another kernel in between must each give what a new run gives.
/// Rule: bit-exact, every word; and the runs that could reuse did.
#[test]
fn kept_runs_give_what_new_runs_give() {
    let ctx = validated_context();
    let sink = ctx.message_sink();
    let taken = || ctx.inner.kept_taken.load(std::sync::atomic::Ordering::Relaxed);
    let spv = compile("double", &double_src());
    let double = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
    let other = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
    let before = taken();
    // Inputs of the same lengths, different bytes: the second run must not read the first's.
    let n = 100;
    let p = params(n as u32);
    let a = items(n);
    let b: Vec<u8> =
        bytemuck::cast_slice::<u32, u8>(&(0..2 * n as u32).map(|w| w * 7 + 5).collect::<Vec<_>>()).to_vec();
    let run = |kernel: &Kernel, it: &[u8], fill: u32| -> Vec<u32> {
        let (out, _) =
            ctx.run(kernel, &[(0, &p), (1, it)], (2, (n + 3) * 8), fill, [2, 1, 1]).unwrap_or_else(|e| panic!("{e}"));
        bytemuck::pod_collect_to_vec(&out)
    };
    let doubled = |it: &[u8], fill: u32| -> Vec<u32> {
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(it);
        (0..n)
            .flat_map(|i| [words[2 * i].wrapping_mul(2), (f32::from_bits(words[2 * i + 1]) * 2.0).to_bits()])
            .chain(std::iter::repeat_n(fill, 6))
            .collect()
    };
    for (step, (kernel, it, fill)) in [
        (&double, &a, 0u32),
        (&double, &b, 0),
        (&double, &b, 0),
        (&double, &a, 0xDEAD_BEEF),
        (&other, &b, 1),
        (&double, &b, 1),
    ]
    .into_iter()
    .enumerate()
    {
        let got = run(kernel, it, fill);
        let want = doubled(it, fill);
        let differ = got.iter().zip(&want).filter(|(g, w)| g != w).count();
        assert_eq!(
            differ,
            0,
            "rule: bit-exact; run {step}: {differ} of {} words differ, first at {:?}",
            want.len(),
            got.iter().zip(&want).position(|(g, w)| g != w)
        );
    }
    // Runs 1, 2 and 3 took run 0's, 1's and 2's; 4 and 5 follow another kernel.
    assert_eq!(taken() - before, 3, "runs that took a kept run's resources");
    // A data image whose bytes change between runs of the same length.
    let spv = compile("data_image", DATA_IMAGE_SRC);
    let quad = StructLayout { name: "Quad", size: 16, fields: vec![field("v", 0, 16)] };
    let buffers = [BindingLayout::single(0, params_layout()), BindingLayout::array(2, quad).writable()];
    let image = ImageBinding { binding: 1, writable: false, format: ImageFormat::Rgba32Uint };
    let kernel = Kernel::with_images(&ctx, "data_image", &spv, &buffers, std::slice::from_ref(&image))
        .unwrap_or_else(|e| panic!("{e}"));
    let texels = 300usize;
    for seed in [1u32, 2, 2, 1] {
        let words: Vec<u32> = (0..4 * texels as u32).map(|w| w.wrapping_mul(0x9E37_79B9) ^ seed).collect();
        let (out, _) = ctx
            .run(
                &kernel,
                &[(0, &params(texels as u32)), (1, bytemuck::cast_slice(&words))],
                (2, texels * 16),
                0,
                [5, 1, 1],
            )
            .unwrap_or_else(|e| panic!("{e}"));
        let got: Vec<u32> = bytemuck::pod_collect_to_vec(&out);
        let want: Vec<u32> = words.chunks(4).flat_map(|t| [t[3], t[2], t[1], t[0]]).collect();
        let differ = got.iter().zip(&want).filter(|(g, w)| g != w).count();
        assert_eq!(differ, 0, "rule: bit-exact; data image seed {seed}: {differ} of {} words differ", want.len());
    }
    drop((double, other, kernel));
    drop(ctx);
    assert_no_messages(&sink, "in the kept-run test");
}

#[test]
fn sentinel_fill_survives_where_the_kernel_does_not_write() {
    const FILL: u32 = 0xDEAD_BEEF;
    let spv = compile("double", &double_src());
    let ctx = validated_context();
    let kernel = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap();
    let words = run_double(&ctx, &kernel, 100, 20, FILL);
    check_doubled(&words, 100);
    let tail = &words[200..];
    let unwritten = tail.iter().filter(|w| **w == FILL).count();
    assert_eq!(unwritten, 40, "rule: every word past the 100 written items is the sentinel; tail {tail:x?}");
    // Nothing written at all: every word is the sentinel.
    let words = run_double(&ctx, &kernel, 0, 8, FILL);
    assert!(words.iter().all(|w| *w == FILL), "{words:x?}");
    drop(kernel);
    let sink = ctx.message_sink();
    drop(ctx);
    assert_no_messages(&sink, "in the sentinel test");
}

#[test]
fn run_rejects_bad_calls_and_checks_limits() {
    let spv = compile("double", &double_src());
    let ctx = validated_context();
    let kernel = Kernel::new(&ctx, "double", &spv, &double_bindings()).unwrap();
    let p = params(0);

    // A missing binding.
    let e = ctx.run(&kernel, &[(0, &p)], (2, 8), 0, [1, 1, 1]).unwrap_err().to_string();
    assert!(e.contains("given bindings [0, 2]") && e.contains("declares [0, 1, 2]"), "{e}");

    // An output beyond maxStorageBufferRange: refused before allocating.
    let range = ctx.max_storage_buffer_range();
    let e = ctx.run(&kernel, &[(0, &p), (1, &[])], (2, range as usize + 4), 0, [1, 1, 1]).unwrap_err();
    assert!(matches!(e, GpuError::TooLarge { .. }), "{e:?}");
    let e = e.to_string();
    assert!(e.starts_with("kernel double: binding 2 (Item[]) needs ") && e.contains("maxStorageBufferRange of"), "{e}");

    // Too many work groups.
    let max = ctx.max_compute_work_group_count();
    if max[0] < u32::MAX {
        let e = ctx.run(&kernel, &[(0, &p), (1, &[])], (2, 8), 0, [max[0] + 1, 1, 1]).unwrap_err().to_string();
        assert!(e.contains("maxComputeWorkGroupCount") && e.contains(&max[0].to_string()), "{e}");
    }
    drop(kernel);
    let sink = ctx.message_sink();
    drop(ctx);
    assert_no_messages(&sink, "in the bad-call test");
}

#[test]
fn timeout_is_an_error_and_teardown_stays_clean() {
    let src = COMMON.to_string()
        + r#"
void main() {
    uint x = gl_GlobalInvocationID.x;
    for (uint k = 0u; k < params.count; ++k) x = x * 1664525u + 1013904223u;
    results[gl_GlobalInvocationID.x].u = x;
}
"#;
    let spv = compile("spin", &src);
    let bindings = vec![BindingLayout::single(0, params_layout()), BindingLayout::array(2, item_layout()).writable()];
    let opts =
        GpuOptions { device: lavapipe(), validation: true, timeout: Duration::from_millis(1), ..Default::default() };
    let ctx = GpuContext::new(&opts).unwrap();
    let kernel = Kernel::new(&ctx, "spin", &spv, &bindings).unwrap();
    let p = params(2_000_000);
    let e = ctx.run(&kernel, &[(0, &p)], (2, 64 * 64 * 8), 0, [64, 1, 1]).unwrap_err();
    assert!(matches!(e, GpuError::Timeout { .. }), "{e:?}");
    assert!(e.to_string().starts_with("the dispatch did not finish within 0.001 s"), "{e}");
    let sink = ctx.message_sink();
    drop(kernel);
    drop(ctx);
    assert_no_messages(&sink, "after a timed-out dispatch");
}

/// A kernel declaring the render bindings of shaders/layout.h.
fn render_like_src(pixels_qualifier: &str) -> String {
    format!(
        r#"
#version 450
#extension GL_GOOGLE_include_directive : require
#include "layout.h"
layout(local_size_x = WORKGROUP_SIZE, local_size_y = WORKGROUP_SIZE) in;
#include "scene_buffers.glsl"
layout(std430, set = 0, binding = BINDING_PIXELS) {pixels_qualifier} buffer Pixels {{ PixelOut pixels[]; }};
void main() {{
    uint i = gl_GlobalInvocationID.y * frame.width + gl_GlobalInvocationID.x;
    pixels[i].normal = primitives[0].object_from_world[0] + materials[0].diffuse + lights[0].color;
    pixels[i].id = NO_HIT;
}}
"#
    )
}

fn struct_of(b: &mut BindingLayout) -> &mut StructLayout {
    match &mut b.shape {
        BufferShape::Single(s) | BufferShape::RuntimeArray(s) | BufferShape::UniformSingle(s) => s,
    }
}

#[test]
fn check_layouts_accepts_the_render_layout() {
    for qualifier in ["", "writeonly"] {
        let spv = compile("render_like", &render_like_src(qualifier));
        reflect::check_layouts("render", &spv, &pixel_kernel_bindings()).unwrap_or_else(|e| panic!("{e}"));
    }
}

#[test]
fn check_layouts_reports_every_planted_mismatch() {
    let spv = compile("render_like", &render_like_src(""));
    let mut host = pixel_kernel_bindings();
    // One offset wrong on the host.
    struct_of(&mut host[1]).fields.iter_mut().find(|f| f.name == "material").unwrap().offset = 64;
    // A wrong stride / struct size.
    struct_of(&mut host[2]).size = 144;
    // A binding missing on the host, one missing in the shader.
    host.retain(|b| b.binding != 3);
    host.push(BindingLayout::array(7, item_layout()));
    // Writability flipped.
    host[0].writable = true;
    // A host field the shader lacks (and so a shader member the host lacks).
    let pixels = host.iter_mut().find(|b| b.binding == 4).unwrap();
    struct_of(pixels).fields.iter_mut().find(|f| f.name == "rays").unwrap().name = "spare";

    let e = reflect::check_layouts("render", &spv, &host).unwrap_err();
    let GpuError::LayoutMismatch { mismatches, .. } = &e else { panic!("{e:?}") };
    let want = [
        r#"kernel render: binding 0 (Frame): read-only in the shader, writable on the host; drop readonly in the shader or set writable: false (host/src/layout.rs)"#,
        r#"kernel render: binding 1 (Primitive[]): member "material": offset 68 in the shader, 64 on the host (host/src/layout.rs)"#,
        r#"kernel render: binding 2 (Material[]): array stride 128 in the shader, 144 on the host (host/src/layout.rs)"#,
        r#"kernel render: binding 2 (Material[]): struct size 128 in the shader, 144 on the host (host/src/layout.rs)"#,
        r#"kernel render: binding 3 (Light[]) is declared in the shader but not on the host (host/src/layout.rs)"#,
        r#"kernel render: binding 4 (PixelOut[]): member "spare" is on the host but not in the shader (host/src/layout.rs)"#,
        r#"kernel render: binding 4 (PixelOut[]): member "rays" (offset 28) is in the shader but not on the host (host/src/layout.rs)"#,
        r#"kernel render: binding 7 (Item[]) is expected by the host (host/src/layout.rs) but not declared in the shader"#,
    ];
    for w in want {
        assert!(mismatches.iter().any(|m| m == w), "missing {w:?} in:\n{}", mismatches.join("\n"));
    }
    assert_eq!(mismatches, &want, "all of them, ordered by binding");
    let text = e.to_string();
    assert!(text.starts_with("kernel render: the shader's buffers do not match the host's (8 mismatches)"), "{text}");
}

#[test]
fn check_layouts_reports_shape_and_name_mismatches() {
    let spv = compile("double", &double_src());
    let mut host = double_bindings();
    host[1].shape = BufferShape::Single(item_layout());
    struct_of(&mut host[2]).name = "Thing";
    let e = reflect::check_layouts("double", &spv, &host).unwrap_err();
    let GpuError::LayoutMismatch { mismatches, .. } = &e else { panic!("{e:?}") };
    assert_eq!(
        mismatches,
        &[
            "kernel double: binding 1 (Item): the block's member is a runtime-sized array of struct Item in the \
             shader, a single struct Item on the host (host/src/layout.rs)",
            r#"kernel double: binding 2 (Thing[]): the struct is named "Item" in the shader, "Thing" on the host (host/src/layout.rs)"#,
        ]
    );
}

/// `src` compiled, then `OpDecorate %var NonReadable` added after the
/// `Binding` decoration of each variable bound at one of `bindings`: what
/// glslang 15 (Debian 13) writes for a `writeonly buffer`, where Debian 12's
/// glslang 11 decorates the members only.
fn with_variable_non_readable(spv: &[u8], bindings: &[u32]) -> Vec<u8> {
    use super::spirv::{instructions, words, DEC_BINDING, DEC_NON_READABLE, OP_DECORATE};
    let words = words(spv).unwrap();
    let mut out = words[..5].to_vec();
    let mut planted = 0;
    for (at, op, ops) in instructions(&words) {
        out.extend_from_slice(&words[at..at + 1 + ops.len()]);
        if let (OP_DECORATE, [target, DEC_BINDING, b, ..]) = (op, ops) {
            if bindings.contains(b) {
                out.extend_from_slice(&[(3 << 16) | OP_DECORATE, *target, DEC_NON_READABLE]);
                planted += 1;
            }
        }
    }
    assert_eq!(out.len(), words.len() + 3 * planted, "the module's every instruction copied");
    assert_eq!(planted, bindings.len(), "bindings {bindings:?} not all found");
    bytemuck::cast_slice(&out).to_vec()
}

/// A `writeonly buffer` as glslang 15 writes it (the variable decorated
/// NonReadable) is a store-only storage access to naga, which its validator
/// refuses; raycast's check takes it, with its access, and still catches a
/// host that calls it read-only. Found building on Debian 13, where every
/// kernel with such a buffer (render, the harness, the FMA probe) failed at
/// start-up.
#[test]
fn check_layouts_takes_a_writeonly_buffer_decorated_on_its_variable() {
    let src = double_src().replace("binding = 2) buffer Outputs", "binding = 2) writeonly buffer Outputs");
    assert!(src.contains("writeonly buffer Outputs"));
    let spv = with_variable_non_readable(&compile("double_writeonly", &src), &[2]);
    // The planted module is what fails naga's own validation (so this test
    // would see the failure if raycast handed naga the module as it is).
    let options = naga::front::spv::Options::default();
    let module = naga::front::spv::parse_u8_slice(&spv, &options).unwrap();
    let e = naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .unwrap_err();
    assert!(format!("{:?}", e.as_inner()).contains("StorageAddressSpaceWriteOnlyNotSupported"), "{e:?}");

    reflect::check_layouts("double_writeonly", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
    let mut host = double_bindings();
    host[2].writable = false;
    let e = reflect::check_layouts("double_writeonly", &spv, &host).unwrap_err().to_string();
    assert!(e.contains("binding 2") && e.contains("writable in the shader, read-only on the host"), "{e}");
}

/// A kernel edit with subgroup operations (`--shaders`, `--versus`): naga
/// 30's SPIR-V reader panics on a shuffle whose lane comes from a loop, as
/// raycast's spirv-opt passes leave it (gfx-rs/wgpu#8389), and its
/// validator refuses a lane's id in an 8x8 work group (a WGSL rule); the
/// check reads the module with a null constant's copy for each subgroup
/// operation and the subgroup ids as other builtins (reflect.rs,
/// `for_naga`). Found pooling shadow rays across a subgroup
/// (BENCHMARKS.md, "A kernel for lanes"): every kernel with the pool
/// failed with a panic.
#[test]
fn check_layouts_reads_subgroup_operations_that_naga_panics_on() {
    let extensions =
        ["shuffle", "ballot", "arithmetic"].map(|e| format!("#extension GL_KHR_shader_subgroup_{e} : require\n"));
    let src = COMMON
        .replace("#version 450\n", &format!("#version 450\n{}", extensions.concat()))
        .replace("layout(local_size_x = 64) in;", "layout(local_size_x = 8, local_size_y = 8) in;")
        + r#"
layout(std430, set = 0, binding = 1) readonly buffer Inputs { Item items[]; };
void main() {
    uint i = gl_GlobalInvocationID.x;
    uint o = 0u;
    for (uint k = 0u; k < gl_SubgroupSize; k++) {
        if (items[k].u > 3u) {
            o = k;
        }
    }
    uvec4 lanes = subgroupBallot(items[i].f > 0.0);
    results[i].u = subgroupShuffle(items[i].u, o) + subgroupAdd(lanes.x);
    results[i].f = items[i].f + float(gl_SubgroupInvocationID);
}
"#;
    let spv = compile("subgroup_shuffle", &src);
    // naga alone panics on it; when a naga update reads it, for_naga's
    // stand-ins can go.
    let options = naga::front::spv::Options::default();
    let alone = std::panic::catch_unwind(|| naga::front::spv::parse_u8_slice(&spv, &options).map(|_| ()));
    assert!(alone.is_err(), "naga read the module by itself: {alone:?}");

    reflect::check_layouts("subgroup_shuffle", &spv, &double_bindings()).unwrap_or_else(|e| panic!("{e}"));
    let mut host = double_bindings();
    host[2].writable = false;
    let e = reflect::check_layouts("subgroup_shuffle", &spv, &host).unwrap_err().to_string();
    assert!(e.contains("binding 2"), "{e}");
}

#[test]
fn check_layouts_rejects_invalid_spirv_and_other_resources() {
    let e = reflect::check_layouts("junk", &[0u8; 64], &[]).unwrap_err();
    assert!(matches!(e, GpuError::InvalidSpirv { .. }), "{e:?}");
    assert!(e.to_string().starts_with("kernel junk: the SPIR-V is not valid: "), "{e}");

    let src = r#"
#version 450
layout(local_size_x = 1) in;
struct Params { uint count; uint pad0; uint pad1; uint pad2; };
layout(std140, set = 0, binding = 0) uniform ParamsBuf { Params params; };
layout(std430, set = 1, binding = 1) buffer Out { uint words[]; };
void main() { words[0] = params.count; }
"#;
    let spv = compile("uniform", src);
    let e = reflect::check_layouts("uniform", &spv, &[]).unwrap_err();
    let GpuError::LayoutMismatch { mismatches, .. } = &e else { panic!("{e:?}") };
    assert_eq!(mismatches.len(), 2, "{e}");
    assert_eq!(
        mismatches,
        &[
            "kernel uniform: binding 0 (Params) is declared in the shader but not on the host (host/src/layout.rs)",
            "kernel uniform: binding 1 (Out) is in descriptor set 1 in the shader; every binding must be in set 0",
        ]
    );
    // A uniform block where the host expects a storage buffer (and the other way round) is named.
    let params = StructLayout {
        name: "Params",
        size: 16,
        fields: ["count", "pad0", "pad1", "pad2"]
            .iter()
            .enumerate()
            .map(|(i, n)| FieldLayout { name: n, offset: 4 * i as u32, size: 4 })
            .collect(),
    };
    for (shape, want) in [
        (BufferShape::Single(params.clone()), "a uniform buffer in the shader, a storage buffer on the host"),
        (BufferShape::UniformSingle(params.clone()), ""),
    ] {
        let host = [BindingLayout { binding: 0, shape, writable: false }];
        let e = reflect::check_layouts("uniform", &spv, &host).unwrap_err().to_string();
        assert!(e.contains(&format!("binding 0 (ParamsBuf) is {want}")) || want.is_empty(), "{e}");
        if want.is_empty() {
            assert!(!e.contains("binding 0"), "the uniform block matches UniformSingle: {e}");
        }
    }
}

#[test]
fn list_devices_finds_lavapipe_and_selectors_work() {
    let devices = list_devices().unwrap_or_else(|e| panic!("{e}"));
    let lvp = devices.iter().find(|d| d.name.contains("llvmpipe")).unwrap_or_else(|| panic!("{devices:#?}"));
    assert_eq!(lvp.kind, "cpu");
    assert!(lvp.api_version.starts_with("1."), "{lvp:?}");
    assert!(!lvp.driver.is_empty(), "{lvp:?}");
    for (i, d) in devices.iter().enumerate() {
        assert_eq!(d.index, i);
    }

    let by_index =
        GpuContext::new(&GpuOptions { device: Some(DeviceSelector::Index(lvp.index)), ..Default::default() })
            .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(by_index.info(), lvp);
    let by_name =
        GpuContext::new(&GpuOptions { device: Some(DeviceSelector::Name("LLVMPIPE".into())), ..Default::default() })
            .unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(by_name.info(), lvp);
    assert!(by_name.take_validation_messages().is_empty());

    // The default choice: the best kind, first in enumeration order within it.
    let rank = |k: &str| ["discrete GPU", "integrated GPU", "virtual GPU", "other", "cpu"].iter().position(|x| *x == k);
    let best = devices.iter().min_by_key(|d| rank(&d.kind)).unwrap();
    let default = GpuContext::new(&GpuOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(default.info(), best);

    for bad in [DeviceSelector::Name("no-such-gpu".into()), DeviceSelector::Index(devices.len())] {
        let e = GpuContext::new(&GpuOptions { device: Some(bad), ..Default::default() }).err().unwrap();
        let text = e.to_string();
        assert!(matches!(e, GpuError::DeviceNotFound { .. }), "{e:?}");
        assert!(text.contains("available devices:") && text.contains(&lvp.name), "{text}");
    }
}

#[test]
fn missing_loader_is_explained() {
    let e = super::instance::load_entry_from("/nonexistent/libvulkan.so.1").err().unwrap().to_string();
    assert!(e.starts_with("cannot load the Vulkan loader libvulkan.so.1 ("), "{e}");
    assert!(e.contains("install libvulkan1") && e.contains("mesa-vulkan-drivers"), "{e}");
}

// Environment variables are process-wide, so these cases run in a child
// process: the test binary re-runs itself with `--exact` on `env_child`.

const CHILD_VAR: &str = "RAYCAST_GPU_TEST_CHILD";

/// Runs `env_child` in a child process with `case` and `envs`; returns its stdout.
fn run_child(case: &str, envs: &[(&str, &str)]) -> String {
    let exe = std::env::current_exe().unwrap();
    let mut cmd = Command::new(exe);
    cmd.args(["--exact", "gpu::tests::env_child", "--nocapture", "--test-threads=1"])
        .env(CHILD_VAR, case)
        .env_remove("VK_ICD_FILENAMES")
        .env_remove("VK_DRIVER_FILES")
        .env_remove("VK_ADD_DRIVER_FILES")
        .env_remove("VK_INSTANCE_LAYERS");
    for (k, v) in envs {
        cmd.env(k, v);
    }
    let out = cmd.output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "child {case} failed:\n{stdout}\n{stderr}");
    assert!(stdout.contains(&format!("env_child {case}: ok")), "child {case} did not run:\n{stdout}\n{stderr}");
    stdout
}

/// Does nothing unless started by `run_child`.
#[test]
fn env_child() {
    let Ok(case) = std::env::var(CHILD_VAR) else { return };
    let opts = GpuOptions { device: None, validation: case == "no_layer", ..Default::default() };
    match GpuContext::new(&opts) {
        Err(e @ GpuError::NoDevice { .. }) => {
            let text = e.to_string();
            assert!(text.starts_with("no Vulkan device found"), "{text}");
            assert!(text.contains("VK_DRIVER_FILES"), "{text}");
            assert!(matches!(list_devices(), Err(GpuError::NoDevice { .. })));
            println!("{text}");
        }
        Err(e @ GpuError::ValidationUnavailable { .. }) if case == "no_layer" => {
            let text = e.to_string();
            assert_eq!(
                text,
                "validation was requested but VK_LAYER_KHRONOS_validation is not installed (Debian package \
                 vulkan-validationlayers)"
            );
        }
        Ok(ctx) if case == "zero_devices" => println!("skipped: the radv ICD found {:?}", ctx.info()),
        other => panic!("case {case}: unexpected {:?}", other.map(|c| c.info().clone())),
    }
    println!("env_child {case}: ok");
}

#[test]
fn no_device_when_driver_files_point_nowhere() {
    println!("{}", run_child("nonexistent", &[("VK_DRIVER_FILES", "/nonexistent/icd.json")]));
    println!("{}", run_child("empty", &[("VK_DRIVER_FILES", "")]));
}

#[test]
fn no_device_when_the_only_driver_finds_no_hardware() {
    // radv loads and creates an instance, then finds no AMD GPU here.
    let icd = "/usr/share/vulkan/icd.d/radeon_icd.x86_64.json";
    if std::path::Path::new(icd).exists() {
        println!("{}", run_child("zero_devices", &[("VK_DRIVER_FILES", icd)]));
    }
}

#[test]
fn missing_validation_layer_is_explained() {
    run_child(
        "no_layer",
        &[("VK_LAYER_PATH", "/nonexistent"), ("XDG_DATA_DIRS", "/nonexistent"), ("XDG_DATA_HOME", "/nonexistent")],
    );
}

#[test]
fn validation_messages_are_captured_and_taken() {
    let ctx = validated_context();
    // Invalid on purpose: VkBufferCreateInfo.size must be greater than 0.
    let info = ash::vk::BufferCreateInfo::default().size(0).usage(ash::vk::BufferUsageFlags::STORAGE_BUFFER);
    let device = &ctx.inner.device;
    if let Ok(buffer) = unsafe { device.create_buffer(&info, None) } {
        unsafe { device.destroy_buffer(buffer, None) };
    }
    let messages = ctx.take_validation_messages();
    assert!(messages.iter().any(|m| m.starts_with("ERROR [VUID-VkBufferCreateInfo-size-00912] ")), "{messages:#?}");
    assert!(ctx.take_validation_messages().is_empty());
}

#[test]
fn zero_physical_devices_is_no_device() {
    let e = super::device::usable_devices(Ok(Vec::new())).unwrap_err();
    assert!(matches!(e, GpuError::NoDevice { .. }), "{e:?}");
    assert!(e.to_string().starts_with("no Vulkan device found: the Vulkan loader reports zero devices; "), "{e}");
}

#[test]
fn context_and_kernel_can_be_shared_between_threads() {
    fn send_sync<T: Send + Sync>() {}
    send_sync::<GpuContext>();
    send_sync::<Kernel>();
    send_sync::<GpuError>();
}

#[test]
fn a_tool_that_hangs_is_stopped() {
    // Without the limit this would wait 30 s and then succeed.
    let mut sleep = Command::new("sleep");
    sleep.arg("30");
    let e = run_tool("sleep", "coreutils", sleep, Duration::from_millis(200)).unwrap_err();
    assert_eq!(e, "sleep took more than 0.2 s and was stopped");
}

#[test]
fn a_tool_is_read_on_both_pipes_at_once() {
    // More than a pipe holds (64 KiB), on standard output and then on standard error:
    // read one pipe after the other, the tool would stall on the second and be stopped.
    let mut chatty = Command::new("sh");
    chatty.args(["-c", "head -c 300000 /dev/zero; head -c 200000 /dev/zero >&2; exit 3"]);
    let out = run_tool("sh", "dash", chatty, Duration::from_secs(20)).unwrap();
    assert_eq!((out.stdout.len(), out.stderr.len(), out.status.code()), (300_000, 200_000, Some(3)));
}

#[test]
fn a_tool_that_leaves_its_output_held_open_is_not_waited_for() {
    // The tool exits at once, but the sleep it leaves behind holds its standard output
    // for 5 s: without the limit on the pipes, this would wait that long and succeed.
    let mut leaver = Command::new("sh");
    leaver.args(["-c", "sleep 5 & echo started"]);
    let e = run_tool("sh", "dash", leaver, Duration::from_millis(300)).unwrap_err();
    assert_eq!(e, "sh exited (exit status: 0), but a process it started kept its output open for more than 0.3 s");
}

#[test]
fn a_tool_that_is_not_installed_is_named_with_its_package() {
    let missing = Command::new("raycast-no-such-tool");
    let e = run_tool("raycast-no-such-tool", "no-such-package", missing, TOOL_LIMIT).unwrap_err();
    assert!(e.starts_with("cannot run raycast-no-such-tool (Debian package no-such-package): "), "{e}");
}
