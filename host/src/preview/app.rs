//! The preview window and its loop: input, camera, reloads, title, picking,
//! screenshots. Frames come from `PreviewRenderer`; this file decides what
//! to draw (camera, size, output mode, sample) and when.

use std::ffi::CStr;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use ash::vk::{self, Handle};
use glam::DVec3;
use glfw::{Action, Key, MouseButton, WindowEvent};

use crate::args::Backend;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, validation_wanted, Error};
use crate::frame::{self, Aov, FrameData, RenderSettings};
use crate::gpu::{
    DeviceInfo, DeviceSelector, FrameStatus, GpuContext, GpuError, GpuOptions, KernelChoice, PresentMode,
};
use crate::image_io::{self, Rgb8};
use crate::layout::{self, Frame, NO_HIT};
use crate::render::Picture;
use crate::scene::{scene_bounds, Bounds, FlattenLimits, ParseOptions, Scene};
use crate::source::load_scene;

use super::layout::PreviewFrame;
use super::reload::{Reload, ShaderFolder, WatchConfig, Watcher, KERNEL_FILE};
use super::renderer::{PreviewKernels, PreviewRenderer};
use super::{PresentArg, PreviewArgs};
use crate::scene::CameraControl;

/// The X extensions one of which NVIDIA's Vulkan driver presents through:
/// its own X driver's GLX (NV-GLX) or DRI3 (XWayland, PRIME offload).
const NVIDIA_PRESENTS_THROUGH: [&CStr; 2] = [c"NV-GLX", c"DRI3"];

/// Why the window cannot take `device`'s pictures, asked before its driver
/// is (`GpuContext::with_surface`'s veto). NVIDIA's Vulkan driver crashes
/// when asked to present to an X display that has neither of
/// NVIDIA_PRESENTS_THROUGH (a call through a null pointer in
/// libnvidia-eglcore while the device is opened for the window; driver
/// 580.159.04 on an H100 under Xvfb, with and without GLX, 2026-11-27): such
/// a display is refused for it. RAYCAST_PRESENT_CHECK=1 applies the rule to
/// every device (how the suite tests it on lavapipe), 0 to none.
pub(crate) fn window_refuses(device: &DeviceInfo) -> Option<String> {
    let forced = crate::gpu::switch("RAYCAST_PRESENT_CHECK");
    let nvidia = device.driver_id == Some(vk::DriverId::NVIDIA_PROPRIETARY);
    if !forced.unwrap_or(nvidia) {
        return None;
    }
    let why = if forced == Some(true) {
        "which RAYCAST_PRESENT_CHECK=1 asks of every device"
    } else {
        "one of which NVIDIA's Vulkan driver presents through (it crashes when asked to present without them; \
         RAYCAST_PRESENT_CHECK=0 tries anyway)"
    };
    let display = std::env::var("DISPLAY").unwrap_or_default();
    refusal(super::x11::display_extensions(None, &NVIDIA_PRESENTS_THROUGH), &display, why)
}

/// The refusal of `window_refuses` where the display answered that it has
/// none of NVIDIA_PRESENTS_THROUGH (`answers`, in that order); nothing where
/// it has one or could not be asked.
fn refusal(answers: Result<Vec<bool>, String>, display: &str, why: &str) -> Option<String> {
    if !answers.is_ok_and(|has| has.len() == NVIDIA_PRESENTS_THROUGH.len() && has.iter().all(|h| !h)) {
        return None;
    }
    Some(format!("the X display {display} has neither NV-GLX (NVIDIA's X driver) nor DRI3, {why}"))
}

/// What to do where no device can present (`window_refuses`): one that can
/// shows the pixels of one that cannot.
const REFUSED_ADVICE: &str = "install a Vulkan device that can present to this display (Debian's mesa-vulkan-drivers: \
                              lavapipe) and the preview shows through it what this one draws (--window-device), run \
                              the preview on a desktop whose X server runs on the GPU, or render headless with \
                              `raycast render`";

/// Samples per pixel after which an interactive preview stops drawing until something changes.
const MAX_SAMPLES: u32 = 1024;
/// A press and release of the left button closer than this (pixels) is a click, not a drag.
const CLICK_SLOP: f64 = 3.0;
/// Orbit degrees per pixel of drag.
const ORBIT_DEG_PER_PIXEL: f64 = 0.3;
const TITLE_INTERVAL: Duration = Duration::from_millis(250);
/// After the camera's last move, frames stay at the motion resolution this long.
const MOTION_HOLD: Duration = Duration::from_millis(300);
/// While the camera moves, a frame should take at most this long: 125 ms (8
/// a second) where the CPU draws (lavapipe, the CPU build), where every
/// pixel is dear, and 33 ms (30 a second) on a GPU, where a window's full
/// size is usually within reach (on an H200, depth 10 with shadows at
/// 1920x1080 took 95 ms a frame at full size: with 125 ms it steered at 10
/// a second). At rest a slow sample is drawn in bands of the same budget.
const MOTION_FRAME_MS: [f64; 2] = [125.0, 1000.0 / 30.0];

/// The frame budget (MOTION_FRAME_MS) of a drawer that runs on the CPU or not.
fn frame_budget_ms(on_cpu: bool) -> f64 {
    MOTION_FRAME_MS[usize::from(!on_cpu)]
}
/// The most the motion resolution divides the width and height by: 2^(MAX_MOTION_STEPS / 4) = 8.
const MAX_MOTION_STEPS: u32 = 12;
/// Frames smaller than this do not update the cost per pixel.
const COST_MIN_PIXELS: u64 = 16384;
/// `--moving`: how far the camera orbits before each frame.
const MOVING_DEG_PER_FRAME: f64 = 2.0;

const HELP: &str = "\
preview controls:
  left drag       orbit about the focus        left click    print what the pixel sees
  right/mid drag  pan                          wheel         dolly toward / away from the focus
  W A S D         fly forward, left, back, right (Shift: faster)
  Q E             fly down, up
  R               back to the scene's camera   F             frame the whole scene
  C               print the camera as a <cameradata> block
  1 to 6          show colour, normal, depth, object id, walk cost (camera ray, all rays)
  H M T           toggle shadows, mirror reflections, textures
  G               toggle refraction (transparent materials opaque)
  B               switch who draws: the device or the CPU build (the same pixels)
  K               recompile the shaders now, as an edit does (the device draws after)
  F1              this help                    Esc           quit";

pub fn run(args: &PreviewArgs) -> Result<(), Error> {
    // --no-textures loads none, as `render --no-textures` (a scene whose
    // textures are missing opens); T then has nothing to turn on.
    let settings = RenderSettings {
        width: args.width,
        height: args.height,
        textures: !args.no_textures,
        ..RenderSettings::default()
    };
    // A screenshot to stdout: the status lines go to stderr, as `render -o /dev/stdout`'s.
    crate::output::status_beside(&args.screenshot);
    settings.validate().map_err(Error::usage)?;
    super::check_script(args)?;
    if let Some(path) = &args.screenshot {
        crate::image_io::check_output(path)?;
    }
    let parse = ParseOptions { assets: args.assets.clone(), skip_textures: args.no_textures };
    let limits = FlattenLimits { max_primitives: args.max_primitives };
    let scene = load_scene(args.scene.as_deref(), &parse, &limits).map_err(Error::scene)?;
    // Nothing written over what the preview reads (its scene, the scene's
    // textures), as `render -o`: refused before any window opens.
    if let Some(path) = &args.screenshot {
        let textures = scene.texture_files();
        crate::output::refuse_overwriting(path, args.scene.iter().chain(&textures).map(PathBuf::as_path))?;
    }
    let data = frame::build(&scene, &settings)?;
    for note in &data.notes {
        errln!("raycast: note: {note}");
    }
    crate::args::cpu_takes_no_shaders(args.backend == Backend::Cpu, &args.shaders)?;
    if args.backend == Backend::Cpu && args.choice.choice() == KernelChoice::Fast {
        return Err(Error::Usage(
            "--kernel fast runs on a Vulkan device, and --backend cpu draws with the CPU build, which is exact: \
             drop one"
                .into(),
        ));
    }
    let (shaders, compile_at_start) = shader_folder(args.shaders.as_deref())?;

    // The window. GLFW reports its errors through the callback.
    let glfw_errors: Arc<Mutex<Vec<String>>> = Arc::default();
    let sink = glfw_errors.clone();
    let last_glfw_error =
        move || glfw_errors.lock().unwrap_or_else(|p| p.into_inner()).last().cloned().unwrap_or_default();
    let mut glfw = glfw::init(move |_, description: String| {
        sink.lock().unwrap_or_else(|p| p.into_inner()).push(description);
    })
    .map_err(|_| {
        Error::from(format!(
            "cannot open a window: GLFW could not start ({}); run it on a desktop, or headless under `xvfb-run -a`",
            last_glfw_error()
        ))
    })?;
    if !glfw.vulkan_supported() {
        return Err(Error::from(format!(
            "cannot open a window: GLFW finds no Vulkan loader ({}); install libvulkan1 and a driver \
             (e.g. Debian's mesa-vulkan-drivers)",
            last_glfw_error()
        )));
    }
    let instance_extensions = glfw.get_required_instance_extensions().unwrap_or_default();
    if instance_extensions.is_empty() {
        return Err(Error::from(no_surface_extension(&last_glfw_error())));
    }
    let fixed_size = args.screenshot.is_some() || args.frames.is_some();
    glfw.window_hint(glfw::WindowHint::ClientApi(glfw::ClientApiHint::NoApi));
    glfw.window_hint(glfw::WindowHint::Resizable(!fixed_size));
    let (mut window, events) = glfw
        .create_window(args.width, args.height, "raycast preview", glfw::WindowMode::Windowed)
        .ok_or_else(|| Error::from(format!("cannot open a window: {}", last_glfw_error())))?;
    window.set_all_polling(true);

    let options = GpuOptions {
        device: args.device.clone(),
        validation: validation_wanted(args.validate),
        timeout: args.timeout,
        kernel: args.choice.choice(),
    };
    let refused = std::cell::RefCell::new(Vec::new());
    let veto = |device: &DeviceInfo| {
        let why = window_refuses(device)?;
        let advice = format!("{why}; {REFUSED_ADVICE}");
        refused.borrow_mut().push((device.index, device.name.clone(), why));
        Some(advice)
    };
    let open_window = |device: Option<DeviceSelector>| {
        let options = GpuOptions { device, ..options.clone() };
        GpuContext::with_surface(
            &options,
            &instance_extensions,
            |instance| {
                let mut surface: glfw::ffi::VkSurfaceKHR = std::ptr::null_mut();
                // SAFETY: `instance` is a live VkInstance with the extensions GLFW asked for.
                let result = unsafe {
                    window.create_window_surface(
                        instance.as_raw() as usize as glfw::ffi::VkInstance,
                        std::ptr::null(),
                        &mut surface,
                    )
                };
                if result != 0 {
                    return Err(format!("glfwCreateWindowSurface failed with {:?}", vk::Result::from_raw(result)));
                }
                Ok(vk::SurfaceKHR::from_raw(surface as usize as u64))
            },
            veto,
        )
    };
    let (context, apart) = choose_devices(args, &options, open_window)?;
    let context = Arc::new(context);
    let info = context.info().clone();
    // Who draws the samples (--backend): the CPU build, and why, or the device.
    let candidate = apart.as_ref().map_or(&info, |a| a.info());
    let cpu_why = match args.backend {
        Backend::Cpu => Some(String::new()),
        // A device named to draw (--device) draws, as render's auto takes
        // it; so does one asked for the fast kernel (the CPU build has none).
        Backend::Auto
            if !compile_at_start
                && args.device.is_none()
                && args.choice.choice() != KernelChoice::Fast
                && candidate.runs_on_cpu() =>
        {
            Some(format!("; --backend auto: {} runs on the CPU", candidate.name))
        }
        Backend::Gpu | Backend::Auto => None,
    };
    // A device apart that runs on the CPU gives way to the CPU build (auto).
    let apart = apart.filter(|_| cpu_why.is_none()).map(Arc::new);
    // The device that draws when the CPU build does not (B).
    let drawing = apart.as_ref().map_or(&info, |a| a.info()).clone();
    let mut refused = refused.into_inner();
    // A retry asks the veto again: each device once.
    refused.sort_by_key(|r| r.0);
    refused.dedup_by_key(|r| r.0);
    for (index, name, why) in refused {
        if index == drawing.index && apart.is_some() {
            errln!("raycast: note: device {index} ({name}) cannot present to this window ({why}); it draws the samples and {} shows them", info.name);
        } else if index != info.index && options.device.is_none() && args.window_device.is_none() {
            // Only where raycast chose the device: one named needs no word about the others.
            errln!("raycast: note: device {index} ({name}) cannot present to this window ({why}); using {}", info.name);
        }
    }
    let cpu = cpu_why.as_ref().map(|_| CpuRenderer::new()).transpose()?;
    match (&cpu, &cpu_why, &apart) {
        (Some(c), Some(why), _) => outln!("device: {}; the window through {}", c.summary(why), info.summary()),
        (_, _, Some(a)) => outln!("device: {}; the window through {}", a.info().summary(), info.summary()),
        _ => outln!("device: {}", info.summary()),
    }
    outln!("scene: {} ({} primitives, {} lights)", scene.path.display(), data.primitives.len(), data.lights.len());

    // A --shaders folder's kernel from the first frame on (so --frames and
    // --screenshot see it); a compile error ends the command.
    let draws = apart.as_ref().unwrap_or(&context);
    let shaders = shaders.map(|dir| ShaderFolder { dir, division: draws.division() });
    let kernel = match (&shaders, compile_at_start) {
        (Some(folder), true) => match folder.compile() {
            Reload::Kernel(kernel) => kernel,
            Reload::Failed(e) => return Err(Error::from(format!("--shaders {}: {e}", folder.dir.display()))),
            Reload::Scene(_) => unreachable!("compile gives a kernel or a failure"),
        },
        _ => PreviewKernels::embedded(draws)?,
    };
    // With a device apart, those are its kernels; the window's device only shows.
    let (kernel, apart_kernels) = match &apart {
        Some(a) => (PreviewKernels::embedded(&context)?, Some((a.clone(), kernel))),
        None => (kernel, None),
    };
    let (fw, fh) = window.get_framebuffer_size();
    let window_size = [fw.max(1) as u32, fh.max(1) as u32];
    let size = if fixed_size { [args.width, args.height] } else { window_size };
    let mode = match args.present_mode {
        PresentArg::Fifo => PresentMode::Fifo,
        PresentArg::Mailbox => PresentMode::Mailbox,
        PresentArg::Immediate => PresentMode::Immediate,
    };
    let renderer = PreviewRenderer::new(context.clone(), kernel, &data, size, window_size, mode, cpu, apart_kernels)?;
    if let Some(why) = renderer.device_cannot_draw() {
        errln!("raycast: preview: note: {why}");
    }
    let sc = renderer.swapchain();
    if sc.mode() != sc.requested_mode() {
        errln!("raycast: note: the window does not offer --present-mode {}; using fifo", sc.requested_mode().name());
    }

    let watcher = Watcher::spawn(WatchConfig {
        scene: args.scene.clone(),
        textures: scene.texture_files(),
        parse,
        limits,
        settings: settings.clone(),
        shaders: shaders.clone(),
    });

    let mut preview = Preview::new(scene, data, &drawing, fixed_size, renderer);
    preview.moving_frames = args.moving;
    preview.click = args.click;
    preview.keys = args.keys.clone().map(|k| k.0).unwrap_or_default();
    preview.shaders = shaders;
    preview.aov = args.aov;
    preview.shadows = !args.no_shadows;
    preview.reflections = !args.no_reflections;
    preview.refraction = !args.no_refraction;
    preview.textures = !args.no_textures;
    preview.textures_loaded = !args.no_textures;
    if args.screenshot.is_none() && args.frames.is_none() {
        errln!("raycast: preview: F1 prints the controls, Esc quits");
        if drawing.runs_on_cpu() && cpu_why.is_none() && !compile_at_start {
            errln!(
                "raycast: preview: hint: {} runs on the CPU; B (or --backend auto) lets the CPU build draw the samples \
                 natively: the same pixels, more frames a second (BENCHMARKS.md, \"The preview\")",
                drawing.name
            );
        }
    }
    let result = preview.run(
        &mut glfw,
        &mut window,
        &events,
        &watcher,
        args.frames.or(args.screenshot.as_ref().map(|_| 1)),
        args.screenshot.as_deref(),
    );

    // Tear down in order: frames and buffers, the watcher's kernels, then
    // what the validation layer said, then the device and the window.
    drop(preview);
    drop(watcher);
    let mut messages = context.take_validation_messages();
    if let Some(a) = apart {
        messages.extend(a.take_validation_messages());
    }
    drop(context);
    drop(window);
    result?;
    check_validation(messages)
}

/// Why the window cannot open where GLFW finds no Vulkan surface extension
/// (`glfw_error`: GLFW's last message, often none). The loader offers none
/// where it found no driver (VK_ICD_FILENAMES at a file that is not there,
/// no driver installed): that is said as `render` says it
/// (`GpuError::no_device`), the CPU build's drawing no way around it.
fn no_surface_extension(glfw_error: &str) -> String {
    let needs = "the preview shows its pictures in the window through Vulkan, even with --backend cpu";
    match crate::gpu::list_devices() {
        Err(e @ (GpuError::NoDevice { .. } | GpuError::LoaderMissing { .. })) => {
            format!("cannot open a window: {e} ({needs})")
        }
        _ => {
            let glfw_error = if glfw_error.is_empty() { String::new() } else { format!(" ({glfw_error})") };
            format!("cannot open a window: no Vulkan surface extension for this window system{glfw_error}; {needs}")
        }
    }
}

/// The window's device, opened by `open_window` for the selector given, and
/// the device that draws where that is another one (the device apart): the
/// one --device names, or the best, where it cannot present to this window;
/// with --window-device, always the --device one (unless the CPU build draws).
fn choose_devices(
    args: &PreviewArgs,
    options: &GpuOptions,
    open_window: impl Fn(Option<DeviceSelector>) -> Result<GpuContext, GpuError>,
) -> Result<(GpuContext, Option<GpuContext>), Error> {
    let device_draws = args.backend != Backend::Cpu;
    // With two device options, a device not found is named by its option.
    let named = |option: &'static str| {
        move |e: GpuError| match e {
            GpuError::DeviceNotFound { .. } => Error::from(format!("{option}: {e}")),
            e => Error::from(e),
        }
    };
    let open_apart = || GpuContext::new(options).map_err(named("--device"));
    if let Some(window_device) = &args.window_device {
        let context = open_window(Some(window_device.clone())).map_err(named("--window-device"))?;
        return Ok((context, device_draws.then(open_apart).transpose()?));
    }
    Ok(match open_window(options.device.clone()) {
        Err(e @ GpuError::Presentation { .. }) if device_draws && options.device.is_some() => {
            // Shown through any device that can; a failure there is the first one's.
            let context = open_window(None).map_err(|_| e)?;
            (context, Some(open_apart()?))
        }
        Err(e) => return Err(named("--device")(e)),
        Ok(context) if device_draws && options.device.is_none() => {
            // The best device, where it is not the window's, draws; if it
            // cannot be opened, the window's device draws, as before.
            let best = crate::gpu::list_devices_with_default()?.1;
            let apart = match (best != context.info().index).then(|| GpuContext::new(options)) {
                Some(Err(e)) => {
                    errln!("raycast: note: device {best} cannot draw ({e}); {} draws", context.info().name);
                    None
                }
                opened => opened.transpose()?,
            };
            (context, apart)
        }
        Ok(context) => (context, None),
    })
}

/// The shader folder to watch, and whether to compile from it at start
/// (only when given on the command line).
fn shader_folder(arg: Option<&Path>) -> Result<(Option<PathBuf>, bool), Error> {
    if let Some(dir) = arg {
        if !dir.join(KERNEL_FILE).is_file() {
            return Err(Error::from(format!("--shaders {}: there is no {KERNEL_FILE} in it", dir.display())));
        }
        return Ok((Some(dir.to_path_buf()), true));
    }
    let source = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders"));
    if source.join(KERNEL_FILE).is_file() {
        Ok((Some(source.canonicalize().unwrap_or_else(|_| source.to_path_buf())), false))
    } else {
        errln!(
            "raycast: note: shader reload is off: the source tree's shaders/ ({}) is not here; use --shaders DIR",
            source.display()
        );
        Ok((None, false))
    }
}

/// Mouse state between events.
#[derive(Default)]
struct Mouse {
    cursor: (f64, f64),
    /// Where the left button went down, while it is down.
    left_from: Option<(f64, f64)>,
    /// The left button moved past the click slop: it orbits.
    orbiting: bool,
    panning: bool,
}

/// Frame-time and ray-rate averages for the title.
#[derive(Default)]
struct Stats {
    frame_ms: f64,
    device_ms: Option<f64>,
    last_submit: Option<Instant>,
}

impl Stats {
    fn average(old: f64, new: f64) -> f64 {
        if old == 0.0 {
            new
        } else {
            old * 0.8 + new * 0.2
        }
    }
}

/// Everything the loop keeps.
struct Preview {
    scene: Scene,
    data: FrameData,
    bounds: Option<Bounds>,
    camera: CameraControl,
    /// The Vulkan device's name.
    device: String,
    /// Whether that device runs on the CPU (lavapipe): the frame budget.
    device_on_cpu: bool,
    /// A shader was reloaded: the device's kernel is no longer the code the
    /// CPU build was built from (so an edit hands the drawing to the device,
    /// and B back to the CPU build says so).
    shader_edited: bool,
    /// The picture stays at the size asked for (screenshots): the window is not resizable.
    fixed_size: bool,
    /// What the window shows (Frame.aov, keys 1 to 6).
    aov: Aov,
    shadows: bool,
    reflections: bool,
    /// Refraction (G): FLAG_REFRACTION where the scene's frame has it.
    refraction: bool,
    textures: bool,
    /// Whether the scene's textures were loaded (not with --no-textures): T can turn them on.
    textures_loaded: bool,
    /// The sample the next frame draws; 0 restarts the accumulation.
    sample: u32,
    /// Scripted runs (--moving N): the first N frames turn the camera.
    moving_frames: u32,
    /// Scripted runs (--click X,Y): the pixel clicked after the last frame.
    click: Option<(u32, u32)>,
    /// Scripted runs (--keys): keys pressed just before frame N (from 1).
    keys: Vec<(u32, Key)>,
    /// The shader folder the watcher follows (None: reload is off): K
    /// recompiles it at once.
    shaders: Option<ShaderFolder>,
    /// K was pressed: recompile before the next frame.
    recompile: bool,
    /// Frames submitted so far.
    rendered: u32,
    /// The size of the frame submitted last.
    frame_sizes: (u32, u32),
    /// Submit-to-submit times of the --moving frames, and their sizes.
    moving_times: Vec<(Duration, [u32; 2])>,
    /// Submit-to-submit times of the frames after them (scripted runs: each a whole sample), and their sizes.
    rest_times: Vec<(Duration, [u32; 2])>,
    /// The first row of the sample's next band (0: the sample starts).
    band_next: u32,
    /// When the camera last moved (`moved`).
    last_move: Option<Instant>,
    /// Device (or frame) milliseconds per pixel of the last frames.
    pixel_cost: PixelCost,
    /// Pixels of the frame in flight, for `pixel_cost`.
    pixels_in_flight: u64,
    /// Pixels of the last frame the device cut short (wrong; lavapipe's loop budget).
    cut_short: u32,
    error: Option<String>,
    mouse: Mouse,
    stats: Stats,
    renderer: PreviewRenderer,
}

/// Milliseconds per pixel of the last COST_FRAMES frames measured.
#[derive(Default)]
struct PixelCost {
    last: std::collections::VecDeque<f64>,
}

/// Frames `PixelCost` keeps.
const COST_FRAMES: usize = 5;

impl PixelCost {
    fn push(&mut self, ms_per_pixel: f64) {
        if !ms_per_pixel.is_finite() || ms_per_pixel <= 0.0 {
            return;
        }
        if self.last.len() == COST_FRAMES {
            self.last.pop_front();
        }
        self.last.push_back(ms_per_pixel);
    }

    /// Their median (None before the first): one slow frame (a pipeline
    /// built, another process on the cores) does not shrink the steering
    /// size, as it did in an average; a lasting change moves it within
    /// three frames.
    fn estimate(&self) -> Option<f64> {
        Some(crate::units::median(self.last.iter().copied())).filter(|m| !m.is_nan())
    }
}

/// The divisor of width and height that brings a frame of `pixels` pixels,
/// at `ms_per_pixel`, within `budget_ms`: the smallest of 1, 2^(1/4),
/// 2^(2/4), … (each step 29% fewer pixels; whole divisors went from 512x384
/// straight to 256x192, a quarter, where 363x272 fits), 1 when the cost is
/// not known yet, at most 2^(MAX_MOTION_STEPS / 4).
fn motion_scale(ms_per_pixel: Option<f64>, pixels: u64, budget_ms: f64) -> f64 {
    let Some(cost) = ms_per_pixel.filter(|c| c.is_finite() && *c > 0.0) else { return 1.0 };
    let full_ms = cost * pixels as f64;
    // Dividing both sides by s = 2^(k/4) divides the pixels by s² = 2^(k/2).
    let steps = (2.0 * (full_ms / budget_ms).log2()).ceil();
    2f64.powf(steps.clamp(0.0, f64::from(MAX_MOTION_STEPS)) / 4.0)
}

/// Rows of a `width`-pixel frame that one frame draws at `ms_per_pixel`
/// within `budget_ms`: a multiple of the work group's height (at least
/// one), all `height` rows when they fit or the cost is not known yet.
fn band_rows(ms_per_pixel: Option<f64>, width: u32, height: u32, budget_ms: f64) -> u32 {
    let Some(cost) = ms_per_pixel.filter(|c| c.is_finite() && *c > 0.0) else { return height };
    let rows = (budget_ms / (cost * f64::from(width.max(1)))).floor();
    if rows >= f64::from(height) {
        return height;
    }
    let group = layout::WORKGROUP_SIZE;
    ((rows as u32) / group * group).max(group)
}

/// RAYCAST_PREVIEW_BAND_ROWS=N: every sample at rest drawn N rows a frame,
/// whatever the device's speed (how the suite resizes a window under a
/// sample in progress on a fast machine).
fn forced_band_rows() -> Option<u32> {
    static ROWS: std::sync::OnceLock<Option<u32>> = std::sync::OnceLock::new();
    *ROWS.get_or_init(|| std::env::var("RAYCAST_PREVIEW_BAND_ROWS").ok()?.parse().ok().filter(|&n: &u32| n > 0))
}

/// "10 frames at 171x128 then 128x96": how many frames, at which sizes in turn.
fn frames_at(times: &[(Duration, [u32; 2])]) -> String {
    let mut sizes: Vec<[u32; 2]> = times.iter().map(|t| t.1).collect();
    sizes.dedup();
    let sizes: Vec<String> = sizes.iter().map(|[w, h]| format!("{w}x{h}")).collect();
    let n = times.len();
    format!("{n} frame{} at {}", if n == 1 { "" } else { "s" }, sizes.join(" then "))
}

/// "median 150.4 ms a frame, 6.6 frames a second" of frame times (at least one).
fn rate(times: &[(Duration, [u32; 2])]) -> String {
    let median = crate::units::median(times.iter().map(|t| t.0.as_secs_f64()));
    format!("median {:.1} ms a frame, {:.1} frames a second", median * 1e3, 1.0 / median.max(1e-9))
}

/// The i-th point of the Halton (2, 3) sequence, centred on 0: sub-pixel
/// offsets in [-0.5, 0.5)², deterministic and evenly spread.
fn jitter(i: u32) -> [f32; 2] {
    fn radical_inverse(mut i: u32, base: u32) -> f64 {
        let (mut f, mut r) = (1.0, 0.0);
        while i > 0 {
            f /= f64::from(base);
            r += f * f64::from(i % base);
            i /= base;
        }
        r
    }
    [(radical_inverse(i, 2) - 0.5) as f32, (radical_inverse(i, 3) - 0.5) as f32]
}

impl Preview {
    fn new(scene: Scene, data: FrameData, device: &DeviceInfo, fixed_size: bool, renderer: PreviewRenderer) -> Preview {
        let bounds = scene_bounds(&scene);
        let camera = CameraControl::new(&scene.camera, bounds);
        Preview {
            scene,
            data,
            bounds,
            camera,
            device: device.name.clone(),
            device_on_cpu: device.runs_on_cpu(),
            shader_edited: false,
            fixed_size,
            aov: Aov::Color,
            shadows: true,
            reflections: true,
            refraction: true,
            textures: true,
            textures_loaded: true,
            sample: 0,
            moving_frames: 0,
            click: None,
            keys: Vec::new(),
            shaders: None,
            recompile: false,
            rendered: 0,
            frame_sizes: (0, 0),
            moving_times: Vec::new(),
            rest_times: Vec::new(),
            band_next: 0,
            last_move: None,
            pixel_cost: PixelCost::default(),
            pixels_in_flight: 0,
            cut_short: 0,
            error: None,
            mouse: Mouse::default(),
            stats: Stats::default(),
            renderer,
        }
    }

    /// The loop: until Esc, the window closes, or `frames` samples are drawn
    /// (then the picture goes to `screenshot`).
    fn run(
        &mut self,
        glfw: &mut glfw::Glfw,
        window: &mut glfw::PWindow,
        events: &glfw::GlfwReceiver<(f64, WindowEvent)>,
        watcher: &Watcher,
        frames: Option<u32>,
        screenshot: Option<&Path>,
    ) -> Result<(), Error> {
        let mut last_title = Instant::now() - TITLE_INTERVAL;
        let mut last_tick = Instant::now();
        let mut recreate = false;
        loop {
            // Input.
            let idle = frames.is_none() && self.sample >= MAX_SAMPLES;
            let (fw, fh) = window.get_framebuffer_size();
            let minimised = fw <= 0 || fh <= 0 || window.is_iconified();
            if idle || minimised {
                glfw.wait_events_timeout(0.05);
                // The pause is not a frame time.
                self.stats.last_submit = None;
            } else {
                glfw.poll_events();
            }
            for (_, event) in glfw::flush_messages(events) {
                match event {
                    WindowEvent::FramebufferSize(..) => recreate = true,
                    other => self.on_event(other, window)?,
                }
            }
            if window.should_close() {
                return Ok(());
            }
            let now = Instant::now();
            let dt = (now - last_tick).as_secs_f64().min(0.1);
            last_tick = now;
            self.fly(window, dt);

            // Reloads, done by the watcher thread.
            while let Some(reload) = watcher.try_recv() {
                self.on_reload(reload)?;
            }

            if last_title.elapsed() >= TITLE_INTERVAL {
                window.set_title(&self.title());
                last_title = Instant::now();
            }
            if minimised {
                continue;
            }
            if recreate || self.renderer.swapchain().extent() != [fw as u32, fh as u32] {
                recreate = false;
                self.renderer.resize_window([fw as u32, fh as u32])?;
                if !self.fixed_size && self.renderer.size() != [fw as u32, fh as u32] {
                    self.renderer.resize([fw as u32, fh as u32])?;
                    // New buffers: the sample in progress, and its band, start over.
                    self.restart();
                }
            }
            if idle {
                continue;
            }

            // One sample.
            let waited = Instant::now();
            let device = self.renderer.wait()?;
            if let Some(t) = device {
                self.stats.device_ms = Some(Stats::average(self.stats.device_ms.unwrap_or(0.0), t.as_secs_f64() * 1e3));
            }
            // Small frames (steering, bands) carry a fixed cost per frame that would
            // inflate the cost per pixel: only frames of COST_MIN_PIXELS or more count.
            if self.pixels_in_flight >= COST_MIN_PIXELS {
                // The frame's own time: the device's, or else since its submission.
                let ms = device
                    .map(|t| t.as_secs_f64() * 1e3)
                    .or_else(|| self.stats.last_submit.map(|s| (waited.max(s) - s).as_secs_f64() * 1e3));
                if let Some(ms) = ms {
                    self.pixel_cost.push(ms / self.pixels_in_flight as f64);
                }
            }
            let cut = self.renderer.cut_short()?;
            if cut > 0 && self.cut_short == 0 {
                errln!(
                    "raycast: preview: the picture is WRONG: the device cut {cut} pixels short. Mesa's lavapipe gives each \
                     shader invocation 65535 loop iterations in all and these pixels need more; \
                     reflections off (M) or another Vulkan device avoid it"
                );
            }
            self.cut_short = cut;
            let steering = frames.is_some() && self.rendered < self.moving_frames;
            if steering {
                self.camera.orbit(MOVING_DEG_PER_FRAME, 0.0);
                self.moved();
            }
            // --keys: those pressed before this frame (the first is frame 1).
            let pressed: Vec<Key> = self.keys.iter().filter(|(n, _)| *n == self.rendered + 1).map(|k| k.1).collect();
            for key in pressed {
                self.on_key(key, glfw::Modifiers::empty(), window);
            }
            // K, from the window or --keys: the kernel this frame draws with.
            if std::mem::take(&mut self.recompile) {
                self.recompile_shaders()?;
            }
            let scale = self.motion_scale(frames.is_some() && !steering);
            if scale > 1.0 || self.renderer.frame_size() != self.renderer.size() {
                // Moving, or the first frame at rest after moving: no samples to add to.
                self.sample = 0;
                self.band_next = 0;
            }
            let frame = self.frame(scale);
            // At full size on a slow device, a sample is drawn a band of rows per frame (each
            // within the frame budget) and shown once whole, so input is never kept waiting
            // for a long frame. Scripted runs and fast devices draw it whole.
            let rows = if scale > 1.0 || frames.is_some() {
                frame.height
            } else {
                forced_band_rows().unwrap_or_else(|| {
                    band_rows(self.pixel_cost.estimate(), frame.width, frame.height, self.frame_budget_ms())
                })
            };
            let band = [self.band_next, (self.band_next + rows).min(frame.height)];
            let whole = band[1] == frame.height;
            self.pixels_in_flight = u64::from(frame.width) * u64::from(band[1] - band[0]);
            let [jx, jy] = jitter(self.sample);
            let preview = PreviewFrame {
                jitter: [jx, jy, 0.0, 0.0],
                sample_index: self.sample,
                row_offset: band[0],
                pad0: 0,
                pad1: 0,
            };
            match self.renderer.render(&self.data, &frame, &preview, band[1], whole)? {
                FrameStatus::OutOfDate => {
                    recreate = true;
                    continue;
                }
                FrameStatus::Suboptimal => recreate = true,
                FrameStatus::Done => {}
            }
            let now = Instant::now();
            if let Some(prev) = self.stats.last_submit.replace(now) {
                self.stats.frame_ms = Stats::average(self.stats.frame_ms, (now - prev).as_secs_f64() * 1e3);
                if frames.is_some() {
                    // Scripted: the frame before this one, a --moving frame or one at rest: its time is now known.
                    let timed = (now - prev, [self.frame_sizes.0, self.frame_sizes.1]);
                    if self.rendered <= self.moving_frames {
                        self.moving_times.push(timed);
                    } else {
                        self.rest_times.push(timed);
                    }
                }
            }
            self.frame_sizes = (frame.width, frame.height);
            self.rendered += 1;
            if whole {
                self.sample += 1;
                self.band_next = 0;
            } else {
                self.band_next = band[1];
                continue;
            }

            if let Some(n) = frames {
                if self.rendered >= n {
                    self.renderer.wait()?;
                    self.report_rates();
                    if let Some((j, i)) = self.click {
                        self.pick_pixel(j, i)?;
                    }
                    if let Some(path) = screenshot {
                        self.save(path)?;
                    }
                    return Ok(());
                }
            }
        }
    }

    /// The Frame of this camera, size, mode and flags. The rest (scene
    /// counts, coefficients) is `frame::build`'s, so the scene's own camera
    /// gives its `raycast render` Frame bit for bit.
    fn frame(&self, scale: f64) -> Frame {
        let [w, h] = self.renderer.size();
        let side = |n: u32| ((f64::from(n) / scale).ceil() as u32).clamp(1, n);
        self.frame_at([side(w), side(h)])
    }

    /// `frame`'s Frame at a size of w x h pixels.
    fn frame_at(&self, [w, h]: [u32; 2]) -> Frame {
        let mut f = self.data.frame;
        f.width = w;
        f.height = h;
        frame::set_camera(&mut f, &self.camera.camera);
        let eye = self.camera.camera.pos;
        f.aov = self.aov.code();
        // As frame::build's for the scene's camera: the depth AOV's range from this one.
        f.aov_scale = frame::aov_scale(frame::depth_range(self.bounds, eye), self.aov.default_cost_max());
        f.flags = (if self.shadows { layout::FLAG_SHADOWS } else { 0 })
            | (if self.reflections { layout::FLAG_REFLECTIONS } else { 0 })
            | (if self.textures { layout::FLAG_TEXTURES } else { 0 })
            | (if self.refraction { self.data.frame.flags & layout::FLAG_REFRACTION } else { 0 });
        f
    }

    fn title(&self) -> String {
        let [w, h] = self.renderer.frame_size();
        let rays = self.pixels_in_flight as f64;
        let ms = self.stats.device_ms.unwrap_or(self.stats.frame_ms);
        let rate = if ms > 0.0 { rays / (ms * 1e-3) / 1e6 } else { 0.0 };
        let on = |b: bool| if b { "on" } else { "off" };
        let name = self.scene.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let mut t = format!(
            "raycast preview | {name} | {} | {:.1} ms/frame, {rate:.2} Mrays/s | {} samples | {} | \
             shadows {}, reflections {}, textures {}",
            self.aov.name(),
            self.stats.frame_ms,
            self.sample,
            self.drawn_by(),
            on(self.shadows),
            on(self.reflections),
            on(self.textures)
        );
        if [w, h] != self.renderer.size() {
            t.push_str(&format!(" | {w}x{h} while moving"));
        } else if self.band_next > 0 {
            t.push_str(&format!(" | sample {}: row {} of {h}", self.sample + 1, self.band_next));
        }
        if self.cut_short > 0 {
            t.push_str(&format!(" | WRONG: {} pixels cut short by the device's loop budget", self.cut_short));
        }
        if let Some(e) = &self.error {
            t.push_str(" | ERROR: ");
            t.push_str(e);
        }
        t
    }

    /// B: the device draws the samples from now on if the CPU build did,
    /// else the CPU build (the same pixels; on lavapipe the faster); the
    /// samples start over. A failure keeps who drew and shows in the title.
    fn switch_drawing(&mut self) {
        let switched = if let Some(why) = self.renderer.device_cannot_draw() {
            Err(Error::Failed(why.to_string()))
        } else if self.renderer.cpu_threads().is_some() {
            self.renderer.draw_on_device().map_err(Error::from)
        } else {
            CpuRenderer::new().and_then(|cpu| Ok(self.renderer.draw_on_cpu(cpu)?))
        };
        match switched {
            Ok(()) if self.shader_edited && self.renderer.cpu_threads().is_some() => errln!(
                "raycast: preview: {} draws: the code raycast was built with, not the edited shader",
                self.drawn_by()
            ),
            Ok(()) => errln!("raycast: preview: {} draws", self.drawn_by()),
            Err(e) => {
                errln!("raycast: preview: error: cannot switch who draws: {e}");
                self.error = Some(format!("cannot switch who draws: {e}"));
            }
        }
        self.restart();
    }

    /// Who draws the samples, for the title.
    fn drawn_by(&self) -> String {
        match self.renderer.cpu_threads() {
            Some(n) => format!("CPU build ({n} threads)"),
            None => self.device.clone(),
        }
    }

    fn restart(&mut self) {
        self.sample = 0;
        self.band_next = 0;
    }

    /// Scripted runs: with `--moving N`, the frame rate of those frames
    /// (the first left out: it renders at full size, before any cost is
    /// known); then that of the frames at rest (the last one's time is not
    /// known: nothing follows it), each a whole sample at the picture's size.
    fn report_rates(&self) {
        if self.moving_frames > 0 {
            let times: Vec<(Duration, [u32; 2])> = self.moving_times.iter().skip(1).copied().collect();
            if times.is_empty() {
                outln!("moving: too few frames to time (--moving 2 or more, with --frames more than that)");
            } else {
                outln!(
                    "moving: {} (the picture {}x{}): {}",
                    frames_at(&times),
                    self.renderer.size()[0],
                    self.renderer.size()[1],
                    rate(&times)
                );
            }
        }
        if !self.rest_times.is_empty() {
            outln!("at rest: {}: {}", frames_at(&self.rest_times), rate(&self.rest_times));
        }
    }

    /// The camera moved: start over, at a lower resolution for a moment
    /// (`motion_scale`).
    fn moved(&mut self) {
        self.restart();
        self.last_move = Some(Instant::now());
    }

    /// The divisor of the picture's width and height for the next frame:
    /// 1 at rest and in scripted runs (but for --moving); while the camera moves (and for
    /// MOTION_HOLD after), the smallest that keeps a frame within
    /// the frame budget at the cost per pixel measured so far, at most 8
    /// (`motion_scale`). A slow device (lavapipe) stays interactive while
    /// you steer; the picture sharpens once you stop.
    fn motion_scale(&self, at_rest: bool) -> f64 {
        let moving = self.last_move.is_some_and(|t| t.elapsed() < MOTION_HOLD);
        if at_rest || !moving {
            return 1.0;
        }
        let [w, h] = self.renderer.size();
        motion_scale(self.pixel_cost.estimate(), u64::from(w) * u64::from(h), self.frame_budget_ms())
    }

    /// MOTION_FRAME_MS of whoever draws now: the CPU build, or the device.
    fn frame_budget_ms(&self) -> f64 {
        frame_budget_ms(self.renderer.cpu_threads().is_some() || self.device_on_cpu)
    }

    fn on_event(&mut self, event: WindowEvent, window: &mut glfw::PWindow) -> Result<(), Error> {
        match event {
            WindowEvent::Close => window.set_should_close(true),
            WindowEvent::Key(key, _, Action::Press, mods) => self.on_key(key, mods, window),
            WindowEvent::MouseButton(button, action, _) => {
                let at = self.mouse.cursor;
                match (button, action) {
                    (MouseButton::Button1, Action::Press) => {
                        self.mouse.left_from = Some(at);
                        self.mouse.orbiting = false;
                    }
                    (MouseButton::Button1, Action::Release) => {
                        let clicked = self.mouse.left_from.take().is_some() && !self.mouse.orbiting;
                        self.mouse.orbiting = false;
                        if clicked {
                            self.pick(at, window)?;
                        }
                    }
                    (MouseButton::Button2 | MouseButton::Button3, Action::Press) => self.mouse.panning = true,
                    (MouseButton::Button2 | MouseButton::Button3, Action::Release) => self.mouse.panning = false,
                    _ => {}
                }
            }
            WindowEvent::CursorPos(x, y) => {
                let (dx, dy) = (x - self.mouse.cursor.0, y - self.mouse.cursor.1);
                self.mouse.cursor = (x, y);
                if let Some(from) = self.mouse.left_from {
                    if !self.mouse.orbiting && ((x - from.0).powi(2) + (y - from.1).powi(2)).sqrt() > CLICK_SLOP {
                        self.mouse.orbiting = true;
                        // The drag so far counts.
                        self.camera.orbit(-(x - from.0) * ORBIT_DEG_PER_PIXEL, (y - from.1) * ORBIT_DEG_PER_PIXEL);
                        self.moved();
                    } else if self.mouse.orbiting {
                        self.camera.orbit(-dx * ORBIT_DEG_PER_PIXEL, dy * ORBIT_DEG_PER_PIXEL);
                        self.moved();
                    }
                } else if self.mouse.panning && (dx != 0.0 || dy != 0.0) {
                    let (_, wh) = window.get_size();
                    self.camera.pan(dx, dy, f64::from(wh.max(1)));
                    self.moved();
                }
            }
            WindowEvent::Scroll(_, y) if y != 0.0 => {
                self.camera.dolly(y);
                self.moved();
            }
            _ => {}
        }
        Ok(())
    }

    fn on_key(&mut self, key: Key, _mods: glfw::Modifiers, window: &mut glfw::PWindow) {
        let aov = match key {
            Key::Num1 | Key::Kp1 => Some(Aov::Color),
            Key::Num2 | Key::Kp2 => Some(Aov::Normal),
            Key::Num3 | Key::Kp3 => Some(Aov::Depth),
            Key::Num4 | Key::Kp4 => Some(Aov::Id),
            Key::Num5 | Key::Kp5 => Some(Aov::Cost),
            Key::Num6 | Key::Kp6 => Some(Aov::CostAll),
            _ => None,
        };
        if let Some(a) = aov {
            self.aov = a;
            self.restart();
            return;
        }
        match key {
            Key::Escape => window.set_should_close(true),
            Key::R => {
                self.camera.reset();
                self.restart();
            }
            Key::F => {
                if let Some(b) = self.bounds {
                    let [w, h] = self.renderer.size();
                    self.camera.frame(&b, f64::from(w) / f64::from(h));
                    self.restart();
                }
            }
            Key::C => outln!("{}", self.camera.cameradata_block()),
            Key::H => {
                self.shadows = !self.shadows;
                self.restart();
            }
            Key::M => {
                self.reflections = !self.reflections;
                self.restart();
            }
            Key::G => {
                self.refraction = !self.refraction;
                self.restart();
            }
            Key::T if !self.textures_loaded => {
                errln!("raycast: preview: no textures were loaded (--no-textures): start without it to turn them on");
            }
            Key::T => {
                self.textures = !self.textures;
                self.restart();
            }
            Key::B => self.switch_drawing(),
            Key::K => self.recompile = true,
            Key::F1 => outln!("{HELP}"),
            _ => {}
        }
    }

    /// WASD / QE while held, at a speed relative to the scene's size.
    fn fly(&mut self, window: &glfw::PWindow, dt: f64) {
        let held = |k: Key| if window.get_key(k) == Action::Press { 1.0 } else { 0.0 };
        let forward = held(Key::W) - held(Key::S);
        let right = held(Key::D) - held(Key::A);
        let up = held(Key::E) - held(Key::Q);
        if forward == 0.0 && right == 0.0 && up == 0.0 {
            return;
        }
        let fast = if window.get_key(Key::LeftShift) == Action::Press { 4.0 } else { 1.0 };
        let size = self.bounds.map_or(2.0, |b| b.radius().max(1e-3));
        let step = size * 0.5 * fast * dt;
        self.camera.fly(forward * step, right * step, up * step);
        self.moved();
    }

    fn on_reload(&mut self, reload: Reload) -> Result<(), Error> {
        match reload {
            Reload::Scene(loaded) => {
                let (scene, data) = *loaded;
                for w in &scene.warnings {
                    errln!("{w}");
                }
                for note in &data.notes {
                    errln!("raycast: note: {note}");
                }
                // An array beyond a storage buffer of the drawing device:
                // the last good scene stays, as after a parse error.
                if let Err(e @ GpuError::TooLarge { .. }) = self.renderer.set_scene(&data) {
                    self.reload_failed(&format!(
                        "raycast: preview: error: {} cannot draw the reloaded {}: {e}",
                        self.device,
                        scene.path.display()
                    ));
                    return Ok(());
                }
                let new_camera = scene.camera != self.scene.camera;
                self.bounds = scene_bounds(&scene);
                if new_camera {
                    self.camera = CameraControl::new(&scene.camera, self.bounds);
                }
                errln!(
                    "raycast: preview: reloaded {} ({} primitives, {} lights)",
                    scene.path.display(),
                    data.primitives.len(),
                    data.lights.len()
                );
                self.scene = scene;
                self.data = data;
                self.error = None;
                self.restart();
            }
            Reload::Kernel(kernels) => match self.renderer.set_kernels(kernels, &self.data)? {
                Ok(()) => {
                    errln!("raycast: preview: reloaded the kernel ({KERNEL_FILE})");
                    self.shader_edited = true;
                    if let Some(why) = self.renderer.device_cannot_draw() {
                        errln!(
                            "raycast: preview: the reloaded kernel cannot draw this scene on {}: {why}; the CPU build \
                             goes on drawing the code raycast was built with",
                            self.device
                        );
                    } else if self.renderer.cpu_threads().is_some() {
                        self.renderer.draw_on_device()?;
                        errln!(
                            "raycast: preview: {} draws from now on: the CPU build is the code raycast was built with \
                             and cannot follow a shader edit (B switches back to it)",
                            self.device
                        );
                    }
                    self.error = None;
                    self.restart();
                }
                Err(why) => self.reload_failed(&format!(
                    "raycast: preview: error: the reloaded kernel ({KERNEL_FILE}) does not build on the device: {why}"
                )),
            },
            Reload::Failed(message) => self.reload_failed(&message),
        }
        Ok(())
    }

    /// K: the watched shader folder compiled now and taken as an edit is
    /// (`on_reload`: the device draws from then on), whether or not a file
    /// changed: after an edit the watcher has not seen, or to hand the
    /// drawing to the device's kernel of the folder's code.
    fn recompile_shaders(&mut self) -> Result<(), Error> {
        let Some(folder) = self.shaders.clone() else {
            errln!("raycast: preview: K: no shader folder to recompile (the source tree's shaders/ is not here; use --shaders DIR)");
            return Ok(());
        };
        errln!("raycast: preview: recompiling the shaders of {}", folder.dir.display());
        self.on_reload(folder.compile())
    }

    /// A reload that did not take: says why, keeps the last good picture
    /// and shows the first error line in the title.
    fn reload_failed(&mut self, message: &str) {
        errln!("{message}");
        errln!("raycast: preview: keeping the last good picture");
        let first = message.lines().find(|l| l.contains("ERROR") || l.contains("error")).or(message.lines().next());
        let first = first.unwrap_or_default().trim();
        self.error = Some(first.strip_prefix("ERROR: ").unwrap_or(first).to_string());
    }

    /// Prints what the pixel under the cursor sees (the ray through its centre).
    fn pick(&mut self, cursor: (f64, f64), window: &glfw::PWindow) -> Result<(), Error> {
        let (ww, wh) = window.get_size();
        let [w, h] = self.renderer.frame_size();
        if ww <= 0 || wh <= 0 || self.sample == 0 {
            return Ok(());
        }
        let j = (cursor.0 / f64::from(ww) * f64::from(w)).floor();
        let i = (cursor.1 / f64::from(wh) * f64::from(h)).floor();
        if j < 0.0 || i < 0.0 || j >= f64::from(w) || i >= f64::from(h) {
            return Ok(());
        }
        self.pick_pixel(j as u32, i as u32)
    }

    /// Prints what pixel (j, i) of the picture sees, and in the colour view
    /// its sample 0's rays as `raycast trace` follows them (the CPU build,
    /// which gives the device's bits).
    fn pick_pixel(&mut self, j: u32, i: u32) -> Result<(), Error> {
        let [w, h] = self.renderer.frame_size();
        if j >= w || i >= h {
            errln!("raycast: preview: pixel ({j}, {i}) is outside the {w}x{h} picture");
            return Ok(());
        }
        let p = self.renderer.pixel(j, i)?;
        // The cost AOVs' passes (PixelOut.normal's w), hit or miss.
        match self.aov {
            Aov::Cost => outln!("pixel ({j}, {i}): its camera ray's walk took {} passes", p.normal[3]),
            Aov::CostAll => outln!("pixel ({j}, {i}): its rays' walks took {} passes in all", p.normal[3]),
            _ => {}
        }
        if p.id == NO_HIT {
            outln!("pixel ({j}, {i}): nothing (the ray misses every primitive)");
            return Ok(());
        }
        let Some(prim) = self.scene.primitive(u64::from(p.id)) else {
            outln!("pixel ({j}, {i}): primitive {} (not in the scene on the host: reloading?)", p.id);
            return Ok(());
        };
        // The ray through the pixel centre, as camera_ray in raycast.glsl (in f64, for the report).
        let world_from_film = frame::world_from_film(&self.camera.camera, w, h);
        let x = ((f64::from(j) + 0.5) / f64::from(w)) * 2.0 - 1.0;
        let y = 1.0 - ((f64::from(i) + 0.5) / f64::from(h)) * 2.0;
        let dir = world_from_film.transform_vector3(DVec3::new(x, y, -1.0));
        let hit = self.camera.camera.pos + dir * f64::from(p.t);
        let m = &self.scene.materials[prim.material as usize];
        let v3 = |v: DVec3| format!("({:.4}, {:.4}, {:.4})", v.x, v.y, v.z);
        outln!("pixel ({j}, {i}): primitive {} ({}) at {}", p.id, prim.shape.name(), prim.loc);
        outln!(
            "  t {} (ray direction not unit; distance {:.4}), position {}, normal {}",
            p.t,
            f64::from(p.t) * dir.length(),
            v3(hit),
            v3(DVec3::new(f64::from(p.normal[0]), f64::from(p.normal[1]), f64::from(p.normal[2])))
        );
        outln!("  material: {}", m.describe());
        self.print_trace(j, i)
    }

    /// The colour view's trace of pixel (j, i) (its sample 0, the centre ray).
    fn print_trace(&self, j: u32, i: u32) -> Result<(), Error> {
        if self.aov != Aov::Color {
            return Ok(());
        }
        let frame = self.frame_at(self.renderer.frame_size());
        let steps = crate::cpu::CpuRenderer::new()?.trace(&self.data, &frame, j, i, 0)?;
        if self.sample > 1 {
            // The window shows the mean of its samples; the trace follows the centre one.
            outln!("  its rays (`raycast trace`), sample 0 (the pixel centre) of the {} averaged here:", self.sample);
        } else {
            outln!("  its rays (`raycast trace`):");
        }
        for line in crate::trace::describe(&self.scene, &steps) {
            outln!("    {line}");
        }
        Ok(())
    }

    /// Writes the last frame's picture (the quantised bytes the kernel wrote) as RGB PNG.
    fn save(&mut self, path: &Path) -> Result<(), Error> {
        let [width, height] = self.renderer.frame_size();
        let pixels = self.renderer.pixels()?;
        crate::render::refuse_cut_short(
            &pixels,
            width,
            &self.device,
            "Turn mirror reflections off (M, or --no-reflections), or use another Vulkan device".into(),
        )?;
        let picture = Picture { width, height, pixels };
        image_io::write_png(path, &Rgb8 { width, height, data: picture.rgb8()? })?;
        let n = self.sample;
        outln!("wrote {} ({width}x{height}, {n} sample{} per pixel)", path.display(), if n == 1 { "" } else { "s" });
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::{band_rows, frame_budget_ms, jitter, motion_scale, refusal, PixelCost};

    /// The median of the last five: a spike leaves it, a lasting change moves it on the third frame.
    #[test]
    fn one_slow_frame_does_not_move_the_pixel_cost() {
        let mut c = PixelCost::default();
        assert_eq!(c.estimate(), None);
        c.push(f64::NAN);
        c.push(0.0);
        assert_eq!(c.estimate(), None);
        for v in [10.0, 1.0, 1.1, 0.9, 1.0] {
            c.push(v);
        }
        assert_eq!(c.estimate(), Some(1.0), "one slow frame among five");
        c.push(3.0);
        c.push(3.0);
        assert_eq!(c.estimate(), Some(1.1), "two of five at 3");
        c.push(3.0);
        assert_eq!(c.estimate(), Some(3.0), "three of five at 3");
    }

    #[test]
    fn bands_keep_a_frame_within_its_budget() {
        // Unknown cost, or the whole frame fits: all rows.
        let cpu = frame_budget_ms(true);
        assert_eq!(band_rows(None, 512, 384, cpu), 384);
        assert_eq!(band_rows(Some(1e-6), 512, 384, cpu), 384);
        // 2.69 s for 512x384: 125 ms is 17.8 rows, so 16 (two work groups).
        assert_eq!(band_rows(Some(2690.0 / (512.0 * 384.0)), 512, 384, cpu), 16);
        // Slower than a work group's rows in the budget: one work group anyway.
        assert_eq!(band_rows(Some(1.0), 512, 384, cpu), 8);
        // A GPU's 33 ms: 95 ms for 1920x1080 is 378.9 rows, so 376 (47 work groups).
        assert_eq!(band_rows(Some(95.0 / (1920.0 * 1080.0)), 1920, 1080, frame_budget_ms(false)), 376);
    }

    /// NVIDIA's driver is refused only a display that says it has neither
    /// NV-GLX nor DRI3; one that has either, or cannot be asked, is tried.
    #[test]
    fn a_display_is_refused_only_without_both_ways_to_present() {
        // Answers for NVIDIA_PRESENTS_THROUGH: NV-GLX, DRI3.
        let m = refusal(Ok(vec![false, false]), ":7", "why").expect("neither NV-GLX nor DRI3: refused");
        assert!(m.starts_with("the X display :7 has neither NV-GLX") && m.ends_with("nor DRI3, why"), "{m}");
        assert_eq!(refusal(Ok(vec![false, true]), ":7", "why"), None, "DRI3 (XWayland, PRIME)");
        assert_eq!(refusal(Ok(vec![true, false]), ":7", "why"), None, "NVIDIA's X driver");
        assert_eq!(refusal(Err("no libX11".to_string()), ":7", "why"), None, "cannot ask: tried");
    }

    #[test]
    fn motion_scale_keeps_a_moving_frame_within_its_budget() {
        let pixels = 512 * 384;
        let (cpu, gpu) = (frame_budget_ms(true), frame_budget_ms(false));
        assert_eq!((cpu, gpu), (125.0, 1000.0 / 30.0), "8 frames a second on a CPU, 30 on a GPU");
        // Unknown cost, or a fast device: full resolution.
        assert_eq!(motion_scale(None, pixels, cpu), 1.0);
        assert_eq!(motion_scale(Some(f64::NAN), pixels, cpu), 1.0);
        assert_eq!(motion_scale(Some(10.0 / pixels as f64), pixels, cpu), 1.0);
        // 2.69 s a frame: 2690 / 125 = 21.5 times the budget, s >= 4.64: 2^(9/4) = 4.76,
        // 108x81 pixels, about 120 ms.
        assert_eq!(motion_scale(Some(2690.0 / pixels as f64), pixels, cpu), 2f64.powf(9.0 / 4.0));
        // 0.24 s (depth 6 without shadows on lavapipe): 2^(2/4), 363x272, about 120 ms.
        assert_eq!(motion_scale(Some(240.0 / pixels as f64), pixels, cpu), 2f64.sqrt());
        // Exactly at the budget stays; just over takes the next step.
        assert_eq!(motion_scale(Some(125.0 * 4.0 / pixels as f64), pixels, cpu), 2.0);
        assert_eq!(motion_scale(Some(125.0 * 4.01 / pixels as f64), pixels, cpu), 2f64.powf(5.0 / 4.0));
        // Never beyond the cap.
        assert_eq!(motion_scale(Some(1.0), pixels, cpu), 8.0);
        // A GPU at 1920x1080, 95 ms a frame (depth 10 with shadows on an H200): 2.85 times
        // its budget, s >= 1.69: 2^(4/4) = 2, 960x540, about 24 ms; at 512x384, 7.2 ms: whole.
        assert_eq!(motion_scale(Some(95.0 / (1920.0 * 1080.0)), 1920 * 1080, gpu), 2.0);
        assert_eq!(motion_scale(Some(7.2 / pixels as f64), pixels, gpu), 1.0);
    }

    #[test]
    fn jitter_is_centred_and_spread() {
        assert_eq!(jitter(0), [-0.5, -0.5], "index 0 of Halton is 0; sample 0 does not use it");
        assert_eq!(jitter(1), [0.0, (1.0f64 / 3.0 - 0.5) as f32]);
        for i in 1..256 {
            let [x, y] = jitter(i);
            assert!((-0.5..0.5).contains(&x) && (-0.5..0.5).contains(&y), "sample {i}: {x}, {y}");
        }
    }
}
