//! Values the command line and the library's option structs share: the
//! backend and kernel choices and the parsers of `X,Y` and seconds.

use crate::error::Error;
use crate::gpu::KernelChoice;
use clap::{Args, ValueEnum};
use std::path::PathBuf;
use std::time::Duration;

/// Where the shared code runs.
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

/// A flag's `--help` text: `text`, then each of `E`'s values on a line with
/// its doc comment, as clap lists them; for a flag whose `-h` line names the
/// values itself (`hide_possible_values`, which hides clap's list too).
pub fn with_values<E: ValueEnum>(text: &str) -> String {
    let mut help = format!("{text}\n\nPossible values:");
    for value in E::value_variants().iter().filter_map(ValueEnum::to_possible_value) {
        let line = value.get_help().map(ToString::to_string).unwrap_or_default();
        help.push_str(&format!("\n- {}: {line}", value.get_name()));
    }
    help
}

/// `X,Y`: two whole numbers (`--pixel`, `--click`).
pub fn parse_pixel(s: &str) -> Result<(u32, u32), String> {
    let parse =
        |t: &str| t.trim().parse::<u32>().map_err(|_| format!("{s:?} is not X,Y (two whole numbers, say 29,4)"));
    match s.split_once(',') {
        Some((x, y)) => Ok((parse(x)?, parse(y)?)),
        None => Err(format!("{s:?} is not X,Y (two whole numbers, say 29,4)")),
    }
}

/// `--timeout`: seconds, more than none, at most a week.
pub fn parse_timeout(s: &str) -> Result<Duration, String> {
    match s.trim().parse::<f64>() {
        Ok(x) if x > 0.0 && x <= 604_800.0 => Ok(Duration::from_secs_f64(x)),
        _ => Err(format!("{s:?} is not a number of seconds above 0 and at most 604800 (a week)")),
    }
}

/// `--shaders DIR` with `--backend cpu`: a usage error, since the CPU build
/// is the code raycast was built with and would silently ignore DIR.
pub fn cpu_takes_no_shaders(cpu_only: bool, shaders: &Option<PathBuf>) -> Result<(), Error> {
    match (cpu_only, shaders) {
        (true, Some(dir)) => Err(Error::Usage(format!(
            "--shaders {} compiles the device's kernel, but --backend cpu runs the CPU build raycast was built with: \
             drop one (rebuild raycast to put a shader change into the CPU build)",
            dir.display()
        ))),
        _ => Ok(()),
    }
}

/// A whole number as the range parsers below take it.
fn whole(s: &str) -> Result<u32, String> {
    s.trim().parse::<u32>().map_err(|_| format!("{s:?} is not a whole number"))
}

/// `--width`: the range [`crate::frame::RenderSettings::validate`] applies, checked as clap parses.
pub fn parse_width(s: &str) -> Result<u32, String> {
    crate::frame::side_in_range("--width", whole(s)?)
}

/// `--height`, as `--width`.
pub fn parse_height(s: &str) -> Result<u32, String> {
    crate::frame::side_in_range("--height", whole(s)?)
}

/// `--spp`: 1 to `frame::MAX_SPP`.
pub fn parse_spp(s: &str) -> Result<u32, String> {
    crate::frame::spp_in_range(whole(s)?)
}

/// `--light-samples`: 1 to `frame::MAX_LIGHT_SAMPLES`.
pub fn parse_light_samples(s: &str) -> Result<u32, String> {
    crate::frame::light_samples_in_range(whole(s)?)
}

/// `--bounces`: at most the kernels' mirror depth.
pub fn parse_bounces(s: &str) -> Result<u32, String> {
    crate::frame::bounces_in_range(whole(s)?)
}

/// `--cost-max`: 1 to `frame::MAX_COST`.
pub fn parse_cost_max(s: &str) -> Result<u32, String> {
    crate::frame::cost_max_in_range(whole(s)?)
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
