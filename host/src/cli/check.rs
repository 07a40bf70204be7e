//! `raycast check`: the device against the CPU build, every buffer bit for bit.

use crate::check;
use crate::cli::batch::*;
use crate::cli::options::*;
use crate::cli::output::*;
use crate::cli::status::*;
use crate::cli::values::*;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, validation_wanted, Error};
use crate::frame::FrameData;
use crate::image_io::{self};
use crate::output::*;
use crate::progress;
use crate::render::{Picture, Renderer};
use crate::units::to_json;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CheckArgs {
    /// XML files or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene files (XML), checked one after the other on one device and one
    /// CPU build (their start-up and each kernel paid once), or generated
    /// scenes (gen:recursive-spheres:6). Without any, the embedded default
    /// scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    render: RenderOptions,
    /// Diff image for one scene [default: SCENE-check.png]
    ///
    /// Where to write the diff image, for one scene [default:
    /// <scene name>-check.png, and only when something differs]: red where
    /// any buffer differs, a dim copy of the device's render elsewhere.
    #[arg(short, long, value_name = "DIFF.png", conflicts_with = "out_dir", value_parser = crate::output::parse_output,
          help_heading = "Output")]
    output: Option<PathBuf>,
    /// Folder for the diff images [default: .]
    ///
    /// Folder for the diff images, each <scene name>-check.png (made if
    /// missing) [default: the current folder]
    #[arg(long, value_name = "DIR", help_heading = "Output")]
    out_dir: Option<PathBuf>,
    /// Succeed when at most K pixels differ
    ///
    /// Succeed when at most K pixels differ (in each scene). For a GPU whose
    /// driver breaks the kernels' exactness (lavapipe and an NVIDIA H100
    /// keep it: docs/exactness.md#on-a-gpu); the output says the check was not
    /// exact.
    #[arg(long, default_value_t = 0, value_name = "K", help_heading = "Rule")]
    allow_pixels: usize,
    /// Also run pixel X,Y alone on both sides (repeatable)
    ///
    /// Also run pixel (X, Y) alone through the shader-test harness:
    /// render_pixel(X, Y) in a one-invocation kernel on the device and in a
    /// C++ build compiled at run time, both from --shaders DIR (or the source
    /// tree's shaders/), compared bit for bit. Tells a difference that
    /// follows the code from one that follows the whole-frame kernel, and
    /// lets instrumentation of DIR run on both sides. Repeatable; one scene.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true,
          help_heading = "Diagnostics")]
    pixel: Vec<(u32, u32)>,
    /// One JSON object per scene on stdout
    ///
    /// One JSON object per scene on stdout (and a summary object for several)
    #[arg(long, help_heading = "Output", conflicts_with = "pixel")]
    json: bool,
}

/// What `check --json` says of one scene.
#[derive(Serialize)]
struct SceneJson<'a> {
    scene: String,
    width: u32,
    height: u32,
    /// Every pixel of every buffer has the same bits.
    identical: bool,
    /// Some pixels differ, but no more than --allow-pixels.
    accepted: bool,
    /// Pixels that differ in at least one buffer.
    differing_pixels: usize,
    /// Each buffer (t, id, normal, rgba, rays), in the report's order.
    buffers: Vec<BufferJson<'a>>,
    /// The diff image written, or null where none was.
    diff_image: Option<String>,
}

/// One buffer of [`SceneJson`]: how many pixels differ, the first (its
/// values on either side, as the text report writes them) and the worst.
#[derive(Serialize)]
struct BufferJson<'a> {
    buffer: &'a str,
    differing: usize,
    /// What `distance` counts ("ULP", "/255", "rays"); null for the ids.
    unit: Option<&'a str>,
    first: Option<FirstJson<'a>>,
    worst: Option<WorstJson>,
}

#[derive(Serialize)]
struct FirstJson<'a> {
    x: u32,
    y: u32,
    device: &'a str,
    cpu: &'a str,
    /// Null for the ids, or a NaN against a number.
    distance: Option<u64>,
}

#[derive(Serialize)]
struct WorstJson {
    x: u32,
    y: u32,
    /// Null for a NaN against a number.
    distance: Option<u64>,
}

/// A distance of `check::CheckReport` in JSON: u64::MAX (a NaN against a number) is no distance.
fn distance(d: u64) -> Option<u64> {
    (d != u64::MAX).then_some(d)
}

impl<'a> SceneJson<'a> {
    fn of(p: &Prepared, report: &'a check::CheckReport, accepted: bool, diff_image: Option<&Path>) -> Self {
        SceneJson {
            scene: p.scene.path.display().to_string(),
            width: report.width,
            height: report.height,
            identical: report.identical(),
            accepted,
            differing_pixels: report.differing_pixels,
            buffers: report
                .buffers
                .iter()
                .map(|b| BufferJson {
                    buffer: b.name,
                    differing: b.differing,
                    unit: Some(b.unit.trim()).filter(|u| !u.is_empty()),
                    first: b.first.as_ref().map(|(x, y, device, cpu, d)| FirstJson {
                        x: *x,
                        y: *y,
                        device,
                        cpu,
                        distance: d.and_then(distance),
                    }),
                    worst: b.worst.map(|(x, y, d)| WorstJson { x, y, distance: distance(d) }),
                })
                .collect(),
            diff_image: diff_image.map(|d| d.display().to_string()),
        }
    }
}

/// What `check --json` says after several scenes.
#[derive(Serialize)]
struct SummaryJson {
    scenes: usize,
    identical: usize,
    accepted: usize,
    differ: usize,
    failed: usize,
}

/// How one scene's check came out.
enum Checked {
    Identical,
    /// Some pixels differ, within --allow-pixels.
    Accepted,
    /// This many pixels differ, beyond --allow-pixels.
    Differ(usize),
}

/// The device and the CPU build `check` compares, opened once, for the first scene that loads.
/// The two builds `check` holds side by side: the device and the CPU build.
struct CheckBackends {
    gpu: Box<dyn Renderer>,
    cpu: Box<dyn Renderer>,
}

pub fn run(args: &CheckArgs) -> Result<(), Error> {
    if args.json && args.output.as_deref().is_some_and(crate::output::is_stdout) {
        return Err(Error::Usage(
            "--json writes to standard output, and so does -o -: write the diff image to a file".into(),
        ));
    }
    args.render.kernel.refuse_fast("check")?;
    status_beside(&args.output);
    let scenes = scene_list(&args.scenes);
    if !args.pixel.is_empty() && scenes.len() > 1 {
        return Err(Error::Usage(format!(
            "--pixel looks at one scene's pixel, but {} scenes were given: check that scene alone",
            scenes.len()
        )));
    }
    // Bad --pixel input fails before any work (the frame's size is the options').
    args.render.settings().validate().map_err(Error::usage)?;
    let (width, height) = (args.render.width, args.render.height);
    if let Some(&(x, y)) = args.pixel.iter().find(|&&(x, y)| x >= width || y >= height) {
        return Err(Error::usage(format!("--pixel {x},{y} is outside the {width}x{height} frame")));
    }
    let diffs = output_paths(&args.output, &args.out_dir, "-check", &scenes)?;
    let mut backends: Option<CheckBackends> = None;
    // The one scene's frame and pictures, for --pixel.
    let mut last = None;
    let batch = each_scene(
        &scenes,
        &diffs,
        &args.render,
        &mut backends,
        || {
            Ok(CheckBackends {
                gpu: Box::new(args.render.kernel.exact_renderer()?),
                cpu: Box::new(CpuRenderer::new()?),
            })
        },
        |backends, p, diff| {
            let (checked, gpu, cpu) = check_scene(args, backends, &p, diff)?;
            if !args.pixel.is_empty() {
                last = Some((p.data, gpu, cpu));
            }
            Ok(checked)
        },
    )?;
    let accepted = batch.done.iter().filter(|(_, c)| matches!(c, Checked::Accepted)).count();
    let differ: Vec<(&str, usize)> = batch
        .done
        .iter()
        .filter_map(|(name, c)| if let Checked::Differ(n) = c { Some((name.as_str(), *n)) } else { None })
        .collect();
    if let Some(b) = backends {
        let messages = b.gpu.take_messages();
        drop(b);
        check_validation(messages)?;
    }
    if let Some((data, gpu_picture, cpu_picture)) = &last {
        isolated_pixels(args, data, gpu_picture, cpu_picture)?;
    }
    let n = scenes.len();
    if n > 1 {
        let identical = n - accepted - differ.len() - batch.failed.len();
        if args.json {
            emit_line(&to_json(&SummaryJson {
                scenes: n,
                identical,
                accepted,
                differ: differ.len(),
                failed: batch.failed.len(),
            }))?;
        }
        let line = format!(
            "check: {identical} of {n} scenes identical, {accepted} within --allow-pixels, {} differ, {} failed",
            differ.len(),
            batch.failed.len()
        );
        // With --json, the summary object's line on stderr, as a status line.
        if args.json {
            summary!("{line}");
        } else {
            outln!("{line}");
        }
    }
    let differ_text = || match &differ[..] {
        [(_, pixels)] if n == 1 => format!("{pixels} pixels differ between the device and the CPU build"),
        _ => {
            let list: Vec<String> = differ.iter().map(|(name, pixels)| format!("{name} ({pixels} pixels)")).collect();
            format!("{} of {n} scenes differ between the device and the CPU build: {}", differ.len(), list.join(", "))
        }
    };
    let also = if differ.is_empty() { String::new() } else { format!("; and {}", differ_text()) };
    match batch.failure(&also) {
        Some(failure) => Err(failure),
        None if differ.is_empty() => Ok(()),
        None => Err(Error::Mismatch { command: "check", message: differ_text() }),
    }
}

/// One scene on the device and on the CPU build, compared and reported; the
/// diff image written to `diff` where asked (-o) or where something differs.
fn check_scene(
    args: &CheckArgs,
    b: &CheckBackends,
    p: &Prepared,
    diff: &Path,
) -> Result<(Checked, Picture, Picture), Error> {
    let device = b.gpu.info().name;
    print_scene(p);
    let intro = format!(
        "check: {} on {device} against the CPU build ({} threads), {}x{}, every buffer bit for bit",
        args.render.kernel.kernel_text(),
        b.cpu.info().threads.unwrap_or(1),
        p.data.frame.width,
        p.data.frame.height
    );
    if args.json {
        detail!("{intro}");
    } else {
        outln!("{intro}");
    }
    let scene = p.scene.path.display();
    let (gpu_picture, _) = progress::told(format!("{scene} on {device}"), |told| b.gpu.render_frame(&p.data, told))?;
    print_kernel(b.gpu.as_ref(), &p.data)?;
    let (cpu_picture, _) =
        progress::told(format!("{scene} on the CPU build"), |told| b.cpu.render_frame(&p.data, told))?;
    let report = check::compare(&gpu_picture, "device", &cpu_picture, "cpu")?;
    report_line(args, format_args!("{report}"));
    let written = args.output.is_some() || !report.identical();
    if written {
        image_io::write_png(diff, &report.diff_image)?;
        summary!("wrote {} (red: pixels that differ)", diff.display());
    } else {
        // The scene's diff image of an earlier run would say it still differs.
        for stale in image_io::remove_stale(&[diff.to_path_buf()])? {
            summary!("removed {}, the diff image of an earlier run", stale.display());
        }
    }
    let checked = match report.differing_pixels {
        _ if report.identical() => Checked::Identical,
        n if n <= args.allow_pixels => {
            report_line(
                args,
                format_args!(
                    "NOT EXACT: {n} pixels differ, accepted by --allow-pixels {} (lavapipe and an NVIDIA H100 measured exact; \
                 a driver that does not fuse `fma` or honour `precise` may not be: docs/exactness.md#on-a-gpu)",
                    args.allow_pixels
                ),
            );
            Checked::Accepted
        }
        n => Checked::Differ(n),
    };
    if args.json {
        let accepted = matches!(checked, Checked::Accepted);
        emit_line(&to_json(&SceneJson::of(p, &report, accepted, written.then_some(diff))))?;
    }
    Ok((checked, gpu_picture, cpu_picture))
}

/// A line of the text report: on stdout, or with --json (whose objects
/// say it) on stderr with -v.
fn report_line(args: &CheckArgs, line: std::fmt::Arguments) {
    if args.json {
        detail!("{line}");
    } else {
        outln!("{line}");
    }
}

/// `check --pixel`: each pixel's render_pixel alone, through the harness.
fn isolated_pixels(
    args: &CheckArgs,
    data: &FrameData,
    gpu_picture: &Picture,
    cpu_picture: &Picture,
) -> Result<(), Error> {
    use crate::harness::{Case, Harness, HarnessOptions, SceneBuffers};
    let width = data.frame.width;
    let mut harness = Harness::new(&HarnessOptions {
        shaders: args.render.kernel.shaders.clone(),
        device: args.render.kernel.device.clone(),
        validation: validation_wanted(args.render.kernel.validate),
        timeout: args.render.kernel.timeout(),
    })
    .map_err(|e| Error::Failed(format!("--pixel: {e}")))?;
    // The frame's buffers under the names scene_buffers.glsl gives them.
    let mut scene = SceneBuffers::new().frame(&data.frame);
    for (binding, what, bytes) in data.scene_buffers() {
        let Some(b) = harness.shaders().scene_buffers.iter().find(|b| b.binding == binding) else {
            return Err(Error::Failed(format!("--pixel: scene_buffers.glsl declares no binding {binding} ({what})")));
        };
        let words = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
        scene = scene.with_words(&b.name, words);
    }
    let scene = std::sync::Arc::new(scene);
    let cases: Vec<Case> = args
        .pixel
        .iter()
        .map(|&(x, y)| {
            Case::new("render_pixel")
                .named(format!("pixel ({x}, {y}) alone"))
                .input("j", x)
                .input("i", y)
                .scene(scene.clone())
        })
        .collect();
    let results = harness.run(&cases);
    for (&(x, y), r) in args.pixel.iter().zip(&results) {
        let index = (y * width + x) as usize;
        outln!("pixel ({x}, {y}) in the frame:  device {}", pixel_text(&gpu_picture.pixels[index]));
        outln!("                              cpu    {}", pixel_text(&cpu_picture.pixels[index]));
        let alone = |v: &Option<crate::harness::Value>| v.as_ref().map_or("did not run".to_string(), |v| v.text());
        outln!("  alone (harness, {}): device {}", if r.passed { "identical" } else { "DIFFER" }, alone(&r.device));
        outln!("                              cpu    {}", alone(&r.cpu));
        if r.device.is_none() || r.cpu.is_none() {
            outln!("{}", r.report);
        }
    }
    check_validation(harness.take_validation_messages())
}

fn pixel_text(p: &crate::layout::PixelOut) -> String {
    format!(
        "{{ t = {:?}, id = {}, normal = [{:?}, {:?}, {:?}], rgba = 0x{:08x}, rays = {} }}",
        p.t, p.id, p.normal[0], p.normal[1], p.normal[2], p.rgba, p.rays
    )
}
