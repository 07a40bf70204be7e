//! The scene in a window (`raycast preview`, whose flags `cli::preview`
//! turns into [`PreviewSettings`]). GLFW opens the window and
//! reports input; the gpu part renders one jittered sample per frame with
//! shaders/preview.comp (or, with `--backend cpu`, the CPU build draws it
//! and the kernel only shows it), accumulating while nothing changes, and
//! presents it. This part owns the window, input and live reload; the camera control
//! it steers with is the scene part's (`scene::CameraControl`, which
//! `render --orbit` uses too).
//!
//! | file | owns |
//! |---|---|
//! | `setup.rs` | the scene loaded, the window opened, the devices chosen, the kernels built |
//! | `app.rs` | the render loop, keys and mouse, the title, picking |
//! | `pacing.rs` | the frame budget, the resolution while moving, bands of rows, the sample pattern |
//! | `display.rs` | the X display's veto of a device |
//! | `reload.rs` | the watcher thread: scene and shader reloads off the render thread |
//! | `renderer.rs` | which buffer goes to which binding of preview.comp; the CPU build's samples (`--backend cpu`) and a device apart from the window's (`--window-device`) |
//! | `x11.rs` | which of some extensions the X display has (the window's veto of a device) |

mod app;
mod display;
mod pacing;
mod reload;
mod renderer;
mod setup;
mod x11;

use std::path::PathBuf;

use std::time::Duration;

use crate::error::Error;
use crate::frame::Aov;
use crate::gpu::{DeviceSelector, KernelChoice, PresentMode};
use crate::render::Backend;

/// What `raycast preview` shows and how (`cli::preview` fills it from the
/// flags, each field's meaning as its flag's help says).
#[derive(Clone, Debug)]
pub struct PreviewSettings {
    /// A scene file (reloaded when it changes) or gen:FAMILY:LEVELS; None: the default scene.
    pub scene: Option<PathBuf>,
    /// The window's (and picture's) size.
    pub width: u32,
    pub height: u32,
    /// The device that draws, and the one that shows the window where it is another.
    pub device: Option<DeviceSelector>,
    pub window_device: Option<DeviceSelector>,
    /// Extra folders to find textures in.
    pub assets: Vec<PathBuf>,
    pub present_mode: PresentMode,
    /// Frames to draw before exiting; None: until the window closes.
    pub frames: Option<u32>,
    /// Where to save the picture after the last frame.
    pub screenshot: Option<PathBuf>,
    /// The first frames drawn as while steering (the camera turned before each).
    pub moving: u32,
    /// Who draws the samples.
    pub backend: Backend,
    /// The shader folder watched and compiled; None: the source tree's shaders/.
    pub shaders: Option<PathBuf>,
    /// What the window shows at first.
    pub aov: Aov,
    /// A pixel clicked after the last frame.
    pub click: Option<(u32, u32)>,
    /// Keys pressed before frames.
    pub keys: Option<KeyPresses>,
    /// What starts off.
    pub no_shadows: bool,
    pub no_reflections: bool,
    pub no_refraction: bool,
    pub no_textures: bool,
    /// Scenes that expand to more primitives are refused.
    pub max_primitives: usize,
    /// The Khronos validation layer on.
    pub validate: bool,
    /// The longest one frame's work may take on the device.
    pub timeout: Duration,
    /// The exact kernel or the fast one.
    pub kernel: KernelChoice,
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

impl std::str::FromStr for KeyPresses {
    type Err = String;

    /// `N:KEY,…` (`--keys`).
    fn from_str(s: &str) -> Result<KeyPresses, String> {
        parse_key_presses(s)
    }
}

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

/// Why a window on this display cannot take `device`'s pictures (asked of
/// the X display, not of the device's driver), for `raycast devices`.
pub(crate) use display::window_refuses;

/// Runs `raycast preview`.
pub fn run(args: &PreviewSettings) -> Result<(), Error> {
    setup::run(args)
}

/// What a scripted run asks of the frames it draws (`--click`, `--keys`,
/// `--moving`), checked before any work: a pixel outside the picture, or a
/// frame past `--frames`, is a usage error (it would be ignored in silence).
fn check_script(args: &PreviewSettings) -> Result<(), Error> {
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
