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
//!
//! A mesh is stored once however many instances draw it (issue 44): the
//! corpus's teapot (mesh/teapot.obj, 6,320 triangles, 907 KiB) placed by
//! 1,000 instances of a master against the same master placed once.
//! - device: the packed scene buffers (`device_bytes`, the same picture
//!   size) of 1,000 placements at most those of one plus 999 ×
//!   PER_INSTANCE_MAX = 512 bytes (an instance's matrices and its share of
//!   the hierarchy); the three mesh buffers byte for byte the same.
//!   Measured: 4,043,040 and 4,157,280 bytes (256×192), 114 bytes a
//!   placement.
//! - host: the peak resident set's growth while the 1,000 placements load
//!   and pack (`measure::reset_peak_host` first) at most
//!   MESH_HOST_PER_FILE_BYTE = 32 times the OBJ file's size.
//!   Measured: 4.6 times (4.1 MiB).
//!
//! Skipped without the corpus. Well under a second, no device. It runs
//! first: the spheres' host bound is on the whole process's peak.

use raycast::frame::{self, RenderSettings};
use raycast::gen::{self, count_primitives, Family, GenOptions};
use raycast::gpu::GpuRenderer;
use raycast::gpu::{DeviceSelector, GpuOptions};
use raycast::layout::NO_HIT;
use raycast::measure::{device_bytes, peak_host_bytes};
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
    // The teapots first: the spheres' bound is on the whole process's peak.
    let teapots = a_thousand_teapots_store_the_mesh_once();
    let spheres = deep_recursive_spheres_fit_in_bounded_memory();
    if spheres && teapots {
        println!("ok: memory");
    }
}

const TEAPOTS: usize = 1000;
const PER_INSTANCE_MAX: u64 = 512;
const MESH_HOST_PER_FILE_BYTE: u64 = 32;

/// The teapot master placed `n` times, in rows of 40.
fn teapots_xml(n: usize) -> String {
    let mut placements = String::new();
    for i in 0..n {
        placements += &format!(
            "<transblock><translate x=\"{}\" y=\"0\" z=\"{}\"/><object type=\"master\" name=\"teapot\"/></transblock>\n",
            (i % 40) as f32 * 1.5,
            (i / 40) as f32 * 1.5
        );
    }
    format!(
        r#"<scenefile>
  <cameradata><pos x="30" y="20" z="60"/><focus x="30" y="0" z="18"/><up x="0" y="1" z="0"/><heightangle v="40"/></cameradata>
  <lightdata><id v="0"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="-1" z="-1"/></lightdata>
  <object type="tree" name="teapot"><transblock>
    <object type="primitive" name="mesh" meshfile="mesh/teapot.obj"><diffuse r="0.9" g="0.5" b="0.2"/></object>
  </transblock></object>
  <object type="tree" name="root">
{placements}  </object>
</scenefile>
"#
    )
}

/// False when skipped.
fn a_thousand_teapots_store_the_mesh_once() -> bool {
    let Some(corpus) = common::corpus("1,000 instances of the teapot") else { return false };
    let obj_bytes = std::fs::metadata(corpus.join("mesh/teapot.obj")).expect("the corpus's mesh/teapot.obj").len();
    let settings = RenderSettings { width: 256, height: 192, ..RenderSettings::default() };
    let pack = |n: usize| {
        let xml = teapots_xml(n);
        let name = corpus.join(format!("teapots-{n}.xml"));
        let file = scene::parse_str(&xml, &name, &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let scene = scene::flatten(&file, &FlattenLimits::default()).unwrap_or_else(|e| panic!("{e}"));
        let data = frame::build(&scene, &settings).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((scene.meshes.len(), data.meshes), (1, 1), "{n} placements: one mesh");
        assert_eq!(data.expanded, n as u64, "{n} placements drawn");
        data
    };
    let one = pack(1);
    let reset = raycast::measure::reset_peak_host();
    let before = peak_host_bytes().expect("VmHWM in /proc/self/status");
    let many = pack(TEAPOTS);
    let host = peak_host_bytes().expect("VmHWM in /proc/self/status").saturating_sub(before);
    let device = |d: &frame::FrameData| device_bytes(d, false, d.frame.height);
    let (d1, dn) = (device(&one), device(&many));
    let per_instance = (dn.saturating_sub(d1)) as f64 / (TEAPOTS - 1) as f64;
    println!(
        "{TEAPOTS} teapots (mesh/teapot.obj, {obj_bytes} bytes, {} triangles): device {dn} bytes against {d1} for one, \
         {per_instance:.0} bytes a placement (bound {PER_INSTANCE_MAX}); host peak grew {:.1} MiB loading and packing \
         them, {:.1} times the file (bound {MESH_HOST_PER_FILE_BYTE}{})",
        many.mesh_triangles.len(),
        host as f64 / MIB,
        host as f64 / obj_bytes as f64,
        if reset { "" } else { "; the peak could not be reset, so it is the process's" }
    );
    let mesh_buffers = |d: &frame::FrameData| {
        d.scene_buffers()
            .into_iter()
            .filter(|(b, _, _)| {
                [
                    raycast::layout::BINDING_MESH_NODES,
                    raycast::layout::BINDING_MESH_TRIANGLES,
                    raycast::layout::BINDING_MESH_VERTICES,
                ]
                .contains(b)
            })
            .map(|(_, _, bytes)| bytes.to_vec())
            .collect::<Vec<_>>()
    };
    assert_eq!(mesh_buffers(&one), mesh_buffers(&many), "the mesh's buffers differ with the placements");
    assert!(
        dn <= d1 + (TEAPOTS as u64 - 1) * PER_INSTANCE_MAX,
        "{TEAPOTS} placements take {dn} bytes, more than {d1} + {} x {PER_INSTANCE_MAX}",
        TEAPOTS - 1
    );
    if reset {
        assert!(
            host <= MESH_HOST_PER_FILE_BYTE * obj_bytes,
            "the host peak grew {host} bytes, more than {MESH_HOST_PER_FILE_BYTE} x the file's {obj_bytes}"
        );
    }
    true
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
    let uniform = renderer.kernel_for(&data).unwrap_or_else(|e| panic!("{e}")).name() == raycast::gpu::UNIFORM_KERNEL;
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
