//! `raycast bench`: frame times, ray rates and memory per scene and backend,
//! for people (a block per scene), machines (`--json`, one object a line)
//! and BENCHMARKS.md (`--markdown`, a table).
//!
//! Per scene: the file is parsed, counted (expanded and unique primitives,
//! without expanding), grouped (`scene::flatten`) and packed
//! (`frame::build`). The build is the part of that `frame::build` reports
//! as `FrameData::build_time`: the bounding volume hierarchies and the
//! packing of the groups; the load is all the rest (parse, count, flatten,
//! textures). Per backend: K warm-up frames, then N timed frames; the
//! median, min and max of their wall times. Every backend runs on the same
//! FrameData in the same process, so ratios compare like with like.

use crate::cli::batch::each_named;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, Error};
use crate::frame::{self, Aov, FrameData, RenderSettings};
use crate::gen::{count_primitives, PrimitiveCounts};
use crate::gpu::{DevicePhases, Executable, GpuError};
use crate::layout::PixelOut;
use crate::measure::{device_bytes, peak_host_bytes, reset_peak_host};
use crate::render::{Picture, Renderer};
use crate::scene::{self, FlattenLimits, ParseOptions, SceneFile};
use crate::source::{parse_scene, scene_label};
use crate::units::median;
use crate::units::{rounded, thousands, to_json};
use clap::{Args, ValueEnum};
use serde::Serialize;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// `raycast bench`.
#[derive(Args, Debug)]
pub struct BenchArgs {
    /// XML files or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene files, or generated scenes as gen:FAMILY:DEPTH (gen:recursive-spheres:6; see
    /// `raycast gen --help`). Without any, the embedded default scene.
    #[arg(value_name = "SCENE")]
    pub scenes: Vec<String>,
    /// gpu (default), cpu (the C++ build) or both
    ///
    /// Where to render: the Vulkan device, the CPU build, or both side by side.
    #[arg(long, value_enum, default_value_t = BenchBackend::Gpu, help_heading = "Device", hide_possible_values = true,
          hide_default_value = true)]
    pub backend: BenchBackend,
    /// Timed frames (the median is reported)
    ///
    /// Timed frames per scene and backend (the median is reported).
    #[arg(long, default_value_t = 5, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=10_000),
          help_heading = "Timing")]
    pub frames: u32,
    /// Untimed frames before them
    #[arg(long, default_value_t = 1, value_name = "K", value_parser = clap::value_parser!(u32).range(0..=10_000),
          help_heading = "Timing")]
    pub warmup: u32,
    #[command(flatten)]
    pub render: crate::cli::options::RenderOptions,
    /// One JSON object per scene and backend, one per line
    #[arg(long, conflicts_with = "markdown", help_heading = "Output")]
    pub json: bool,
    /// A Markdown table (BENCHMARKS.md) with its command line
    ///
    /// A Markdown table (BENCHMARKS.md), with the command line that made it.
    #[arg(long, help_heading = "Output")]
    pub markdown: bool,
    /// Time a kernel from DIR's shaders against the first
    ///
    /// Time a second device kernel, compiled from DIR's shaders, against the
    /// first (the built-in one, or --shaders') in one process, frame pairs
    /// in turn: per scene both dispatch medians, the median of the paired
    /// ratios, how many pairs each won (with a sign test), and whether the
    /// two pictures have the same bits.
    #[arg(long, value_name = "DIR", conflicts_with_all = ["growth", "markdown"], help_heading = "Timing")]
    pub versus: Option<PathBuf>,
    /// How scene times grow against the first's, beside ln N
    ///
    /// After the results, how each scene's frame median grows against the
    /// first scene's, beside ln N / ln N0 (what logarithmic growth in the
    /// primitive count N allows), and the times fitted against ln N (a +
    /// b·ln N and R², from three scenes on); with --json a line a scene,
    /// told by its `growth_against`, and a line a fit, by its `growth_fit`.
    #[arg(long, help_heading = "Timing")]
    pub growth: bool,
    /// The driver's statistics of each scene's kernel
    ///
    /// Per scene, the device driver's statistics of the kernel it ran
    /// (registers, shared memory, occupancy: whatever the driver names,
    /// through VK_KHR_pipeline_executable_properties, as NVIDIA's offers),
    /// from the pipeline built again to keep them; where the driver reports
    /// none (lavapipe), says so. With --json, a row's `kernel_statistics`.
    #[arg(long, conflicts_with_all = ["markdown", "versus"], help_heading = "Output")]
    pub kernel_stats: bool,
}

/// What `--kernel-stats` says where the driver reports no statistics.
const NO_KERNEL_STATS: &str =
    "not reported by this driver (it lacks VK_KHR_pipeline_executable_properties or its pipelineExecutableInfo)";

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum BenchBackend {
    Gpu,
    Cpu,
    Both,
}

/// A scene loaded for benchmarking, with what it took.
pub struct LoadedScene {
    pub name: String,
    pub counts: PrimitiveCounts,
    pub lights: usize,
    /// Parse (generate, for gen: names), count, flatten, and `frame::build`
    /// apart from its `build_time`.
    pub load: Duration,
    /// `FrameData::build_time`: the hierarchies and the packing of the groups.
    pub build: Duration,
    pub data: FrameData,
}

#[cfg(test)]
/// Loads, counts, flattens and builds one scene, timing each part. Prints
/// the scene's warnings and notes to stderr.
pub fn load_scene(
    name: Option<&str>,
    opts: &ParseOptions,
    limits: &FlattenLimits,
    settings: &RenderSettings,
) -> Result<LoadedScene, Error> {
    let start = Instant::now();
    let file = parse_scene(name, opts)?;
    let counts = count_primitives(&file);
    load_parsed(name, file, counts, start, limits, settings)
}

/// `load_scene` for `bench`: None once the scene is listed as skipped
/// (`skipped`, in `args`' format) because it expands to more than
/// `limits.max_primitives` (where `load_scene`'s flattening refuses it).
pub(crate) fn load_or_skip(
    name: Option<&str>,
    opts: &ParseOptions,
    limits: &FlattenLimits,
    settings: &RenderSettings,
    args: &BenchArgs,
) -> Result<Option<LoadedScene>, Error> {
    let start = Instant::now();
    let file = parse_scene(name, opts)?;
    let counts = count_primitives(&file);
    if counts.expanded > limits.max_primitives as u64 {
        let why = format!("skipped: expands to more than --max-primitives {}", thousands(limits.max_primitives as u64));
        skipped(&scene_label(name), None, counts, &why, args);
        return Ok(None);
    }
    load_parsed(name, file, counts, start, limits, settings).map(Some)
}

/// The rest of `load_or_skip` once the file is parsed (at `start`) and counted.
fn load_parsed(
    name: Option<&str>,
    file: SceneFile,
    counts: PrimitiveCounts,
    start: Instant,
    limits: &FlattenLimits,
    settings: &RenderSettings,
) -> Result<LoadedScene, Error> {
    let scene = scene::flatten(&file, limits).map_err(Error::scene)?;
    drop(file);
    for w in &scene.warnings {
        errln!("{w}");
    }
    let data = frame::build(&scene, settings)?;
    let build = data.build_time;
    let load = start.elapsed().saturating_sub(build);
    for note in &data.notes {
        errln!("raycast: note: {note}");
    }
    Ok(LoadedScene { name: scene_label(name), counts, lights: data.lights.len(), load, build, data })
}

/// One scene on one backend.
struct Row {
    scene: String,
    backend: &'static str,
    device: String,
    counts: PrimitiveCounts,
    lights: usize,
    load: Duration,
    build: Duration,
    /// Timed frames, sorted.
    frames: Vec<Duration>,
    /// The device's dispatch alone, sorted (GPU only).
    dispatch: Vec<Duration>,
    /// The device's phases by its timestamps, one per timed frame (GPU
    /// rows where the queue has timestamps).
    phases: Vec<DevicePhases>,
    primary_rays: u64,
    /// Every ray of one frame (camera, shadow and mirror), as the pixels count them.
    all_rays: u64,
    host_peak: Option<u64>,
    device_bytes: Option<u64>,
    /// CPU rows: the CPU's frame median over the GPU's, and whether their pictures are identical.
    cpu_over_gpu: Option<f64>,
    identical: Option<bool>,
    /// GPU rows: the time to build the scene's kernel (pipeline or shader
    /// object; zero where an earlier scene's is the same) and how it was
    /// built (`Kernel::how_built`).
    kernel_build: Option<(Duration, Option<String>)>,
    /// GPU rows with --kernel-stats: the driver's statistics of the
    /// kernel's executables, None where it reports none.
    kernel_stats: Option<Option<Vec<Executable>>>,
}

/// `median` of durations (none: zero).
fn median_time(times: &[Duration]) -> Duration {
    Duration::try_from_secs_f64(median(times.iter().map(Duration::as_secs_f64))).unwrap_or_default()
}

impl Row {
    /// Whether this row is of `backend` ("gpu" covers "gpu uniform" and
    /// "gpu storage"), matched by the first word.
    fn is(&self, backend: &str) -> bool {
        self.backend.split(' ').next() == Some(backend)
    }

    fn median(&self) -> Duration {
        median_time(&self.frames)
    }

    fn mrays(&self) -> f64 {
        self.primary_rays as f64 / self.median().as_secs_f64().max(1e-12) / 1e6
    }

    fn all_mrays(&self) -> f64 {
        self.all_rays as f64 / self.median().as_secs_f64().max(1e-12) / 1e6
    }

    /// The median of each device phase over the timed frames (each phase's
    /// own median); None where the device wrote no timestamps.
    fn phase_medians(&self) -> Option<DevicePhases> {
        if self.phases.is_empty() {
            return None;
        }
        let of = |f: fn(&DevicePhases) -> Duration| median_time(&self.phases.iter().map(f).collect::<Vec<_>>());
        Some(DevicePhases { clear: of(|p| p.clear), dispatch: of(|p| p.dispatch), readback: of(|p| p.readback) })
    }
}

/// Milliseconds with three significant digits (at least one decimal).
fn ms(d: Duration) -> String {
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

fn mib(bytes: Option<u64>) -> String {
    match bytes {
        None => "n/a".to_string(),
        Some(b) if b < 1 << 20 => format!("{:.1} KiB", b as f64 / 1024.0),
        Some(b) => format!("{:.1} MiB", b as f64 / (1u64 << 20) as f64),
    }
}

fn ms_f(d: Duration) -> f64 {
    (d.as_secs_f64() * 1e6).round() / 1e3
}

fn settings_text(s: &RenderSettings) -> String {
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
fn command_line() -> String {
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
struct RowJson<'a> {
    scene: &'a str,
    backend: &'a str,
    device: &'a str,
    width: u32,
    height: u32,
    spp: u32,
    shadows: bool,
    reflections: bool,
    textures: bool,
    max_depth: u32,
    bvh: bool,
    primitives_expanded: u64,
    primitives_unique: u64,
    lights: usize,
    load_ms: f64,
    build_ms: f64,
    warmup: u32,
    frames: usize,
    frame_ms_median: f64,
    frame_ms_min: f64,
    frame_ms_max: f64,
    dispatch_ms_median: Option<f64>,
    /// The device's phases by its timestamps (`DevicePhases`), medians;
    /// null where the queue has no timestamps (and on the CPU build).
    device_clear_ms_median: Option<f64>,
    device_dispatch_ms_median: Option<f64>,
    device_readback_ms_median: Option<f64>,
    primary_rays_per_frame: u64,
    primary_mrays_per_s: f64,
    all_rays_per_frame: u64,
    all_mrays_per_s: f64,
    host_peak_bytes: Option<u64>,
    device_bytes: Option<u64>,
    cpu_over_gpu: Option<f64>,
    identical_to_gpu: Option<bool>,
    kernel_build_ms: Option<f64>,
    /// With --kernel-stats: the executables and their statistics, or the
    /// words `NO_KERNEL_STATS`.
    #[serde(skip_serializing_if = "Option::is_none")]
    kernel_statistics: Option<serde_json::Value>,
    host_cpu: String,
    host_threads: usize,
}

impl Row {
    fn json(&self, settings: &RenderSettings, warmup: u32) -> String {
        let d = |v: &[Duration], f: fn(&[Duration]) -> Duration| if v.is_empty() { None } else { Some(ms_f(f(v))) };
        to_json(&RowJson {
            scene: &self.scene,
            backend: self.backend,
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

    fn human(&self) -> String {
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

    fn markdown(&self) -> String {
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

const MARKDOWN_HEADER: &str = "\
| scene | backend | primitives (expanded / unique) | load | build | frame (median) | frame (min – max) | dispatch (median) | primary Mrays/s | all Mrays/s | host peak | device | cpu ÷ gpu, pictures |
|---|---|---|---|---|---|---|---|---|---|---|---|---|";

/// A scene's name for a table: a file's name without its folder (the
/// command line above the table has the whole path); gen: names as they are.
fn short_name(scene: &str) -> &str {
    if scene.starts_with("gen:") || scene.starts_with('<') {
        return scene;
    }
    Path::new(scene).file_name().and_then(|n| n.to_str()).unwrap_or(scene)
}

/// One line of `bench --json` for a scene not timed (`skipped`).
#[derive(Serialize)]
struct SkippedJson<'a> {
    scene: &'a str,
    #[serde(skip_serializing_if = "Option::is_none")]
    backend: Option<&'a str>,
    skipped: &'a str,
    primitives_expanded: u64,
    primitives_unique: u64,
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

/// One line of the growth table: a scene, its expanded primitive count,
/// ln N / ln N0, and its frame median over the first scene's for the
/// device and the CPU build (None where that backend did not run).
struct Growth<'a> {
    scene: &'a str,
    primitives: u64,
    log_ratio: Option<f64>,
    /// Every ray of the frame (camera, shadow, mirror) over the first
    /// scene's: a property of the scene, the same on every backend.
    rays: Option<f64>,
    gpu: Option<f64>,
    /// The device's dispatch median over the first scene's: the frame
    /// without the upload and readback, which a GPU's frame is mostly.
    gpu_dispatch: Option<f64>,
    cpu: Option<f64>,
}

impl Growth<'_> {
    /// A backend's frame ratio over the rays' ratio: how the time of one
    /// ray grows.
    fn per_ray(&self, frame: Option<f64>) -> Option<f64> {
        Some(frame? / self.rays?)
    }

    /// One line of `--growth --json`: told from a result's line by its
    /// `growth_against` (the first scene's name); a ratio that is not there
    /// is null.
    fn json(&self, against: &str) -> String {
        to_json(&GrowthJson {
            growth_against: against,
            scene: self.scene,
            primitives_expanded: self.primitives,
            log_ratio: self.log_ratio,
            rays_ratio: self.rays,
            gpu_frame_ratio: self.gpu,
            gpu_ray_ratio: self.per_ray(self.gpu),
            gpu_dispatch_ratio: self.gpu_dispatch,
            cpu_frame_ratio: self.cpu,
            cpu_ray_ratio: self.per_ray(self.cpu),
        })
    }
}

/// One line of `bench --growth --json` (`Growth::json`).
#[derive(Serialize)]
struct GrowthJson<'a> {
    growth_against: &'a str,
    scene: &'a str,
    primitives_expanded: u64,
    log_ratio: Option<f64>,
    rays_ratio: Option<f64>,
    gpu_frame_ratio: Option<f64>,
    gpu_ray_ratio: Option<f64>,
    gpu_dispatch_ratio: Option<f64>,
    cpu_frame_ratio: Option<f64>,
    cpu_ray_ratio: Option<f64>,
}

/// One line of `bench --growth --json` for a fitted line: `a + b ln N`
/// for a backend's frame or ray (`growth_fit`), and its R².
#[derive(Serialize)]
struct GrowthFitJson<'a> {
    growth_fit: &'a str,
    against: &'a str,
    a: f64,
    b: f64,
    r2: f64,
}

/// The growth table of `rows`, against the first scene; a backend is
/// matched by its first word ("gpu" covers "gpu uniform" and "gpu storage").
fn growth(rows: &[Row]) -> Vec<Growth<'_>> {
    let Some(first) = rows.first() else { return Vec::new() };
    let find = |scene: &str, backend: &str| rows.iter().find(|r| r.scene == scene && r.is(backend));
    let median = |scene: &str, backend: &str| find(scene, backend).map(Row::median);
    let dispatch = |scene: &str| {
        find(scene, "gpu").filter(|r| !r.dispatch.is_empty()).map(|r| median_time(&r.dispatch).as_secs_f64())
    };
    let n0 = first.counts.expanded as f64;
    let mut out: Vec<Growth> = Vec::new();
    for r in rows {
        if out.iter().any(|g| g.scene == r.scene) {
            continue;
        }
        let ratio = |backend: &str| match (median(&r.scene, backend), median(&first.scene, backend)) {
            (Some(m), Some(b)) => Some(m.as_secs_f64() / b.as_secs_f64().max(1e-12)),
            _ => None,
        };
        out.push(Growth {
            scene: &r.scene,
            primitives: r.counts.expanded,
            log_ratio: (n0 > 1.0).then(|| (r.counts.expanded as f64).ln() / n0.ln()),
            rays: (r.all_rays > 0 && first.all_rays > 0).then(|| r.all_rays as f64 / first.all_rays as f64),
            gpu: ratio("gpu"),
            gpu_dispatch: dispatch(&r.scene).zip(dispatch(&first.scene)).map(|(m, b)| m / b.max(1e-12)),
            cpu: ratio("cpu"),
        });
    }
    out
}

/// Each scene's frame median over the first scene's, per backend, beside
/// the ratio of the logarithms of their expanded primitive counts.
fn print_growth(rows: &[Row], markdown: bool) {
    let Some(first) = rows.first() else { return };
    outln!();
    outln!(
        "Growth against {} ({} primitives): frame median over its frame median, and ln N / ln N0, the ratio logarithmic growth allows; \
         rays: every ray of the frame over its, and a ray: the frame ratio over the rays' (deeper scenes cover more of the picture, \
         so they trace more shadow and mirror rays); gpu dispatch: the device's dispatch median over its (the frame without upload and readback).",
        first.scene,
        thousands(first.counts.expanded)
    );
    if markdown {
        outln!();
        outln!("| scene | primitives N | ln N / ln N0 | rays / first | gpu frame / first | gpu a ray / first | gpu dispatch / first | cpu frame / first | cpu a ray / first |");
        outln!("|---|---|---|---|---|---|---|---|---|");
    }
    let text = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{x:.2}"));
    for g in growth(rows) {
        let (l, rays, gpu, cpu) = (text(g.log_ratio), text(g.rays), text(g.gpu), text(g.cpu));
        let (gpu_ray, cpu_ray, dispatch) = (text(g.per_ray(g.gpu)), text(g.per_ray(g.cpu)), text(g.gpu_dispatch));
        if markdown {
            outln!(
                "| {} | {} | {l} | {rays} | {gpu} | {gpu_ray} | {dispatch} | {cpu} | {cpu_ray} |",
                short_name(g.scene),
                thousands(g.primitives)
            );
        } else {
            outln!(
                "  {}: N = {}, ln N / ln N0 {l}, rays {rays}, gpu {gpu} ({gpu_ray} a ray, dispatch {dispatch}), cpu {cpu} ({cpu_ray} a ray)",
                g.scene,
                thousands(g.primitives)
            );
        }
    }
}

/// A least-squares line y = a + b·x over points (x, y), and its R².
#[derive(Clone, Copy, Debug, PartialEq)]
struct Fit {
    a: f64,
    b: f64,
    r2: f64,
}

/// The least-squares line through `points`; None for fewer than three or
/// where every x is the same.
fn fit(points: &[(f64, f64)]) -> Option<Fit> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = points.iter().map(|p| (p.1 - my).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let residual: f64 = points.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum();
    Some(Fit { a, b, r2: if syy > 0.0 { 1.0 - residual / syy } else { 1.0 } })
}

/// The growth table's times fitted against ln N, per backend: the frame
/// median (ms), and one ray's time (the frame over the rays' ratio to the
/// first scene's: ms at the first scene's rays). A cost a + b·ln N grows
/// logarithmically; it keeps within the table's ln N / ln N0 column only
/// where a ≥ 0. Each: its key in `--json`, its words, the fit.
fn growth_fits(rows: &[Row]) -> Vec<(&'static str, &'static str, Fit)> {
    let Some(first) = rows.first() else { return Vec::new() };
    let mut out = Vec::new();
    for (backend, keys) in [
        ("gpu", [("gpu_frame_ms", "gpu frame, ms"), ("gpu_ray_ms", "gpu a ray, ms at the first scene's rays")]),
        ("cpu", [("cpu_frame_ms", "cpu frame, ms"), ("cpu_ray_ms", "cpu a ray, ms at the first scene's rays")]),
    ] {
        let (mut frame, mut ray, mut seen) = (Vec::new(), Vec::new(), Vec::new());
        for r in rows.iter().filter(|r| r.is(backend) && r.counts.expanded > 0) {
            if seen.contains(&&r.scene) {
                continue;
            }
            seen.push(&r.scene);
            let (x, ms) = ((r.counts.expanded as f64).ln(), r.median().as_secs_f64() * 1e3);
            frame.push((x, ms));
            if r.all_rays > 0 && first.all_rays > 0 {
                ray.push((x, ms * first.all_rays as f64 / r.all_rays as f64));
            }
        }
        for ((key, words), points) in keys.into_iter().zip([frame, ray]) {
            if let Some(f) = fit(&points) {
                out.push((key, words, f));
            }
        }
    }
    out
}

/// A fit's line as words: `-185 + 47.2 ln N`.
fn fit_text(f: &Fit) -> String {
    let sig = |x: f64| {
        let digits = if x.abs() >= 100.0 {
            0
        } else if x.abs() >= 10.0 {
            1
        } else {
            2
        };
        format!("{x:.digits$}")
    };
    format!("{} {} {} ln N", sig(f.a), if f.b < 0.0 { "−" } else { "+" }, sig(f.b.abs())).replace('-', "−")
}

fn print_growth_fits(rows: &[Row], markdown: bool) {
    let fits = growth_fits(rows);
    if fits.is_empty() {
        return;
    }
    outln!();
    outln!(
        "Fitted by least squares against ln N over these scenes: a cost a + b·ln N grows logarithmically, and keeps within \
         ln N / ln N0 only where a ≥ 0."
    );
    if markdown {
        outln!();
        outln!("| what | fit | R² |");
        outln!("|---|---|---|");
    }
    for (_, words, f) in &fits {
        if markdown {
            outln!("| {words} | {} | {:.3} |", fit_text(f), f.r2);
        } else {
            outln!("  {words}: {}, R² {:.3}", fit_text(f), f.r2);
        }
    }
}

pub(crate) fn run(args: &BenchArgs) -> Result<(), Error> {
    if let Some(dir) = &args.versus {
        return super::versus::run(args, dir);
    }
    crate::cli::options::cpu_takes_no_device_options(args.backend == BenchBackend::Cpu, &args.render.kernel)?;
    let settings = args.render.settings();
    settings.validate().map_err(Error::usage)?;
    let r = &args.render;
    let (want_gpu, want_cpu) = match args.backend {
        BenchBackend::Gpu => (true, false),
        BenchBackend::Cpu => (false, true),
        BenchBackend::Both => (true, true),
    };
    let gpu = if want_gpu { Some(r.kernel.renderer()?) } else { None };
    let cpu = if want_cpu { Some(CpuRenderer::new()?) } else { None };
    let gpu_device = gpu.as_ref().map(|g| {
        let i = g.context().info();
        format!("{} ({})", i.name, i.kind)
    });
    let cpu_device = cpu.as_ref().map(|c| format!("CPU build, {} threads", c.threads));
    let peaks_per_scene = reset_peak_host();

    let plural = |n: u32, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    // The device's name, and how its kernels divide (a GPU's correct it).
    let gpu_header =
        gpu.as_ref().zip(gpu_device.as_ref()).map(|(g, d)| format!("{d}{}", g.context().division().kernels_clause()));
    let frames_text =
        format!("median of {} after {}", plural(args.frames, "frame"), plural(args.warmup, "warm-up frame"));
    if args.markdown {
        outln!("`{}`", command_line());
        outln!();
        let devices: Vec<&str> = [gpu_header.as_deref(), cpu_device.as_deref()].into_iter().flatten().collect();
        outln!("{}; {frames_text}; {}.", settings_text(&settings), devices.join("; "));
        outln!();
        outln!("{MARKDOWN_HEADER}");
    } else if !args.json {
        for d in [&gpu_header, &cpu_device].into_iter().flatten() {
            outln!("device: {d}");
        }
        outln!("settings: {}; {frames_text}", settings_text(&settings));
        if !peaks_per_scene {
            outln!(
                "note: cannot reset the peak resident set (/proc/self/clear_refs): host peaks are the process's so far"
            );
        }
    }

    let opts = r.parse_options();
    let limits = FlattenLimits { max_primitives: r.max_primitives };
    let names = crate::cli::batch::scene_names(&args.scenes);
    let primary_rays = u64::from(settings.width) * u64::from(settings.height) * u64::from(settings.spp);
    let mut all_rows: Vec<Row> = Vec::new();
    // A scene loaded and timed on each backend: its rows (None: skipped, and listed so).
    let time = |name: Option<&str>| -> Result<Option<(LoadedScene, Vec<Row>)>, Error> {
        reset_peak_host();
        let Some(loaded) = load_or_skip(name, &opts, &limits, &settings, args)? else {
            return Ok(None);
        };
        let load_peak = peak_host_bytes();
        let row = |backend: &'static str, device: &str| Row {
            scene: loaded.name.clone(),
            backend,
            device: device.to_string(),
            counts: loaded.counts,
            lights: loaded.lights,
            load: loaded.load,
            build: loaded.build,
            frames: Vec::new(),
            dispatch: Vec::new(),
            phases: Vec::new(),
            primary_rays,
            all_rays: 0,
            host_peak: None,
            device_bytes: None,
            cpu_over_gpu: None,
            identical: None,
            kernel_build: None,
            kernel_stats: None,
        };
        let peak = |since_reset: Option<u64>| match (load_peak, since_reset) {
            (Some(a), Some(b)) => Some(a.max(b)),
            (a, b) => a.or(b),
        };
        let mut rows = Vec::new();
        let mut gpu_picture: Option<Picture> = None;
        if let (Some(g), Some(device)) = (&gpu, &gpu_device) {
            // Which kernel: the scene's arrays in uniform or in storage buffers (--scene-buffers).
            let compiled_before = g.compile_time();
            let kernel = g.kernel_for(&loaded.data)?;
            let uniform = kernel.name() == crate::render::UNIFORM_KERNEL;
            let backend = if uniform { "gpu uniform" } else { "gpu storage" };
            let mut row = row(backend, device);
            row.kernel_build = Some((g.compile_time() - compiled_before, kernel.how_built()));
            if args.kernel_stats {
                row.kernel_stats = Some(g.kernel_statistics(&loaded.data)?);
            }
            reset_peak_host();
            let timed = (|| {
                for _ in 0..args.warmup {
                    g.render(&loaded.data)?;
                }
                for _ in 0..args.frames {
                    let start = Instant::now();
                    let (picture, t) = g.render(&loaded.data)?;
                    row.frames.push(start.elapsed());
                    row.dispatch.push(t.dispatch);
                    row.phases.extend(t.device);
                    row.all_rays = picture.rays();
                    gpu_picture = Some(picture);
                }
                Ok::<(), GpuError>(())
            })();
            match timed {
                Ok(()) => {
                    row.host_peak = peak(peak_host_bytes());
                    row.device_bytes = Some(device_bytes(&loaded.data, uniform, g.band_rows(&loaded.data.frame)));
                    rows.push(row);
                }
                Err(GpuError::CutShort { count, total, .. }) => {
                    let why = format!(
                        "not timed: the device cut {} of {} pixels short (Mesa's loop budget per invocation; `raycast render` says more)",
                        thousands(count as u64),
                        thousands(total as u64)
                    );
                    skipped(&loaded.name, Some("gpu"), loaded.counts, &why, args);
                }
                Err(e) => return Err(e.into()),
            }
        }
        if let (Some(c), Some(device)) = (&cpu, &cpu_device) {
            let mut row = row("cpu", device);
            reset_peak_host();
            for _ in 0..args.warmup {
                c.render_frame(&loaded.data, &|_| {})?;
            }
            let mut last = None;
            for _ in 0..args.frames {
                let start = Instant::now();
                let (picture, _) = c.render_frame(&loaded.data, &|_| {})?;
                row.frames.push(start.elapsed());
                row.all_rays = picture.rays();
                last = Some(picture);
            }
            row.host_peak = peak(peak_host_bytes());
            if let (Some(g), Some(p)) = (rows.first(), &gpu_picture) {
                row.frames.sort();
                row.cpu_over_gpu = Some(median_time(&row.frames).as_secs_f64() / g.median().as_secs_f64().max(1e-12));
                row.identical = last.map(|c| {
                    bytemuck::cast_slice::<PixelOut, u8>(&c.pixels) == bytemuck::cast_slice::<PixelOut, u8>(&p.pixels)
                });
            }
            rows.push(row);
        }
        Ok(Some((loaded, rows)))
    };
    // Of several scenes, one that fails is reported as it happens and the
    // others go on (as `render`, `check` and `info`); the command fails at
    // the end, naming it. One scene's failure ends the command.
    let batch = each_named(&names, scene_label, |name| {
        let (loaded, mut rows) = match time(name) {
            Ok(Some(timed)) => timed,
            Ok(None) => return Ok(Ok(())),
            Err(e) => return Ok(Err(e)),
        };
        for row in &mut rows {
            row.frames.sort();
            row.dispatch.sort();
        }
        if args.json {
            for row in &rows {
                crate::output::emit_line(&row.json(&settings, args.warmup))?;
            }
        } else if args.markdown {
            for row in &rows {
                outln!("{}", row.markdown());
            }
        } else {
            outln!(
                "scene: {} ({} primitives expanded, {} unique; {} lights)\n  load {} (parse, count, flatten, textures), build {} (hierarchy)",
                loaded.name,
                thousands(loaded.counts.expanded),
                thousands(loaded.counts.unique),
                loaded.lights,
                ms(loaded.load),
                ms(loaded.build)
            );
            for row in &rows {
                outln!("{}", row.human());
            }
        }
        all_rows.extend(rows);
        Ok(Ok(()))
    })?;
    if args.markdown {
        outln!();
        outln!(
            "load: parse, count, flatten, textures; build: the bounding volume hierarchies and the packing of the groups (`FrameData::build_time`); frame: one whole render call (gpu: upload, dispatch, readback; cpu: every row on every thread); \
             dispatch: the device's part of the gpu frame (recording, submission and the wait for the device; the rest of the frame is the buffers' upload and the picture's readback); \
             primary Mrays/s: {}x{}x{} camera rays over the frame median; all Mrays/s: every ray of the frame (camera, shadow, mirror; the pixels count them) over the frame median; \
             host peak: VmHWM while loading that scene and rendering it on that backend (the Vulkan driver included); \
             device: bytes on the device: uploaded (frame, scene buffers), cleared there (the samples' running sums) and read back (the pixel buffer); \
             cpu ÷ gpu: the CPU's frame median over the device's, and whether their pictures are identical (every buffer, bit for bit).",
            settings.width, settings.height, settings.spp
        );
    }
    if args.growth && args.json {
        for g in growth(&all_rows) {
            crate::output::emit_line(&g.json(&all_rows[0].scene))?;
        }
        for (key, _, f) in growth_fits(&all_rows) {
            crate::output::emit_line(&to_json(&GrowthFitJson {
                growth_fit: key,
                against: "ln N",
                a: f.a,
                b: f.b,
                r2: f.r2,
            }))?;
        }
    } else if args.growth {
        print_growth(&all_rows, args.markdown);
        print_growth_fits(&all_rows, args.markdown);
    }
    let result = batch.failure("").map_or(Ok(()), Err);
    if let Some(g) = gpu {
        let messages = g.context().take_validation_messages();
        drop(g);
        return result.and(check_validation(messages));
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{Frame, SampleSum};

    #[test]
    fn peak_host_memory_is_read_and_reset() {
        let before = peak_host_bytes().expect("VmHWM in /proc/self/status");
        assert!(before > 0);
        // Touch 64 MiB: the peak must see it.
        let block = vec![1u8; 64 << 20];
        let touched: u64 = block.iter().step_by(4096).map(|&b| u64::from(b)).sum();
        assert_eq!(touched, (64 << 20) / 4096);
        let high = peak_host_bytes().unwrap();
        assert!(high >= 64 << 20, "VmHWM {high} after touching 64 MiB");
        drop(block);
        if reset_peak_host() {
            let after = peak_host_bytes().unwrap();
            assert!(after < high, "VmHWM {after} not reset below {high}");
        }
    }

    #[test]
    fn device_bytes_counts_every_buffer() {
        let settings = RenderSettings { width: 10, height: 4, textures: false, ..RenderSettings::default() };
        let loaded =
            load_scene(Some("gen:recursive-spheres:2"), &ParseOptions::default(), &FlattenLimits::default(), &settings)
                .unwrap();
        assert_eq!(loaded.counts, PrimitiveCounts { expanded: 7, unique: 2 });
        let scene: u64 = loaded.data.scene_buffers().iter().map(|b| b.2.len() as u64).sum();
        assert!(scene > 0);
        let per_pixel = std::mem::size_of::<PixelOut>() + std::mem::size_of::<SampleSum>();
        let expect = std::mem::size_of::<Frame>() as u64 + scene + 40 * per_pixel as u64;
        assert_eq!(device_bytes(&loaded.data, false, u32::MAX), expect);
        // In bands of 2 rows, half the pixels at a time.
        assert_eq!(device_bytes(&loaded.data, false, 2), expect - 20 * per_pixel as u64);
        // The uniform kernels' images are uploaded as `padded_for_uniform` pads them:
        // at least one texel, and these arrays are all shorter than a row.
        let images: u64 = loaded
            .data
            .scene_buffers()
            .iter()
            .map(|&(binding, _, bytes)| {
                let image = crate::layout::UNIFORM_KERNEL_IMAGES.contains(&binding);
                (if image { bytes.len().max(16) } else { bytes.len() }) as u64
            })
            .sum();
        assert_eq!(device_bytes(&loaded.data, true, 4), expect - scene + images);
    }

    #[test]
    fn least_squares_lines() {
        // On a line: that line, R² 1.
        let f = fit(&[(1.0, 5.0), (2.0, 7.0), (4.0, 11.0)]).unwrap();
        assert!((f.a - 3.0).abs() < 1e-12 && (f.b - 2.0).abs() < 1e-12 && (f.r2 - 1.0).abs() < 1e-12, "{f:?}");
        // Off it: y = 1, 3, 2 at x = 0, 1, 2 fits 1.5 + 0.5x, residuals −0.5, 1, −0.5: R² 1 − 1.5 / 2.
        let f = fit(&[(0.0, 1.0), (1.0, 3.0), (2.0, 2.0)]).unwrap();
        assert!((f.a - 1.5).abs() < 1e-12 && (f.b - 0.5).abs() < 1e-12 && (f.r2 - 0.25).abs() < 1e-12, "{f:?}");
        assert_eq!(fit(&[(0.0, 1.0), (1.0, 2.0)]), None);
        assert_eq!(fit(&[(1.0, 1.0), (1.0, 2.0), (1.0, 3.0)]), None);
        assert_eq!(fit_text(&Fit { a: -185.04, b: 47.21, r2: 0.989 }), "−185 + 47.2 ln N");
        assert_eq!(fit_text(&Fit { a: 2.5, b: -0.126, r2: 1.0 }), "2.50 − 0.13 ln N");
    }

    /// One median for bench's frames and versus's ratios: unsorted input,
    /// odd and even counts, none.
    #[test]
    fn medians() {
        assert_eq!(median([3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median([4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(std::iter::empty()).is_nan());
        let ms = Duration::from_millis;
        assert_eq!(median_time(&[ms(30), ms(10), ms(20), ms(40)]), ms(25));
        assert_eq!(median_time(&[]), Duration::ZERO);
    }

    #[test]
    fn growth_matches_backends_by_their_first_word() {
        let row = |scene: &str, backend: &'static str, n: u64, ms: u64| Row {
            scene: scene.into(),
            backend,
            device: String::new(),
            counts: PrimitiveCounts { expanded: n, unique: 1 },
            lights: 1,
            load: Duration::ZERO,
            build: Duration::ZERO,
            frames: vec![Duration::from_millis(ms)],
            // The device's dispatch: a fifth of its frame (none on the CPU).
            dispatch: if backend == "cpu" { Vec::new() } else { vec![Duration::from_millis(ms) / 5] },
            phases: Vec::new(),
            primary_rays: 1,
            // Twice the rays in the deeper scene.
            all_rays: if n > 100 { 40 } else { 20 },
            host_peak: None,
            device_bytes: None,
            cpu_over_gpu: None,
            identical: None,
            kernel_build: None,
            kernel_stats: None,
        };
        let rows = [
            row("a", "gpu uniform", 100, 10),
            row("a", "cpu", 100, 4),
            row("b", "gpu storage", 10_000, 25),
            row("b", "cpu", 10_000, 6),
        ];
        let g = growth(&rows);
        assert_eq!(g.len(), 2);
        assert_eq!((g[0].gpu, g[0].cpu, g[0].log_ratio), (Some(1.0), Some(1.0), Some(1.0)));
        assert_eq!((g[1].gpu, g[1].cpu), (Some(2.5), Some(1.5)));
        assert_eq!(g[1].rays, Some(2.0));
        assert_eq!((g[1].per_ray(g[1].gpu), g[1].per_ray(g[1].cpu)), (Some(1.25), Some(0.75)));
        assert_eq!((g[0].gpu_dispatch, g[1].gpu_dispatch), (Some(1.0), Some(2.5)));
        assert!((g[1].log_ratio.unwrap() - 2.0).abs() < 1e-12);
        // Two scenes are too few to fit a line; a third makes one for each backend, its frame and a ray.
        assert!(growth_fits(&rows).is_empty());
        let three = [
            row("a", "gpu uniform", 100, 10),
            row("a", "cpu", 100, 4),
            row("b", "gpu storage", 10_000, 25),
            row("b", "cpu", 10_000, 6),
            row("c", "gpu storage", 1_000_000, 40),
            row("c", "cpu", 1_000_000, 8),
        ];
        let fits = growth_fits(&three);
        let keys: Vec<&str> = fits.iter().map(|f| f.0).collect();
        assert_eq!(keys, ["gpu_frame_ms", "gpu_ray_ms", "cpu_frame_ms", "cpu_ray_ms"]);
        // gpu frames 10, 25, 40 ms at ln N = 2, 4, 6 ln 10: 10 + 7.5 (ln N / ln 10 - 2) ms, exactly.
        let f = fits[0].2;
        assert!((f.b * 10f64.ln() - 7.5).abs() < 1e-9 && (f.r2 - 1.0).abs() < 1e-12, "{f:?}");
        // --growth --json: a line a scene, after the results' lines.
        let j = g[1].json(&rows[0].scene);
        assert!(j.starts_with("{\"growth_against\":\""), "{j}");
        for needle in [
            "\"gpu_frame_ratio\":2.5,\"gpu_ray_ratio\":1.25,\"gpu_dispatch_ratio\":2.5,",
            "\"cpu_frame_ratio\":1.5,\"cpu_ray_ratio\":0.75}",
        ] {
            assert!(j.contains(needle), "{needle} in {j}");
        }
    }

    #[test]
    fn json_and_markdown_rows() {
        let row = Row {
            scene: "a \"b\"".into(),
            backend: "gpu",
            device: "llvmpipe".into(),
            counts: PrimitiveCounts { expanded: 2_929_687, unique: 10 },
            lights: 3,
            load: Duration::from_micros(1500),
            build: Duration::from_micros(250),
            frames: vec![Duration::from_millis(10), Duration::from_millis(20), Duration::from_millis(40)],
            dispatch: vec![Duration::from_millis(9)],
            phases: Vec::new(),
            primary_rays: 1_000_000,
            all_rays: 4_000_000,
            host_peak: Some(3 << 20),
            device_bytes: Some(2048),
            cpu_over_gpu: None,
            identical: None,
            kernel_build: Some((Duration::from_micros(43_500), Some("SPIR-V specialised ahead".into()))),
            kernel_stats: None,
        };
        let j = row.json(&RenderSettings::default(), 1);
        assert!(j.starts_with("{\"scene\":\"a \\\"b\\\"\",\"backend\":\"gpu\""), "{j}");
        // serde_json writes a whole f64 as 20.0 where format! wrote 20: the values compared.
        let v: serde_json::Value = serde_json::from_str(&j).unwrap();
        for (key, want) in [
            ("primitives_expanded", serde_json::json!(2929687)),
            ("frame_ms_median", serde_json::json!(20.0)),
            ("frame_ms_min", serde_json::json!(10.0)),
            ("primary_mrays_per_s", serde_json::json!(50.0)),
            ("all_rays_per_frame", serde_json::json!(4000000)),
            ("all_mrays_per_s", serde_json::json!(200.0)),
            ("device_bytes", serde_json::json!(2048)),
            ("cpu_over_gpu", serde_json::Value::Null),
            ("kernel_build_ms", serde_json::json!(43.5)),
        ] {
            assert_eq!(v[key], want, "{key} in {j}");
        }
        assert!(j.contains("\"all_rays_per_frame\":4000000,\"all_mrays_per_s\":200.0,"), "{j}");
        assert!(j.contains("\"kernel_build_ms\":43.5,\"host_cpu\":\""), "{j}");
        assert!(!j.contains('\n'));
        let m = row.markdown();
        assert!(
            m.contains("| 2,929,687 / 10 |")
                && m.contains("| 20.0 ms | 10.0 ms – 40.0 ms | 9.00 ms |")
                && m.contains("| 3.0 MiB | 2.0 KiB |"),
            "{m}"
        );
        assert_eq!(m.matches('|').count(), MARKDOWN_HEADER.lines().next().unwrap().matches('|').count());
    }
}
