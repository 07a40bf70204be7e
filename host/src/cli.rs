//! The command line: commands and flags, progress lines, exit codes.
//!
//! Exit codes: 0 success, 1 an error (scene, device, file), 2 a usage error,
//! 3 the Vulkan validation layer reported something (with --validate or
//! RAYCAST_VALIDATION=1).

use crate::frame::{self, Aov, RenderSettings};
use crate::gpu::{self, DeviceSelector, GpuOptions};
use crate::image_io::{self, Rgb8};
use crate::render::GpuRenderer;
use crate::scene::{self, FlattenLimits, ParseOptions, Scene};
use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

/// The embedded default scene (scenes/default.xml): all four primitives and
/// three kinds of light.
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.xml");
const DEFAULT_SCENE_NAME: &str = "<default scene>";

#[derive(Parser, Debug)]
#[command(name = "raycast", version, about = "A ray caster in a Vulkan compute shader for CS1230/CS123/Comp175 XML scenes")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Render a scene to a PNG (the embedded default scene when none is given).
    Render(RenderArgs),
    /// List the Vulkan devices.
    Devices,
}

#[derive(Args, Debug)]
struct RenderArgs {
    /// Scene file (XML). Without one, the embedded default scene.
    scene: Option<PathBuf>,
    /// Output PNG [default: <scene name>.png in the current folder]
    #[arg(short, long, value_name = "OUT.png")]
    output: Option<PathBuf>,
    #[arg(long, default_value_t = 512, value_name = "W")]
    width: u32,
    #[arg(long, default_value_t = 384, value_name = "H")]
    height: u32,
    /// What the picture shows.
    #[arg(long, value_enum, default_value_t = AovArg::Color)]
    aov: AovArg,
    /// Turn shadow rays off (they land with issue "shadows, reflections, textures").
    #[arg(long)]
    no_shadows: bool,
    /// Turn mirror reflections off.
    #[arg(long)]
    no_reflections: bool,
    /// Turn texture mapping off.
    #[arg(long)]
    no_textures: bool,
    /// Vulkan device: an index from `raycast devices` or part of its name.
    #[arg(long, value_name = "NAME|INDEX")]
    device: Option<String>,
    /// Extra folder to find textures in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR")]
    assets: Vec<PathBuf>,
    /// Refuse scenes that expand to more primitives than this.
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N")]
    max_primitives: usize,
    /// Enable the Khronos validation layer; any message fails the command (exit 3).
    /// Also on when RAYCAST_VALIDATION=1.
    #[arg(long)]
    validate: bool,
}

#[derive(Clone, Copy, Debug, ValueEnum)]
enum AovArg {
    Color,
    Normal,
}

/// A failure to report: the message and the exit code.
struct Failure(String, u8);

impl<E: std::fmt::Display> From<E> for Failure {
    fn from(e: E) -> Self {
        Failure(format!("raycast: error: {e}"), 1)
    }
}

/// A scene error: it already reads `file:line:col: error: …`.
fn scene_failure(e: String) -> Failure {
    Failure(e, 1)
}

pub fn main() -> ExitCode {
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
        Command::Devices => devices(),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure(message, code)) => {
            eprintln!("{message}");
            ExitCode::from(code)
        }
    }
}

fn validation_wanted(flag: bool) -> bool {
    flag || std::env::var("RAYCAST_VALIDATION").is_ok_and(|v| v == "1")
}

fn parse_device(arg: &Option<String>) -> Option<DeviceSelector> {
    arg.as_ref().map(|s| match s.parse::<usize>() {
        Ok(i) => DeviceSelector::Index(i),
        Err(_) => DeviceSelector::Name(s.clone()),
    })
}

/// Fails with exit code 3 if the validation layer said anything.
fn check_validation(messages: Vec<String>) -> Result<(), Failure> {
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        eprintln!("raycast: validation: {m}");
    }
    Err(Failure(format!("raycast: error: the Vulkan validation layer reported {} message(s)", messages.len()), 3))
}

fn devices() -> Result<(), Failure> {
    let list = gpu::list_devices()?;
    for d in &list {
        println!("{}: {} ({}, Vulkan {}, driver {})", d.index, d.name, d.kind, d.api_version, d.driver);
    }
    Ok(())
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// Loads the scene file, or the embedded default scene when `path` is None.
/// Prints the scene's warnings to stderr.
pub fn load_scene(path: Option<&Path>, opts: &ParseOptions, limits: &FlattenLimits) -> Result<Scene, String> {
    let scene = match path {
        Some(p) => scene::load(p, opts, limits),
        None => scene::parse_str(DEFAULT_SCENE, Path::new(DEFAULT_SCENE_NAME), opts)
            .and_then(|f| scene::flatten(&f, limits)),
    }
    .map_err(|e| e.to_string())?;
    for w in &scene.warnings {
        eprintln!("{w}");
    }
    Ok(scene)
}

fn render(args: &RenderArgs) -> Result<(), Failure> {
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        aov: match args.aov {
            AovArg::Color => Aov::Color,
            AovArg::Normal => Aov::Normal,
        },
        shadows: !args.no_shadows,
        reflections: !args.no_reflections,
        textures: !args.no_textures,
        ..RenderSettings::default()
    };
    settings.validate()?;
    let output = match &args.output {
        Some(o) => o.clone(),
        None => {
            let stem = args.scene.as_ref().and_then(|s| s.file_stem()).map(|s| s.to_string_lossy().into_owned());
            PathBuf::from(format!("{}.png", stem.as_deref().unwrap_or("default")))
        }
    };

    let start = Instant::now();
    let parse = ParseOptions { assets: args.assets.clone() };
    let scene = load_scene(args.scene.as_deref(), &parse, &FlattenLimits { max_primitives: args.max_primitives })
        .map_err(scene_failure)?;
    let data = frame::build(&scene, &settings);
    for note in &data.notes {
        eprintln!("raycast: note: {note}");
    }
    let load = start.elapsed();

    let options = GpuOptions {
        device: parse_device(&args.device),
        validation: validation_wanted(args.validate),
        ..GpuOptions::default()
    };
    let renderer = GpuRenderer::new(&options)?;
    let info = renderer.context().info();
    println!("device: {} ({}, Vulkan {})", info.name, info.kind, info.api_version);
    println!(
        "scene: {} ({} primitives, {} lights)",
        scene.path.display(),
        data.primitives.len(),
        data.lights.len()
    );
    let (picture, t) = renderer.render(&data)?;
    let image = Rgb8 { width: picture.width, height: picture.height, data: picture.rgb8() };
    image_io::write_png(&output, &image)?;
    let rays = u64::from(settings.width) * u64::from(settings.height);
    println!(
        "time: load {}, upload {}, compile {}, dispatch {}, readback {}",
        ms(load),
        ms(t.upload),
        ms(renderer.compile_time),
        ms(t.dispatch),
        ms(t.readback)
    );
    println!(
        "rate: {:.2} M primary rays/s ({rays} rays in {})",
        rays as f64 / t.dispatch.as_secs_f64().max(1e-9) / 1e6,
        ms(t.dispatch)
    );
    println!("wrote {} ({}x{})", output.display(), settings.width, settings.height);
    let messages = renderer.context().take_validation_messages();
    drop(renderer);
    check_validation(messages)
}
