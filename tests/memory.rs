//! Memory grows with the scene file, not with its expansion (issue 7): the
//! recursive spheres at depth 10, 2,929,687 spheres from a file of 11 KB,
//! load, build and render (256×192, shadows and reflections on, textures
//! off) within fixed bounds of host and device memory.
//!
//! Bounds (the issue asks for "well under 1 GB" of each):
//! - host: the test process's peak resident set (VmHWM), the Vulkan driver
//!   and the validation layer included, at most HOST_PEAK_MAX = 512 MiB.
//!   Measured: 142 MiB, 164 MiB with validation (lavapipe, instancing and
//!   the hierarchy of commit dde480e). Flattening depth 10 would take
//!   about 1 GB more.
//! - device: the bytes uploaded for the frame plus the samples' sums and
//!   the pixel buffer (`raycast::measure::device_bytes`), at most
//!   DEVICE_MAX = 64 MiB.
//!   Measured: 3.0 MiB at 256x192. A flat upload of depth 10 would be 2,929,687
//!   80-byte primitives = 234 MB.
//!
//! Where the scene is not kept as instances (`raycast::frame::INSTANCING`
//! false) the test skips, saying so: flattening 2.9 million spheres would
//! exhaust the memory it is meant to bound. About 5 s on lavapipe, 2 cores.

use raycast::frame::{self, RenderSettings};
use raycast::gen::{self, count_primitives, Family, GenOptions};
use raycast::gpu::{DeviceSelector, GpuOptions};
use raycast::layout::NO_HIT;
use raycast::measure::{device_bytes, peak_host_bytes};
use raycast::render::GpuRenderer;
use raycast::scene::{self, FlattenLimits, ParseOptions};
use std::path::Path;
use std::time::Instant;

mod common;

const DEPTH: u32 = 10;
const HOST_PEAK_MAX: u64 = 512 << 20;
const DEVICE_MAX: u64 = 64 << 20;
const MIB: f64 = (1u64 << 20) as f64;

/// One check, run without libtest's harness so that the skip message shows
/// in ctest's output.
fn main() {
    if deep_recursive_spheres_fit_in_bounded_memory() {
        println!("ok: memory");
    }
}

/// False when skipped.
fn deep_recursive_spheres_fit_in_bounded_memory() -> bool {
    if !raycast::frame::INSTANCING {
        common::skip(&format!(
            "raycast::frame::INSTANCING is false; flattening gen recursive-spheres --depth {DEPTH} \
             ({} spheres) would exhaust memory. This test runs once instances land.",
            Family::RecursiveSpheres.expanded_count(DEPTH)
        ));
        return false;
    }
    let start = Instant::now();
    let xml = gen::generate(Family::RecursiveSpheres, DEPTH, &GenOptions { texture: None }).unwrap();
    let name = format!("gen:recursive-spheres:{DEPTH}");
    let file = scene::parse_str(&xml, Path::new(&name), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    let counts = count_primitives(&file);
    assert_eq!(counts.expanded, 2_929_687, "{name}: expanded primitives");
    let scene = scene::flatten(&file, &FlattenLimits::default()).unwrap_or_else(|e| panic!("{e}"));
    let settings = RenderSettings { width: 256, height: 192, textures: false, ..RenderSettings::default() };
    let data = frame::build(&scene, &settings).unwrap_or_else(|e| panic!("{e}"));
    let loaded = start.elapsed();

    let validation = std::env::var("RAYCAST_VALIDATION").is_ok_and(|v| v == "1");
    let renderer = GpuRenderer::new(&GpuOptions {
        device: Some(DeviceSelector::Name("llvmpipe".into())),
        validation,
        ..GpuOptions::default()
    })
    .unwrap_or_else(|e| panic!("{e}"));
    let (picture, timings) = renderer.render(&data).unwrap_or_else(|e| panic!("{e}"));
    let messages = renderer.context().take_validation_messages();
    assert!(messages.is_empty(), "validation layer: {messages:#?}");

    let host = peak_host_bytes().expect("VmHWM in /proc/self/status");
    let uniform =
        renderer.kernel_for(&data).unwrap_or_else(|e| panic!("{e}")).name() == raycast::render::UNIFORM_KERNEL;
    let device = device_bytes(&data, uniform, renderer.band_rows(&data.frame));
    println!(
        "{name}: {} spheres expanded, {} in the file ({} bytes); load and build {:.1} ms, dispatch {:.1} ms at {}x{}; \
         host peak {:.1} MiB (bound {:.0}), device {:.1} MiB (bound {:.0})",
        counts.expanded,
        counts.unique,
        xml.len(),
        loaded.as_secs_f64() * 1e3,
        timings.dispatch.as_secs_f64() * 1e3,
        settings.width,
        settings.height,
        host as f64 / MIB,
        HOST_PEAK_MAX as f64 / MIB,
        device as f64 / MIB,
        DEVICE_MAX as f64 / MIB
    );
    // The render is a picture of the scene, not an empty frame: the big
    // sphere fills much of it.
    let hits = picture.pixels.iter().filter(|p| p.id != NO_HIT).count();
    assert!(hits * 4 > picture.pixels.len(), "only {hits} of {} pixels hit anything", picture.pixels.len());
    assert!(
        host <= HOST_PEAK_MAX,
        "host peak (VmHWM) {:.1} MiB is over the bound of {:.0} MiB",
        host as f64 / MIB,
        HOST_PEAK_MAX as f64 / MIB
    );
    assert!(
        device <= DEVICE_MAX,
        "device bytes {:.1} MiB are over the bound of {:.0} MiB",
        device as f64 / MIB,
        DEVICE_MAX as f64 / MIB
    );
    true
}
