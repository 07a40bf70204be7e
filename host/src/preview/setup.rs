//! The preview's set-up: the scene loaded, the window opened, the devices
//! chosen (which draws, which shows), the kernels built, then the loop
//! (`app`) until the window closes.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};

use ash::vk::{self, Handle};

use crate::cpu::{CpuProgressive, CpuRenderer};
use crate::error::{check_validation, validation_wanted, Error};
use crate::frame::RenderSettings;
use crate::gpu::{DeviceInfo, DeviceSelector, GpuContext, GpuError, GpuOptions, KernelChoice};
use crate::render::Backend;
use crate::scene::{FlattenLimits, ParseOptions};
use crate::source::load_scene;

use super::app::Preview;
use super::display::{window_refuses, REFUSED_ADVICE};
use super::reload::{Reload, ShaderFolder, WatchConfig, Watcher, KERNEL_FILE};
use super::renderer::{PreviewKernels, PreviewRenderer};
use super::PreviewSettings;

pub fn run(args: &PreviewSettings) -> Result<(), Error> {
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
    let data = crate::source::pack(&scene, &settings)?;
    if args.backend == Backend::Cpu && args.kernel == KernelChoice::Fast {
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
        kernel: args.kernel,
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
                && args.kernel != KernelChoice::Fast
                && candidate.runs_on_cpu() =>
        {
            Some(format!("--backend auto: {} runs on the CPU", candidate.name))
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
    let cpu = cpu_why.as_ref().map(|why| CpuRenderer::new().map(|c| c.chosen_because(why))).transpose()?;
    match (&cpu, &apart) {
        (Some(c), _) => outln!("device: {}; the window through {}", c.summary(), info.summary()),
        (_, Some(a)) => outln!("device: {}; the window through {}", a.info().summary(), info.summary()),
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
    let mode = args.present_mode;
    let cpu = cpu.map(|c| Box::new(CpuProgressive::new(c, size)) as Box<dyn crate::render::Progressive>);
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
    args: &PreviewSettings,
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
