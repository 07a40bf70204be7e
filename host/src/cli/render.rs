//! `raycast render`: scenes to PNGs, one after the other on one backend.

use crate::cli::batch::*;
use crate::cli::options::*;
use crate::cli::output::*;
use crate::cli::status::*;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, Error};
use crate::frame::{self};
use crate::image_io::{self};
use crate::output::*;
use crate::progress;
use crate::render::Backend;
use crate::render::{finish_cut_short, Picture, Renderer};
use crate::scene::{self};
use crate::source::*;
use crate::watch::FileWatch;
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Duration;

#[derive(Args, Clone, Debug)]
pub struct RenderArgs {
    /// XML files, `-` for stdin, or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene files (XML), rendered one after the other on one device (its
    /// start-up and each kernel paid once), `-` for XML on standard input,
    /// or generated scenes (gen:recursive-spheres:6; cones, cubes). Without
    /// any, the embedded default scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<PathBuf>,
    #[command(flatten)]
    render: RenderOptions,
    /// Output PNG for one scene, `-` for stdout
    ///
    /// Output PNG, for one scene; `-` writes it to standard output [default: SCENE.png in the current folder]
    #[arg(short, long, value_name = "OUT.png", conflicts_with = "out_dir", value_parser = crate::output::parse_output,
          help_heading = "Output")]
    output: Option<PathBuf>,
    /// Folder for the pictures [default: .]
    #[arg(long, value_name = "DIR", help_heading = "Output")]
    out_dir: Option<PathBuf>,
    /// gpu (default), cpu (the C++ build) or auto
    #[arg(long, value_enum, default_value_t = Backend::Gpu, help_heading = "Device", hide_possible_values = true,
          hide_default_value = true, long_help = crate::cli::values::with_values::<Backend>(
              "Where to run the shared code: a Vulkan device, or its C++ build on every core [default: gpu]"))]
    backend: Backend,
    /// A turntable: N pictures, 360/N degrees apart
    ///
    /// A turntable: N pictures of each scene, the camera turned 360/N degrees
    /// further each time about the scene's up through the point it looks at
    /// (as the preview's orbit), the first the scene's own camera; each
    /// named as without --orbit with -000, -001, … before `.png`
    #[arg(long, value_name = "N", help_heading = "Output", hide_short_help = true)]
    orbit: Option<u32>,
    /// Render again when a scene, texture or shader changes
    ///
    /// Keep going: render again whenever a scene file, one of its textures
    /// or the --shaders folder changes (for a picture viewer that reloads
    /// the PNG, say over SSH, where no preview window can open); a failure
    /// is reported and the watch goes on. Ctrl-C stops it.
    #[arg(long, help_heading = "Output")]
    watch: bool,
    /// One JSON object per picture on stdout
    #[arg(long, help_heading = "Output")]
    json: bool,
    /// Draw as the course drew PNG: its size and settings
    ///
    /// Draw each scene as the course drew the official render PNG, to
    /// compare with it: at PNG's size, with its settings. One of the
    /// corpus's references (bench/…) gets its case's (`raycast
    /// conformance`): local Phong only for test_unit and test_intersect, the
    /// adaptive supersampling and texture filter of the 1024x768 extra
    /// credit; another picture the course's for its size (1024x768: the
    /// adaptive supersampling). Takes the place of --width, --height, --aov,
    /// --spp, --supersample, --texture-filter, --no-shadows,
    /// --no-reflections and --no-textures.
    #[arg(long, value_name = "PNG", help_heading = "Picture", conflicts_with_all = [
        "width", "height", "aov", "spp", "supersample", "texture_filter", "no_shadows", "no_reflections", "no_textures"])]
    like: Option<PathBuf>,
}

impl RenderArgs {
    /// These arguments drawing each scene as the course drew `png`
    /// (`RenderOptions::like`).
    fn like(&self, png: &Path) -> Result<RenderArgs, Error> {
        let reference = image_io::read_picture(png)?;
        let mut args = self.clone();
        args.render.like = Some(Like { png: png.to_path_buf(), width: reference.width, height: reference.height });
        Ok(args)
    }
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

pub fn run(args: &RenderArgs) -> Result<(), Error> {
    let liked;
    let args = match &args.like {
        Some(png) => {
            liked = args.like(png)?;
            &liked
        }
        None => args,
    };
    cpu_takes_no_device_options(args.backend == Backend::Cpu, &args.render.kernel)?;
    if let Some(n) = args.orbit.filter(|n| !(1..=MAX_ORBIT).contains(n)) {
        return Err(Error::Usage(format!("--orbit {n} is out of range: 1 to {MAX_ORBIT} pictures")));
    }
    let scenes = scene_list(&args.scenes);
    let outputs = output_paths(&args.output, &args.out_dir, "", &scenes)?;
    if let (Some(n), Some(device)) = (args.orbit, args.output.as_ref().filter(|o| image_io::not_a_file(o))) {
        // Numbered names beside a device would be new files in its folder (/dev/stdout-000.png).
        return Err(Error::Usage(format!(
            "--orbit {n} writes {n} pictures, each named as -o's file with -000, -001, … before \
                 .png, and {} is not a file: name a file, or use --out-dir DIR",
            device.display()
        )));
    }
    if args.json && args.output.as_deref().is_some_and(crate::output::is_stdout) {
        return Err(Error::Usage(
            "--json writes to standard output, and so does -o -: write the picture to a file".into(),
        ));
    }
    status_beside(&args.output);
    let mut backend: Option<Box<dyn Renderer>> = None;
    // The textures the scenes loaded use (what --watch follows beside them).
    let textures: std::cell::RefCell<Vec<PathBuf>> = Default::default();
    let round = |backend: &mut Option<Box<dyn Renderer>>| {
        textures.borrow_mut().clear();
        let batch = render_scenes(args, &scenes, &outputs, backend, &textures);
        batch.and_then(|batch| batch.failure("").map_or(Ok(()), Err))
    };
    if !args.watch {
        let result = round(&mut backend);
        return finish_render(backend, result);
    }
    // Followed: the scene files, their textures, the shader folder's sources.
    let files: Vec<PathBuf> = scenes.iter().flatten().filter(|p| is_file(p)).map(|p| p.to_path_buf()).collect();
    if files.is_empty() && args.render.kernel.shaders.is_none() {
        return Err(Error::Usage(
            "--watch follows scene files and a --shaders folder, and this render has neither (the \
             embedded default scene or generated ones only)"
                .into(),
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
    backend: &mut Option<Box<dyn Renderer>>,
    textures: &std::cell::RefCell<Vec<PathBuf>>,
    round: impl Fn(&mut Option<Box<dyn Renderer>>) -> Result<(), Error>,
) -> Result<(), Error> {
    let shaders = args.render.kernel.shaders.as_deref();
    let folders: Vec<PathBuf> = shaders.into_iter().map(Path::to_path_buf).collect();
    let followed = || files.iter().chain(textures.borrow().iter()).cloned().collect::<Vec<PathBuf>>();
    let mut watch = FileWatch::new();
    watch.follow(&followed(), &folders);
    loop {
        let result = round(backend);
        // The files the round used: one newly named (a texture) stamped as it
        // is now, one no longer named dropped; the others as before the round.
        watch.follow(&followed(), &folders);
        if let Err(e) = result {
            errln!("{}", e.line());
        }
        if let Some(renderer) = backend.as_ref() {
            for m in renderer.take_messages() {
                errln!("raycast: validation: {m}");
            }
        }
        let n = watch.len();
        summary!("watching {n} file{} for changes (Ctrl-C stops)", if n == 1 { "" } else { "s" });
        let changed = loop {
            let changed = watch.changes(Duration::from_secs(3600));
            if !changed.is_empty() {
                break changed;
            }
        };
        let names: Vec<String> = changed.iter().map(|p| p.display().to_string()).collect();
        summary!("changed: {}", names.join(", "));
        if shaders.is_some_and(|dir| changed.iter().any(|c| c.starts_with(dir))) {
            // The kernel from --shaders DIR is compiled as the device opens.
            *backend = None;
        }
    }
}

/// One round of `render`: every scene, on `backend` (opened for the first
/// that loads), each scene's textures noted in `textures`.
fn render_scenes(
    args: &RenderArgs,
    scenes: &[Option<&Path>],
    outputs: &[PathBuf],
    backend: &mut Option<Box<dyn Renderer>>,
    textures: &std::cell::RefCell<Vec<PathBuf>>,
) -> Result<Batch<()>, Error> {
    let render_one = |backend: &dyn Renderer, p: &Prepared, output: &Path| {
        let rendered = render_on(backend, &args.render, p, output)?;
        if args.json {
            crate::output::emit_line(&serde_json::to_string(&rendered).map_err(|e| Error::Failed(e.to_string()))?)?;
        }
        Ok(())
    };
    each_scene(
        scenes,
        outputs,
        &args.render,
        backend,
        || open_render_backend(args.backend, &args.render),
        |backend, mut p, output| {
            textures.borrow_mut().extend(p.scene.texture_files());
            let Some(n) = args.orbit else { return render_one(backend.as_ref(), &p, output) };
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
                detail!(
                    "orbit: picture {} of {n}, turned {degrees:.1}° about the point looked at: eye ({:.4}, {:.4}, {:.4})",
                    k + 1,
                    c.pos.x,
                    c.pos.y,
                    c.pos.z
                );
                render_one(backend.as_ref(), &p, &numbered(output, k, n))?;
            }
            Ok(())
        },
    )
}

/// What `render --json` says of one picture.
#[derive(serde::Serialize)]
struct Rendered {
    scene: String,
    output: String,
    width: u32,
    height: u32,
    /// Load, upload, dispatch and readback (or the CPU build's render), in seconds.
    seconds: f64,
    camera_rays: u64,
    rays: u64,
}

impl Rendered {
    fn of(p: &Prepared, output: &Path, picture: &Picture, time: Duration) -> Rendered {
        let f = &p.data.frame;
        Rendered {
            scene: p.scene.path.display().to_string(),
            output: output.display().to_string(),
            width: picture.width,
            height: picture.height,
            seconds: time.as_secs_f64(),
            camera_rays: f.camera_rays(),
            rays: picture.rays(),
        }
    }
}

/// One picture of `p` on `renderer`, written to `output`. Pixels the device
/// cut short are finished by the CPU build, which runs the same code (not
/// with --shaders: the CPU build is the built-in code, not the folder's).
fn render_on(renderer: &dyn Renderer, o: &RenderOptions, p: &Prepared, output: &Path) -> Result<Rendered, Error> {
    print_scene(p);
    let (mut picture, t) = progress::told(output.display().to_string(), |told| {
        if o.kernel.shaders.is_some() {
            renderer.render_frame(&p.data, told)
        } else {
            renderer.render_marked(&p.data, told)
        }
    })?;
    if picture.pixels.iter().any(crate::layout::PixelOut::is_cut_short) {
        let cpu = CpuRenderer::new()?;
        let label = format!("{}, the pixels cut short", output.display());
        let finished = progress::told(label, |told| finish_cut_short(&mut picture, &p.data, &cpu, told))?;
        errln!(
            "raycast: note: {} cut {finished} of {} pixels short (Mesa's lavapipe gives each shader invocation 65535 loop \
             iterations in all); the CPU build of the same code computed those pixels, which on lavapipe gives the \
             same bits (`raycast check` compares the two builds)",
            renderer.info().name,
            picture.pixels.len()
        );
    }
    detail!("time: load {}, {}", ms(p.load), t.phases_text(ms));
    if t.bands > 1 {
        detail!(
            "bands: {} dispatches of up to {} rows each: the picture's pixel records ({}) do not fit one storage buffer \
             of this device ({})",
            t.bands,
            t.band_rows,
            crate::units::fmt_bytes(picture.pixels.len() as u64 * std::mem::size_of::<crate::layout::PixelOut>() as u64),
            crate::units::fmt_bytes(t.band_bytes)
        );
    }
    print_rates(&p.data, &picture, t.dispatch);
    print_kernel(renderer, &p.data)?;
    let time = p.load + t.frame();
    write_picture(output, &picture, time)?;
    Ok(Rendered::of(p, output, &picture, time))
}

/// After `render`'s scenes: the hint for a device that is a CPU, then what
/// the validation layer said (which fails the command), then `result`.
fn finish_render(backend: Option<Box<dyn Renderer>>, result: Result<(), Error>) -> Result<(), Error> {
    let Some(renderer) = backend else { return result };
    let info = renderer.info();
    if info.device_on_cpu && result.is_ok() {
        detail!(
            "hint: {} runs on the CPU; `--backend cpu` runs the same code natively, without Vulkan's start-up or a \
             pipeline to build: usually faster on such a machine, and on lavapipe the same bits (BENCHMARKS.md); \
             `--backend auto` does so wherever the device is a CPU",
            info.name
        );
    }
    let messages = renderer.take_messages();
    drop(renderer);
    let validation = check_validation(messages);
    result.and(validation)
}
