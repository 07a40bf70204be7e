//! `raycast preview`: the scene in a window. GLFW opens the window and
//! reports input; the gpu part renders one jittered sample per frame with
//! shaders/preview.comp (or, with `--backend cpu`, the CPU build draws it
//! and the kernel only shows it), accumulating while nothing changes, and
//! presents it. This part owns the window, input and live reload; the camera control
//! it steers with is the scene part's (`scene::CameraControl`, which
//! `render --orbit` uses too).
//!
//! | file | owns |
//! |---|---|
//! | `app.rs` | the window, the render loop, keys and mouse, the title, picking |
//! | `reload.rs` | the watcher thread: scene and shader reloads off the render thread |
//! | `renderer.rs` | which buffer goes to which binding of preview.comp; the CPU build's samples (`--backend cpu`) and a device apart from the window's (`--window-device`) |
//! | `layout.rs` | Rust mirrors of shaders/preview.h |
//! | `x11.rs` | which of some extensions the X display has (the window's veto of a device) |

mod app;
pub mod layout;
mod reload;
mod renderer;
mod x11;

use std::path::PathBuf;

use clap::{Args, ValueEnum};

use crate::args::Backend;
use crate::error::Error;
use crate::frame::Aov;
use crate::gpu::DeviceSelector;
use crate::scene::FlattenLimits;

/// `raycast preview` flags.
#[derive(Args, Debug)]
pub struct PreviewArgs {
    /// An XML file (reloaded) or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene file (XML), reloaded when it changes, or a generated scene (gen:recursive-spheres:6).
    /// Without one, the embedded default scene.
    pub scene: Option<PathBuf>,
    /// Window (and picture) width
    #[arg(long, default_value_t = 512, value_name = "W", value_parser = crate::args::parse_width,
          help_heading = "Picture")]
    pub width: u32,
    /// Window (and picture) height
    #[arg(long, default_value_t = 384, value_name = "H", value_parser = crate::args::parse_height,
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
    #[arg(long, value_enum, default_value_t = PresentArg::Fifo, value_name = "MODE", help_heading = "Device",
          hide_possible_values = true, hide_default_value = true)]
    pub present_mode: PresentArg,
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
          hide_default_value = true, long_help = crate::args::with_values::<Backend>(
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
          hide_default_value = true, long_help = crate::args::with_values::<Aov>("What the window shows at first (keys 1 to 6 switch) [default: color]"))]
    pub aov: Aov,
    /// With --frames: click pixel X,Y after the last
    ///
    /// With --frames: after the last frame, click pixel (X, Y) of the
    /// picture, as a left click does (what it sees, then its rays as
    /// `raycast trace` follows them).
    #[arg(long, value_name = "X,Y", value_parser = crate::args::parse_pixel, requires = "frames",
          help_heading = "Diagnostics")]
    pub click: Option<(u32, u32)>,
    /// With --frames: press keys before frames (2:H,3:B)
    ///
    /// With --frames: press keys as in the window, each just before frame N
    /// (counted from 1): N:KEY,… with KEY one of 1 to 6, H, M, T, R, F, C,
    /// B and K (say 2:H,3:B).
    #[arg(long, value_name = "KEYS", value_parser = parse_key_presses, requires = "frames",
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
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = crate::args::parse_timeout,
          help_heading = "Device", hide_short_help = true)]
    pub timeout: std::time::Duration,
    #[command(flatten)]
    pub choice: crate::args::KernelChoiceArgs,
}

/// The keys `--keys` may press (the window's controls that print or
/// switch something), by the character that names them.
const SCRIPTED_KEYS: [(char, glfw::Key); 15] = [
    ('1', glfw::Key::Num1),
    ('2', glfw::Key::Num2),
    ('3', glfw::Key::Num3),
    ('4', glfw::Key::Num4),
    ('5', glfw::Key::Num5),
    ('6', glfw::Key::Num6),
    ('H', glfw::Key::H),
    ('M', glfw::Key::M),
    ('G', glfw::Key::G),
    ('T', glfw::Key::T),
    ('R', glfw::Key::R),
    ('F', glfw::Key::F),
    ('C', glfw::Key::C),
    ('B', glfw::Key::B),
    ('K', glfw::Key::K),
];

/// `--keys`: (frame counted from 1, key) in the order given.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct KeyPresses(pub Vec<(u32, glfw::Key)>);

fn parse_key_presses(s: &str) -> Result<KeyPresses, String> {
    let names: String = SCRIPTED_KEYS.iter().map(|k| k.0).collect();
    let bad = || format!("{s:?} is not N:KEY,… (frames from 1; keys {names}; say 2:H,3:B)");
    let mut presses = Vec::new();
    for part in s.split(',') {
        let (n, key) = part.trim().split_once(':').ok_or_else(bad)?;
        let n: u32 = n.trim().parse().map_err(|_| bad())?;
        let mut chars = key.trim().chars();
        let (Some(c), None) = (chars.next().map(|c| c.to_ascii_uppercase()), chars.next()) else { return Err(bad()) };
        let key = SCRIPTED_KEYS.iter().find(|k| k.0 == c).map(|k| k.1);
        match key {
            Some(key) if n > 0 => presses.push((n, key)),
            _ => return Err(bad()),
        }
    }
    Ok(KeyPresses(presses))
}

#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum PresentArg {
    Fifo,
    Mailbox,
    Immediate,
}

/// Why a window on this display cannot take `device`'s pictures (asked of
/// the X display, not of the device's driver), for `raycast devices`.
pub(crate) use app::window_refuses;
pub(crate) use reload::{shader_stamps, stamps, POLL};

/// Runs `raycast preview`.
pub(crate) fn run(args: &PreviewArgs) -> Result<(), Error> {
    app::run(args)
}

/// What a scripted run asks of the frames it draws (`--click`, `--keys`,
/// `--moving`), checked before any work: a pixel outside the picture, or a
/// frame past `--frames`, is a usage error (it would be ignored in silence).
fn check_script(args: &PreviewArgs) -> Result<(), Error> {
    let (w, h) = (args.width, args.height);
    if let Some((x, y)) = args.click.filter(|&(x, y)| x >= w || y >= h) {
        return Err(Error::usage(format!("--click {x},{y} is outside the {w}x{h} picture")));
    }
    // --keys and --moving require --frames.
    let Some(frames) = args.frames else { return Ok(()) };
    let past = |what: String, n: u32| Error::usage(format!("{what} before frame {n}, past --frames {frames}"));
    let keys = args.keys.as_ref().map_or(&[][..], |k| &k.0[..]);
    if let Some(&(n, key)) = keys.iter().find(|(n, _)| *n > frames) {
        let name = SCRIPTED_KEYS.iter().find(|k| k.1 == key).map_or('?', |k| k.0);
        return Err(past(format!("--keys {n}:{name} presses {name}"), n));
    }
    if args.moving > frames {
        return Err(past(format!("--moving {} turns the camera", args.moving), args.moving));
    }
    Ok(())
}
