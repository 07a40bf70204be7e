//! The command line's value types: the names of the library's plain enums
//! (each variant's value, its aliases and its line in `--help`) and the
//! parsers of numbers, pixels and seconds. The library keeps its enums and
//! settings free of clap; this is the one place that says how a flag spells
//! them.

use crate::frame::{Aov, Supersample, TextureFilter};
use crate::gpu::{KernelChoice, PresentMode, SceneBuffers};
use crate::render::Backend;
use clap::ValueEnum;
use std::time::Duration;

/// `impl clap::ValueEnum` for a library enum: each variant with its value,
/// any aliases after `|`, and its help line.
macro_rules! value_enum {
    ($ty:ty { $($variant:path => $name:literal $(| $alias:literal)* : $help:expr),* $(,)? }) => {
        impl clap::ValueEnum for $ty {
            fn value_variants<'a>() -> &'a [Self] {
                &[$($variant),*]
            }

            fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
                Some(match self {
                    $($variant => clap::builder::PossibleValue::new($name)$(.alias($alias))*.help($help)),*
                })
            }
        }
    };
}

value_enum!(SceneBuffers {
    SceneBuffers::Auto => "auto": "Images and uniform blocks when the scene fits them, storage buffers otherwise",
    SceneBuffers::Storage => "storage": "Storage buffers (render.comp): any size",
    SceneBuffers::Uniform => "uniform" | "images":
        "Images and uniform blocks (render_uniform.comp): an error naming what does not fit when the scene does not \
         (docs/scale.md#shaped-for-lavapipe). Also spelled `images`: the scene's arrays are storage images, only the \
         frame is a uniform block",
});

value_enum!(Backend {
    Backend::Gpu => "gpu": "A Vulkan device (--device, or the best one)",
    Backend::Cpu => "cpu": "The C++ build of the shared GLSL on every core",
    Backend::Auto => "auto":
        "The device, unless it runs on the CPU (lavapipe) and nothing asks for the device (--device, --shaders; and \
         for render, check, bench and conformance --scene-buffers, --validate, --timeout), or none opens and no \
         --device is given (not the preview, which needs Vulkan for its window): then the CPU build",
});

value_enum!(KernelChoice {
    KernelChoice::Auto => "auto":
        "The fast kernels on a discrete or integrated GPU, the exact ones on every other device (lavapipe and other \
         CPU devices)",
    KernelChoice::Exact => "exact": "The exact kernels: the CPU build's bits on every device",
    KernelChoice::Fast => "fast":
        "The fast kernels (FAST_MATH): the device's own division, square root and transcendentals; within a stated \
         rule of the CPU build",
});

value_enum!(Aov {
    Aov::Color => "color": "The shaded colour",
    Aov::Normal => "normal": "The first hit's world-space normal, floor(255·clamp((n+1)/2)); black on a miss",
    Aov::Depth => "depth":
        "The first hit's distance from the eye in grey: white at the near end of the depth range, black at its far \
         end and beyond, and on a miss (render and check: --depth-range, by default the scene's bounding sphere as \
         the camera sees it; the preview: that sphere, following the camera)",
    Aov::Id => "id": "The first hit's primitive, a colour each (its id scrambled); black on a miss",
    Aov::Cost => "cost":
        "What the camera ray's walk through the hierarchy cost: its passes on a heat scale, dark blue for none, dark \
         red from 64 passes on (render and check: --cost-max); misses too",
    Aov::CostAll => "cost-all":
        "What all the pixel's rays cost (camera, shadow and mirror rays, traced as in colour): their walks' passes \
         summed, on the same scale, dark red from 256 passes on (render and check: --cost-max)",
    Aov::Lanes => "lanes":
        "As cost-all, with each kind of ray's passes and the bytes fetched in the pixel's record, for `bench \
         --lanes` (docs/scale.md#lane-use)",
    Aov::Samples => "samples":
        "How many samples (camera rays) the pixel took, on the heat scale, dark red at 84 (the most `--supersample \
         course` takes); the colour is drawn as usual to decide them",
});

value_enum!(TextureFilter {
    TextureFilter::Nearest => "nearest": "The texel the point falls in, as the course's renders",
    TextureFilter::Bilinear => "bilinear": "The four nearest texels, weighted",
    TextureFilter::Course => "course":
        "The course's bilinear filter: texels k and k + 1 weighted by the fraction of x = u·W, without the \
         half-texel shift (docs/scene-format.md#texture-filters)",
});

value_enum!(Supersample {
    Supersample::Pattern => "pattern":
        "--spp samples in a fixed pattern, averaged: the pixel's area average as --spp grows",
    Supersample::Course => "course":
        "The course's adaptive scheme: 4 samples at the quadrant centres, each quadrant refined the same way where \
         they differ by more than 0.2 in a channel, down to 8x8 (docs/scene-format.md#adaptive-supersampling)",
});

/// `--present-mode`: its values name themselves.
impl ValueEnum for PresentMode {
    fn value_variants<'a>() -> &'a [Self] {
        &[PresentMode::Fifo, PresentMode::Mailbox, PresentMode::Immediate]
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(match self {
            PresentMode::Fifo => "fifo",
            PresentMode::Mailbox => "mailbox",
            PresentMode::Immediate => "immediate",
        }))
    }
}

/// A flag's `--help` text: `text`, then each of `E`'s values on a line with
/// its help, as clap lists them; for a flag whose `-h` line names the
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

/// `--depth-range NEAR,FAR` (checked by `RenderSettings::validate`).
pub fn parse_depth_range(s: &str) -> Result<[f32; 2], String> {
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `Aov::name` (the preview's status line, `bench`, `conformance`) is what `--aov` takes.
    #[test]
    fn aov_names_are_the_command_lines() {
        for aov in Aov::value_variants() {
            assert_eq!(aov.to_possible_value().unwrap().get_name(), aov.name());
        }
    }

    /// `--aov`'s help (render's, check's and the preview's) tells the cost
    /// views' default scales as they are.
    #[test]
    fn aov_help_tells_the_cost_scales() {
        let help = |v: Aov| v.to_possible_value().unwrap().get_help().unwrap().to_string();
        assert!(help(Aov::Cost).contains(&format!("from {} passes on", Aov::Cost.default_cost_max())));
        assert!(help(Aov::CostAll).contains(&format!("from {} passes on", Aov::CostAll.default_cost_max())));
    }
}
