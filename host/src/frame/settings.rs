//! The settings of one render, independent of the backend: the picture's
//! size, what it shows, what is traced, how it is sampled; and the ranges
//! each setting is checked against (the command line's parsers apply the
//! same ones).

use crate::layout;
use crate::scene::Bounds;
use glam::DVec3;

/// Largest width or height accepted (the pixel buffer of 16384² is 8 GiB);
/// defined with the pictures (`image_io`), which read nothing larger.
pub use crate::image_io::MAX_IMAGE_SIDE;
/// Scenes keep masters as instanced groups: memory grows with the file.
pub const INSTANCING: bool = true;

/// Most samples per pixel accepted.
pub const MAX_SPP: u32 = 4096;
/// Points on each area light a sample, unless `--light-samples` says (docs/scene-format.md#area-lights).
pub const DEFAULT_LIGHT_SAMPLES: u32 = 16;
/// Most `--light-samples` accepted.
pub const MAX_LIGHT_SAMPLES: u32 = 1024;
/// Most passes `--cost-max` takes (its scale is a float: exact to 2^24).
pub const MAX_COST: u32 = 1 << 24;
/// Most texels of all textures together (4 bytes each).
pub const MAX_TEXELS: u64 = 1 << 28;

/// What the picture shows (`--aov`; each variant's text is its line in
/// `--help`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Aov {
    /// The shaded colour
    #[default]
    Color,
    /// The first hit's world-space normal, floor(255·clamp((n+1)/2)); black on a miss
    Normal,
    /// The first hit's distance from the eye in grey: white at the near end of the depth range, black at its far
    /// end and beyond, and on a miss (render and check: --depth-range, by default the scene's bounding sphere as the
    /// camera sees it; the preview: that sphere, following the camera)
    Depth,
    /// The first hit's primitive, a colour each (its id scrambled); black on a miss
    Id,
    /// What the camera ray's walk through the hierarchy cost: its passes on a heat scale, dark blue for none, dark
    /// red from 64 passes on (render and check: --cost-max); misses too
    Cost,
    /// What all the pixel's rays cost (camera, shadow and mirror rays, traced as in colour): their walks' passes
    /// summed, on the same scale, dark red from 256 passes on (render and check: --cost-max)
    CostAll,
    /// How many samples (camera rays) the pixel took, on the heat scale, dark red at 84 (the most
    /// `--supersample course` takes); the colour is drawn as usual to decide them
    Samples,
    /// As CostAll, with each kind of ray's passes and the bytes the walks
    /// fetched in the pixel's record (layout.h AOV_LANES): `bench --lanes`.
    Lanes,
}

impl Aov {
    /// The command line's name for it (`--aov`).
    pub fn name(self) -> &'static str {
        match self {
            Aov::Color => "color",
            Aov::Normal => "normal",
            Aov::Depth => "depth",
            Aov::Id => "id",
            Aov::Cost => "cost",
            Aov::CostAll => "cost-all",
            Aov::Lanes => "lanes",
            Aov::Samples => "samples",
        }
    }

    /// Its Frame.aov value (layout.h AOV_*).
    pub fn code(self) -> u32 {
        match self {
            Aov::Color => layout::AOV_COLOR,
            Aov::Normal => layout::AOV_NORMAL,
            Aov::Depth => layout::AOV_DEPTH,
            Aov::Id => layout::AOV_ID,
            Aov::Cost => layout::AOV_COST,
            Aov::CostAll => layout::AOV_COST_ALL,
            Aov::Lanes => layout::AOV_LANES,
            Aov::Samples => layout::AOV_SAMPLES,
        }
    }

    /// The passes drawn hottest when `--cost-max` is not given: a camera
    /// ray's walk is a few passes, a pixel's rays in all several times that.
    pub fn default_cost_max(self) -> u32 {
        match self {
            Aov::CostAll | Aov::Lanes => 4 * COST_MAX,
            _ => COST_MAX,
        }
    }
}

/// The depth AOV's range when none is given: white at the nearest point of
/// the scene's bounding sphere (seen from `eye`), black at its farthest;
/// 0 to 10 for a scene with nothing in it.
pub fn depth_range(bounds: Option<Bounds>, eye: DVec3) -> [f32; 2] {
    let Some(b) = bounds else { return [0.0, 10.0] };
    let d = (b.center() - eye).length();
    let r = b.radius();
    [(d - r).max(0.0) as f32, (d + r).max(1e-3) as f32]
}

/// The cost AOV's passes drawn hottest when none is given (`Aov::default_cost_max`).
pub const COST_MAX: u32 = 64;

/// Frame.aov_scale: the depth AOV's distances drawn white and black, the
/// cost AOV's passes drawn hottest.
pub fn aov_scale(depth_range: [f32; 2], cost_max: u32) -> [f32; 4] {
    [depth_range[0], depth_range[1], cost_max as f32, 0.0]
}

/// How textures are sampled (`--texture-filter`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TextureFilter {
    /// The texel the point falls in, as the course's renders
    #[default]
    Nearest,
    /// The four nearest texels, weighted
    Bilinear,
    /// The course's bilinear filter: texels k and k + 1 weighted by the fraction of x = u·W, without the half-texel
    /// shift (docs/scene-format.md#texture-filters)
    Course,
}

/// Where a pixel's samples go (`--supersample`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Supersample {
    /// --spp samples in a fixed pattern, averaged: the pixel's area average as --spp grows
    #[default]
    Pattern,
    /// The course's adaptive scheme: 4 samples at the quadrant centres, each quadrant refined the same way where
    /// they differ by more than 0.2 in a channel, down to 8x8 (docs/scene-format.md#adaptive-supersampling)
    Course,
}

/// Settings of one render, independent of the backend.
#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub aov: Aov,
    pub shadows: bool,
    pub reflections: bool,
    pub textures: bool,
    /// Mirror bounces.
    pub max_depth: u32,
    /// Cull with the bounding volume hierarchy (off: every primitive is
    /// tested, through the same matrices, for the identical picture).
    pub bvh: bool,
    /// Samples per pixel (the fixed pattern of raycast.glsl's sample_offset).
    pub spp: u32,
    /// The fixed pattern of `spp` samples, or the course's adaptive scheme.
    pub supersample: Supersample,
    pub texture_filter: TextureFilter,
    /// Aov::Depth: the distances drawn white and black; None for the
    /// scene's bounding sphere seen from the camera (`depth_range`).
    pub depth_range: Option<[f32; 2]>,
    /// Aov::Cost and CostAll: the passes drawn at the hot end; None for
    /// `Aov::default_cost_max`.
    pub cost_max: Option<u32>,
    /// The thin lens of a camera with an aperture (off: `--no-dof`, the pinhole).
    pub dof: bool,
    /// Points on each area light a sample (`--light-samples`).
    pub light_samples: u32,
    /// Refracted rays through transparent materials (FLAG_REFRACTION, set
    /// only where the scene has one: `transmits`).
    pub refraction: bool,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 384,
            aov: Aov::Color,
            shadows: true,
            reflections: true,
            textures: true,
            max_depth: 4,
            bvh: true,
            spp: 1,
            supersample: Supersample::Pattern,
            texture_filter: TextureFilter::Nearest,
            depth_range: None,
            cost_max: None,
            dof: true,
            light_samples: DEFAULT_LIGHT_SAMPLES,
            refraction: true,
        }
    }
}

/// A problem with the render settings, naming the setting.
#[derive(Clone, Debug, PartialEq)]
pub struct SettingsError(pub String);

impl std::fmt::Display for SettingsError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SettingsError {}

/// A picture side (`--width`, `--height`) within 1 to MAX_IMAGE_SIDE: the
/// one range the command line's parser and [`RenderSettings::validate`] apply.
pub fn side_in_range(name: &str, v: u32) -> Result<u32, String> {
    if v == 0 || v > MAX_IMAGE_SIDE {
        return Err(format!("{name} {v} is out of range: an image side must be between 1 and {MAX_IMAGE_SIDE} pixels"));
    }
    Ok(v)
}

/// `--spp` within 1 to MAX_SPP.
pub fn spp_in_range(v: u32) -> Result<u32, String> {
    if v == 0 || v > MAX_SPP {
        return Err(format!("--spp {v} is out of range: between 1 and {MAX_SPP} samples per pixel"));
    }
    Ok(v)
}

/// `--light-samples` within 1 to MAX_LIGHT_SAMPLES.
pub fn light_samples_in_range(v: u32) -> Result<u32, String> {
    if v == 0 || v > MAX_LIGHT_SAMPLES {
        return Err(format!("--light-samples {v} is out of range: between 1 and {MAX_LIGHT_SAMPLES} points a light"));
    }
    Ok(v)
}

/// `--bounces` at most layout::MAX_DEPTH.
pub fn bounces_in_range(v: u32) -> Result<u32, String> {
    if v > layout::MAX_DEPTH {
        return Err(format!("--bounces {v} is out of range: at most {} mirror bounces", layout::MAX_DEPTH));
    }
    Ok(v)
}

/// `--cost-max` within 1 to MAX_COST.
pub fn cost_max_in_range(v: u32) -> Result<u32, String> {
    if v == 0 || v > MAX_COST {
        return Err(format!("--cost-max {v} is out of range: between 1 and {MAX_COST} passes"));
    }
    Ok(v)
}

impl RenderSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        side_in_range("--width", self.width).map_err(SettingsError)?;
        side_in_range("--height", self.height).map_err(SettingsError)?;
        spp_in_range(self.spp).map_err(SettingsError)?;
        if self.supersample == Supersample::Course && self.spp > 1 {
            return Err(SettingsError(format!(
                "--spp {} and --supersample course are two ways to place samples: choose one",
                self.spp
            )));
        }
        bounces_in_range(self.max_depth).map_err(SettingsError)?;
        light_samples_in_range(self.light_samples).map_err(SettingsError)?;
        if self.depth_range.is_some() && self.aov != Aov::Depth {
            return Err(SettingsError("--depth-range is for --aov depth; this render is not one".to_string()));
        }
        match self.cost_max {
            Some(_) if !matches!(self.aov, Aov::Cost | Aov::CostAll | Aov::Lanes) => {
                return Err(SettingsError(
                    "--cost-max is for --aov cost or cost-all; this render is neither".to_string(),
                ))
            }
            Some(n) => {
                cost_max_in_range(n).map_err(SettingsError)?;
            }
            _ => {}
        }
        if let Some([near, far]) = self.depth_range {
            if !(near.is_finite() && far.is_finite() && near >= 0.0 && far > near) {
                // As 32-bit floats, in few digits: two numbers given apart
                // may be one float (1e-45,2e-45), which the message says.
                let same = if near == far { " (as the renderer's 32-bit floats they are the same)" } else { "" };
                return Err(SettingsError(format!(
                    "--depth-range {},{}{same} is out of range: two finite distances with 0 <= NEAR < FAR",
                    crate::units::fmt_number(near),
                    crate::units::fmt_number(far)
                )));
            }
        }
        Ok(())
    }
}
