//! `raycast preview`: its flags, turned into the preview's settings.

use super::options::{cpu_takes_no_shaders, KernelChoiceArgs};
use super::values::*;
use crate::error::Error;
use crate::frame::Aov;
use crate::gpu::{DeviceSelector, PresentMode};
use crate::preview::{KeyPresses, PreviewSettings};
use crate::render::Backend;
use crate::scene::FlattenLimits;
use clap::Args;
use std::path::PathBuf;

/// `raycast preview` flags.
#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// An XML file (reloaded) or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene file (XML), reloaded when it changes, or a generated scene (gen:recursive-spheres:6).
    /// Without one, the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Window (and picture) width
    #[arg(long, default_value_t = 512, value_name = "W", value_parser = parse_width,
          help_heading = "Picture")]
    pub width: u32,
    /// Window (and picture) height
    #[arg(long, default_value_t = 384, value_name = "H", value_parser = parse_height,
          help_heading = "Picture")]
    pub height: u32,
    /// Device that draws, from `raycast devices`
    ///
    /// Vulkan device that draws: an index from `raycast devices` or part of its name.
    /// Where it cannot present to this window (NVIDIA's driver under Xvfb or VNC),
    /// it draws and the first device that can present shows its pixels.
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Device")]
    pub device: Option<DeviceSelector>,
    /// Device that shows the window, if another
    ///
    /// Vulkan device that shows the window, apart from the one that draws
    /// (--device, or the CPU build): each frame's pixels come back through the
    /// host to it. Without it, the drawing device shows them itself where it can.
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Device")]
    pub window_device: Option<DeviceSelector>,
    /// Extra folder to find textures in (repeatable)
    ///
    /// Extra folder to find textures in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR", help_heading = "Picture")]
    pub assets: Vec<PathBuf>,
    /// fifo (default), mailbox or immediate
    ///
    /// When a finished frame replaces the one on screen (fifo: at vertical blank).
    #[arg(long, value_enum, default_value_t = PresentMode::Fifo, value_name = "MODE", help_heading = "Device",
          hide_possible_values = true, hide_default_value = true)]
    pub present_mode: PresentMode,
    /// Render N frames (N samples per pixel), then exit
    ///
    /// Render N frames (N samples per pixel), then exit; with --screenshot, save the last.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), help_heading = "Output")]
    pub frames: Option<u32>,
    /// Save the picture as PNG after the last frame
    ///
    /// Save the window's picture as PNG after the last frame (1 frame unless --frames says more).
    #[arg(long, value_name = "PATH", help_heading = "Output")]
    pub screenshot: Option<PathBuf>,
    /// With --frames: turn the camera over the first N
    ///
    /// With --frames: turn the camera a little before each of the first N
    /// frames, as a drag would, so that they render at the resolution the
    /// preview uses while you steer; then print their frame rate. Measures
    /// how steering feels on a device.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        requires = "frames",
        help_heading = "Diagnostics",
        hide_default_value = true
    )]
    pub moving: u32,
    /// Who draws: auto (default), gpu or cpu
    #[arg(long, value_enum, default_value_t = Backend::Auto, help_heading = "Device", hide_possible_values = true,
          hide_default_value = true, long_help = with_values::<Backend>(
              "Who draws the samples: the Vulkan device, or the C++ build of the shared GLSL on every core (the \
               same pixels; the device still shows them), or auto: the CPU build where the device runs on the CPU \
               (lavapipe, where it is the faster), the device otherwise and with --shaders. An edited shader hands \
               the drawing to the device (the CPU build cannot follow it); B in the window switches who draws. \
               [default: auto]"))]
    pub backend: Backend,
    /// Watch DIR and compile preview.comp from it
    ///
    /// Shader folder to watch and recompile preview.comp from [default: the source tree's shaders/].
    #[arg(long, value_name = "DIR", help_heading = "Device")]
    pub shaders: Option<PathBuf>,
    /// color (default), normal, depth, id, cost, cost-all
    #[arg(long, value_enum, default_value_t = Aov::Color, help_heading = "Picture", hide_possible_values = true,
          hide_default_value = true, long_help = with_values::<Aov>("What the window shows at first (keys 1 to 6 switch) [default: color]"))]
    pub aov: Aov,
    /// With --frames: click pixel X,Y after the last
    ///
    /// With --frames: after the last frame, click pixel (X, Y) of the
    /// picture, as a left click does (what it sees, then its rays as
    /// `raycast trace` follows them).
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, requires = "frames",
          help_heading = "Diagnostics")]
    pub click: Option<(u32, u32)>,
    /// With --frames: press keys before frames (2:H,3:B)
    ///
    /// With --frames: press keys as in the window, each just before frame N
    /// (counted from 1): N:KEY,… with KEY one of 1 to 6, H, M, T, R, F, C,
    /// B and K (say 2:H,3:B).
    #[arg(long, value_name = "KEYS", value_parser = str::parse::<KeyPresses>, requires = "frames",
          help_heading = "Diagnostics")]
    pub keys: Option<KeyPresses>,
    /// Start with shadow rays off (H)
    ///
    /// Start with shadow rays off (H turns them on and off).
    #[arg(long, help_heading = "Picture")]
    pub no_shadows: bool,
    /// Start with mirror reflections off (M)
    #[arg(long, help_heading = "Picture")]
    pub no_reflections: bool,
    /// Start with refraction off (G)
    ///
    /// Start with refraction off (G turns it on and off): transparent materials drawn opaque.
    #[arg(long, help_heading = "Picture")]
    pub no_refraction: bool,
    /// Start with texture mapping off (T)
    #[arg(long, help_heading = "Picture")]
    pub no_textures: bool,
    /// Refuse scenes that expand to more primitives than this
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N",
          help_heading = "Quality", hide_short_help = true)]
    pub max_primitives: usize,
    /// Enable the Khronos validation layer (exit 3 on any message)
    ///
    /// Enable the Khronos validation layer; any message fails the command (exit 3).
    /// Also on when RAYCAST_VALIDATION=1.
    #[arg(long, help_heading = "Diagnostics")]
    pub validate: bool,
    /// Longest one frame's work may take on the device [default: 60]
    ///
    /// The longest the device may take over one frame's work before the
    /// preview gives up with an error (a shader edit's endless loop on a
    /// GPU would otherwise hold the window; lavapipe cuts such a loop short
    /// itself). A frame at rest aims at 33 to 125 ms.
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = parse_timeout,
          help_heading = "Device", hide_short_help = true)]
    pub timeout: std::time::Duration,
    #[command(flatten)]
    pub choice: KernelChoiceArgs,
}

impl PreviewArgs {
    /// The preview's settings, as the flags give them.
    fn settings(&self) -> PreviewSettings {
        PreviewSettings {
            scene: self.scene.clone(),
            width: self.width,
            height: self.height,
            device: self.device.clone(),
            window_device: self.window_device.clone(),
            assets: self.assets.clone(),
            present_mode: self.present_mode,
            frames: self.frames,
            screenshot: self.screenshot.clone(),
            moving: self.moving,
            backend: self.backend,
            shaders: self.shaders.clone(),
            aov: self.aov,
            click: self.click,
            keys: self.keys.clone(),
            no_shadows: self.no_shadows,
            no_reflections: self.no_reflections,
            no_refraction: self.no_refraction,
            no_textures: self.no_textures,
            max_primitives: self.max_primitives,
            validate: self.validate,
            timeout: self.timeout,
            kernel: self.choice.choice(),
        }
    }
}

/// Runs `raycast preview`.
pub(crate) fn run(args: &PreviewArgs) -> Result<(), Error> {
    cpu_takes_no_shaders(args.backend == Backend::Cpu, &args.shaders)?;
    crate::preview::run(&args.settings())
}
