//! `bench`'s rows: one scene on one backend, its times, rates and memory,
//! for people, for `--json` and for BENCHMARKS.md's tables.

use super::{BenchArgs, NO_KERNEL_STATS};
use crate::frame::{Aov, RenderSettings};
use crate::gen::PrimitiveCounts;
use crate::render::{DevicePhases, Executable};
use crate::units::{median, rounded, thousands, to_json};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::Path;
use std::time::Duration;

/// One scene on one backend.
pub(super) struct Row {
    pub(super) scene: String,
    /// `gpu uniform`, `gpu storage` (where the scene's arrays are) or `cpu`.
    pub(super) backend: String,
    pub(super) device: String,
    pub(super) counts: PrimitiveCounts,
    pub(super) lights: usize,
    pub(super) load: Duration,
    pub(super) build: Duration,
    /// Timed frames, sorted.
    pub(super) frames: Vec<Duration>,
    /// The device's dispatch alone, sorted (GPU only).
    pub(super) dispatch: Vec<Duration>,
    /// The device's phases by its timestamps, one per timed frame (GPU
    /// rows where the queue has timestamps).
    pub(super) phases: Vec<DevicePhases>,
    pub(super) primary_rays: u64,
    /// Every ray of one frame (camera, shadow and mirror), as the pixels count them.
    pub(super) all_rays: u64,
    pub(super) host_peak: Option<u64>,
    pub(super) device_bytes: Option<u64>,
    /// CPU rows: the CPU's frame median over the GPU's, and whether their pictures are identical.
    pub(super) cpu_over_gpu: Option<f64>,
    pub(super) identical: Option<bool>,
    /// GPU rows: the time to build the scene's kernel (pipeline or shader
    /// object; zero where an earlier scene's is the same) and how it was
    /// built (`Kernel::how_built`).
    pub(super) kernel_build: Option<(Duration, Option<String>)>,
    /// GPU rows with --kernel-stats: the driver's statistics of the
    /// kernel's executables, None where it reports none.
    pub(super) kernel_stats: Option<Option<Vec<Executable>>>,
}

/// `median` of durations (none: zero).
pub(super) fn median_time(times: &[Duration]) -> Duration {
    Duration::try_from_secs_f64(median(times.iter().map(Duration::as_secs_f64))).unwrap_or_default()
}

impl Row {
    /// Whether this row is of `backend` ("gpu" covers "gpu uniform" and
    /// "gpu storage"), matched by the first word.
    pub(super) fn is(&self, backend: &str) -> bool {
        self.backend.split(' ').next() == Some(backend)
    }

    pub(super) fn median(&self) -> Duration {
        median_time(&self.frames)
    }

    pub(super) fn mrays(&self) -> f64 {
        self.primary_rays as f64 / self.median().as_secs_f64().max(1e-12) / 1e6
    }

    pub(super) fn all_mrays(&self) -> f64 {
        self.all_rays as f64 / self.median().as_secs_f64().max(1e-12) / 1e6
    }

    /// The median of each device phase over the timed frames (each phase's
    /// own median); None where the device wrote no timestamps.
    pub(super) fn phase_medians(&self) -> Option<DevicePhases> {
        if self.phases.is_empty() {
            return None;
        }
        let of = |f: fn(&DevicePhases) -> Duration| median_time(&self.phases.iter().map(f).collect::<Vec<_>>());
        Some(DevicePhases { clear: of(|p| p.clear), dispatch: of(|p| p.dispatch), readback: of(|p| p.readback) })
    }
}

/// Milliseconds with three significant digits (at least one decimal).
pub(super) fn ms(d: Duration) -> String {
    let v = d.as_secs_f64() * 1e3;
    let decimals = if v >= 10.0 {
        1
    } else if v >= 1.0 {
        2
    } else {
        3
    };
    format!("{v:.decimals$} ms")
}

pub(super) fn mib(bytes: Option<u64>) -> String {
    match bytes {
        None => "n/a".to_string(),
        Some(b) if b < 1 << 20 => format!("{:.1} KiB", b as f64 / 1024.0),
        Some(b) => format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64),
    }
}

pub(super) fn ms_f(d: Duration) -> f64 {
    (d.as_secs_f64() * 1e6).round() / 1e3
}

pub(super) fn settings_text(s: &RenderSettings) -> String {
    let on = |b: bool| if b { "on" } else { "off" };
    format!(
        "{}x{}, {}, shadows {}, reflections {} ({} bounces), textures {}, {}, {}",
        s.width,
        s.height,
        match s.aov {
            Aov::Color => "colour".to_string(),
            aov => format!("{} AOV", aov.name()),
        },
        on(s.shadows),
        on(s.reflections),
        s.max_depth,
        on(s.textures),
        match s.supersample {
            crate::frame::Supersample::Course => "the course's adaptive supersampling".to_string(),
            crate::frame::Supersample::Pattern => format!("{} spp", s.spp),
        },
        if s.bvh { "BVH" } else { "no BVH (--no-bvh)" }
    )
}

/// The command line as typed, quoted where needed.
pub(super) fn command_line() -> String {
    std::env::args()
        .map(|a| {
            if a.is_empty() || a.contains(|c: char| c.is_whitespace() || "\"'$`\\<>|&;*?".contains(c)) {
                format!("'{}'", a.replace('\'', "'\\''"))
            } else {
                a
            }
        })
        .collect::<Vec<_>>()
        .join(" ")
}

/// One line of `bench --json`: a scene on a backend. Times in ms to the
/// µs; a number that is not there (or not finite) is null.
#[derive(Serialize)]
pub(super) struct RowJson<'a> {
    pub(super) scene: &'a str,
    pub(super) backend: &'a str,
    pub(super) device: &'a str,
    pub(super) width: u32,
    pub(super) height: u32,
    pub(super) spp: u32,
    pub(super) shadows: bool,
    pub(super) reflections: bool,
    pub(super) textures: bool,
    pub(super) max_depth: u32,
    pub(super) bvh: bool,
    pub(super) primitives_expanded: u64,
    pub(super) primitives_unique: u64,
    pub(super) lights: usize,
    pub(super) load_ms: f64,
    pub(super) build_ms: f64,
    pub(super) warmup: u32,
    pub(super) frames: usize,
    pub(super) frame_ms_median: f64,
    pub(super) frame_ms_min: f64,
    pub(super) frame_ms_max: f64,
    pub(super) dispatch_ms_median: Option<f64>,
    /// The device's phases by its timestamps (`DevicePhases`), medians;
    /// null where the queue has no timestamps (and on the CPU build).
    pub(super) device_clear_ms_median: Option<f64>,
    pub(super) device_dispatch_ms_median: Option<f64>,
    pub(super) device_readback_ms_median: Option<f64>,
    pub(super) primary_rays_per_frame: u64,
    pub(super) primary_mrays_per_s: f64,
    pub(super) all_rays_per_frame: u64,
    pub(super) all_mrays_per_s: f64,
    pub(super) host_peak_bytes: Option<u64>,
    pub(super) device_bytes: Option<u64>,
    pub(super) cpu_over_gpu: Option<f64>,
    pub(super) identical_to_gpu: Option<bool>,
    pub(super) kernel_build_ms: Option<f64>,
    /// With --kernel-stats: the executables and their statistics, or the
    /// words `NO_KERNEL_STATS`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) kernel_statistics: Option<serde_json::Value>,
    pub(super) host_cpu: String,
    pub(super) host_threads: usize,
}

impl Row {
    pub(super) fn json(&self, settings: &RenderSettings, warmup: u32) -> String {
        let d = |v: &[Duration], f: fn(&[Duration]) -> Duration| if v.is_empty() { None } else { Some(ms_f(f(v))) };
        to_json(&RowJson {
            scene: &self.scene,
            backend: &self.backend,
            device: &self.device,
            width: settings.width,
            height: settings.height,
            spp: settings.spp,
            shadows: settings.shadows,
            reflections: settings.reflections,
            textures: settings.textures,
            max_depth: settings.max_depth,
            bvh: settings.bvh,
            primitives_expanded: self.counts.expanded,
            primitives_unique: self.counts.unique,
            lights: self.lights,
            load_ms: ms_f(self.load),
            build_ms: ms_f(self.build),
            warmup,
            frames: self.frames.len(),
            frame_ms_median: ms_f(self.median()),
            frame_ms_min: ms_f(self.frames[0]),
            frame_ms_max: ms_f(*self.frames.last().unwrap()),
            dispatch_ms_median: d(&self.dispatch, median_time),
            device_clear_ms_median: self.phase_medians().map(|p| ms_f(p.clear)),
            device_dispatch_ms_median: self.phase_medians().map(|p| ms_f(p.dispatch)),
            device_readback_ms_median: self.phase_medians().map(|p| ms_f(p.readback)),
            primary_rays_per_frame: self.primary_rays,
            primary_mrays_per_s: rounded(self.mrays(), 4),
            all_rays_per_frame: self.all_rays,
            all_mrays_per_s: rounded(self.all_mrays(), 4),
            host_peak_bytes: self.host_peak,
            device_bytes: self.device_bytes,
            cpu_over_gpu: self.cpu_over_gpu.map(|r| rounded(r, 3)),
            identical_to_gpu: self.identical,
            kernel_build_ms: self.kernel_build.as_ref().map(|(t, _)| ms_f(*t)),
            kernel_statistics: self.kernel_stats.as_ref().map(|stats| match stats {
                Some(executables) => serde_json::to_value(executables).unwrap_or_default(),
                None => serde_json::Value::from(NO_KERNEL_STATS),
            }),
            host_cpu: crate::cpu::host_cpu(),
            host_threads: crate::cpu::host_threads(),
        })
    }

    pub(super) fn human(&self) -> String {
        let mut s = format!(
            "  {:<4} frame {} median (min {}, max {}; {} frames)",
            self.backend,
            ms(self.median()),
            ms(self.frames[0]),
            ms(*self.frames.last().unwrap()),
            self.frames.len()
        );
        if !self.dispatch.is_empty() {
            let _ = write!(s, ", dispatch {} median", ms(median_time(&self.dispatch)));
        }
        if let Some(p) = self.phase_medians() {
            let _ = write!(
                s,
                "\n       device timestamps (medians): clears and data-image copies {}, dispatch {}, readback copy {}",
                ms(p.clear),
                ms(p.dispatch),
                if p.readback.is_zero() {
                    "none (the kernel writes host-visible memory)".to_string()
                } else {
                    ms(p.readback)
                }
            );
        }
        let _ = write!(
            s,
            "\n       {:.3} M primary rays/s, {:.3} M rays/s in all ({:.2} rays per camera ray)\n       host peak {}, device {}",
            self.mrays(),
            self.all_mrays(),
            self.all_rays as f64 / (self.primary_rays as f64).max(1.0),
            mib(self.host_peak),
            self.device_bytes.map_or("- (no upload)".to_string(), |b| mib(Some(b)))
        );
        match &self.kernel_build {
            Some((t, _)) if t.is_zero() => s.push_str("\n       kernel: the one built for an earlier scene"),
            Some((t, how)) => {
                let how = how.as_ref().map(|h| format!(" ({h})")).unwrap_or_default();
                let _ = write!(s, "\n       kernel built in {}{how}", ms(*t));
            }
            None => {}
        }
        match &self.kernel_stats {
            Some(None) => {
                let _ = write!(s, "\n       kernel statistics: {NO_KERNEL_STATS}");
            }
            Some(Some(executables)) => {
                for e in executables {
                    let _ = write!(
                        s,
                        "\n       kernel statistics of executable {} ({}; subgroup size {}):",
                        e.name, e.description, e.subgroup_size
                    );
                    for stat in &e.statistics {
                        let _ = write!(s, "\n         {}: {} ({})", stat.name, stat.value, stat.description);
                    }
                }
            }
            None => {}
        }
        if let Some(r) = self.cpu_over_gpu {
            let _ = write!(s, "\n       cpu/gpu frame median {r:.2}");
        }
        match self.identical {
            Some(true) => s.push_str(", picture identical to the gpu's (every buffer, bit for bit)"),
            Some(false) => s.push_str(", picture DIFFERS from the gpu's"),
            None => {}
        }
        s
    }

    pub(super) fn markdown(&self) -> String {
        format!(
            "| {} | {} | {} / {} | {} | {} | {} | {} – {} | {} | {:.3} | {:.3} | {} | {} | {} |",
            short_name(&self.scene),
            self.backend,
            thousands(self.counts.expanded),
            thousands(self.counts.unique),
            ms(self.load),
            ms(self.build),
            ms(self.median()),
            ms(self.frames[0]),
            ms(*self.frames.last().unwrap()),
            if self.dispatch.is_empty() { "–".to_string() } else { ms(median_time(&self.dispatch)) },
            self.mrays(),
            self.all_mrays(),
            mib(self.host_peak),
            self.device_bytes.map_or("–".to_string(), |b| mib(Some(b))),
            match (self.cpu_over_gpu, self.identical) {
                (Some(r), Some(true)) => format!("{r:.2}, identical"),
                (Some(r), Some(false)) => format!("{r:.2}, pictures DIFFER"),
                (Some(r), None) => format!("{r:.2}"),
                (None, _) => "–".to_string(),
            },
        )
    }
}

pub(super) const MARKDOWN_HEADER: &str = "\
| scene | backend | primitives (expanded / unique) | load | build | frame (median) | frame (min – max) | dispatch (median) | primary Mrays/s | all Mrays/s | host peak | device | cpu ÷ gpu, pictures |
|---|---|---|---|---|---|---|---|---|---|---|---|---|";

/// A scene's name for a table: a file's name without its folder (the
/// command line above the table has the whole path); gen: names as they are.
pub(super) fn short_name(scene: &str) -> &str {
    if scene.starts_with("gen:") || scene.starts_with('<') {
        return scene;
    }
    Path::new(scene).file_name().and_then(|n| n.to_str()).unwrap_or(scene)
}

/// One line of `bench --json` for a scene not timed (`skipped`).
#[derive(Serialize)]
pub(super) struct SkippedJson<'a> {
    pub(super) scene: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(super) backend: Option<&'a str>,
    pub(super) skipped: &'a str,
    pub(super) primitives_expanded: u64,
    pub(super) primitives_unique: u64,
}

/// A scene (or one backend of it) listed but not timed, and not an error,
/// so that one table can name every depth while only some are feasible:
/// over --max-primitives, or cut short by the device (lavapipe's loop budget).
pub(crate) fn skipped(scene: &str, backend: Option<&str>, counts: PrimitiveCounts, why: &str, args: &BenchArgs) {
    if args.json {
        outln!(
            "{}",
            to_json(&SkippedJson {
                scene,
                backend,
                skipped: why,
                primitives_expanded: counts.expanded,
                primitives_unique: counts.unique
            })
        );
    } else if args.markdown {
        outln!(
            "| {} | {} | {} / {} | {why} |{}",
            short_name(scene),
            backend.unwrap_or("–"),
            thousands(counts.expanded),
            thousands(counts.unique),
            " – |".repeat(MARKDOWN_HEADER.lines().next().unwrap_or("").matches('|').count() - 5)
        );
    } else {
        outln!(
            "scene: {scene} ({} primitives expanded, {} unique){}: {why}",
            thousands(counts.expanded),
            thousands(counts.unique),
            backend.map(|b| format!(", {b}")).unwrap_or_default()
        );
    }
}

/// One line of `bench --lanes --json`: a scene's lane use in each warp shape.
#[derive(Serialize)]
pub(super) struct LanesJson<'a> {
    pub(super) scene: &'a str,
    pub(super) lanes: &'a [crate::render::LaneUse; 2],
}

/// A share as `0.81`, or `–` where there is no such ray.
fn share(x: Option<f64>) -> String {
    x.map_or("–".to_string(), |x| format!("{x:.2}"))
}

/// `bench --lanes`'s lines under a scene.
pub(super) fn lanes_text(lanes: &[crate::render::LaneUse; 2]) -> String {
    let warp = |u: &crate::render::LaneUse| {
        format!(
            "{} lanes: camera {}, shadow {}, mirror {}, all {} ({} in step, {} compacted)",
            u.lanes,
            share(u.camera),
            share(u.shadow),
            share(u.mirror),
            share(u.all),
            share(u.all_in_step),
            share(u.all_compacted)
        )
    };
    format!(
        "  lane use, {}; {}\n       per ray: {:.0} B of hierarchy, {:.0} B of primitives fetched",
        warp(&lanes[0]),
        warp(&lanes[1]),
        lanes[0].node_bytes_per_ray,
        lanes[0].primitive_bytes_per_ray
    )
}

pub(super) const LANES_HEADER: &str = "\
| scene | camera (32) | shadow (32) | mirror (32) | all (32) | all in step (32) | all compacted (32) | camera (8) | all (8) | all in step (8) | all compacted (8) | hierarchy B/ray | primitive B/ray |
|---|---|---|---|---|---|---|---|---|---|---|---|---|";

pub(super) const LANES_FOOTER: &str = "lane use: the passes a tile's lanes need over the passes its warp pays (its lanes × the tile's most), summed \
    over the picture's tiles of 8x4 pixels (32 lanes, a GPU's warp) and 4x2 (8 lanes, lavapipe's AVX2), as the \
    kernels lay pixels on lanes, per kind of ray (a pixel's rays of that kind summed) and for all of a pixel's rays (Aila and Laine's model: a warp steps as long as its slowest lane); \
    all in step: the same rays as the kernels step them, a vector's lanes through the tracing loop's turns together, in a turn its ray's walk \
    and then the light loop's shadow rays a light point at a time, each step paid at its slowest lane's passes (from `raycast trace`'s walks \
    of every pixel); all compacted: the same rays as a wavefront kernel would take them (a model, not built), each turn's rays of one kind \
    (its camera, mirror or refracted rays; its shadow rays to one light point) from every pixel in one queue, in the tiles' order, a warp's lanes at a time; drawn with \
    `--aov lanes` on the CPU build, which walks as the device kernel does, pass for pass; bytes: the hierarchy's \
    (nodes, instance records, instances) and the primitives' fetched by the walks, per ray traced (a mesh's own walk \
    over its triangles within a pass counts a pass a node it takes, its bytes the nodes' and the triangles' with \
    their positions).";

/// A scene's row of the lanes table.
pub(super) fn lanes_markdown(scene: &str, lanes: &[crate::render::LaneUse; 2]) -> String {
    let [w32, w8] = lanes;
    format!(
        "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.0} | {:.0} |",
        short_name(scene),
        share(w32.camera),
        share(w32.shadow),
        share(w32.mirror),
        share(w32.all),
        share(w32.all_in_step),
        share(w32.all_compacted),
        share(w8.camera),
        share(w8.all),
        share(w8.all_in_step),
        share(w8.all_compacted),
        w32.node_bytes_per_ray,
        w32.primitive_bytes_per_ray
    )
}
