//! The options every rendering command shares (`render`, `check`, `bench`,
//! `trace`, `conformance`): the picture, the quality, the device.

use super::values::*;
use crate::cpu::CpuRenderer;
use crate::error::{check_validation, validation_wanted, Error};
use crate::frame::{Aov, RenderSettings, Supersample, TextureFilter};
use crate::gpu::{DeviceSelector, GpuOptions, GpuRenderer, KernelChoice, SceneBuffers};
use crate::render::{Backend, Renderer};
use crate::scene::{FlattenLimits, ParseOptions};
use clap::Args;
use std::path::{Path, PathBuf};
use std::time::Duration;

/// The options the exporters (`pov`, `mitsuba`) share, the scene and the
/// output aside: where to find the scene's files, the picture's size.
#[derive(Args, Debug)]
pub struct ExportOptions {
    /// Extra folder to find textures and meshes in (repeatable)
    ///
    /// Extra folder to find textures and meshes in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR", help_heading = "Picture")]
    pub assets: Vec<PathBuf>,
    /// Picture width in pixels (1 to 16384)
    ///
    /// The picture's width, for the camera's film (and, in `pov`, the command line in the file's head).
    #[arg(long, default_value_t = 512, value_name = "W", value_parser = parse_width, help_heading = "Picture")]
    pub width: u32,
    /// Picture height in pixels (1 to 16384)
    ///
    /// The picture's height.
    #[arg(long, default_value_t = 384, value_name = "H", value_parser = parse_height, help_heading = "Picture")]
    pub height: u32,
}

/// The options of every command that renders frames (`render`, `check`,
/// `bench`), the scene aside.
#[derive(Args, Clone, Debug)]
pub struct RenderOptions {
    /// Picture width in pixels (1 to 16384)
    #[arg(long, default_value_t = 512, value_name = "W", value_parser = parse_width, help_heading = "Picture")]
    pub width: u32,
    /// Picture height in pixels (1 to 16384)
    #[arg(long, default_value_t = 384, value_name = "H", value_parser = parse_height, help_heading = "Picture")]
    pub height: u32,
    /// color (default), normal, depth, id, cost[-all], samples
    #[arg(long, value_enum, default_value_t = Aov::Color, help_heading = "Picture", hide_possible_values = true,
          hide_default_value = true, long_help = with_values::<Aov>("What the picture shows [default: color]"))]
    pub aov: Aov,
    /// With --aov depth: the distances drawn white and black
    ///
    /// With `--aov depth`: the distances from the eye drawn white and black
    /// [default: the scene's bounding sphere, nearest to farthest]
    #[arg(long, value_name = "NEAR,FAR", value_parser = parse_depth_range, allow_hyphen_values = true,
          help_heading = "Picture", hide_short_help = true)]
    pub depth_range: Option<[f32; 2]>,
    /// With --aov cost or cost-all: the passes drawn dark red
    ///
    /// With `--aov cost` or `cost-all`: the passes drawn dark red (and beyond) [default: 64, cost-all 256]
    #[arg(long, value_name = "N", value_parser = parse_cost_max, help_heading = "Picture", hide_short_help = true)]
    pub cost_max: Option<u32>,
    /// Turn shadow rays off
    #[arg(long, help_heading = "Picture")]
    pub no_shadows: bool,
    /// Turn mirror reflections off
    #[arg(long, help_heading = "Picture")]
    pub no_reflections: bool,
    /// Turn refraction off: transparent materials drawn opaque
    #[arg(long, help_heading = "Picture", hide_short_help = true)]
    pub no_refraction: bool,
    /// Turn texture mapping off
    #[arg(long, help_heading = "Picture")]
    pub no_textures: bool,
    /// Turn depth of field off (the pinhole camera)
    #[arg(long, help_heading = "Picture", hide_short_help = true)]
    pub no_dof: bool,
    /// Points on each area light a sample, 1 to 1024
    ///
    /// Points on each area light a sample, 1 to 1024 [default: 16]: the
    /// soft shadows converge with these and with --spp.
    #[arg(long, default_value_t = crate::frame::DEFAULT_LIGHT_SAMPLES, value_name = "N",
          value_parser = parse_light_samples, help_heading = "Quality", hide_default_value = true, hide_short_help = true)]
    pub light_samples: u32,
    /// Mirror bounces, 0 to 16 (alias --depth)
    #[arg(long, alias = "depth", default_value_t = 4, value_name = "N", value_parser = parse_bounces, help_heading = "Picture")]
    pub bounces: u32,
    /// Extra folder to find textures in (repeatable)
    ///
    /// Extra folder to find textures in, after the scene file's folder
    /// (repeatable). Generated scenes (`raycast gen`) name the corpus's
    /// texture: pass the corpus root.
    #[arg(long, value_name = "DIR", help_heading = "Picture")]
    pub assets: Vec<PathBuf>,
    /// Samples per pixel (a fixed pattern)
    ///
    /// Samples per pixel, in a fixed pattern (the same on every device and the CPU).
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = parse_spp, help_heading = "Quality")]
    pub spp: u32,
    /// pattern (default) or course (adaptive)
    #[arg(long, value_enum, default_value_t = Supersample::Pattern, value_name = "S", help_heading = "Quality",
          hide_possible_values = true, hide_default_value = true,
          long_help = with_values::<Supersample>("Where a pixel's samples go [default: pattern]"))]
    pub supersample: Supersample,
    /// nearest (default), bilinear or course
    #[arg(long, value_enum, default_value_t = TextureFilter::Nearest, value_name = "F", help_heading = "Quality",
          hide_possible_values = true, hide_default_value = true,
          long_help = with_values::<TextureFilter>("How textures are sampled [default: nearest]"))]
    pub texture_filter: TextureFilter,
    /// Test every primitive for every ray (no hierarchy; same picture)
    ///
    /// Test every primitive for every ray: no bounding volume hierarchy. The
    /// picture is identical; only slower.
    #[arg(long, help_heading = "Quality", hide_short_help = true)]
    pub no_bvh: bool,
    /// Refuse scenes that expand to more primitives than this
    ///
    /// Refuse scenes that expand to more primitives than this (`bench` lists
    /// them as skipped and goes on).
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N",
          help_heading = "Quality", hide_short_help = true)]
    pub max_primitives: usize,
    #[command(flatten)]
    pub kernel: KernelOptions,
    /// `render --like PNG`: each scene drawn as the course drew PNG, in
    /// place of the picture's options (`settings_for`).
    #[arg(skip)]
    pub like: Option<Like>,
}

/// A picture to draw like (`render --like`): its path and size.
#[derive(Clone, Debug)]
pub struct Like {
    pub png: PathBuf,
    pub width: u32,
    pub height: u32,
}

/// The device and the kernel of the commands that render on a device
/// (`render`, `check`, `bench`, `conformance`).
#[derive(Args, Clone, Debug)]
pub struct KernelOptions {
    /// From `raycast devices`: an index or part of a name
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Device")]
    pub device: Option<DeviceSelector>,
    /// Compile the device's kernel from DIR/render.comp
    ///
    /// Compile the device's kernel from DIR/render.comp at start-up instead of
    /// the one built in (the CPU build is always the built-in code).
    #[arg(long, value_name = "DIR", help_heading = "Device")]
    pub shaders: Option<PathBuf>,
    /// Scene arrays in storage buffers or uniform blocks
    ///
    /// Where the device kernel keeps the scene's arrays: storage images and
    /// uniform blocks (render_uniform.comp, several times faster on
    /// lavapipe) when the scene fits them, storage buffers (render.comp, any
    /// size) otherwise; or either one.
    #[arg(long, value_enum, default_value_t = SceneBuffers::Auto, help_heading = "Device", hide_short_help = true)]
    pub scene_buffers: SceneBuffers,
    /// Enable the Khronos validation layer (exit 3 on any message)
    ///
    /// Enable the Khronos validation layer (slow: not for timing); any
    /// message fails the command (exit 3; `conformance`: its case).
    /// Also on when RAYCAST_VALIDATION=1.
    #[arg(long, help_heading = "Diagnostics", hide_short_help = true)]
    pub validate: bool,
    /// Longest one submission may take on the device [default: 600]
    ///
    /// The longest the device may take over one submission of its work
    /// before the command gives up with an error (a kernel that never ends,
    /// say a shader edit's endless loop). The samples go in submissions of
    /// about a quarter of a second each, so this bounds one sample of the
    /// picture, or of a band of its rows: raise it for a huge or very slow
    /// picture (`--no-bvh` on millions of primitives).
    /// [default: 600]
    #[arg(long, value_name = "SECONDS", value_parser = parse_timeout, help_heading = "Device", hide_short_help = true)]
    pub timeout: Option<Duration>,
    #[command(flatten)]
    pub choice: KernelChoiceArgs,
}

impl KernelOptions {
    /// `--timeout`, or its default.
    pub fn timeout(&self) -> Duration {
        self.timeout.unwrap_or(crate::gpu::GpuOptions::default().timeout)
    }

    /// The options given that only a Vulkan device uses (by flag), which
    /// the CPU build would ignore: `trace` and `--backend cpu` refuse them.
    pub(crate) fn device_only_given(&self) -> Vec<&'static str> {
        [
            ("--device", self.device.is_some()),
            ("--shaders", self.shaders.is_some()),
            ("--scene-buffers", self.scene_buffers != SceneBuffers::Auto),
            ("--validate", self.validate),
            ("--timeout", self.timeout.is_some()),
            ("--kernel fast", self.choice.choice() == KernelChoice::Fast),
        ]
        .into_iter()
        .filter_map(|(flag, given)| given.then_some(flag))
        .collect()
    }

    /// The render kernel on the device these options name (`open_renderer`).
    pub(crate) fn renderer(&self) -> Result<GpuRenderer, Error> {
        open_renderer(self, self.shaders.as_deref())
    }

    /// `--kernel fast` given to `command`, which compares bits (`check`): a
    /// usage error, as only the exact kernel gives the CPU build's.
    pub(crate) fn refuse_fast(&self, command: &str) -> Result<(), Error> {
        if self.choice.choice() != KernelChoice::Fast {
            return Ok(());
        }
        Err(Error::Usage(format!(
            "{command} compares the device's pixels with the CPU build's bits, which only the exact kernel gives: \
             drop --kernel fast (`raycast compare` weighs two pictures within a tolerance)"
        )))
    }

    /// `renderer` with the exact kernel, whatever `--kernel` said (`refuse_fast`): `check`'s.
    pub(crate) fn exact_renderer(&self) -> Result<GpuRenderer, Error> {
        let exact = KernelChoiceArgs { kernel: KernelChoice::Exact, exact: false };
        KernelOptions { choice: exact, ..self.clone() }.renderer()
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
            max_depth: self.bounces,
            bvh: !self.no_bvh,
            spp: self.spp,
            supersample: self.supersample,
            texture_filter: self.texture_filter,
            depth_range: self.depth_range,
            cost_max: self.cost_max,
            dof: !self.no_dof,
            light_samples: self.light_samples,
            refraction: !self.no_refraction,
        }
    }

    /// How the scene files are read: textures looked for in `--assets`,
    /// and not at all under `--no-textures`.
    pub fn parse_options(&self) -> ParseOptions {
        ParseOptions { assets: self.assets.clone(), skip_textures: self.no_textures }
    }

    /// The settings for `scene`: these options', or with `--like` the
    /// course's for its picture and the scene (`conformance::course_look`),
    /// with what chose them for `-v`.
    pub fn settings_for(&self, scene: Option<&Path>) -> (RenderSettings, Option<String>) {
        let settings = self.settings();
        let Some(like) = &self.like else { return (settings, None) };
        let look = crate::conformance::course_look(scene, &like.png, like.width, like.height);
        let sampling = match look.supersample {
            Supersample::Course => "the course's adaptive supersampling".to_string(),
            Supersample::Pattern => format!("{} sample{} a pixel", look.spp, if look.spp == 1 { "" } else { "s" }),
        };
        let view = if look.aov == Aov::Color { String::new() } else { format!(", the {} view", look.aov.name()) };
        let lit = if look.features { "shadows, reflections and textures on" } else { "local Phong only" };
        let said = format!(
            "like {}: {}x{}, {sampling}{view}, {lit} (as the course drew {})",
            like.png.display(),
            look.width,
            look.height,
            look.because
        );
        (look.apply(&settings), Some(said))
    }
}

/// The render kernel on the device `--device` names (validated where
/// asked, with `--timeout`), built in or compiled from `shaders`, reading
/// the scene as `--scene-buffers` says: for `render`, `check` and `bench`.
pub(crate) fn open_renderer(k: &KernelOptions, shaders: Option<&Path>) -> Result<GpuRenderer, Error> {
    let options = GpuOptions {
        device: k.device.clone(),
        validation: validation_wanted(k.validate),
        timeout: k.timeout(),
        kernel: k.choice.choice(),
    };
    let mut renderer = match shaders {
        Some(dir) => GpuRenderer::from_shaders(&options, dir)?,
        None => GpuRenderer::new(&options)?,
    };
    renderer.set_scene_buffers(k.scene_buffers);
    Ok(renderer)
}

/// `--backend cpu` with options only a Vulkan device uses (`--device`,
/// `--scene-buffers`, `--validate`, `--timeout`; `--shaders` with its own
/// message): a usage error, as the CPU build would silently ignore them.
pub(crate) fn cpu_takes_no_device_options(cpu_only: bool, k: &KernelOptions) -> Result<(), Error> {
    cpu_takes_no_shaders(cpu_only, &k.shaders)?;
    let given = k.device_only_given();
    if !cpu_only || given.is_empty() {
        return Ok(());
    }
    Err(Error::Usage(format!(
        "{} {} for a Vulkan device, and --backend cpu runs the CPU build without one: drop {}, or \
             the --backend cpu",
        crate::units::listed(&given, "and"),
        if given.len() == 1 { "is" } else { "are" },
        if given.len() == 1 { "it" } else { "them" }
    )))
}

/// `--shaders DIR` with `--backend cpu`: a usage error, since the CPU build
/// is the code raycast was built with and would silently ignore DIR.
pub(crate) fn cpu_takes_no_shaders(cpu_only: bool, shaders: &Option<PathBuf>) -> Result<(), Error> {
    match (cpu_only, shaders) {
        (true, Some(dir)) => Err(Error::Usage(format!(
            "--shaders {} compiles the device's kernel, but --backend cpu runs the CPU build raycast was \
                 built with: drop one (rebuild raycast to put a shader change into the CPU build)",
            dir.display()
        ))),
        _ => Ok(()),
    }
}

/// Where `render` and `conformance` run. `--backend auto` takes the device
/// unless it runs on the CPU (a Vulkan device of type CPU, as lavapipe: the
/// CPU build of the same code is about twice as fast there, without
/// Vulkan's start-up or a pipeline to build, and on lavapipe gives the same
/// bits) or, without `--device`, none opens (no driver, no device): then
/// the CPU build, and its `device:` line says why. With `--shaders` it is
/// the device (the folder's kernel runs only there), as with any option
/// only a device uses (`KernelOptions::device_only_given`).
pub(crate) fn open_backend(backend: Backend, k: &KernelOptions) -> Result<Box<dyn Renderer>, Error> {
    let cpu = |why: &str| -> Result<Box<dyn Renderer>, Error> { Ok(Box::new(CpuRenderer::new()?.chosen_because(why))) };
    match backend {
        Backend::Cpu => cpu(""),
        Backend::Gpu => Ok(Box::new(k.renderer()?)),
        // Options only a device uses (a shader folder, a device named,
        // validation, a buffer kind, a timeout) ask for the device.
        Backend::Auto if !k.device_only_given().is_empty() => Ok(Box::new(k.renderer()?)),
        Backend::Auto => match k.renderer() {
            Ok(renderer) if renderer.context().info().runs_on_cpu() => {
                let why = format!("--backend auto: {} runs on the CPU", renderer.context().info().name);
                check_validation(renderer.context().take_validation_messages())?;
                drop(renderer);
                cpu(&why)
            }
            Ok(renderer) => Ok(Box::new(renderer)),
            Err(e) if k.device.is_none() => {
                let message = e.to_string();
                errln!("raycast: note: {message}; --backend auto renders with the CPU build instead");
                cpu("--backend auto: no Vulkan device opened")
            }
            Err(e) => Err(e),
        },
    }
}

/// The backend `render` runs on, announced.
pub(crate) fn open_render_backend(backend: Backend, o: &RenderOptions) -> Result<Box<dyn Renderer>, Error> {
    let opened = open_backend(backend, &o.kernel)?;
    detail!("device: {}", opened.info().summary);
    Ok(opened)
}

/// `--kernel` and its shorthand `--exact`: the device's exact kernel or its
/// fast one (docs/exactness.md, "The fast kernel"), for every command that
/// runs the render kernel on a device (`render`, `bench`, `conformance`,
/// `preview`; `check` runs the exact one only).
#[derive(Args, Clone, Copy, Debug, Default)]
pub struct KernelChoiceArgs {
    /// auto (default), exact or fast
    #[arg(long = "kernel", value_enum, default_value_t = KernelChoice::Auto, value_name = "K", help_heading = "Device",
          hide_possible_values = true, hide_default_value = true, hide_short_help = true, long_help = with_values::<KernelChoice>(
              "Which kernel the device runs: exact (the CPU build's bits on every device), fast (the device's own \
               division, square root and transcendentals: faster on GPUs, within 2/255 of the CPU build on all but \
               a few pixels), or auto: fast on a discrete or integrated GPU, exact on every other device (lavapipe). \
               [default: auto]"))]
    pub kernel: KernelChoice,
    /// The exact kernel on any device: --kernel exact
    #[arg(long, conflicts_with = "kernel", help_heading = "Device", hide_short_help = true)]
    pub exact: bool,
}

impl KernelChoiceArgs {
    /// The choice `--kernel` or `--exact` made.
    pub fn choice(&self) -> KernelChoice {
        if self.exact {
            KernelChoice::Exact
        } else {
            self.kernel
        }
    }
}
