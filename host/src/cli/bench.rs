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

mod growth;
mod rows;

use crate::cli::batch::each_named;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, Error};
use crate::frame::{FrameData, RenderSettings};
use crate::gen::{count_primitives, PrimitiveCounts};
use growth::{growth, growth_fits, print_growth, print_growth_fits, GrowthFitJson};
pub(crate) use rows::skipped;
use rows::{
    command_line, lanes_markdown, lanes_text, median_time, ms, settings_text, LanesJson, Row, LANES_FOOTER,
    LANES_HEADER, MARKDOWN_HEADER,
};

use crate::layout::PixelOut;
use crate::measure::{peak_host_bytes, reset_peak_host};
use crate::render::{compacted, in_step, BackendInfo, CutShort, LaneUse, Picture, Progress, Renderer, Told, WARPS};
use crate::scene::{self, FlattenLimits, ParseOptions, SceneFile};
use crate::source::{pack, parse_scene, print_warnings, scene_label};
use crate::units::{thousands, to_json};
use clap::{Args, ValueEnum};
use std::path::PathBuf;
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
    /// How well each scene's rays keep SIMT lanes busy
    ///
    /// Per scene, drawn once more with --aov lanes on the CPU build (the
    /// device kernel's walk, pass for pass): each kind of ray's passes over
    /// warps of 8x4 pixels (a GPU's 32 lanes) and 4x2 (lavapipe's 8), the
    /// passes the lanes need over those their warps pay (Aila and Laine's
    /// model: a warp costs its slowest lane), all rays also in step (each
    /// step of the tracing loop at its slowest lane, as the kernel takes
    /// them) and compacted by kind (as a wavefront kernel would take them:
    /// a model), and the bytes of hierarchy and primitives fetched per ray
    /// (docs/scale.md#lane-use). With --json a line a scene (`lanes`);
    /// with --markdown a table after the results.
    #[arg(long, conflicts_with = "versus", help_heading = "Timing")]
    pub lanes: bool,
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
    print_warnings(&scene);
    let data = pack(&scene, settings)?;
    let build = data.build_time;
    let load = start.elapsed().saturating_sub(build);
    Ok(LoadedScene { name: scene_label(name), counts, lights: data.lights.len(), load, build, data })
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
    // The device first: the CPU build's row compares with its picture.
    let mut renderers: Vec<Box<dyn Renderer>> = Vec::new();
    if want_gpu {
        renderers.push(Box::new(r.kernel.renderer()?));
    }
    if want_cpu {
        renderers.push(Box::new(CpuRenderer::new()?));
    }
    let infos: Vec<BackendInfo> = renderers.iter().map(|r| r.info()).collect();
    let peaks_per_scene = reset_peak_host();

    let plural = |n: u32, what: &str| format!("{n} {what}{}", if n == 1 { "" } else { "s" });
    // Each backend's name, and how a device's kernels divide (a GPU's correct it).
    let headers: Vec<String> = infos.iter().map(|i| format!("{}{}", i.label, i.kernels_clause)).collect();
    let frames_text =
        format!("median of {} after {}", plural(args.frames, "frame"), plural(args.warmup, "warm-up frame"));
    if args.markdown {
        outln!("`{}`", command_line());
        outln!();
        outln!("{}; {frames_text}; {}.", settings_text(&settings), headers.join("; "));
        outln!();
        outln!("{MARKDOWN_HEADER}");
    } else if !args.json {
        for d in &headers {
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
    let mut all_rows: Vec<Row> = Vec::new();
    // A scene loaded and timed on each backend: its rows (None: skipped, and listed so).
    // Its frames told as they go: `scene` of the names, each backend's warm-up and timed frames.
    let time = |name: Option<&str>, scene: usize, told: Told| -> Result<Option<(LoadedScene, Vec<Row>)>, Error> {
        reset_peak_host();
        let Some(loaded) = load_or_skip(name, &opts, &limits, &settings, args)? else {
            return Ok(None);
        };
        let load_peak = peak_host_bytes();
        let row = |backend: String, device: &str| Row {
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
            primary_rays: loaded.data.frame.camera_rays(),
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
        let mut rows: Vec<Row> = Vec::new();
        // The device's picture, which the CPU build's row compares with.
        let mut device_picture: Option<Picture> = None;
        let per_backend = f64::from(args.warmup + args.frames);
        for (b, (renderer, info)) in renderers.iter().zip(&infos).enumerate() {
            let tell = |frame: u32| {
                let done = (b as f64 + f64::from(frame) / per_backend) / renderers.len() as f64;
                told(Progress {
                    fraction: (scene as f64 + done) / names.len() as f64,
                    detail: format!("scene {} of {}, {} frame {frame}", scene + 1, names.len(), info.label),
                })
            };
            // Which kernel: the scene's arrays in uniform or in storage buffers (--scene-buffers).
            let kernel = renderer.kernel(&loaded.data)?;
            let backend = kernel.as_ref().map_or("cpu".to_string(), |k| format!("gpu {}", k.arrays));
            let mut row = row(backend, &info.label);
            if let Some(k) = &kernel {
                row.kernel_build = Some((k.build_time, k.how_built.clone()));
                if args.kernel_stats {
                    row.kernel_stats = Some(renderer.kernel_statistics(&loaded.data)?);
                }
            }
            reset_peak_host();
            let timed = (|| {
                for k in 0..args.warmup {
                    tell(k);
                    renderer.render_frame(&loaded.data, &|_| {})?;
                }
                let mut last = None;
                for k in 0..args.frames {
                    tell(args.warmup + k);
                    let start = Instant::now();
                    let (picture, t) = renderer.render_frame(&loaded.data, &|_| {})?;
                    row.frames.push(start.elapsed());
                    if t.on_device {
                        row.dispatch.push(t.dispatch);
                    }
                    row.phases.extend(t.device);
                    row.all_rays = picture.rays();
                    last = Some(picture);
                }
                Ok::<Option<Picture>, Error>(last)
            })();
            match timed {
                Ok(picture) => {
                    row.host_peak = peak(peak_host_bytes());
                    row.device_bytes = renderer.device_bytes(&loaded.data)?;
                    if !info.cpu_build {
                        device_picture = picture;
                    } else if let (Some(g), Some(p)) = (rows.first(), &device_picture) {
                        row.frames.sort();
                        row.cpu_over_gpu =
                            Some(median_time(&row.frames).as_secs_f64() / g.median().as_secs_f64().max(1e-12));
                        row.identical = picture.map(|c| {
                            bytemuck::cast_slice::<PixelOut, u8>(&c.pixels)
                                == bytemuck::cast_slice::<PixelOut, u8>(&p.pixels)
                        });
                    }
                    rows.push(row);
                }
                Err(Error::CutShort(CutShort { count, total, .. })) => {
                    let why = format!(
                        "not timed: the device cut {} of {} pixels short (Mesa's loop budget per invocation; `raycast render` says more)",
                        thousands(count as u64),
                        thousands(total as u64)
                    );
                    skipped(&loaded.name, Some("gpu"), loaded.counts, &why, args);
                }
                Err(e) => return Err(e),
            }
        }
        Ok(Some((loaded, rows)))
    };
    // Of several scenes, one that fails is reported as it happens and the
    // others go on (as `render`, `check` and `info`); the command fails at
    // the end, naming it. One scene's failure ends the command.
    let scene = std::cell::Cell::new(0);
    // --lanes: each scene's lane use, drawn by the CPU build.
    let lane_cpu = if args.lanes { Some(CpuRenderer::new()?) } else { None };
    let mut lane_rows: Vec<(String, [LaneUse; 2])> = Vec::new();
    let batch = crate::progress::told("bench", |told| {
        each_named(&names, scene_label, |name| {
            scene.set(scene.get() + 1);
            let (loaded, mut rows) = match time(name, scene.get() - 1, told) {
                Ok(Some(timed)) => timed,
                Ok(None) => return Ok(Ok(())),
                Err(e) => return Ok(Err(e)),
            };
            for row in &mut rows {
                row.frames.sort();
                row.dispatch.sort();
            }
            let lanes = match &lane_cpu {
                Some(cpu) => {
                    let mut drawn = loaded.data.clone();
                    drawn.frame.aov = crate::layout::AOV_LANES;
                    let (picture, _) = cpu.render_frame(&drawn, &|_| {})?;
                    let walks = cpu.walks(&drawn, &drawn.frame);
                    Some(WARPS.map(|warp| LaneUse {
                        all_in_step: walks.as_ref().and_then(|w| in_step(w, picture.width, picture.height, warp)),
                        all_compacted: walks.as_ref().and_then(|w| compacted(w, picture.width, picture.height, warp)),
                        ..LaneUse::of(&picture, warp)
                    }))
                }
                None => None,
            };
            if args.json {
                for row in &rows {
                    crate::output::emit_line(&row.json(&settings, args.warmup))?;
                }
                if let Some(lanes) = &lanes {
                    crate::output::emit_line(&to_json(&LanesJson { scene: &loaded.name, lanes }))?;
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
                if let Some(lanes) = &lanes {
                    outln!("{}", lanes_text(lanes));
                }
            }
            if let Some(lanes) = lanes {
                lane_rows.push((loaded.name.clone(), lanes));
            }
            all_rows.extend(rows);
            Ok(Ok(()))
        })
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
    if args.markdown && !lane_rows.is_empty() {
        outln!();
        outln!("{LANES_HEADER}");
        for (scene, lanes) in &lane_rows {
            outln!("{}", lanes_markdown(scene, lanes));
        }
        outln!();
        outln!("{LANES_FOOTER}");
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
    let messages: Vec<String> = renderers.iter().flat_map(|r| r.take_messages()).collect();
    drop(renderers);
    result.and(check_validation(messages))
}

#[cfg(test)]
mod tests;
