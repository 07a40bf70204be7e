//! The command line: commands and flags, progress lines, exit codes.
//!
//! Exit codes: 0 success, 1 an error (scene, device, file), 2 a usage error,
//! 3 the Vulkan validation layer reported something (with --validate or
//! RAYCAST_VALIDATION=1), 4 `check` found differences.

use crate::check;
use crate::cpu::CpuRenderer;
use crate::frame::{self, Aov, FrameData, RenderSettings, TextureFilter};
use crate::gpu::{self, DeviceSelector, GpuOptions};
use crate::image_io::{self, Rgb8};
use crate::layout;
use crate::progress;
use crate::render::{GpuRenderer, Picture, SceneBuffers};
use crate::scene::{self, FlattenLimits, ParseOptions, Scene};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The embedded default scene (scenes/default.xml): all four primitives and
/// three kinds of light.
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.xml");
pub(crate) const DEFAULT_SCENE_NAME: &str = "<default scene>";

#[derive(Parser, Debug)]
#[command(
    name = "raycast",
    version,
    about = "A ray caster in a Vulkan compute shader for CS1230/CS123/Comp175 XML scenes"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render scenes to PNGs, one after the other on one device (the embedded default scene when none is given).
    Render(RenderArgs),
    /// Render on the device and on the CPU build and compare every buffer bit for bit.
    Check(CheckArgs),
    /// Show a scene in a window, refined while still, reloaded when its file or the shaders change.
    Preview(crate::preview::PreviewArgs),
    /// Compare two pictures (say, your render and a course reference): how many
    /// pixels differ by more than a tolerance, the first and the worst.
    Compare(CompareArgs),
    /// Run shader unit tests (tests/shaders/*.toml by default) on the device and the CPU build.
    ShaderTest(crate::harness::cli::ShaderTestArgs),
    /// Follow one sample of one pixel through the shared code (its CPU build), step by step: each ray and what it meets, each light's term and shadow ray, each level's colour and mirror weight.
    // Hidden from its help: the options of the renders it shares that
    // trace refuses (a device's, the AOVs'), which it would list otherwise.
    #[command(
        mut_arg("device", |a| a.hide(true)),
        mut_arg("shaders", |a| a.hide(true)),
        mut_arg("scene_buffers", |a| a.hide(true)),
        mut_arg("validate", |a| a.hide(true)),
        mut_arg("timeout", |a| a.hide(true)),
        mut_arg("aov", |a| a.hide(true)),
        mut_arg("depth_range", |a| a.hide(true)),
        mut_arg("cost_max", |a| a.hide(true))
    )]
    Trace(TraceArgs),
    /// Describe scenes without rendering them: camera, primitives, lights, materials, the world box, each group's hierarchy (nodes, leaves, depth, SAH cost) and buffer sizes
    Info(InfoArgs),
    /// List the Vulkan devices.
    Devices,
    /// Write a scale-test scene: the corpus's recursive spheres, cones or cubes, N levels deep.
    Gen(crate::gen::GenArgs),
    /// Time scenes per backend: median frame time, ray rates, primitives, memory.
    Bench(crate::bench::BenchArgs),
    /// Render every scene of the course's corpus as its official reference was made, and compare under a stated rule.
    Conformance(ConformanceArgs),
    /// Write a scene in POV-Ray 3.7's scene language (masters as declared objects), to time or view it beside POV-Ray.
    Pov(PovArgs),
}

/// The options of every command that renders frames (`render`, `check`,
/// `bench`), the scene aside.
#[derive(Args, Debug)]
pub struct RenderOptions {
    #[arg(long, default_value_t = 512, value_name = "W")]
    pub width: u32,
    #[arg(long, default_value_t = 384, value_name = "H")]
    pub height: u32,
    /// What the picture shows
    #[arg(long, value_enum, default_value_t = Aov::Color)]
    pub aov: Aov,
    /// With `--aov depth`: the distances from the eye drawn white and black
    /// [default: the scene's bounding sphere, nearest to farthest]
    #[arg(long, value_name = "NEAR,FAR", value_parser = parse_depth_range, allow_hyphen_values = true)]
    pub depth_range: Option<[f32; 2]>,
    /// With `--aov cost` or `cost-all`: the passes drawn dark red (and beyond) [default: 64, cost-all 256]
    #[arg(long, value_name = "N")]
    pub cost_max: Option<u32>,
    /// Turn shadow rays off.
    #[arg(long)]
    pub no_shadows: bool,
    /// Turn mirror reflections off.
    #[arg(long)]
    pub no_reflections: bool,
    /// Turn texture mapping off.
    #[arg(long)]
    pub no_textures: bool,
    /// Mirror bounces (at most 16).
    #[arg(long, default_value_t = 4, value_name = "N")]
    pub depth: u32,
    /// Test every primitive for every ray: no bounding volume hierarchy. The
    /// picture is identical; only slower.
    #[arg(long)]
    pub no_bvh: bool,
    /// Samples per pixel, in a fixed pattern (the same on every device and the CPU).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub spp: u32,
    /// How textures are sampled
    #[arg(long, value_enum, default_value_t = TextureFilter::Nearest)]
    pub texture_filter: TextureFilter,
    /// Extra folder to find textures in, after the scene file's folder
    /// (repeatable). Generated scenes (`raycast gen`) name the corpus's
    /// texture: pass the corpus root.
    #[arg(long, value_name = "DIR")]
    pub assets: Vec<PathBuf>,
    /// Refuse scenes that expand to more primitives than this (`bench` lists
    /// them as skipped and goes on).
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N")]
    pub max_primitives: usize,
    #[command(flatten)]
    pub kernel: KernelOptions,
}

/// The device and the kernel of the commands that render on a device
/// (`render`, `check`, `bench`, `conformance`).
#[derive(Args, Debug)]
pub struct KernelOptions {
    /// Vulkan device: an index from `raycast devices` or part of its name.
    #[arg(long, value_name = "NAME|INDEX")]
    pub device: Option<DeviceSelector>,
    /// Compile the device's kernel from DIR/render.comp at start-up instead of
    /// the one built in (the CPU build is always the built-in code).
    #[arg(long, value_name = "DIR")]
    pub shaders: Option<PathBuf>,
    /// Where the device kernel keeps the scene's arrays: storage images and
    /// uniform blocks (render_uniform.comp, several times faster on
    /// lavapipe) when the scene fits them, storage buffers (render.comp, any
    /// size) otherwise; or either one.
    #[arg(long, value_enum, default_value_t = SceneBuffers::Auto)]
    pub scene_buffers: SceneBuffers,
    /// Enable the Khronos validation layer (slow: not for timing); any
    /// message fails the command (exit 3; `conformance`: its case).
    /// Also on when RAYCAST_VALIDATION=1.
    #[arg(long)]
    pub validate: bool,
    /// The longest the device may take over one submission of its work
    /// before the command gives up with an error (a kernel that never ends,
    /// say a shader edit's endless loop). The samples go in submissions of
    /// about a quarter of a second each, so this bounds one sample of the
    /// picture, or of a band of its rows: raise it for a huge or very slow
    /// picture (`--no-bvh` on millions of primitives).
    /// [default: 600]
    #[arg(long, value_name = "SECONDS", value_parser = parse_timeout)]
    pub timeout: Option<Duration>,
}

impl KernelOptions {
    /// `--timeout`, or its default.
    pub fn timeout(&self) -> Duration {
        self.timeout.unwrap_or(crate::gpu::GpuOptions::default().timeout)
    }

    /// The options given that only a Vulkan device uses (by flag), which
    /// the CPU build would ignore: `trace` and `--backend cpu` refuse them.
    fn device_only_given(&self) -> Vec<&'static str> {
        [
            ("--device", self.device.is_some()),
            ("--shaders", self.shaders.is_some()),
            ("--scene-buffers", self.scene_buffers != SceneBuffers::Auto),
            ("--validate", self.validate),
            ("--timeout", self.timeout.is_some()),
        ]
        .into_iter()
        .filter_map(|(flag, given)| given.then_some(flag))
        .collect()
    }

    /// The render kernel on the device these options name (`open_renderer`).
    pub(crate) fn renderer(&self) -> Result<GpuRenderer, Failure> {
        open_renderer(self, self.shaders.as_deref())
    }

    /// Which kernel, for the commands' first line.
    pub(crate) fn kernel_text(&self) -> &'static str {
        if self.shaders.is_some() {
            "the kernel from --shaders"
        } else {
            "the built-in kernel"
        }
    }
}

impl RenderOptions {
    /// The settings these options ask for (checked later: `RenderSettings::validate`).
    pub fn settings(&self) -> RenderSettings {
        RenderSettings {
            width: self.width,
            height: self.height,
            aov: self.aov,
            shadows: !self.no_shadows,
            reflections: !self.no_reflections,
            textures: !self.no_textures,
            max_depth: self.depth,
            bvh: !self.no_bvh,
            spp: self.spp,
            texture_filter: self.texture_filter,
            depth_range: self.depth_range,
            cost_max: self.cost_max,
        }
    }

    /// How the scene files are read: textures looked for in `--assets`,
    /// and not at all under `--no-textures`.
    pub fn parse_options(&self) -> ParseOptions {
        ParseOptions { assets: self.assets.clone(), skip_textures: self.no_textures }
    }
}

/// `--depth-range NEAR,FAR` (checked by `RenderSettings::validate`).
/// `--timeout`: seconds, more than none, at most a week.
pub(crate) fn parse_timeout(s: &str) -> Result<Duration, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 && x <= 604_800.0 => Ok(Duration::from_secs_f64(x)),
        _ => Err(format!("{s:?} is not a number of seconds above 0 and at most 604800 (a week)")),
    }
}

fn parse_depth_range(s: &str) -> Result<[f32; 2], String> {
    let wrong = || format!("{s:?} is not NEAR,FAR (two distances, say 2,12)");
    let (near, far) = s.split_once(',').ok_or_else(wrong)?;
    let parse = |t: &str| {
        let x = t.trim().parse::<f64>().map_err(|_| wrong())?;
        // A distance the picture's 32-bit floats cannot hold is told as written, not as "inf".
        if x.is_finite() && !crate::units::f32_holds(x) {
            return Err(format!("{s:?}: {} is beyond what the renderer's 32-bit floats hold (about 3.4e38)", t.trim()));
        }
        Ok(x as f32)
    };
    Ok([parse(near)?, parse(far)?])
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Scene files (XML), rendered one after the other on one device (its
    /// start-up and each kernel paid once), or generated scenes
    /// (gen:recursive-spheres:6; cones, cubes). Without any, the embedded
    /// default scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    render: RenderOptions,
    /// Output PNG, for one scene [default: <scene name>.png in the current folder]
    #[arg(short, long, value_name = "OUT.png", conflicts_with = "out_dir")]
    output: Option<PathBuf>,
    /// Folder for the pictures, each <scene name>.png (made if missing) [default: the current folder]
    #[arg(long, value_name = "DIR")]
    out_dir: Option<PathBuf>,
    /// Where to run the shared code: a Vulkan device, or its C++ build on every core.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// A turntable: N pictures of each scene, the camera turned 360/N degrees
    /// further each time about the scene's up through the point it looks at
    /// (as the preview's orbit), the first the scene's own camera; each
    /// named as without --orbit with -000, -001, … before `.png`
    #[arg(long, value_name = "N")]
    orbit: Option<u32>,
    /// Keep going: render again whenever a scene file, one of its textures
    /// or the --shaders folder changes (for a picture viewer that reloads
    /// the PNG, say over SSH, where no preview window can open); a failure
    /// is reported and the watch goes on. Ctrl-C stops it.
    #[arg(long)]
    watch: bool,
}

/// A usage error where `output` is one of the files the command reads
/// (`inputs`: the same file, by device and inode, whatever the names say):
/// writing it would replace what it was made from (`render -o` a texture
/// of its scene, `compare -o` one of the pictures compared).
pub(crate) fn refuse_overwriting<'a>(output: &Path, inputs: impl IntoIterator<Item = &'a Path>) -> Result<(), Failure> {
    use std::os::unix::fs::MetadataExt;
    let Ok(out) = std::fs::metadata(output) else { return Ok(()) };
    let same = |input: &Path| std::fs::metadata(input).is_ok_and(|m| (m.dev(), m.ino()) == (out.dev(), out.ino()));
    if !out.is_file() {
        return Ok(()); // a device (/dev/stdout) is no file the command reads
    }
    match inputs.into_iter().find(|input| same(input)) {
        Some(input) => Err(Failure(
            format!(
                "raycast: error: {} would be written over {}, which this command reads: name another file",
                output.display(),
                input.display()
            ),
            2,
        )),
        None => Ok(()),
    }
}

/// Whether a picture can be written to `path` (`image_io`'s checks): a
/// name of another format is a usage error (exit 2), a folder that is not
/// there or takes no file an error (exit 1).
pub(crate) fn check_output(path: &Path) -> Result<(), Failure> {
    image_io::check_output_name(path).map_err(usage_error)?;
    Ok(image_io::check_output_path(path)?)
}

/// Most pictures `render --orbit` takes.
const MAX_ORBIT: u32 = 10_000;

/// `path` with `-NNN` (`index`, as many digits as `count - 1` needs, at
/// least 3) before its extension: `spin.png` → `spin-007.png`.
fn numbered(path: &Path, index: u32, count: u32) -> PathBuf {
    let digits = (count.saturating_sub(1)).to_string().len().max(3);
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let name = match path.extension() {
        Some(ext) => format!("{stem}-{index:0digits$}.{}", ext.to_string_lossy()),
        None => format!("{stem}-{index:0digits$}"),
    };
    path.with_file_name(name)
}

#[derive(Args, Debug)]
struct CheckArgs {
    /// Scene files (XML), checked one after the other on one device and one
    /// CPU build (their start-up and each kernel paid once), or generated
    /// scenes (gen:recursive-spheres:6). Without any, the embedded default
    /// scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    render: RenderOptions,
    /// Where to write the diff image, for one scene [default:
    /// <scene name>-check.png, and only when something differs]: red where
    /// any buffer differs, a dim copy of the device's render elsewhere.
    #[arg(short, long, value_name = "DIFF.png", conflicts_with = "out_dir")]
    output: Option<PathBuf>,
    /// Folder for the diff images, each <scene name>-check.png (made if
    /// missing) [default: the current folder]
    #[arg(long, value_name = "DIR")]
    out_dir: Option<PathBuf>,
    /// Succeed when at most K pixels differ (in each scene). For a GPU whose
    /// driver breaks the kernels' exactness (lavapipe and an NVIDIA H100
    /// keep it: README, "On a GPU too"); the output says the check was not
    /// exact.
    #[arg(long, default_value_t = 0, value_name = "K")]
    allow_pixels: usize,
    /// Also run pixel (X, Y) alone through the shader-test harness:
    /// render_pixel(X, Y) in a one-invocation kernel on the device and in a
    /// C++ build compiled at run time, both from --shaders DIR (or the source
    /// tree's shaders/), compared bit for bit. Tells a difference that
    /// follows the code from one that follows the whole-frame kernel, and
    /// lets instrumentation of DIR run on both sides. Repeatable; one scene.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true)]
    pixel: Vec<(u32, u32)>,
}

pub(crate) fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let parse =
        |t: &str| t.trim().parse::<u32>().map_err(|_| format!("{s:?} is not X,Y (two whole numbers, say 29,4)"));
    match s.split_once(',') {
        Some((x, y)) => Ok((parse(x)?, parse(y)?)),
        None => Err(format!("{s:?} is not X,Y (two whole numbers, say 29,4)")),
    }
}

#[derive(Args, Debug)]
struct TraceArgs {
    /// A scene file (XML) or a generated scene (gen:FAMILY:DEPTH). Without one, the embedded default scene.
    #[arg(value_name = "SCENE")]
    scene: Option<PathBuf>,
    /// The pixel: X columns from the left, Y rows from the top.
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true)]
    pixel: (u32, u32),
    /// Which of the pixel's `--spp` samples (0 is the pixel centre when there is one).
    #[arg(long, default_value_t = 0, value_name = "S")]
    sample: u32,
    /// One JSON object instead of text: the pixel, the sample, every step with its numbers as computed (floats in
    /// shortest round-trip digits) and, at one sample a pixel, the render's pixel and whether the trace agrees with it.
    #[arg(long)]
    json: bool,
    /// The picture's settings, as `render` takes them (the colour only; the CPU build traces).
    #[command(flatten)]
    render: RenderOptions,
}

#[derive(Args, Debug)]
struct InfoArgs {
    /// Scene files (XML) or generated scenes (gen:FAMILY:DEPTH). Without any, the embedded default scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<String>,
    /// Extra folder to find textures in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR")]
    assets: Vec<PathBuf>,
    /// Refuse scenes that expand to more primitives than this.
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N")]
    max_primitives: usize,
    /// One JSON object a line, a scene each, instead of text.
    #[arg(long)]
    json: bool,
}

/// `raycast trace`: the steps of one sample of one pixel (crate::trace),
/// from the CPU build; at one sample a pixel, checked against the render of
/// that pixel (its 8-bit colour, its rays, and its first hit).
fn trace(args: &TraceArgs) -> Result<(), Failure> {
    let o = &args.render;
    let k = &o.kernel;
    let given = k.device_only_given();
    if !given.is_empty() {
        return Err(Failure(
            format!(
                "raycast: error: trace runs the CPU build of the shared code: {} {} for the commands that render on a \
                 device (`raycast check --pixel X,Y` runs one pixel on both)",
                crate::units::listed(&given, "and"),
                if given.len() == 1 { "is" } else { "are" }
            ),
            2,
        ));
    }
    if o.aov != Aov::Color {
        return Err(Failure(
            "raycast: error: trace follows the colour's rays; --aov is for render and check".to_string(),
            2,
        ));
    }
    // Usage errors before any work (the picture's size and samples are the options').
    o.settings().validate().map_err(usage_error)?;
    let (x, y) = args.pixel;
    if x >= o.width || y >= o.height {
        return Err(usage_error(format!("--pixel {x},{y} is outside the {}x{} picture", o.width, o.height)));
    }
    if args.sample >= o.spp.max(1) {
        return Err(usage_error(format!(
            "--sample {} is not one of the pixel's {} (0 to {})",
            args.sample,
            o.spp.max(1),
            o.spp.max(1) - 1
        )));
    }
    let p = prepare(args.scene.as_deref(), o)?;
    if !args.json {
        print_scene(&p);
    }
    let cpu = CpuRenderer::new()?;
    let steps =
        cpu.trace(&p.data, &p.data.frame, x, y, args.sample).map_err(|e| Failure(format!("raycast: error: {e}"), 1))?;
    let spp = p.data.frame.spp.max(1);
    // At one sample a pixel, the render's pixel: the same 8-bit colour, rays and first hit.
    let render = (spp == 1).then(|| cpu.render_rows(&p.data, &[y])[0][x as usize]);
    let rays = steps.iter().filter(|s| s.is_ray()).count();
    let first = steps.iter().find(|s| s.kind == layout::TRACE_CAMERA);
    let colour = steps.iter().find(|s| s.kind == layout::TRACE_PIXEL).map(|s| s.id);
    let agrees = |pixel: &layout::PixelOut| {
        colour == Some(pixel.rgba)
            && rays == pixel.rays as usize
            && first.is_some_and(|c| {
                c.id == pixel.id && (c.id == layout::NO_HIT || c.value[3].to_bits() == pixel.t.to_bits())
            })
    };
    if args.json {
        let render_json = render.map_or("null".to_string(), |pixel| {
            format!(
                "{{\"rgba8\":[{}],\"rays\":{},\"agrees\":{}}}",
                pixel.rgba.to_le_bytes().map(|c| c.to_string()).join(","),
                pixel.rays,
                agrees(&pixel)
            )
        });
        crate::emit_line(&format!(
            "{{\"scene\":{},\"pixel\":[{x},{y}],\"sample\":{},\"spp\":{spp},\"rays\":{rays},\"steps\":[{}],\"render\":{render_json}}}",
            crate::units::json_str(&args.scene.as_deref().map_or(DEFAULT_SCENE_NAME.to_string(), |s| s.display().to_string())),
            args.sample,
            crate::trace::json(&p.scene, &steps).join(",")
        ))?;
    } else {
        outln!("pixel ({x}, {y}), sample {} of {spp}:", args.sample);
        for line in crate::trace::describe(&p.scene, &steps) {
            outln!("{line}");
        }
        if spp > 1 {
            outln!("(the pixel is the mean of its {spp} samples: `--sample S` traces another)");
        }
    }
    let Some(pixel) = render else { return Ok(()) };
    if !agrees(&pixel) {
        return Err(Failure(
            format!(
                "raycast: error: the trace and the render of pixel ({x}, {y}) disagree: render RGBA {:#010x}, {} rays, id {}; \
                 trace {:?}, {rays} rays, first hit {:?}",
                pixel.rgba,
                pixel.rays,
                pixel.id,
                colour,
                first.map(|c| c.id)
            ),
            1,
        ));
    }
    if !args.json {
        outln!("the render's pixel: the same 8-bit colour, {rays} rays and first hit");
    }
    Ok(())
}

/// `raycast info`: each scene loaded and packed as a default render packs
/// it, and described. A scene that fails is reported and the others go on;
/// the command then fails naming it.
fn info(args: &InfoArgs) -> Result<(), Failure> {
    let names = scene_names(&args.scenes);
    let parse = ParseOptions { assets: args.assets.clone(), ..ParseOptions::default() };
    let limits = FlattenLimits { max_primitives: args.max_primitives };
    let batch = each_named(&names, scene_label, |name| {
        let label = scene_label(name);
        // Warnings on stderr as every command prints them; the notes are in the description.
        let described = load_scene(name.map(Path::new), &parse, &limits).and_then(|scene| {
            let data = crate::info::pack(&scene)?;
            Ok(crate::info::Info::of(&label, &scene, &data))
        });
        Ok(match described {
            Ok(info) if args.json => Ok(crate::emit_line(&info.json())?),
            Ok(info) => {
                out!("{}", info.text());
                Ok(())
            }
            Err(e) => Err(scene_failure(e)),
        })
    })?;
    batch.failure("").map_or(Ok(()), Err)
}

#[derive(Args, Debug)]
struct ConformanceArgs {
    /// The cs1230 corpus: its scene folders (test_unit, test_intersect, …)
    /// and bench/ of official renders [default: $RAYCAST_CORPUS]
    #[arg(value_name = "CORPUS")]
    corpus: Option<PathBuf>,
    /// Folder for each failing case's actual / expected / diff pictures and
    /// for table.md, the measured fractions (made if missing).
    #[arg(long, value_name = "DIR", default_value = "conformance")]
    out_dir: PathBuf,
    /// Where to run the shared code: a Vulkan device, or its C++ build on every core.
    #[arg(long, value_enum, default_value_t = Backend::Gpu)]
    backend: Backend,
    /// The device and its kernel (`--shaders DIR`: does a shader change still match the course's renders?).
    #[command(flatten)]
    kernel: KernelOptions,
    /// Only the cases whose name holds TEXT (`test_light/`, `Normal`,
    /// `recursiveSpheres4 Color`); repeatable, a case runs if any matches.
    #[arg(long, value_name = "TEXT")]
    only: Vec<String>,
}

#[derive(Args, Debug)]
struct CompareArgs {
    /// The picture to judge (PNG, JPEG, BMP or PNM, told by its content).
    actual: PathBuf,
    /// The picture it should match (PNG, JPEG, BMP or PNM).
    expected: PathBuf,
    /// A pixel differs when a colour channel (red, green or blue, at 8 bits;
    /// alpha is not compared) is off by more than this (0 to 255).
    #[arg(long, default_value_t = 2, value_name = "N")]
    tolerance: u8,
    /// Fail (exit 4) when more than this percentage of pixels differ.
    #[arg(long, default_value_t = 0.1, value_name = "PERCENT")]
    max_percent: f64,
    /// Where to write the diff image (red where pixels differ).
    #[arg(short, long, value_name = "DIFF.png")]
    output: Option<PathBuf>,
    /// One JSON object instead of text (for graders): the two files, the counts, the first and worst pixel, the
    /// rule (--tolerance, --max-percent) and whether the pictures pass it; the exit status is the same.
    #[arg(long)]
    json: bool,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, ValueEnum)]
pub enum Backend {
    /// A Vulkan device (--device, or the best one).
    Gpu,
    /// The C++ build of the shared GLSL on every core.
    Cpu,
    /// The device, unless it runs on the CPU (lavapipe) and nothing asks for the device (--device, --shaders; and
    /// for render, check, bench and conformance --scene-buffers, --validate, --timeout), or none opens and no
    /// --device is given (not the preview, which needs Vulkan for its window): then the CPU build.
    Auto,
}

/// A failure to report: the message and the exit code.
pub(crate) struct Failure(pub(crate) String, pub(crate) u8);

impl<E: std::fmt::Display> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure(format!("raycast: error: {e}"), 1)
    }
}

/// A flag's value out of range (frame::SettingsError and the like): a usage
/// error, exit 2, as clap's own.
pub(crate) fn usage_error(e: impl std::fmt::Display) -> Failure {
    Failure(format!("raycast: error: {e}"), 2)
}

/// A scene error: it already reads `file:line:col: error: …`.
pub(crate) fn scene_failure(e: String) -> Failure {
    Failure(e, 1)
}

pub fn main() -> ExitCode {
    crate::gpu::prepare_process();
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            // --help and --version print and succeed; usage errors exit 2.
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    let result = match cli.command {
        Command::Render(args) => render(&args),
        Command::Check(args) => check(&args),
        Command::Compare(args) => compare(&args),
        Command::Preview(args) => crate::preview::run(&args),
        Command::Info(args) => info(&args),
        Command::Trace(args) => trace(&args),
        Command::Devices => devices(),
        Command::ShaderTest(args) => crate::harness::cli::run(&args).map_err(|(message, code)| Failure(message, code)),
        Command::Gen(args) => crate::gen::run(&args),
        Command::Bench(args) => crate::bench::run(&args),
        Command::Conformance(args) => conformance(&args),
        Command::Pov(args) => pov(&args),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure(message, code)) => {
            errln!("{message}");
            if crate::gpu::device_left_running() {
                end_now(code);
            }
            ExitCode::from(code)
        }
    }
}

/// Ends the process at once with `code`, without the clean-up at exit: a
/// device was left running work that outlived its timeout
/// (`gpu::device_left_running`), and Mesa's clean-up at exit joins its
/// worker threads, one of which runs that work for ever.
fn end_now(code: u8) -> ! {
    use std::io::Write as _;
    let _ = std::io::stdout().flush();
    let _ = std::io::stderr().flush();
    extern "C" {
        fn _exit(status: i32) -> !;
    }
    // SAFETY: _exit (POSIX) ends the process; the buffered output is flushed above.
    unsafe { _exit(i32::from(code)) }
}

pub(crate) fn validation_wanted(flag: bool) -> bool {
    flag || std::env::var("RAYCAST_VALIDATION").is_ok_and(|v| v == "1")
}

/// Fails with exit code 3 if the validation layer said anything.
pub(crate) fn check_validation(messages: Vec<String>) -> Result<(), Failure> {
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        errln!("raycast: validation: {m}");
    }
    Err(Failure(format!("raycast: error: the Vulkan validation layer reported {} message(s)", messages.len()), 3))
}

fn devices() -> Result<(), Failure> {
    // The CPU build renders without Vulkan: its line comes whatever the driver says.
    let cpu_line = || {
        let (threads, cpu) = (crate::cpu::host_threads(), crate::cpu::host_cpu());
        outln!("cpu: the CPU build (--backend cpu), {threads} threads on {cpu}");
    };
    let (list, default) = match gpu::list_devices_with_default() {
        Ok(found) => found,
        Err(e) => {
            cpu_line();
            return Err(e.into());
        }
    };
    for d in &list {
        outln!("{}: {} ({}, Vulkan {}, driver {})", d.index, d.name, d.kind, d.api_version, d.driver);
        outln!("   arithmetic: {}", d.arithmetic);
        if d.corrects_division {
            outln!("   {}", division_line(d.index));
        }
        if d.shader_objects {
            let kept = match gpu::cache_dir() {
                Some(dir) => format!("their binaries kept in {}", dir.display()),
                None => "no cache folder to keep their binaries in (set RAYCAST_CACHE_DIR)".to_string(),
            };
            let validated = match (&d.validation_layer, d.shader_objects_validated) {
                (Some(layer), true) => format!("with validation too (the validation layer, {layer}, knows them)"),
                (Some(layer), false) => {
                    format!("pipelines with validation (the validation layer, {layer}, predates them)")
                }
                (None, _) => "no validation layer installed".to_string(),
            };
            outln!("   kernels: shader objects (VK_EXT_shader_object), {kept}; {validated}; pipelines with RAYCAST_SHADER_OBJECTS=0");
        }
        if d.specialises_ahead {
            let kept = match gpu::cache_dir() {
                Some(dir) => format!("the results kept in {}", dir.display()),
                None => "the results not kept: no cache folder (set RAYCAST_CACHE_DIR)".to_string(),
            };
            outln!("   pipelines: specialised ahead of the driver by spirv-opt, {kept}; by the driver with RAYCAST_SPECIALIZE=0");
        }
        if let Some(why) = crate::preview::window_refuses(d) {
            outln!(
                "   preview: cannot present to this display ({why}); `raycast preview` draws here and a device that \
                 can present shows the pixels (--window-device)"
            );
        }
    }
    if let Some(d) = list.get(default) {
        // As open_backend decides for --backend auto.
        let auto =
            if d.runs_on_cpu() { "the CPU build instead, as this device runs on the CPU" } else { "this device" };
        outln!("default: device {} (without --device); --backend auto renders with {auto}", d.index);
    }
    cpu_line();
    Ok(())
}

/// How device `index`'s kernels take the residuals of their division
/// correction, which the fma probe decides once the device is open
/// (`GpuContext::division`).
fn division_line(index: usize) -> String {
    let ctx =
        match gpu::GpuContext::new(&GpuOptions { device: Some(DeviceSelector::Index(index)), ..Default::default() }) {
            Ok(ctx) => ctx,
            Err(e) => return format!("division correction: residuals not known, the device does not open ({e})"),
        };
    let why = |probe: &str| match gpu::forced_residuals() {
        Some(_) => "as RAYCAST_FMA_RESIDUALS says".to_string(),
        None => format!("the fma probe saw this device's fma() {probe}"),
    };
    match ctx.division() {
        gpu::Division::CorrectedFma => format!("division correction: residuals by fma() ({})", why("round once")),
        _ => format!("division correction: residuals by Dekker's exact product ({})", why("round more than once")),
    }
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// `path` as a generated scene's name (`gen:FAMILY:DEPTH`), where no file
/// has that name: a file of that name wins.
fn generated_name(path: &Path) -> Option<&str> {
    Some(path).filter(|p| !p.exists()).and_then(Path::to_str).filter(|n| crate::gen::parse_scene_name(n).is_some())
}

/// Loads the scene file, or the embedded default scene when `path` is None,
/// or a generated one (`gen:FAMILY:DEPTH`, as `bench` and `info` take it)
/// where no file has that name. Prints the scene's warnings to stderr.
pub fn load_scene(path: Option<&Path>, opts: &ParseOptions, limits: &FlattenLimits) -> Result<Scene, String> {
    Ok(load_scene_file(path, opts, limits)?.1)
}

/// [`load_scene`], with the file as parsed (its masters kept as masters).
fn load_scene_file(
    path: Option<&Path>,
    opts: &ParseOptions,
    limits: &FlattenLimits,
) -> Result<(scene::SceneFile, Scene), String> {
    let file = match (path, path.and_then(generated_name)) {
        (Some(p), None) => scene::parse_file(p, opts).map_err(|e| e.to_string())?,
        // The embedded default scene (None) or the generated one.
        (_, name) => crate::bench::parse_scene(name, opts)?,
    };
    let scene = scene::flatten(&file, limits).map_err(|e| e.to_string())?;
    for line in scene::warning_lines(&scene.warnings) {
        errln!("{line}");
    }
    Ok((file, scene))
}

#[derive(Args, Debug)]
struct PovArgs {
    /// A scene file (XML) or a generated scene (gen:FAMILY:DEPTH) [default: the embedded default scene].
    #[arg(value_name = "SCENE")]
    scene: Option<String>,
    /// Write the POV-Ray scene to FILE [default: standard output].
    #[arg(short, long, value_name = "FILE")]
    output: Option<PathBuf>,
    /// Extra folder to find textures in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR")]
    assets: Vec<PathBuf>,
    /// The picture's width, for the camera's film and the command line in the file's head.
    #[arg(long, default_value_t = 512, value_name = "W")]
    width: u32,
    /// The picture's height.
    #[arg(long, default_value_t = 384, value_name = "H")]
    height: u32,
    /// Lights that cast no shadows (`shadowless`), as `render --no-shadows`.
    #[arg(long)]
    no_shadows: bool,
    /// No mirror reflections, as `render --no-reflections`.
    #[arg(long)]
    no_reflections: bool,
    /// No textures, as `render --no-textures`.
    #[arg(long)]
    no_textures: bool,
    /// Mirror bounces (POV-Ray's max_trace_level is one more: it counts the camera ray).
    #[arg(long, default_value_t = 4, value_name = "N")]
    depth: u32,
}

/// `raycast pov`: the scene, checked as `render` checks it (its warnings on
/// stderr, its errors located), written in POV-Ray's language (crate::pov);
/// what POV-Ray draws otherwise said as notes.
fn pov(args: &PovArgs) -> Result<(), Failure> {
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        shadows: !args.no_shadows,
        reflections: !args.no_reflections,
        textures: !args.no_textures,
        max_depth: args.depth,
        ..RenderSettings::default()
    };
    settings.validate().map_err(usage_error)?;
    let name = args.scene.as_deref();
    if let Some(out) = &args.output {
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("pov")) {
            return Err(usage_error(format!("{}: a POV-Ray scene is written to a .pov file", out.display())));
        }
        refuse_overwriting(out, name.map(Path::new))?;
    }
    let parse = ParseOptions { assets: args.assets.clone(), skip_textures: args.no_textures };
    let (file, _) = load_scene_file(name.map(Path::new), &parse, &FlattenLimits::default()).map_err(scene_failure)?;
    let export = crate::pov::export(&file, &settings, &scene_label(name));
    for note in &export.notes {
        errln!("raycast: note: POV-Ray draws this otherwise: {note}");
    }
    match &args.output {
        None => crate::emit(&export.sdl).map_err(|e| format!("cannot write the scene to standard output: {e}"))?,
        Some(path) => {
            crate::write_whole(path, export.sdl.as_bytes())?;
            errln!(
                "wrote {} ({} bytes); render it with: {}",
                path.display(),
                export.sdl.len(),
                crate::pov::povray_command(
                    &path.display().to_string(),
                    &path.with_extension("png").display().to_string(),
                    &settings,
                    crate::cpu::host_threads()
                )
            );
        }
    }
    Ok(())
}

/// A scene loaded and packed for rendering, with what it took.
struct Prepared {
    scene: Scene,
    data: FrameData,
    load: Duration,
}

/// `scene` (None: the embedded default scene) loaded and packed as `o` asks.
fn prepare(scene: Option<&Path>, o: &RenderOptions) -> Result<Prepared, Failure> {
    let settings = o.settings();
    settings.validate().map_err(usage_error)?;
    let start = Instant::now();
    let parse = o.parse_options();
    let scene =
        load_scene(scene, &parse, &FlattenLimits { max_primitives: o.max_primitives }).map_err(scene_failure)?;
    let data = frame::build(&scene, &settings).map_err(scene_failure)?;
    for note in &data.notes {
        errln!("raycast: note: {note}");
    }
    Ok(Prepared { scene, data, load: start.elapsed() })
}

/// `<scene stem><suffix>.png` ("default" for the embedded scene) in `dir`,
/// or in the current folder.
fn default_output(scene: Option<&Path>, suffix: &str, dir: Option<&Path>) -> PathBuf {
    let stem = scene.and_then(|s| s.file_stem()).map(|s| s.to_string_lossy().into_owned());
    // gen:recursive-spheres:6 → recursive-spheres-6.
    let stem = stem.map(|s| s.strip_prefix("gen:").map_or(s.clone(), |g| g.replace(':', "-")));
    let name = format!("{}{suffix}.png", stem.as_deref().unwrap_or("default"));
    dir.map_or_else(|| PathBuf::from(&name), |d| d.join(&name))
}

/// The render kernel on the device `--device` names (validated where
/// asked, with `--timeout`), built in or compiled from `shaders`, reading
/// the scene as `--scene-buffers` says: for `render`, `check` and `bench`.
pub(crate) fn open_renderer(k: &KernelOptions, shaders: Option<&Path>) -> Result<GpuRenderer, Failure> {
    let options =
        GpuOptions { device: k.device.clone(), validation: validation_wanted(k.validate), timeout: k.timeout() };
    let mut renderer = match shaders {
        Some(dir) => GpuRenderer::from_shaders(&options, dir)?,
        None => GpuRenderer::new(&options)?,
    };
    renderer.set_scene_buffers(k.scene_buffers);
    Ok(renderer)
}

fn print_scene(p: &Prepared) {
    outln!(
        "scene: {} ({} primitives, {} unique in {} groups, {} lights; hierarchy built in {})",
        p.scene.path.display(),
        p.data.expanded,
        p.data.primitives.len(),
        p.data.groups,
        p.data.lights.len(),
        ms(p.data.build_time)
    );
}

/// Which kernel drew `data`, and what its specialization kept of the shaders.
fn print_kernel(renderer: &GpuRenderer, data: &FrameData) -> Result<(), Failure> {
    let kernel = renderer.kernel_for(data)?;
    let spec = crate::render::Specialization::of(data, &data.frame);
    // The device's division and square root corrected (raycast.glsl div_rn).
    let corrected = renderer.context().division().describe();
    // A shader object (compiled, or from the binary a run before kept), or a pipeline specialised ahead.
    let how = kernel.how_built().map(|h| format!(" ({h})")).unwrap_or_default();
    outln!("kernel: {}{corrected}{how}, specialised for the scene: {}", kernel.name(), spec.describe());
    Ok(())
}

/// The rate line, and with the cost AOV what the walks took.
fn print_rates(data: &FrameData, picture: &Picture, time: Duration) {
    outln!("{}", rate_line(data, picture, time));
    let what = match data.frame.aov {
        layout::AOV_COST => "a camera ray's walk takes",
        layout::AOV_COST_ALL => "a pixel's rays walk",
        _ => return,
    };
    outln!("{}", picture.passes_text(what));
    // A scale far above the picture's passes leaves it all dark blue: say what would spread it.
    let scale = data.frame.aov_scale[2];
    let most = picture.most_passes().map_or(0, |(_, n)| n) as f32;
    if most > 0.0 && most * 2.0 <= scale {
        outln!("cost: drawn dark red at {scale} passes (--cost-max), twice the most here or more: --cost-max {most} spreads the colours over this picture");
    }
}

/// Camera rays (width x height x spp) and every ray the pixels counted, per second of `time`.
fn rate_line(data: &FrameData, picture: &Picture, time: Duration) -> String {
    let f = &data.frame;
    let primary = u64::from(f.width) * u64::from(f.height) * u64::from(f.spp.max(1));
    let all = picture.rays();
    let per_s = |n: u64| n as f64 / time.as_secs_f64().max(1e-9) / 1e6;
    format!(
        "rate: {:.2} M primary rays/s, {:.2} M rays/s in all ({primary} camera rays, {all} in all, in {})",
        per_s(primary),
        per_s(all),
        ms(time)
    )
}

fn write_picture(path: &Path, picture: &Picture) -> Result<(), Failure> {
    let image = Rgb8 { width: picture.width, height: picture.height, data: picture.rgb8()? };
    image_io::write_png(path, &image)?;
    outln!("wrote {} ({}x{})", path.display(), picture.width, picture.height);
    Ok(())
}

/// The scenes a command was given: each path, or None for the embedded default scene.
fn scene_list(scenes: &[PathBuf]) -> Vec<Option<&Path>> {
    if scenes.is_empty() {
        vec![None]
    } else {
        scenes.iter().map(|s| Some(s.as_path())).collect()
    }
}

/// A scene as the command's messages name it.
fn scene_name(scene: Option<&Path>) -> String {
    scene.map_or("the default scene".to_string(), |s| s.display().to_string())
}

/// Where each scene's picture goes (`render`: `<scene name>.png`; `check`:
/// `<scene name>-check.png`, its diff image): `-o` for one scene, else in
/// `--out-dir` (made here) or the current folder. Checked before any work:
/// -o with several scenes, a path that cannot be written, two scenes
/// writing one file.
fn output_paths(
    output: &Option<PathBuf>,
    out_dir: &Option<PathBuf>,
    suffix: &str,
    scenes: &[Option<&Path>],
) -> Result<Vec<PathBuf>, Failure> {
    if output.is_some() && scenes.len() > 1 {
        return Err(Failure(
            format!(
                "raycast: error: -o names one picture, but {} scenes were given: use --out-dir DIR (each picture <scene name>{suffix}.png)",
                scenes.len()
            ),
            2,
        ));
    }
    if let Some(dir) = out_dir {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot make the folder {} (--out-dir): {e}", dir.display()))?;
    }
    let outputs: Vec<PathBuf> = scenes
        .iter()
        .map(|scene| output.clone().unwrap_or_else(|| default_output(*scene, suffix, out_dir.as_deref())))
        .collect();
    for (i, path) in outputs.iter().enumerate() {
        check_output(path)?;
        if let Some(j) = outputs[..i].iter().position(|earlier| earlier == path) {
            return Err(Failure(
                format!(
                    "raycast: error: {} and {} would both be written to {}: give them in separate commands, or rename one",
                    scene_name(scenes[j]),
                    scene_name(scenes[i]),
                    path.display()
                ),
                2,
            ));
        }
    }
    Ok(outputs)
}

/// What came of the scenes of a command that takes several (`each_scene`).
pub(crate) struct Batch<T> {
    /// Each scene that went through, by name, with what it gave.
    done: Vec<(String, T)>,
    /// The scenes that failed (already reported), by name.
    failed: Vec<String>,
}

impl<T> Batch<T> {
    /// `K of N scenes failed: …` (exit 1), with `also` added, where any failed.
    pub(crate) fn failure(&self, also: &str) -> Option<Failure> {
        let n = self.done.len() + self.failed.len();
        (!self.failed.is_empty()).then(|| {
            Failure(
                format!("raycast: error: {} of {n} scenes failed: {}{also}", self.failed.len(), self.failed.join(", ")),
                1,
            )
        })
    }
}

/// Each of `scenes` loaded as `o` asks and given to `each` with its output
/// path, on the backend that `open` makes for the first scene that loads
/// (kept in `backend`; its failure ends the command). One scene's failure
/// ends the command as it always did; of several, a scene that fails is
/// reported and named in the batch, and the others go on.
fn each_scene<B, T>(
    scenes: &[Option<&Path>],
    outputs: &[PathBuf],
    o: &RenderOptions,
    backend: &mut Option<B>,
    open: impl Fn() -> Result<B, Failure>,
    mut each: impl FnMut(&B, Prepared, &Path) -> Result<T, Failure>,
) -> Result<Batch<T>, Failure> {
    let pairs: Vec<(Option<&Path>, &Path)> = scenes.iter().copied().zip(outputs.iter().map(PathBuf::as_path)).collect();
    each_named(
        &pairs,
        |(scene, _)| scene_name(scene),
        |(scene, output)| {
            let prepared = prepare(scene, o).and_then(|p| {
                refuse_overwriting(
                    output,
                    scene.into_iter().chain(p.scene.texture_files().iter().map(PathBuf::as_path)),
                )?;
                Ok(p)
            });
            Ok(match prepared {
                Ok(p) => {
                    if backend.is_none() {
                        // The backend's failure ends the command.
                        *backend = Some(open()?);
                    }
                    each(backend.as_ref().expect("opened above"), p, output)
                }
                Err(e) => Err(e),
            })
        },
    )
}

/// The scenes named on a command line as `bench`, `info` and `bench
/// --versus` take them (a file or a generated scene's name), None (the
/// embedded default scene) where none is.
pub(crate) fn scene_names(scenes: &[String]) -> Vec<Option<&str>> {
    if scenes.is_empty() {
        vec![None]
    } else {
        scenes.iter().map(|s| Some(s.as_str())).collect()
    }
}

/// A scene of `scene_names` as batch reports name it.
pub(crate) fn scene_label(name: Option<&str>) -> String {
    name.unwrap_or(DEFAULT_SCENE_NAME).to_string()
}

/// Each of `names` given to `one`, whose inner result is that one's (a
/// failure of its own) and whose outer error ends the command (a device
/// that does not open). Of several, one that fails is reported on stderr
/// as it happens and named in the batch while the others go on; one alone
/// ends the command with its error. `render`, `check`, `bench` and
/// `bench --versus` (`name` says how each is named).
pub(crate) fn each_named<N: Copy, T>(
    names: &[N],
    name: impl Fn(N) -> String,
    mut one: impl FnMut(N) -> Result<Result<T, Failure>, Failure>,
) -> Result<Batch<T>, Failure> {
    let mut batch = Batch { done: Vec::new(), failed: Vec::new() };
    for &n in names {
        match one(n)? {
            Ok(t) => batch.done.push((name(n), t)),
            Err(e) if names.len() == 1 => return Err(e),
            Err(Failure(message, _)) => {
                errln!("{message}");
                batch.failed.push(name(n));
            }
        }
    }
    Ok(batch)
}

/// Where `render` runs its scenes: opened once, for the first scene that loads.
enum RenderBackend {
    Cpu(CpuRenderer),
    Gpu(GpuRenderer),
}

/// `--backend cpu` with options only a Vulkan device uses (`--device`,
/// `--scene-buffers`, `--validate`, `--timeout`; `--shaders` with its own
/// message): a usage error, as the CPU build would silently ignore them.
pub(crate) fn cpu_takes_no_device_options(cpu_only: bool, k: &KernelOptions) -> Result<(), Failure> {
    cpu_takes_no_shaders(cpu_only, &k.shaders)?;
    let given = k.device_only_given();
    if !cpu_only || given.is_empty() {
        return Ok(());
    }
    Err(Failure(
        format!(
            "raycast: error: {} {} for a Vulkan device, and --backend cpu runs the CPU build without one: drop {}, or \
             the --backend cpu",
            crate::units::listed(&given, "and"),
            if given.len() == 1 { "is" } else { "are" },
            if given.len() == 1 { "it" } else { "them" }
        ),
        2,
    ))
}

/// `--shaders DIR` with `--backend cpu`: a usage error, since the CPU build
/// is the code raycast was built with and would silently ignore DIR.
pub(crate) fn cpu_takes_no_shaders(cpu_only: bool, shaders: &Option<PathBuf>) -> Result<(), Failure> {
    match (cpu_only, shaders) {
        (true, Some(dir)) => Err(Failure(
            format!(
                "raycast: error: --shaders {} compiles the device's kernel, but --backend cpu runs the CPU build raycast was \
                 built with: drop one (rebuild raycast to put a shader change into the CPU build)",
                dir.display()
            ),
            2,
        )),
        _ => Ok(()),
    }
}

fn render(args: &RenderArgs) -> Result<(), Failure> {
    cpu_takes_no_device_options(args.backend == Backend::Cpu, &args.render.kernel)?;
    if let Some(n) = args.orbit.filter(|n| !(1..=MAX_ORBIT).contains(n)) {
        return Err(Failure(format!("raycast: error: --orbit {n} is out of range: 1 to {MAX_ORBIT} pictures"), 2));
    }
    let scenes = scene_list(&args.scenes);
    let outputs = output_paths(&args.output, &args.out_dir, "", &scenes)?;
    if let (Some(n), Some(device)) = (args.orbit, args.output.as_ref().filter(|o| image_io::not_a_file(o))) {
        // Numbered names beside a device would be new files in its folder (/dev/stdout-000.png).
        return Err(Failure(
            format!(
                "raycast: error: --orbit {n} writes {n} pictures, each named as -o's file with -000, -001, … before \
                 .png, and {} is not a file: name a file, or use --out-dir DIR",
                device.display()
            ),
            2,
        ));
    }
    status_beside(&args.output);
    let mut backend: Option<RenderBackend> = None;
    // The textures the scenes loaded use (what --watch follows beside them).
    let textures: std::cell::RefCell<Vec<PathBuf>> = Default::default();
    let round = |backend: &mut Option<RenderBackend>| {
        textures.borrow_mut().clear();
        let batch = render_scenes(args, &scenes, &outputs, backend, &textures);
        batch.and_then(|batch| batch.failure("").map_or(Ok(()), Err))
    };
    if !args.watch {
        let result = round(&mut backend);
        return finish_render(backend, result);
    }
    // Followed: the scene files, their textures, the shader folder's sources.
    let files: Vec<PathBuf> =
        scenes.iter().flatten().filter(|p| generated_name(p).is_none()).map(|p| p.to_path_buf()).collect();
    if files.is_empty() && args.render.kernel.shaders.is_none() {
        return Err(Failure(
            "raycast: error: --watch follows scene files and a --shaders folder, and this render has neither (the \
             embedded default scene or generated ones only)"
                .into(),
            2,
        ));
    }
    watch_renders(args, &files, &mut backend, &textures, round)
}

/// `render --watch`: a round of renders (`round`), then, each time one of
/// the files followed changes (`files`, the textures the last round used,
/// the --shaders folder's sources), says which and renders again; a
/// round's failure is reported and the watch goes on. Ends only with the
/// process (Ctrl-C).
fn watch_renders(
    args: &RenderArgs,
    files: &[PathBuf],
    backend: &mut Option<RenderBackend>,
    textures: &std::cell::RefCell<Vec<PathBuf>>,
    round: impl Fn(&mut Option<RenderBackend>) -> Result<(), Failure>,
) -> Result<(), Failure> {
    let shaders = args.render.kernel.shaders.as_deref();
    let watched = || {
        let mut stamps = shaders.map(crate::preview::shader_stamps).unwrap_or_default();
        stamps.extend(crate::preview::stamps(files));
        stamps.extend(crate::preview::stamps(textures.borrow().iter()));
        stamps
    };
    let mut before = watched();
    loop {
        let result = round(backend);
        // The files the round used: one newly named (a texture) with its stamp
        // as it is now, one no longer named dropped; the others as before the round.
        let after = watched();
        before.retain(|path, _| after.contains_key(path));
        for (path, stamp) in after {
            before.entry(path).or_insert(stamp);
        }
        if let Err(Failure(message, _)) = result {
            errln!("{message}");
        }
        if let Some(RenderBackend::Gpu(renderer)) = backend.as_ref() {
            for m in renderer.context().take_validation_messages() {
                errln!("raycast: validation: {m}");
            }
        }
        let n = before.len();
        outln!("watching {n} file{} for changes (Ctrl-C stops)", if n == 1 { "" } else { "s" });
        let changed = next_change(&mut before, watched);
        let names: Vec<String> = changed.iter().map(|p| p.display().to_string()).collect();
        outln!("changed: {}", names.join(", "));
        if shaders.is_some_and(|dir| changed.iter().any(|c| c.starts_with(dir))) {
            // The kernel from --shaders DIR is compiled as the device opens.
            *backend = None;
        }
    }
}

/// Polls `watched` until its stamps differ from `before` and hold still for
/// one more poll (an editor's save can be several writes); returns the paths
/// whose stamps changed, `before` updated to the new stamps.
fn next_change<S: PartialEq + Clone>(
    before: &mut std::collections::BTreeMap<PathBuf, S>,
    watched: impl Fn() -> std::collections::BTreeMap<PathBuf, S>,
) -> Vec<PathBuf> {
    loop {
        std::thread::sleep(crate::preview::POLL);
        if watched() == *before {
            continue;
        }
        std::thread::sleep(crate::preview::POLL);
        let now = watched();
        let paths: Vec<PathBuf> =
            now.iter().filter(|(path, stamp)| before.get(*path) != Some(stamp)).map(|(path, _)| path.clone()).collect();
        *before = now;
        if !paths.is_empty() {
            return paths;
        }
    }
}

/// One round of `render`: every scene, on `backend` (opened for the first
/// that loads), each scene's textures noted in `textures`.
fn render_scenes(
    args: &RenderArgs,
    scenes: &[Option<&Path>],
    outputs: &[PathBuf],
    backend: &mut Option<RenderBackend>,
    textures: &std::cell::RefCell<Vec<PathBuf>>,
) -> Result<Batch<()>, Failure> {
    let render_one = |backend: &RenderBackend, p: &Prepared, output: &Path| match backend {
        RenderBackend::Cpu(cpu) => render_on_cpu(cpu, p, output),
        RenderBackend::Gpu(gpu) => render_on_gpu(gpu, &args.render, p, output),
    };
    each_scene(
        scenes,
        outputs,
        &args.render,
        backend,
        || open_render_backend(args.backend, &args.render),
        |backend, mut p, output| {
            textures.borrow_mut().extend(p.scene.texture_files());
            let Some(n) = args.orbit else { return render_one(backend, &p, output) };
            // Each picture turned from the scene's camera (not from the one
            // before, which would drift); the first is that camera itself.
            let home = scene::CameraControl::new(&p.scene.camera, scene::scene_bounds(&p.scene));
            for k in 0..n {
                let degrees = 360.0 * f64::from(k) / f64::from(n);
                let mut turned = home.clone();
                if k > 0 {
                    turned.orbit(degrees, 0.0);
                }
                frame::set_camera(&mut p.data.frame, &turned.camera);
                let c = &turned.camera;
                outln!(
                    "orbit: picture {} of {n}, turned {degrees:.1}° about the point looked at: eye ({:.4}, {:.4}, {:.4})",
                    k + 1,
                    c.pos.x,
                    c.pos.y,
                    c.pos.z
                );
                render_one(backend, &p, &numbered(output, k, n))?;
            }
            Ok(())
        },
    )
}

/// Where `render` and `conformance` run. `--backend auto` takes the device
/// unless it runs on the CPU (a Vulkan device of type CPU, as lavapipe: the
/// CPU build of the same code is about twice as fast there, without
/// Vulkan's start-up or a pipeline to build, and on lavapipe gives the same
/// bits) or, without `--device`, none opens (no driver, no device): then
/// the CPU build, and a line says why. With `--shaders` it is the device
/// (the folder's kernel runs only there), as with any option only a device
/// uses (`KernelOptions::device_only_given`). The second value says why the
/// CPU build was chosen (`; --backend auto: …`, or empty), to follow its
/// thread count on the command's first line.
fn open_backend(backend: Backend, k: &KernelOptions) -> Result<(RenderBackend, String), Failure> {
    let cpu = |why: Option<String>| {
        Ok((RenderBackend::Cpu(CpuRenderer::new()?), why.map_or(String::new(), |w| format!("; {w}"))))
    };
    match backend {
        Backend::Cpu => cpu(None),
        Backend::Gpu => Ok((RenderBackend::Gpu(k.renderer()?), String::new())),
        // Options only a device uses (a shader folder, a device named,
        // validation, a buffer kind, a timeout) ask for the device.
        Backend::Auto if !k.device_only_given().is_empty() => Ok((RenderBackend::Gpu(k.renderer()?), String::new())),
        Backend::Auto => match k.renderer() {
            Ok(renderer) if renderer.context().info().runs_on_cpu() => {
                let why = format!("--backend auto: {} runs on the CPU", renderer.context().info().name);
                check_validation(renderer.context().take_validation_messages())?;
                drop(renderer);
                cpu(Some(why))
            }
            Ok(renderer) => Ok((RenderBackend::Gpu(renderer), String::new())),
            Err(Failure(message, _)) if k.device.is_none() => {
                let message = message.strip_prefix("raycast: error: ").unwrap_or(&message);
                errln!("raycast: note: {message}; --backend auto renders with the CPU build instead");
                cpu(Some("--backend auto: no Vulkan device opened".to_string()))
            }
            Err(e) => Err(e),
        },
    }
}

/// The backend `render` runs on, announced.
fn open_render_backend(backend: Backend, o: &RenderOptions) -> Result<RenderBackend, Failure> {
    let (opened, why) = open_backend(backend, &o.kernel)?;
    match &opened {
        RenderBackend::Cpu(cpu) => outln!("device: {}", cpu.summary(&why)),
        RenderBackend::Gpu(renderer) => outln!("device: {}", renderer.context().info().summary()),
    }
    Ok(opened)
}

fn render_on_cpu(cpu: &CpuRenderer, p: &Prepared, output: &Path) -> Result<(), Failure> {
    print_scene(p);
    let start = Instant::now();
    let picture = progress::told(output.display().to_string(), |told| cpu.render_told(&p.data, told))?;
    let time = start.elapsed();
    outln!("time: load {}, render {}", ms(p.load), ms(time));
    print_rates(&p.data, &picture, time);
    write_picture(output, &picture)
}

fn render_on_gpu(renderer: &GpuRenderer, o: &RenderOptions, p: &Prepared, output: &Path) -> Result<(), Failure> {
    let info = renderer.context().info();
    print_scene(p);
    let compiled_before = renderer.compile_time();
    let (mut picture, t) = progress::told(output.display().to_string(), |told| {
        if o.kernel.shaders.is_some() {
            // The CPU build is the built-in code, not --shaders DIR's: it cannot finish this kernel's pixels.
            renderer.render_told(&p.data, told)
        } else {
            renderer.render_marked_told(&p.data, told)
        }
    })?;
    if picture.pixels.iter().any(crate::layout::PixelOut::is_cut_short) {
        let cpu = CpuRenderer::new()?;
        let label = format!("{}, the pixels cut short", output.display());
        let finished = progress::told(label, |told| crate::render::finish_cut_short(&mut picture, &p.data, &cpu, told));
        errln!(
            "raycast: note: {} cut {finished} of {} pixels short (Mesa's lavapipe gives each shader invocation 65535 loop \
             iterations in all); the CPU build of the same code computed those pixels, which on lavapipe gives the \
             same bits (`raycast check` compares the two builds)",
            info.name,
            picture.pixels.len()
        );
    }
    outln!(
        "time: load {}, upload {}, compile {}, dispatch {}, readback {}",
        ms(p.load),
        ms(t.upload),
        ms(renderer.compile_time() - compiled_before),
        ms(t.dispatch),
        ms(t.readback)
    );
    if t.bands > 1 {
        outln!(
            "bands: {} dispatches of up to {} rows each: the picture's pixel records ({}) do not fit one storage buffer \
             of this device ({})",
            t.bands,
            t.band_rows,
            crate::units::fmt_bytes(picture.pixels.len() as u64 * std::mem::size_of::<crate::layout::PixelOut>() as u64),
            crate::units::fmt_bytes(renderer.context().max_storage_bytes())
        );
    }
    print_rates(&p.data, &picture, t.dispatch);
    print_kernel(renderer, &p.data)?;
    write_picture(output, &picture)
}

/// After `render`'s scenes: the hint for a device that is a CPU, then what
/// the validation layer said (which fails the command), then `result`.
fn finish_render(backend: Option<RenderBackend>, result: Result<(), Failure>) -> Result<(), Failure> {
    let Some(RenderBackend::Gpu(renderer)) = backend else { return result };
    let info = renderer.context().info();
    if info.runs_on_cpu() && result.is_ok() {
        outln!(
            "hint: {} runs on the CPU; `--backend cpu` runs the same code natively, without Vulkan's start-up or a \
             pipeline to build: usually faster on such a machine, and on lavapipe the same bits (BENCHMARKS.md); \
             `--backend auto` does so wherever the device is a CPU",
            info.name
        );
    }
    let messages = renderer.context().take_validation_messages();
    drop(renderer);
    let validation = check_validation(messages);
    result.and(validation)
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
struct CheckBackends {
    gpu: GpuRenderer,
    cpu: CpuRenderer,
}

/// Status lines to stderr where `-o` sends the picture to stdout
/// (`render`, `check`'s and `compare`'s diff images): they would corrupt it.
pub(crate) fn status_beside(output: &Option<PathBuf>) {
    if output.as_deref() == Some(Path::new("/dev/stdout")) {
        crate::status_to_stderr();
    }
}

fn check(args: &CheckArgs) -> Result<(), Failure> {
    status_beside(&args.output);
    let scenes = scene_list(&args.scenes);
    if !args.pixel.is_empty() && scenes.len() > 1 {
        return Err(Failure(
            format!(
                "raycast: error: --pixel looks at one scene's pixel, but {} scenes were given: check that scene alone",
                scenes.len()
            ),
            2,
        ));
    }
    // Bad --pixel input fails before any work (the frame's size is the options').
    args.render.settings().validate().map_err(usage_error)?;
    let (width, height) = (args.render.width, args.render.height);
    if let Some(&(x, y)) = args.pixel.iter().find(|&&(x, y)| x >= width || y >= height) {
        return Err(usage_error(format!("--pixel {x},{y} is outside the {width}x{height} frame")));
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
        || Ok(CheckBackends { gpu: args.render.kernel.renderer()?, cpu: CpuRenderer::new()? }),
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
        let messages = b.gpu.context().take_validation_messages();
        drop(b);
        check_validation(messages)?;
    }
    if let Some((data, gpu_picture, cpu_picture)) = &last {
        isolated_pixels(args, data, gpu_picture, cpu_picture)?;
    }
    let n = scenes.len();
    if n > 1 {
        outln!(
            "check: {} of {n} scenes identical, {} within --allow-pixels, {} differ, {} failed",
            n - accepted - differ.len() - batch.failed.len(),
            accepted,
            differ.len(),
            batch.failed.len()
        );
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
        None => Err(Failure(format!("raycast: check failed: {}", differ_text()), 4)),
    }
}

/// One scene on the device and on the CPU build, compared and reported; the
/// diff image written to `diff` where asked (-o) or where something differs.
fn check_scene(
    args: &CheckArgs,
    b: &CheckBackends,
    p: &Prepared,
    diff: &Path,
) -> Result<(Checked, Picture, Picture), Failure> {
    let device = b.gpu.context().info().name.clone();
    print_scene(p);
    outln!(
        "check: {} on {device} against the CPU build ({} threads), {}x{}, every buffer bit for bit",
        args.render.kernel.kernel_text(),
        b.cpu.threads,
        p.data.frame.width,
        p.data.frame.height
    );
    let scene = p.scene.path.display();
    let (gpu_picture, _) = progress::told(format!("{scene} on {device}"), |told| b.gpu.render_told(&p.data, told))?;
    print_kernel(&b.gpu, &p.data)?;
    let cpu_picture = progress::told(format!("{scene} on the CPU build"), |told| b.cpu.render_told(&p.data, told))?;
    let report = check::compare(&gpu_picture, "device", &cpu_picture, "cpu")?;
    outln!("{report}");
    if args.output.is_some() || !report.identical() {
        image_io::write_png(diff, &report.diff_image)?;
        outln!("wrote {} (red: pixels that differ)", diff.display());
    } else {
        // The scene's diff image of an earlier run would say it still differs.
        for stale in image_io::remove_stale(&[diff.to_path_buf()])? {
            outln!("removed {}, the diff image of an earlier run", stale.display());
        }
    }
    let checked = match report.differing_pixels {
        _ if report.identical() => Checked::Identical,
        n if n <= args.allow_pixels => {
            outln!(
                "NOT EXACT: {n} pixels differ, accepted by --allow-pixels {} (lavapipe and an NVIDIA H100 measured exact; \
                 a driver that does not fuse `fma` or honour `precise` may not be: README, \"On a GPU too\")",
                args.allow_pixels
            );
            Checked::Accepted
        }
        n => Checked::Differ(n),
    };
    Ok((checked, gpu_picture, cpu_picture))
}

/// `check --pixel`: each pixel's render_pixel alone, through the harness.
fn isolated_pixels(
    args: &CheckArgs,
    data: &FrameData,
    gpu_picture: &Picture,
    cpu_picture: &Picture,
) -> Result<(), Failure> {
    use crate::harness::{Case, Harness, HarnessOptions, SceneBuffers};
    let width = data.frame.width;
    let mut harness = Harness::new(&HarnessOptions {
        shaders: args.render.kernel.shaders.clone(),
        device: args.render.kernel.device.clone(),
        validation: validation_wanted(args.render.kernel.validate),
        timeout: args.render.kernel.timeout(),
    })
    .map_err(|e| Failure(format!("raycast: error: --pixel: {e}"), 1))?;
    // The frame's buffers under the names scene_buffers.glsl gives them.
    let mut scene = SceneBuffers::new().frame(&data.frame);
    for (binding, what, bytes) in data.scene_buffers() {
        let Some(b) = harness.shaders().scene_buffers.iter().find(|b| b.binding == binding) else {
            return Err(Failure(
                format!("raycast: error: --pixel: scene_buffers.glsl declares no binding {binding} ({what})"),
                1,
            ));
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

fn conformance(args: &ConformanceArgs) -> Result<(), Failure> {
    cpu_takes_no_device_options(args.backend == Backend::Cpu, &args.kernel)?;
    let from_env = std::env::var_os("RAYCAST_CORPUS").filter(|v| !v.is_empty()).map(PathBuf::from);
    let Some(corpus) = args.corpus.clone().or(from_env) else {
        return Err(Failure(
            "raycast: error: conformance needs the cs1230 corpus: give its folder (say ../shared/corpus/cs1230), or set RAYCAST_CORPUS".into(),
            2,
        ));
    };
    // Not a corpus, or one that cannot be read, fails before the device starts.
    let all = crate::conformance::cases(&corpus)?;
    let total = all.len();
    let cases: Vec<_> = all
        .into_iter()
        .filter(|c| args.only.is_empty() || args.only.iter().any(|t| c.label().contains(t.as_str())))
        .collect();
    if cases.is_empty() {
        return Err(Failure(
            format!(
                "raycast: error: no case of the {total} in {} matches --only {}",
                corpus.display(),
                args.only.join(", --only ")
            ),
            2,
        ));
    }
    let count = cases.len();
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("cannot make the folder {} (--out-dir): {e}", args.out_dir.display()))?;
    let summary = match open_backend(args.backend, &args.kernel)? {
        (RenderBackend::Cpu(cpu), why) => {
            outln!("conformance: the {} against {}, {count} cases", cpu.summary(&why), corpus.display());
            crate::conformance::run(&corpus, &cases, &args.out_dir, |data| cpu.render(data), Vec::new)?
        }
        (RenderBackend::Gpu(renderer), _) => {
            outln!(
                "conformance: {} on {} against {}, {count} cases",
                args.kernel.kernel_text(),
                renderer.context().info().name,
                corpus.display()
            );
            crate::conformance::run(
                &corpus,
                &cases,
                &args.out_dir,
                |data| renderer.render(data).map(|(picture, _)| picture).map_err(|e| e.to_string()),
                || renderer.context().take_validation_messages(),
            )?
        }
    };
    outln!("{} passed, {} failed; the measured fractions: {}", summary.passed, summary.failed, summary.table.display());
    if summary.failed > 0 {
        return Err(Failure(
            format!(
                "raycast: conformance failed: {} of {count} cases (each FAILED line above says why; the actual, expected \
                 and diff pictures of those beyond the rule are in {})",
                summary.failed,
                args.out_dir.display()
            ),
            4,
        ));
    }
    Ok(())
}

fn compare(args: &CompareArgs) -> Result<(), Failure> {
    status_beside(&args.output);
    if !(0.0..=100.0).contains(&args.max_percent) {
        return Err(Failure(
            format!("raycast: error: --max-percent {} is out of range: 0 to 100", args.max_percent),
            2,
        ));
    }
    if let Some(path) = &args.output {
        check_output(path)?;
        refuse_overwriting(path, [args.actual.as_path(), args.expected.as_path()])?;
    }
    let read = |path: &Path| {
        let (rgb, translucent) = image_io::read_picture_counting_alpha(path)?;
        if translucent > 0 {
            eprintln!(
                "raycast: warning: {}: {} of {} pixels are not opaque; compare reads the colour channels only (alpha is \
                 not compared)",
                path.display(),
                crate::units::thousands(translucent as u64),
                crate::units::thousands(u64::from(rgb.width) * u64::from(rgb.height))
            );
        }
        Ok::<_, String>(rgb)
    };
    let path = |p: &Path| crate::units::json_str(&p.display().to_string());
    let compared = read(&args.actual).and_then(|actual| {
        let expected = read(&args.expected)?;
        image_io::compare(&actual, &expected, args.tolerance)
    });
    let diff = match compared {
        Ok(diff) => diff,
        // With --json a grader still gets its object: the pictures could
        // not be compared (sizes that differ, a file that is no picture).
        Err(e) if args.json => {
            crate::emit_line(&format!(
                "{{\"actual\":{},\"expected\":{},\"error\":{},\"passes\":false}}",
                path(&args.actual),
                path(&args.expected),
                crate::units::json_str(&e)
            ))?;
            return Err(e.into());
        }
        Err(e) => return Err(e.into()),
    };
    let passes = diff.fraction() * 100.0 <= args.max_percent;
    if let Some(path) = &args.output {
        image_io::write_png(path, &diff.diff_image)?;
    }
    if args.json {
        crate::emit_line(&format!(
            "{{\"actual\":{},\"expected\":{},{},\"max_percent\":{},\"passes\":{passes},\"diff_image\":{}}}",
            path(&args.actual),
            path(&args.expected),
            diff.json_fields(),
            args.max_percent,
            args.output.as_deref().map_or("null".to_string(), path)
        ))?;
    } else {
        outln!("{diff}");
        if let Some(path) = &args.output {
            outln!("wrote {} (red: pixels that differ)", path.display());
        }
    }
    if !passes {
        return Err(Failure(
            format!(
                "raycast: compare failed: {:.4}% of pixels differ, more than --max-percent {}",
                diff.fraction() * 100.0,
                args.max_percent
            ),
            4,
        ));
    }
    Ok(())
}
