//! Turns a flattened [`Scene`] and the render settings into the buffers of
//! `shaders/layout.h`: what both the GPU kernel and the CPU build consume.
//! Everything computed here (camera matrix, light directions) is computed
//! once, in f64, and handed to both backends as the same f32 bits.

use crate::bvh::{self, Aabb};
use crate::error::Error;
use crate::image_io;
use crate::layout::{self, Mat4, Vec4};
use crate::scene::{scene_bounds, Bounds, Camera, Group, Instance, LightKind, Primitive, Scene, Shape, TextureRef};
use glam::{DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::path::PathBuf;

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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
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
            Aov::Samples => layout::AOV_SAMPLES,
        }
    }

    /// The passes drawn hottest when `--cost-max` is not given: a camera
    /// ray's walk is a few passes, a pixel's rays in all several times that.
    pub fn default_cost_max(self) -> u32 {
        match self {
            Aov::CostAll => 4 * COST_MAX,
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
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
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
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
            Some(_) if !matches!(self.aov, Aov::Cost | Aov::CostAll) => {
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

/// The buffers of one frame, laid out as `shaders/layout.h`.
#[derive(Clone, Debug, Default)]
pub struct FrameData {
    pub frame: layout::Frame,
    pub primitives: Vec<layout::Primitive>,
    pub materials: Vec<layout::Material>,
    pub lights: Vec<layout::Light>,
    pub textures: Vec<layout::Texture>,
    /// Every texture's texels, one after the other.
    pub texels: Vec<layout::Texel>,
    pub nodes: Vec<layout::BvhNode>,
    pub leaf_items: Vec<layout::LeafItem>,
    pub instances: Vec<layout::Instance>,
    /// Every mesh's hierarchy, triangles and vertices (`pack_meshes`).
    pub mesh_nodes: Vec<layout::BvhNode>,
    pub mesh_triangles: Vec<layout::MeshTriangle>,
    pub mesh_vertices: Vec<layout::MeshVertex>,
    /// The meshes packed (each file once).
    pub meshes: usize,
    /// Each scene group's root node in `nodes` (its nodes follow it, its
    /// inner nodes' children at `first` and `first + 1`); u32::MAX for a
    /// group with nothing to draw. Empty without a hierarchy.
    pub group_roots: Vec<u32>,
    /// The levels the walk enters: 1 (the root group) and the deepest
    /// nesting of masters under it; at most layout::MAX_LEVELS.
    pub levels: u32,
    /// Primitives the scene expands to (every instance counted).
    pub expanded: u64,
    /// The groups packed: the root tree and each master tree it places
    /// (fewer than the scene's where `fit_nesting` wrote masters out).
    pub groups: usize,
    /// Time to build the hierarchies and pack the groups.
    pub build_time: std::time::Duration,
    /// Things about the scene the renderer does not draw as written.
    pub notes: Vec<String>,
}

impl FrameData {
    /// The scene's storage buffers other than the frame itself, as
    /// (binding, what it is for messages, bytes): the one list every kernel
    /// that includes raycast.glsl binds (shaders/scene_buffers.glsl).
    pub fn scene_buffers(&self) -> [(u32, &'static str, &[u8]); 11] {
        [
            (layout::BINDING_PRIMITIVES, "the primitives", bytemuck::cast_slice(&self.primitives)),
            (layout::BINDING_MATERIALS, "the materials", bytemuck::cast_slice(&self.materials)),
            (layout::BINDING_LIGHTS, "the lights", bytemuck::cast_slice(&self.lights)),
            (layout::BINDING_TEXTURES, "the textures", bytemuck::cast_slice(&self.textures)),
            (layout::BINDING_TEXELS, "the texels", bytemuck::cast_slice(&self.texels)),
            (layout::BINDING_NODES, "the hierarchy's nodes", bytemuck::cast_slice(&self.nodes)),
            (layout::BINDING_LEAF_ITEMS, "the hierarchy's leaf items", bytemuck::cast_slice(&self.leaf_items)),
            (layout::BINDING_INSTANCES, "the instances", bytemuck::cast_slice(&self.instances)),
            (layout::BINDING_MESH_NODES, "the meshes' nodes", bytemuck::cast_slice(&self.mesh_nodes)),
            (layout::BINDING_MESH_TRIANGLES, "the meshes' triangles", bytemuck::cast_slice(&self.mesh_triangles)),
            (layout::BINDING_MESH_VERTICES, "the meshes' vertices", bytemuck::cast_slice(&self.mesh_vertices)),
        ]
    }
}

/// Textures loaded for one frame, each file once.
#[derive(Default)]
struct TextureTable {
    index: HashMap<PathBuf, i32>,
    textures: Vec<layout::Texture>,
    texels: Vec<layout::Texel>,
}

impl TextureTable {
    /// The index of `t`'s image, loading it on first use. Errors name the
    /// scene element: `file:line:col: error: …`.
    fn add(&mut self, t: &TextureRef) -> Result<i32, Error> {
        let Some(path) = &t.resolved else {
            return Err(Error::Scene(format!(
                "{}: error: texture \"{}\" not found as a picture file (the warning at this element says where raycast looked); \
                 pass the folder that holds it with --assets DIR, or render with --no-textures",
                t.loc, t.file
            )));
        };
        if let Some(&i) = self.index.get(path) {
            return Ok(i);
        }
        let cannot = |e: String| Error::Scene(format!("{}: error: cannot read texture {}: {e}", t.loc, path.display()));
        // The size from the header first: a picture too large for the
        // texture table is told so before it is decoded into memory.
        let (width, height) = image_io::picture_size(path).map_err(cannot)?;
        let total = self.texels.len() as u64 + u64::from(width) * u64::from(height);
        if width == 0 || height == 0 || total > MAX_TEXELS {
            return Err(Error::Scene(format!(
                "{}: error: texture {} ({width}x{height}) does not fit: all textures together may hold at most {} texels",
                t.loc,
                path.display(),
                crate::units::thousands(MAX_TEXELS)
            )));
        }
        let image = image_io::decode_picture(path).map_err(|e| cannot(format!("{e} ({width}x{height})")))?.to_rgba8();
        let i = self.textures.len() as i32;
        self.textures.push(layout::Texture { offset: self.texels.len() as u32, width, height, pad0: 0 });
        self.texels.extend(image.pixels().map(|p| layout::Texel { rgba: u32::from_le_bytes(p.0) }));
        self.index.insert(path.clone(), i);
        Ok(i)
    }
}

fn vec4(v: DVec3, w: f32) -> Vec4 {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn rgb(c: [f32; 3]) -> Vec4 {
    [c[0], c[1], c[2], 0.0]
}

/// The farthest a positioned light may be from the origin: the shader
/// squares a light's distance in f32 (raycast.glsl, `dot3(d, d)`), which
/// overflows beyond about 1.8e19, and such a light lights nothing.
const LIGHT_REACH: f64 = 1.0e19;

/// The scene's positioned lights within what the renderer's 32-bit floats
/// can light with (`LIGHT_REACH`; the parser holds every number the
/// renderer takes as written, the camera's position among them, to f32).
fn check_light_reach(scene: &Scene) -> Result<(), Error> {
    for l in scene.lights.iter().filter(|l| l.kind != LightKind::Directional) {
        let distance = l.position.length();
        if distance > LIGHT_REACH {
            return Err(Error::Scene(format!(
                "{}: error: this light is {distance:.3e} units from the origin: the renderer squares a light's distance in \
                 32-bit floats, which overflows beyond about 1.8e19, so it would light nothing; for light from far \
                 away, use type=\"directional\"",
                l.loc
            )));
        }
    }
    Ok(())
}

/// How far the walk may scale a ray's direction (a unit vector in the
/// world) into a primitive's or a master's space, either way: a shape drawn
/// more than 1e15 times its canonical size, or less than 1e-15 times, meets
/// rays whose squared length (the quadratic's leading term: a sphere's,
/// a cylinder's, an instance's bounding sphere) is beyond 1e30 or below
/// 1e-30, where the 32-bit tests lose it: a sphere scaled by 1e20 drew
/// as a one-pixel ring, one placed through masters scaled by 3e22 and 1e-23
/// not at all (and `--no-bvh` drew it).
const MAX_SCALING: f64 = 1e15;

/// The narrowest angle between two rows' camera rays the renderer's
/// 32-bit floats resolve, in radians: where a row spans less, a hit
/// point's rounding (a few f32 steps of its distance from the origin, the
/// eye's included) is larger than the row's footprint, whatever the scene's
/// layout, and the picture is noise (a sphere filling 72 rows drew 3.9% of
/// its normals wrong at 1.7e-8 radians a row, none at 1.7e-7).
const MIN_ROW_ANGLE: f64 = 1e-7;

/// The camera's height angle over the picture's rows, refused below
/// `MIN_ROW_ANGLE` (a telescope of heightangle 1e-5 degrees drew a sphere
/// with wrong normals and gaps, without a word).
fn check_row_angle(scene: &Scene, height: u32) -> Result<(), Error> {
    let degrees = scene.camera.height_angle_deg;
    let per_row = degrees.to_radians() / f64::from(height.max(1));
    if per_row >= MIN_ROW_ANGLE {
        return Ok(());
    }
    let place = match &scene.camera.height_angle_loc {
        Some(loc) => loc.to_string(),
        None => format!("{} (its default heightangle)", scene.path.display()),
    };
    Err(Error::Scene(format!(
        "{place}: error: the camera's heightangle of {}° over {height} rows is {per_row:.1e} radians a row, less than the \
         {MIN_ROW_ANGLE:.0e} the renderer's 32-bit floats resolve (the picture would be noise): widen it (at least \
         {:.1e}°), or render fewer rows",
        crate::units::fmt_number(degrees),
        (MIN_ROW_ANGLE * f64::from(height.max(1))).to_degrees()
    )))
}

/// The largest singular value of `m`'s linear part: the most it stretches
/// a vector (the square root of the largest eigenvalue of LᵀL, by the
/// closed form for symmetric 3x3 matrices, which is accurate for the
/// largest one).
fn stretch(m: &DMat4) -> f64 {
    let l = glam::DMat3::from_mat4(*m);
    let a = l.transpose() * l;
    let (a00, a11, a22) = (a.x_axis.x, a.y_axis.y, a.z_axis.z);
    let off = a.y_axis.x * a.y_axis.x + a.z_axis.x * a.z_axis.x + a.z_axis.y * a.z_axis.y;
    let largest = if off == 0.0 {
        a00.max(a11).max(a22)
    } else {
        let q = (a00 + a11 + a22) / 3.0;
        let p = (((a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * off) / 6.0).sqrt();
        let b = (a - glam::DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
        let phi = (b.determinant() / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    largest.max(0.0).sqrt()
}

/// A shape (or a master) drawn at a scale the 32-bit intersection tests
/// cannot hold (`MAX_SCALING`), through its transforms and those of every
/// chain of masters placing it: an error at the element, where it would
/// otherwise drop out of the picture. Each group's range of scalings from
/// the world is bounded from its placements' singular values (the most a
/// matrix stretches, and the most its inverse does), so nothing is
/// expanded.
fn check_scaling(scene: &Scene) -> Result<(), Error> {
    // A ray's direction, of length 1 in the world, is of length within [lo, hi] in group g's space.
    let mut range = vec![(f64::INFINITY, 0.0f64); scene.groups.len()];
    if let Some(root) = range.first_mut() {
        *root = (1.0, 1.0);
    }
    let beyond = |(lo, hi): (f64, f64), what: &str, loc: &crate::scene::SourceLoc| {
        let (shrunk, grown) = (lo < 1.0 / MAX_SCALING, hi > MAX_SCALING);
        (shrunk || grown).then(|| {
            let scale = if shrunk { format!("up to {:.1e}", 1.0 / lo) } else { format!("down to {:.1e}", 1.0 / hi) };
            Error::Scene(format!(
                "{loc}: error: this {what} is scaled by {scale} in all (its transforms and those of the masters \
                 placing it): beyond {MAX_SCALING:.0e}, or below {:.0e}, the renderer's 32-bit intersection tests lose \
                 it, so it would drop out of the picture; scale the scene to other units",
                1.0 / MAX_SCALING
            ))
        })
    };
    for g in scene.groups_children_first().into_iter().rev() {
        let (lo, hi) = range[g];
        for p in &scene.groups[g].primitives {
            let r = (lo / stretch(&p.world_from_object), hi * stretch(&p.object_from_world));
            if let Some(e) = beyond(r, "primitive", &p.loc) {
                return Err(e);
            }
        }
        for i in &scene.groups[g].instances {
            let r = (lo / stretch(&i.parent_from_group), hi * stretch(&i.group_from_parent));
            if let Some(e) = beyond(r, "master", &i.loc) {
                return Err(e);
            }
            let child = &mut range[i.group as usize];
            *child = (child.0.min(r.0), child.1.max(r.1));
        }
    }
    Ok(())
}

fn mat4(m: &DMat4) -> Mat4 {
    let c = m.to_cols_array_2d();
    c.map(|col| col.map(|x| x as f32))
}

/// world_from_film = translate(eye) · rotation(u, v, w) · scale⁻¹ (the seed
/// handout), where w = -look/|look|, u = (up × w)/|up × w|, v = w × u, and
/// scale⁻¹ = diag(tan(θw/2), tan(θh/2), 1) with θh the scene's height angle
/// and tan(θw/2) = tan(θh/2)·width/height.
pub fn world_from_film(cam: &Camera, width: u32, height: u32) -> DMat4 {
    let w = -cam.look.normalize();
    let u = cam.up.cross(w).normalize();
    let v = w.cross(u);
    let tan_h = (cam.height_angle_deg.to_radians() * 0.5).tan();
    let tan_w = tan_h * f64::from(width) / f64::from(height);
    let translate = DMat4::from_translation(cam.pos);
    let rotate = DMat4::from_cols(u.extend(0.0), v.extend(0.0), w.extend(0.0), DVec4::W);
    let scale_inv = DMat4::from_scale(DVec3::new(tan_w, tan_h, 1.0));
    translate * rotate * scale_inv
}

/// The thin lens of `camera`, (radius, focal distance) in world units, or
/// None for a pinhole: no aperture, or one of 0
/// (docs/scene-format.md#depth-of-field). The parser has checked both
/// numbers: an aperture comes with a positive focal length.
pub fn lens(camera: &Camera) -> Option<(f32, f32)> {
    let aperture = camera.aperture.filter(|&a| a > 0.0)?;
    let focal = camera.focal_length?;
    Some(((aperture * LENS_RADIUS_PER_APERTURE) as f32, focal as f32))
}

/// The lens radius of an `<aperture>` of 1, in world units: fitted to the
/// course's render of test_dof/dof.xml (docs/scene-format.md#depth-of-field).
pub const LENS_RADIUS_PER_APERTURE: f64 = 1.5;

/// An area light's in-plane unit axes (e_u, e_v) for its unit normal `n`
/// (the direction it faces): e_u is the world x axis made perpendicular to
/// n when n is within about 26 degrees of straight up or down (|n_y| >=
/// 0.9), e_v = n x e_u; otherwise e_v is the world y axis made
/// perpendicular to n, e_u = e_v x n (docs/scene-format.md#area-lights).
pub fn area_edges(n: DVec3) -> (DVec3, DVec3) {
    if n.y.abs() >= 0.9 {
        let e_u = (DVec3::X - DVec3::X.dot(n) * n).normalize();
        (e_u, n.cross(e_u))
    } else {
        let e_v = (DVec3::Y - DVec3::Y.dot(n) * n).normalize();
        (e_v.cross(n), e_v)
    }
}

/// `frame` seen through `camera`: its world_from_film (for the frame's
/// width and height) and eye, each element computed in f64 and rounded to
/// f32, as `build` makes them for a scene with that camera.
pub fn set_camera(frame: &mut layout::Frame, camera: &Camera) {
    frame.world_from_film = mat4(&world_from_film(camera, frame.width, frame.height));
    frame.eye = vec4(camera.pos, 1.0);
}

/// Packs `scene` for rendering with `settings`. With textures on, loads
/// every texture; one that cannot be found or read is an error naming the
/// scene element.
pub fn build(scene: &Scene, settings: &RenderSettings) -> Result<FrameData, Error> {
    let mut notes = Vec::new();
    let mut table = TextureTable::default();

    check_light_reach(scene)?;
    check_scaling(scene)?;
    check_row_angle(scene, settings.height)?;
    let start = std::time::Instant::now();
    let fitted;
    let scene = match fit_nesting(scene)? {
        Some((written_out, note)) => {
            notes.push(note);
            fitted = written_out;
            &fitted
        }
        None => scene,
    };
    let mut packed = pack_groups(scene)?;
    let meshes = pack_meshes(scene)?;
    for p in packed.primitives.iter_mut().filter(|p| p.shape == layout::SHAPE_MESH) {
        p.mesh = meshes.roots[p.mesh as usize];
    }
    let build_time = start.elapsed();

    let materials = scene
        .materials
        .iter()
        .map(|m| {
            let texture = match (&m.texture, settings.textures) {
                (Some(t), true) => table.add(t)?,
                _ => -1,
            };
            Ok(layout::Material {
                diffuse: rgb(m.diffuse),
                ambient: rgb(m.ambient),
                specular: rgb(m.specular),
                reflective: rgb(m.reflective),
                transparent: rgb(m.transparent),
                emissive: rgb(m.emissive),
                shininess: m.shininess,
                blend: m.blend,
                ior: m.ior,
                texture,
                texture_repeat: m
                    .texture
                    .as_ref()
                    .map(|t| [t.repeat_u, t.repeat_v, 0.0, 0.0])
                    .unwrap_or([1.0, 1.0, 0.0, 0.0]),
            })
        })
        .collect::<Result<Vec<_>, Error>>()?;
    let (materials, material_index) = unique_materials(materials);
    for p in &mut packed.primitives {
        p.material = material_index[p.material as usize];
    }

    let lights = scene
        .lights
        .iter()
        .map(|l| {
            let kind = match l.kind {
                LightKind::Point => layout::LIGHT_POINT,
                LightKind::Directional => layout::LIGHT_DIRECTIONAL,
                LightKind::Spot => layout::LIGHT_SPOT,
                LightKind::Area => layout::LIGHT_AREA,
            };
            // Directions are unit vectors only when they are not zero; the
            // parser rejects a zero direction where the light uses it.
            let axis = if l.direction.length_squared() > 0.0 { l.direction.normalize() } else { DVec3::ZERO };
            // An area light keeps its rectangle's edges where the others
            // keep their directions (layout.h, Light).
            let (to_light, spot_axis) = match l.kind {
                LightKind::Area => {
                    let (e_u, e_v) = area_edges(axis);
                    (e_u * f64::from(l.width), e_v * f64::from(l.height))
                }
                _ => (-axis, axis),
            };
            layout::Light {
                color: rgb(l.color),
                position: vec4(l.position, 1.0),
                direction_to_light: vec4(to_light, 0.0),
                spot_axis: vec4(spot_axis, 0.0),
                attenuation: [l.attenuation[0], l.attenuation[1], l.attenuation[2], 0.0],
                kind,
                angle_deg: l.angle_deg,
                penumbra_deg: l.penumbra_deg,
                pad0: 0,
            }
        })
        .collect::<Vec<_>>();

    let g = &scene.globals;
    let mut flags = 0;
    if !settings.bvh {
        flags |= layout::FLAG_NO_BVH;
    }
    if settings.shadows {
        flags |= layout::FLAG_SHADOWS;
    }
    if settings.reflections {
        flags |= layout::FLAG_REFLECTIONS;
    }
    if settings.textures {
        flags |= layout::FLAG_TEXTURES;
    }
    if settings.supersample == Supersample::Course {
        flags |= layout::FLAG_COURSE_SAMPLING;
    }
    let lens = lens(&scene.camera).filter(|_| settings.dof);
    if lens.is_some() {
        flags |= layout::FLAG_DOF;
    }
    if settings.refraction && transmits(&materials, scene.globals.kt) {
        flags |= layout::FLAG_REFRACTION;
    }
    let mut frame = layout::Frame {
        k: [g.ka, g.kd, g.ks, g.kt],
        width: settings.width,
        height: settings.height,
        primitive_count: packed.primitives.len() as u32,
        light_count: lights.len() as u32,
        aov: settings.aov.code(),
        // The bounds are a walk over every group: only for the depth AOV.
        aov_scale: aov_scale(
            match (settings.aov, settings.depth_range) {
                (Aov::Depth, Some(range)) => range,
                (Aov::Depth, None) => depth_range(scene_bounds(scene), scene.camera.pos),
                _ => [0.0; 2],
            },
            settings.cost_max.unwrap_or(settings.aov.default_cost_max()),
        ),
        flags,
        max_depth: settings.max_depth,
        spp: settings.spp,
        texture_filter: match settings.texture_filter {
            TextureFilter::Nearest => layout::FILTER_NEAREST,
            TextureFilter::Bilinear => layout::FILTER_BILINEAR,
            TextureFilter::Course => layout::FILTER_COURSE,
        },
        // The root group's root node (0 without a hierarchy).
        root_node: packed.group_roots.first().copied().unwrap_or(0),
        node_count: packed.nodes.len() as u32,
        loop_canary: layout::LOOP_CANARY,
        lens_radius: lens.map_or(0.0, |l| l.0),
        focal_distance: lens.map_or(0.0, |l| l.1),
        light_samples: settings.light_samples,
        ..layout::Frame::default()
    };
    set_camera(&mut frame, &scene.camera);
    Ok(FrameData {
        frame,
        primitives: packed.primitives,
        materials,
        lights,
        textures: table.textures,
        texels: table.texels,
        nodes: packed.nodes,
        leaf_items: packed.leaf_items,
        instances: packed.instances,
        mesh_nodes: meshes.nodes,
        mesh_triangles: meshes.triangles,
        mesh_vertices: meshes.vertices,
        meshes: scene.meshes.len(),
        group_roots: packed.group_roots,
        levels: packed.levels,
        expanded: scene.primitive_count(),
        groups: scene.groups.len(),
        build_time,
        notes,
    })
}

/// Every mesh of a scene as the device buffers hold them (layout.h,
/// BINDING_MESH_*): each its own hierarchy, built once however many
/// primitives draw it.
#[derive(Default)]
struct PackedMeshes {
    nodes: Vec<layout::BvhNode>,
    triangles: Vec<layout::MeshTriangle>,
    vertices: Vec<layout::MeshVertex>,
    /// Each mesh's root node.
    roots: Vec<u32>,
}

/// Builds each mesh's hierarchy over its triangles (bvh.rs, the groups'
/// builder: binned SAH, at most 4 triangles a leaf) and packs its nodes,
/// its triangles in leaf order and its vertices, with global indices.
fn pack_meshes(scene: &Scene) -> Result<PackedMeshes, Error> {
    let mut out = PackedMeshes::default();
    for mesh in &scene.meshes {
        let too_many = |what: &str| {
            Error::Scene(format!(
                "{}: error: the meshes together have more {what} than the shader can index",
                mesh.path.display()
            ))
        };
        let vertex_base = u32::try_from(out.vertices.len()).map_err(|_| too_many("vertices"))?;
        let triangle_base = u32::try_from(out.triangles.len()).map_err(|_| too_many("triangles"))?;
        let node_base = u32::try_from(out.nodes.len()).map_err(|_| too_many("nodes"))?;
        let bounds: Vec<Aabb> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.iter().fold(Aabb::EMPTY, |b, &v| {
                    let p = mesh.positions[v as usize];
                    let d = DVec3::new(p[0].into(), p[1].into(), p[2].into());
                    b.union(Aabb { lo: d, hi: d })
                })
            })
            .collect();
        let built = bvh::build(&bounds, bounds.len());
        // The walk keeps at most depth + 1 entries (shape_mesh.glsl).
        if built.depth as usize + 1 > layout::MESH_STACK_SIZE as usize {
            return Err(Error::Scene(format!(
                "{}: error: the mesh's hierarchy is {} deep, more than the shader's {} (degenerate triangles?)",
                mesh.path.display(),
                built.depth,
                layout::MESH_STACK_SIZE - 1
            )));
        }
        out.roots.push(node_base);
        for node in &built.nodes {
            let (lo, hi) = node.bounds.padded_f32();
            let first = if node.count == 0 { node_base + node.first } else { triangle_base + node.first };
            out.nodes.push(layout::BvhNode {
                lo,
                hi,
                first,
                count: node.count,
                axis: node.axis,
                primitives: node.count,
            });
        }
        for &t in &built.order {
            let [a, b, c] = mesh.triangles[t as usize];
            let flags = if mesh.smooth[t as usize] { layout::MESH_SMOOTH } else { 0 };
            out.triangles.push(layout::MeshTriangle {
                a: vertex_base + a,
                b: vertex_base + b,
                c: vertex_base + c,
                flags,
            });
        }
        for (i, p) in mesh.positions.iter().enumerate() {
            let n = mesh.normals.get(i).copied().unwrap_or([0.0; 3]);
            // OBJ's v = 0 is the image's bottom row, the textures' top (textures.glsl).
            let [u, v] = mesh.uvs.get(i).map_or([0.0, 0.0], |&[u, v]| [u, 1.0 - v]);
            out.vertices.push(layout::MeshVertex { position: [p[0], p[1], p[2], u], normal: [n[0], n[1], n[2], v] });
        }
    }
    if out.nodes.len() > layout::MAX_INDEX as usize || out.vertices.len() > layout::MAX_INDEX as usize {
        return Err(Error::Scene(format!(
            "{}: error: the scene's meshes need more nodes or vertices than the shader can index ({})",
            scene.path.display(),
            layout::MAX_INDEX
        )));
    }
    Ok(out)
}

/// Whether a material lets light through: k_t O_t, the refracted ray's
/// weight (lighting.glsl surface_at), has a channel other than 0. Without
/// one FLAG_REFRACTION stays off and the picture is an opaque scene's.
pub fn transmits(materials: &[layout::Material], kt: f32) -> bool {
    materials.iter().any(|m| m.transparent[..3].iter().any(|&t| kt * t != 0.0))
}

/// Scenes of one group with at most this many primitives skip the hierarchy.
const SMALL_SCENE: usize = 8;

/// The groups of a scene as the device buffers hold them.
struct Packed {
    primitives: Vec<layout::Primitive>,
    nodes: Vec<layout::BvhNode>,
    leaf_items: Vec<layout::LeafItem>,
    instances: Vec<layout::Instance>,
    /// Each group's root node, the scene's root group first; empty without a hierarchy.
    group_roots: Vec<u32>,
    /// The walk's levels: 1 and the deepest nesting of masters under the root.
    levels: u32,
}

fn shape_code(shape: &Shape) -> u32 {
    match shape {
        Shape::Cube => layout::SHAPE_CUBE,
        Shape::Cone => layout::SHAPE_CONE,
        Shape::Cylinder => layout::SHAPE_CYLINDER,
        Shape::Torus => layout::SHAPE_TORUS,
        // flatten() keeps only drawn shapes.
        Shape::Mesh { .. } => layout::SHAPE_MESH,
        Shape::Sphere => layout::SHAPE_SPHERE,
    }
}

/// Builds each group's hierarchy (children before the groups that place
/// them, so instance boxes are known) and packs primitives, nodes, leaf
/// items and instances, with global indices. Proves that traversal fits the
/// shader's fixed stack and level arrays.
/// `materials` with repeats folded: each distinct material (bit for bit:
/// the same bytes shade the same) once, in order of first use, and where
/// each of the given ones went: a file that writes the same material on
/// many primitives uploads it once.
fn unique_materials(materials: Vec<layout::Material>) -> (Vec<layout::Material>, Vec<u32>) {
    let mut unique: Vec<layout::Material> = Vec::new();
    let mut index_of: std::collections::HashMap<Vec<u8>, u32> = std::collections::HashMap::new();
    let index = materials
        .iter()
        .map(|m| {
            *index_of.entry(bytemuck::bytes_of(m).to_vec()).or_insert_with(|| {
                unique.push(*m);
                (unique.len() - 1) as u32
            })
        })
        .collect();
    (unique, index)
}

/// One axis of a box as an instance record holds it (layout.h, BvhNode):
/// `q_lo` and `q_hi` steps in from the low and high sides `lo`, `hi` of the
/// leaf's box, computed in f32 exactly as the shader computes them.
fn stepped(lo: f32, hi: f32, q_lo: u32, q_hi: u32) -> (f32, f32) {
    let step = (hi - lo) / layout::BOX_STEPS as f32;
    (lo + q_lo as f32 * step, hi - q_hi as f32 * step)
}

/// The most steps in from each side of the leaf's box `leaf` whose box
/// (`stepped`) still holds `inner`; None where no number of steps
/// does (`inner` outside `leaf`, or a box too large for f32 steps).
pub(crate) fn box_steps(leaf: ([f32; 4], [f32; 4]), inner: ([f32; 4], [f32; 4])) -> Option<([u32; 3], [u32; 3])> {
    let (lo, hi) = leaf;
    let max = layout::BOX_STEPS;
    let mut q_lo = [0u32; 3];
    let mut q_hi = [0u32; 3];
    for a in 0..3 {
        let step = (hi[a] - lo[a]) / max as f32;
        if !step.is_finite() || lo[a] > inner.0[a] || hi[a] < inner.1[a] {
            return None;
        }
        if step == 0.0 {
            continue; // no steps: the leaf's own sides
        }
        let holds_lo = |q: u32| stepped(lo[a], hi[a], q, 0).0 <= inner.0[a];
        let holds_hi = |q: u32| stepped(lo[a], hi[a], 0, q).1 >= inner.1[a];
        // An estimate, then a step at a time to the last that holds (0 always does).
        let estimate = |d: f32| ((d / step).floor() as u32).min(max);
        q_lo[a] = most_steps(estimate(inner.0[a] - lo[a]), holds_lo);
        q_hi[a] = most_steps(estimate(hi[a] - inner.1[a]), holds_hi);
    }
    Some((q_lo, q_hi))
}

/// The largest q in 0..=BOX_STEPS with `holds(q)`, searched from
/// `estimate` (holds(0) is true; holds is true up to a point, then false).
fn most_steps(estimate: u32, holds: impl Fn(u32) -> bool) -> u32 {
    let mut q = estimate;
    while q > 0 && !holds(q) {
        q -= 1;
    }
    while q < layout::BOX_STEPS && holds(q + 1) {
        q += 1;
    }
    q
}

/// An instance record's four leaf-item words (layout.h, BvhNode): the
/// steps in from the leaf box's low and high sides, then `item`
/// (ITEM_INSTANCE | instance index).
fn instance_record(q_lo: [u32; 3], q_hi: [u32; 3], item: u32) -> [u32; 4] {
    [q_lo[0] | q_lo[1] << 16, q_lo[2] | q_hi[0] << 16, q_hi[1] | q_hi[2] << 16, item]
}

/// A sphere that holds everything `m` places of a group whose primitives
/// and instances lie within `radius` of `centre` (group space): its centre
/// and radius in the space `m` maps to. The radius grows by the largest
/// stretch of m's linear part, bounded above by the square root of the
/// largest row sum of |MᵀM| (exact for rotations and uniform scales).
fn placed_sphere(m: &DMat4, (centre, radius): (DVec3, f64)) -> (DVec3, f64) {
    let l = glam::DMat3::from_mat4(*m);
    let g = l.transpose() * l;
    let rows = (0..3).map(|r| g.row(r).abs().element_sum()).fold(0.0, f64::max);
    (m.transform_point3(centre), radius * rows.sqrt())
}

/// A shape's bounding sphere in object space: a canonical shape's about
/// the origin, a mesh's about its box's centre.
fn shape_sphere(scene: &Scene, shape: &Shape) -> (DVec3, f64) {
    if let Some(i) = scene.mesh_index(shape) {
        return scene.meshes[i].bounding_sphere();
    }
    let radius = match shape {
        Shape::Sphere | Shape::Torus => 0.5,
        Shape::Cone | Shape::Cylinder => 0.5f64.sqrt(),
        _ => 0.75f64.sqrt(),
    };
    (DVec3::ZERO, radius)
}

/// The farthest any point of a primitive (a shape placed by `m`, within
/// its object box) lies from `c`: the nearer of the box's farthest corner
/// and the shape's own bounding sphere placed by m.
fn primitive_reach(scene: &Scene, shape: &Shape, m: &DMat4, c: DVec3) -> f64 {
    let corners =
        scene.object_box(shape).corners().iter().map(|&k| (m.transform_point3(k) - c).length()).fold(0.0, f64::max);
    let (centre, radius) = placed_sphere(m, shape_sphere(scene, shape));
    corners.min((centre - c).length() + radius)
}

/// A sphere that holds a group's primitives and instances (`spheres`: each
/// group's, in its own space), in the group's space: about a centre moved
/// from the box's towards the farthest item (Bădoiu and Clarkson's
/// iteration, over each item's own bounding sphere), out to the farthest
/// point of any item.
fn bounding_sphere(
    scene: &Scene,
    group: &crate::scene::Group,
    bounds: &Aabb,
    spheres: &[(DVec3, f64)],
) -> (DVec3, f64) {
    let balls: Vec<(DVec3, f64)> = group
        .primitives
        .iter()
        .map(|p| placed_sphere(&p.world_from_object, shape_sphere(scene, &p.shape)))
        .chain(group.instances.iter().map(|i| placed_sphere(&i.parent_from_group, spheres[i.group as usize])))
        .collect();
    let reach = |c: DVec3| {
        let prims = group.primitives.iter().map(|p| primitive_reach(scene, &p.shape, &p.world_from_object, c));
        let insts = balls[group.primitives.len()..].iter().map(|(b, r)| (*b - c).length() + r);
        prims.chain(insts).fold(0.0, f64::max)
    };
    let start = bounds.centroid();
    let mut c = start;
    // Each pass looks at every item: a few million looks in all.
    let passes = (2_000_000 / balls.len().max(1)).clamp(1, 200);
    for k in 1..=passes {
        let far = |&(b, r): &(DVec3, f64)| (b - c).length() + r;
        let Some(&(b, r)) = balls.iter().max_by(|x, y| far(x).total_cmp(&far(y))) else { break };
        let towards = (b - c).try_normalize().unwrap_or(DVec3::X);
        c += (b + towards * r - c) / (k as f64 + 1.0);
    }
    let (from_start, from_c) = (reach(start), reach(c));
    if from_c < from_start {
        (c, from_c)
    } else {
        (start, from_start)
    }
}

/// An instance record for a bounding sphere (layout.h, BvhNode): the
/// centre `c` to the nearest step of the leaf's box, the radius grown by
/// the step's error and 2^-16 of itself for rounding, then rounded up to
/// f32. None where the radius is beyond f32 or the leaf's steps are.
fn sphere_record(leaf: ([f32; 4], [f32; 4]), (c, radius): (DVec3, f64), item: u32) -> Option<[u32; 4]> {
    let (lo, hi) = leaf;
    let mut q = [0u32; 3];
    let mut at = DVec3::ZERO;
    for a in 0..3 {
        let step = (hi[a] - lo[a]) / layout::BOX_STEPS as f32;
        if !step.is_finite() {
            return None;
        }
        if step > 0.0 {
            q[a] =
                ((c[a] - f64::from(lo[a])) / f64::from(step)).round().clamp(0.0, f64::from(layout::BOX_STEPS)) as u32;
        }
        at[a] = f64::from(stepped(lo[a], hi[a], q[a], 0).0);
    }
    let reach = (radius + (at - c).length()) * (1.0 + 1.0 / 65536.0) + f64::from(f32::MIN_POSITIVE);
    let r = reach as f32;
    let r = if f64::from(r) < reach { r.next_up() } else { r };
    r.is_finite().then_some([q[0] | q[1] << 16, q[2], r.to_bits(), layout::RECORD_SPHERE | item])
}

/// The steps of an instance record's words, as the shader reads them.
#[cfg(test)]
fn record_steps(w: [u32; 4]) -> ([u32; 3], [u32; 3]) {
    ([w[0] & 0xffff, w[0] >> 16, w[1] & 0xffff], [w[1] >> 16, w[2] & 0xffff, w[2] >> 16])
}

/// The most primitives `fit_nesting` stores in all before it gives up
/// (each about 300 bytes on the host, 80 on the device, before the
/// hierarchy).
const MAX_WRITTEN_OUT: usize = 1_000_000;

/// A scene whose masters nest deeper than the shader's levels (the root
/// and MAX_LEVELS - 1 levels of instances below it) with its deepest
/// levels written out: each group that places no other is copied into the
/// groups that place it (its primitives through the instance's matrices,
/// their ids kept, so the tie rule and `--no-bvh` see the same scene), one
/// level a round, until the nesting fits; groups no longer placed are
/// dropped (in one pass: `rounds` below). With the note that says so; None
/// where the scene fits as it is.
/// The deepest levels are the cheapest to write out: a master there holds
/// few primitives, and nothing is copied more often than it is placed.
pub(crate) fn fit_nesting(scene: &Scene) -> Result<Option<(Scene, String)>, Error> {
    let mut height = vec![0usize; scene.groups.len()];
    for g in scene.groups_children_first() {
        height[g] = scene.groups[g].instances.iter().map(|i| height[i.group as usize] + 1).max().unwrap_or(0);
    }
    let (deepest, max) = (height.first().copied().unwrap_or(0), layout::MAX_LEVELS as usize - 1);
    if deepest <= max {
        return Ok(None);
    }
    let stored = |groups: &[Group]| groups.iter().map(|g| g.primitives.len()).sum::<usize>();
    let before = stored(&scene.groups);
    // Round r (from 0) of writing out the bottom level copies each group of
    // height r into the groups placing it, by then holding its whole
    // subtree; so after `rounds` rounds, each instance of a group of height
    // below `rounds` is written out, its copies after the group's own
    // primitives in the order of the rounds (the placed group's height,
    // then the instances' order). Done so in one pass, children first:
    // round by round over every group took time cubic, then quadratic, in
    // the chain's depth (minutes for a chain of 6,000 masters).
    let rounds = deepest - max;
    let mut groups = scene.groups.clone();
    let mut total = before;
    for p in scene.groups_children_first() {
        let (mut placed, kept): (Vec<Instance>, Vec<Instance>) =
            std::mem::take(&mut groups[p].instances).into_iter().partition(|i| height[i.group as usize] < rounds);
        groups[p].instances = kept;
        placed.sort_by_key(|i| height[i.group as usize]);
        total += placed.iter().map(|i| groups[i.group as usize].primitives.len()).sum::<usize>();
        if total > MAX_WRITTEN_OUT {
            return Err(Error::Scene(format!(
                "{}: error: masters are nested {deepest} deep, more than the shader's {max} levels, and writing the \
                 deepest levels out into the masters that place them would store more than {MAX_WRITTEN_OUT} \
                 primitives: nest the masters less deeply",
                scene.path.display()
            )));
        }
        let copies: Vec<Primitive> = placed
            .iter()
            .flat_map(|i| {
                groups[i.group as usize].primitives.iter().map(move |c| Primitive {
                    world_from_object: i.parent_from_group * c.world_from_object,
                    object_from_world: c.object_from_world * i.group_from_parent,
                    id_offset: i.id_offset + c.id_offset,
                    ..c.clone()
                })
            })
            .collect();
        groups[p].primitives.extend(copies);
    }
    // The groups still placed, in their order (the root first), renumbered.
    let mut reached = vec![false; groups.len()];
    reached[0] = true;
    let mut stack = vec![0usize];
    while let Some(g) = stack.pop() {
        for i in &groups[g].instances {
            if !std::mem::replace(&mut reached[i.group as usize], true) {
                stack.push(i.group as usize);
            }
        }
    }
    let mut number = vec![u32::MAX; groups.len()];
    let mut kept = Vec::new();
    for (g, group) in groups.into_iter().enumerate().filter(|(g, _)| reached[*g]) {
        number[g] = kept.len() as u32;
        kept.push(group);
    }
    for i in kept.iter_mut().flat_map(|g| g.instances.iter_mut()) {
        i.group = number[i.group as usize];
    }
    let note = format!(
        "{}: masters are nested {deepest} deep, more than the shader's {max} levels: the deepest {} written out into \
         the masters that place them ({before} primitives stored, now {}, in {} groups)",
        scene.path.display(),
        if deepest - max == 1 { "level".to_string() } else { format!("{} levels", deepest - max) },
        stored(&kept),
        kept.len()
    );
    let written_out = Scene {
        path: scene.path.clone(),
        globals: scene.globals,
        camera: scene.camera.clone(),
        lights: scene.lights.clone(),
        groups: kept,
        materials: scene.materials.clone(),
        meshes: scene.meshes.clone(),
        warnings: scene.warnings.clone(),
    };
    Ok(Some((written_out, note)))
}

/// The scene's groups packed for the device; an error names the file (and
/// the element, where one is to blame).
fn pack_groups(scene: &Scene) -> Result<Packed, Error> {
    let whole = |message: String| Error::Scene(format!("{}: error: {message}", scene.path.display()));
    let groups = &scene.groups;
    let n = groups.len();
    if scene.primitive_count() >= u64::from(layout::NO_HIT) {
        return Err(whole(format!(
            "the scene expands to {} primitives; ids are 32-bit, so at most {}",
            scene.primitive_count(),
            layout::NO_HIT - 1
        )));
    }
    let post = scene.groups_children_first();
    let mut prim_base = vec![0u32; n];
    let mut inst_base = vec![0u32; n];
    let (mut p_total, mut i_total) = (0u32, 0u32);
    for g in 0..n {
        prim_base[g] = p_total;
        inst_base[g] = i_total;
        p_total += groups[g].primitives.len() as u32;
        i_total += groups[g].instances.len() as u32;
    }

    let mut nodes: Vec<layout::BvhNode> = Vec::new();
    let mut leaf_items: Vec<layout::LeafItem> = Vec::new();
    let mut group_root = vec![u32::MAX; n];
    let mut group_bounds = vec![Aabb::EMPTY; n];
    // Each group's bounding sphere (centre, radius), in its own space.
    let mut group_sphere = vec![(DVec3::ZERO, 0.0f64); n];
    // The sphere records written (where in leaf_items, and the box record
    // in their place), and the surface of the bounds chosen against boxes.
    let mut spheres: Vec<(usize, Result<[u32; 4], Error>)> = Vec::new();
    struct Areas {
        chosen: f64,
        boxes: f64,
        any_box: bool,
    }
    let mut areas = Areas { chosen: 0.0, boxes: 0.0, any_box: false };
    // Stack entries and instance levels a traversal starting in the group needs.
    let mut need = vec![0u32; n];
    let mut levels = vec![0u32; n];
    for &g in &post {
        let group = &groups[g];
        let np = group.primitives.len();
        let bounds: Vec<Aabb> = group
            .primitives
            .iter()
            .map(|p| scene.object_box(&p.shape).transformed(&p.world_from_object))
            .chain(group.instances.iter().map(|i| group_bounds[i.group as usize].transformed(&i.parent_from_group)))
            .collect();
        let built = bvh::build(&bounds, np);
        if built.nodes.is_empty() {
            continue;
        }
        let node_base = nodes.len() as u32;
        group_root[g] = node_base;
        group_bounds[g] = built.nodes[0].bounds;
        if g != 0 {
            group_sphere[g] = bounding_sphere(scene, group, &built.nodes[0].bounds, &group_sphere);
        }
        // Depth of each node, for the stack bound.
        let mut depth = vec![0u32; built.nodes.len()];
        for (i, node) in built.nodes.iter().enumerate() {
            let (lo, hi) = node.bounds.padded_f32();
            let interior = node.count == 0;
            let mut first = node_base + node.first;
            // An inner node's split axis; a leaf's first primitive (layout.h, BvhNode).
            let mut axis = node.axis;
            if interior {
                depth[node.first as usize] = depth[i] + 1;
                depth[node.first as usize + 1] = depth[i] + 1;
            } else {
                // Its primitives, then its instances' records from the next
                // multiple of 4 (layout.h, BvhNode).
                first = leaf_items.len() as u32;
                let items = &built.order[node.first as usize..(node.first + node.count) as usize];
                axis = items.iter().find(|&&k| (k as usize) < np).map_or(0, |&k| prim_base[g] + k);
                for &k in items.iter().filter(|&&k| (k as usize) < np) {
                    leaf_items.push(layout::LeafItem { item: prim_base[g] + k });
                }
                while node.primitives < node.count && !leaf_items.len().is_multiple_of(4) {
                    leaf_items.push(layout::LeafItem::default());
                }
                for &k in items.iter().filter(|&&k| (k as usize) >= np) {
                    let inst = &group.instances[k as usize - np];
                    let (ilo, ihi) =
                        group_bounds[inst.group as usize].transformed(&inst.parent_from_group).padded_f32();
                    let item = layout::ITEM_INSTANCE | (inst_base[g] + k - np as u32);
                    // A sphere where its surface is less than twice the
                    // box's (a ray meets a convex bound about in proportion
                    // to its surface, and the sphere's test is the cheaper:
                    // on recursive-cubes depth 6, spheres everywhere, each
                    // at least 1.57 times its cube's surface, took 517-527
                    // ms against 593-601 with boxes alone). It holds every
                    // hit because each shape's test errs by a few f32 steps
                    // of the ray's offset (raycast.glsl, sphere_hit).
                    let sphere = placed_sphere(&inst.parent_from_group, group_sphere[inst.group as usize]);
                    let size: [f64; 3] = std::array::from_fn(|a| f64::from(ihi[a]) - f64::from(ilo[a]));
                    let box_area = 2.0 * (size[0] * size[1] + size[1] * size[2] + size[2] * size[0]);
                    let sphere_area = 4.0 * std::f64::consts::PI * sphere.1 * sphere.1;
                    let boxed = || {
                        let (q_lo, q_hi) = box_steps((lo, hi), (ilo, ihi)).ok_or_else(|| {
                            Error::Scene(format!("{}: error: this master's box cannot be written in steps of its leaf's (coordinates beyond about 1e38?)", inst.loc))
                        })?;
                        Ok::<_, Error>(instance_record(q_lo, q_hi, item))
                    };
                    areas.boxes += box_area;
                    let record = match sphere_record((lo, hi), sphere, item) {
                        Some(record) if sphere_area < 2.0 * box_area => {
                            areas.chosen += sphere_area;
                            spheres.push((leaf_items.len(), boxed()));
                            record
                        }
                        _ => {
                            areas.chosen += box_area;
                            areas.any_box = true;
                            boxed()?
                        }
                    };
                    leaf_items.extend(record.map(|item| layout::LeafItem { item }));
                }
                let placed: Vec<usize> = items
                    .iter()
                    .filter(|&&k| k as usize >= np)
                    .map(|&k| group.instances[k as usize - np].group as usize)
                    .collect();
                let child_need = placed.iter().map(|&c| need[c]).max().unwrap_or(0);
                let k = placed.len() as u32;
                let leaf_need = depth[i] + if k == 0 { 1 } else { k.max(k - 1 + child_need) };
                need[g] = need[g].max(leaf_need);
                levels[g] = levels[g].max(placed.iter().map(|&c| levels[c] + 1).max().unwrap_or(0));
            }
            nodes.push(layout::BvhNode { lo, hi, first, count: node.count, axis, primitives: node.primitives });
        }
        // An interior node's two children are pushed at once: one more entry.
        need[g] += 1;
    }
    // Both kinds cost a kernel both tests for every record (lavapipe runs
    // both sides of an `if`): spheres beside boxes only where they cut the
    // surface a ray may meet by a fifth (recursive-cubes depth 6 with the
    // spheres only where smaller than the box, 32% less surface: 607-639 ms
    // against 593-601 with boxes alone).
    if areas.any_box && areas.chosen >= 0.8 * areas.boxes {
        for (at, boxed) in spheres {
            let words = boxed?;
            for (i, w) in words.into_iter().enumerate() {
                leaf_items[at + i].item = w;
            }
        }
    }
    if need[0] > layout::STACK_SIZE {
        return Err(whole(format!(
            "the scene's hierarchy needs a traversal stack of {} entries, more than the shader's {} (masters nested too deeply)",
            need[0],
            layout::STACK_SIZE
        )));
    }
    if levels[0] >= layout::MAX_LEVELS {
        // `build` wrote the deepest levels out first (fit_nesting).
        return Err(whole(format!(
            "internal error: masters are nested {} deep after fit_nesting, more than the shader's {} levels",
            levels[0],
            layout::MAX_LEVELS - 1
        )));
    }
    let primitives = groups
        .iter()
        .flat_map(|g| &g.primitives)
        .map(|p| layout::Primitive {
            object_from_world: mat4(&p.object_from_world),
            shape: shape_code(&p.shape),
            material: p.material,
            id_offset: p.id_offset as u32,
            // The mesh's index here; `build` makes it its root node.
            mesh: scene.mesh_index(&p.shape).map_or(0, |i| i as u32),
        })
        .collect();
    let instances = groups
        .iter()
        .flat_map(|g| &g.instances)
        .map(|i| layout::Instance {
            object_from_parent: mat4(&i.group_from_parent),
            root: group_root[i.group as usize],
            id_offset: i.id_offset as u32,
            ..Default::default()
        })
        .collect();
    for (what, count) in [("nodes", nodes.len()), ("primitives", p_total as usize), ("instances", i_total as usize)] {
        if count > layout::MAX_INDEX as usize {
            return Err(whole(format!(
                "the scene needs {count} {what}, more than the shader can index ({})",
                layout::MAX_INDEX
            )));
        }
    }
    if group_root[0] == u32::MAX {
        // Nothing to draw: no hierarchy, no primitives.
        return Ok(Packed {
            primitives: vec![],
            nodes: vec![],
            leaf_items: vec![],
            instances: vec![],
            group_roots: vec![],
            levels: 1,
        });
    }
    if n == 1 && p_total as usize <= SMALL_SCENE {
        // A few primitives and no instances: testing them in order is cheaper
        // than walking a hierarchy, and computes exactly the same.
        return Ok(Packed {
            primitives,
            nodes: vec![],
            leaf_items: vec![],
            instances: vec![],
            group_roots: vec![],
            levels: 1,
        });
    }
    Ok(Packed { primitives, nodes, leaf_items, instances, group_roots: group_root, levels: levels[0] + 1 })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Camera;
    use clap::ValueEnum;

    /// `Aov::name` (the preview's status line, `bench`, `conformance`) is what `--aov` takes.
    #[test]
    fn aov_names_are_the_command_lines() {
        for aov in Aov::value_variants() {
            assert_eq!(aov.to_possible_value().unwrap().get_name(), aov.name());
        }
    }

    /// The film corner (1, 1, -1) must map to the direction of the top-right
    /// pixel edge given by docs/scene-format.md#camera: U/2·u + V/2·v - w.
    #[test]
    fn world_from_film_matches_the_documented_camera() {
        let cam = Camera {
            pos: DVec3::new(1.0, 2.0, 3.0),
            look: DVec3::new(0.0, 0.0, -2.0),
            up: DVec3::new(0.0, 1.0, 0.0),
            height_angle_deg: 90.0,
            ..Camera::default()
        };
        let m = world_from_film(&cam, 200, 100);
        // Looking down -z with y up: u = +x, v = +y, w = +z. V = 2, U = 4.
        let p = m.transform_point3(DVec3::new(1.0, 1.0, -1.0));
        let expect = DVec3::new(1.0 + 2.0, 2.0 + 1.0, 3.0 - 1.0);
        assert!((p - expect).length() < 1e-12, "film corner went to {p}, expected {expect}");
        let eye = m.transform_point3(DVec3::ZERO);
        assert!((eye - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12, "film origin went to {eye}, expected the eye");
    }

    /// Every primitive id is reached exactly once walking the packed
    /// hierarchy from the root through every instance, every leaf's axis
    /// is its first primitive, every node's box holds its children's, every instance record's box (as the shader
    /// computes it) its root's, and every record's sphere the points of
    /// every primitive it leads to.
    #[test]
    fn packed_hierarchy_reaches_every_primitive_once() {
        let xml = r#"<scenefile>
          <object type="tree" name="leaf"><transblock><object type="primitive" name="sphere"/></transblock>
            <transblock><translate x="1" y="0" z="0"/><object type="primitive" name="cube"/></transblock></object>
          <object type="tree" name="mid">
            <transblock><object type="primitive" name="cone"/></transblock>
            <transblock><translate x="3" y="0" z="0"/><object type="master" name="leaf"/></transblock>
            <transblock><translate x="0" y="3" z="0"/><scale x="2" y="2" z="2"/><object type="master" name="leaf"/></transblock></object>
          <object type="tree" name="root">
            <transblock><object type="master" name="mid"/></transblock>
            <transblock><rotate x="0" y="1" z="0" angle="30"/><translate x="10" y="0" z="0"/><object type="master" name="mid"/></transblock>
            <transblock><object type="primitive" name="cylinder"/></transblock>
            <transblock><translate x="-4" y="0" z="0"/><object type="master" name="leaf"/></transblock>
            <transblock><translate x="0" y="-6" z="0"/><scale x="8" y="0.25" z="0.25"/><object type="master" name="leaf"/></transblock>
          </object></scenefile>"#;
        let scene = crate::scene::from_xml(xml, "t.xml");
        assert_eq!(scene.primitive_count(), 2 * 5 + 1 + 2 + 2);
        let mut kinds = check_packed_hierarchy(&scene);
        // The generated families: spheres, upright cones, axis-aligned cubes.
        for family in [
            crate::gen::Family::RecursiveSpheres,
            crate::gen::Family::RecursiveCones,
            crate::gen::Family::RecursiveCubes,
        ] {
            let xml = crate::gen::generate(family, 3, &crate::gen::GenOptions { texture: None }).unwrap();
            let file = crate::scene::parse_str(&xml, std::path::Path::new("gen.xml"), &Default::default()).unwrap();
            let (boxes, spheres) = check_packed_hierarchy(&crate::scene::flatten(&file, &Default::default()).unwrap());
            kinds = (kinds.0 + boxes, kinds.1 + spheres);
        }
        assert!(kinds.0 > 0 && kinds.1 > 0, "records (boxes, spheres) {kinds:?}: both kinds checked");
    }

    /// A chain of masters `levels` deep: each a sphere and two smaller
    /// copies of the one below, turned (the root places the top one).
    fn chain(levels: usize) -> String {
        let mut xml = String::from(
            r#"<scenefile><object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>"#,
        );
        for i in 1..levels {
            xml += &format!(
                r#"<object type="tree" name="m{i}"><transblock><object type="primitive" name="sphere"/></transblock>
                <transblock><translate x="0.75" y="0" z="0"/><rotate x="0" y="1" z="0" angle="40"/><scale x="0.6" y="0.6" z="0.6"/><object type="master" name="m{}"/></transblock>
                <transblock><translate x="0" y="0.75" z="0"/><scale x="0.5" y="0.5" z="0.5"/><object type="master" name="m{}"/></transblock></object>"#,
                i - 1,
                i - 1
            );
        }
        xml + &format!(
            r#"<object type="tree" name="root"><transblock><object type="master" name="m{}"/></transblock></object></scenefile>"#,
            levels - 1
        )
    }

    /// Masters nested deeper than the shader's levels render: the deepest
    /// levels are written out into the masters that place them until the
    /// nesting fits, every primitive still reached once with its id; a
    /// scene that fits is packed as it is.
    #[test]
    fn masters_nested_too_deeply_are_written_out_until_they_fit() {
        let max = layout::MAX_LEVELS as usize - 1;
        let fits = crate::scene::from_xml(chain(max), "fits.xml");
        let data = build(&fits, &RenderSettings::default()).unwrap();
        assert_eq!((data.levels, data.groups, data.notes.len()), (layout::MAX_LEVELS, max + 1, 0), "{:?}", data.notes);
        let deep = crate::scene::from_xml(chain(max + 3), "deep.xml");
        let data = build(&deep, &RenderSettings::default()).unwrap();
        assert_eq!((data.levels, data.groups), (layout::MAX_LEVELS, max + 1));
        assert_eq!(data.expanded, (1 << (max + 3)) - 1);
        assert_eq!(
            data.notes,
            [format!(
                "deep.xml: masters are nested {} deep, more than the shader's {max} levels: the deepest 3 levels written \
                 out into the masters that place them ({} primitives stored, now {}, in {} groups)",
                max + 3,
                max + 3,
                (max - 1) + 15,
                max + 1
            )]
        );
        check_packed_hierarchy(&deep);
        // A long chain, each master placing the one before once (a file of
        // 2.8 MB): written out in one pass over the groups, where a round
        // per level over every group took minutes (cubic in the depth).
        let n = 20_000;
        let mut xml = String::from(
            r#"<scenefile><object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>"#,
        );
        for i in 1..n {
            xml += &format!(
                r#"<object type="tree" name="m{i}"><transblock><translate x="0.0001" y="0" z="0"/><object type="master" name="m{}"/></transblock></object>"#,
                i - 1
            );
        }
        xml += &format!(
            r#"<object type="tree" name="root"><transblock><object type="master" name="m{}"/></transblock></object></scenefile>"#,
            n - 1
        );
        let data = build(&crate::scene::from_xml(&xml, "long.xml"), &RenderSettings::default()).unwrap();
        assert_eq!((data.expanded, data.primitives.len(), data.groups), (1, 1, max + 1), "{:?}", data.notes);
        assert!(data.notes[0].contains(&format!("the deepest {} levels written out", n - max)), "{:?}", data.notes);
    }

    /// Points on a canonical shape's surface, its farthest from the centre.
    fn surface_points(shape: u32) -> Vec<DVec3> {
        let mut points = Vec::new();
        for i in 0..27 {
            let d = DVec3::new((i % 3) as f64 - 1.0, ((i / 3) % 3) as f64 - 1.0, (i / 9) as f64 - 1.0);
            match shape {
                layout::SHAPE_SPHERE if d != DVec3::ZERO => points.push(d.normalize() * 0.5),
                layout::SHAPE_CUBE if d.abs() == DVec3::ONE => points.push(d * 0.5),
                _ => {}
            }
        }
        if shape == layout::SHAPE_CONE || shape == layout::SHAPE_CYLINDER {
            for k in 0..16 {
                let a = k as f64 * std::f64::consts::TAU / 16.0;
                points.push(DVec3::new(0.5 * a.cos(), -0.5, 0.5 * a.sin()));
                points.push(DVec3::new(0.5 * a.cos(), 0.5, 0.5 * a.sin()));
            }
        }
        points
    }

    /// The walk of `packed_hierarchy_reaches_every_primitive_once` over one
    /// scene; how many box and sphere records it checked.
    fn check_packed_hierarchy(scene: &Scene) -> (usize, usize) {
        let data = build(scene, &RenderSettings::default()).unwrap();
        assert!(data.frame.node_count > 0);
        let mat = |m: &Mat4| glam::Mat4::from_cols_array_2d(m).as_dmat4();
        let mut seen = vec![0u32; scene.primitive_count() as usize];
        let mut kinds = (0, 0);
        // (node, first id of the group, world from the group's space, the
        // spheres of the records that led there: their space from the
        // world's, centre, radius)
        type Spheres = Vec<(DMat4, DVec3, f64)>;
        let mut stack: Vec<(u32, u32, DMat4, Spheres)> =
            vec![(data.frame.root_node, 0u32, DMat4::IDENTITY, Vec::new())];
        while let Some((n, first_id, world_from_group, spheres)) = stack.pop() {
            let node = data.nodes[n as usize];
            if node.count == 0 {
                for c in [node.first, node.first + 1] {
                    let child = data.nodes[c as usize];
                    for a in 0..3 {
                        assert!(
                            node.lo[a] <= child.lo[a] && node.hi[a] >= child.hi[a],
                            "node {n} does not hold child {c}"
                        );
                    }
                    stack.push((c, first_id, world_from_group, spheres.clone()));
                }
                continue;
            }
            // A leaf's axis is its first primitive (the walk reads it in place of that item).
            let first = if node.primitives > 0 { data.leaf_items[node.first as usize].item } else { 0 };
            assert_eq!(node.axis, first, "node {n}: its axis is not its first primitive");
            for k in node.first..node.first + node.primitives {
                let item = data.leaf_items[k as usize].item;
                assert_eq!(item & layout::ITEM_INSTANCE, 0, "node {n}: item {k} is not a primitive");
                let p = &data.primitives[item as usize];
                seen[(first_id + p.id_offset) as usize] += 1;
                let world_from_object = world_from_group * mat(&p.object_from_world).inverse();
                for point in surface_points(p.shape) {
                    let w = world_from_object.transform_point3(point);
                    for (space_from_world, c, r) in &spheres {
                        let d = (space_from_world.transform_point3(w) - *c).length();
                        assert!(d <= r * (1.0 + 1e-4), "node {n}: primitive {item}'s point {w} is {d} from a record's sphere's centre {c}, radius {r}");
                    }
                }
            }
            // The instances' records, from the next multiple of 4: each box,
            // as the shader computes it, holds the instance's root box mapped
            // back from the placed group's space (within rounding); each
            // sphere is checked at the primitives below it.
            let records = (node.first + node.primitives).next_multiple_of(4);
            for r in 0..node.count - node.primitives {
                let w: [u32; 4] = std::array::from_fn(|i| data.leaf_items[(records + 4 * r) as usize + i].item);
                assert_ne!(w[3] & layout::ITEM_INSTANCE, 0, "node {n}: record {r} is not an instance");
                let inst = data.instances[(w[3] & !(layout::ITEM_INSTANCE | layout::RECORD_SPHERE)) as usize];
                let m = mat(&inst.object_from_parent).inverse();
                let mut below = spheres.clone();
                let (q_lo, q_hi) = record_steps(w);
                if w[3] & layout::RECORD_SPHERE != 0 {
                    kinds.1 += 1;
                    let c = DVec3::from(std::array::from_fn::<f64, 3, _>(|a| {
                        f64::from(stepped(node.lo[a], node.hi[a], q_lo[a], 0).0)
                    }));
                    below.push((world_from_group.inverse(), c, f64::from(f32::from_bits(w[2]))));
                } else {
                    kinds.0 += 1;
                    let sides: [(f32, f32); 3] =
                        std::array::from_fn(|a| stepped(node.lo[a], node.hi[a], q_lo[a], q_hi[a]));
                    let (lo, hi) =
                        (DVec3::from(sides.map(|s| f64::from(s.0))), DVec3::from(sides.map(|s| f64::from(s.1))));
                    let root = data.nodes[inst.root as usize];
                    let root_box = Aabb {
                        lo: glam::Vec3::from_slice(&root.lo).as_dvec3(),
                        hi: glam::Vec3::from_slice(&root.hi).as_dvec3(),
                    };
                    let slack = (hi - lo).max_element() * 1e-4;
                    for corner in root_box.corners() {
                        let p = m.transform_point3(corner);
                        assert!(
                            p.cmpge(lo - slack).all() && p.cmple(hi + slack).all(),
                            "node {n}, record {r}: the root box's corner {p} is outside the record's box {lo} .. {hi}"
                        );
                    }
                }
                stack.push((inst.root, first_id + inst.id_offset, world_from_group * m, below));
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "ids reached other than once: {seen:?}");
        // Ids follow flatten order: the world matrices of primitive(id) agree.
        let flat = scene.flat_primitives();
        for (id, p) in flat.iter().enumerate() {
            assert_eq!(scene.primitive(id as u64).unwrap().world_from_object, p.world_from_object, "id {id}");
        }
        kinds
    }

    /// Steps hold the box exactly as the shader computes them, as tight as
    /// a step allows; boxes outside the leaf, or too large for f32 steps,
    /// have none.
    #[test]
    fn box_steps_hold_the_box_and_are_tight() {
        let leaf = ([-3.0f32, 1000.0, -1e-3, 0.0], [5.0f32, 1001.0, 1e-3, 0.0]);
        let inner = ([-1.0f32, 1000.25, -1e-3, 0.0], [4.999f32, 1000.5, 0.0, 0.0]);
        let (q_lo, q_hi) = box_steps(leaf, inner).unwrap();
        for a in 0..3 {
            let (lo, hi) = stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a]);
            assert!(lo <= inner.0[a] && hi >= inner.1[a], "axis {a}: {lo}..{hi}");
            // One step more is too many (or the count is at its largest).
            let (lo1, _) = stepped(leaf.0[a], leaf.1[a], q_lo[a] + 1, q_hi[a]);
            let (_, hi1) = stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a] + 1);
            assert!(lo1 > inner.0[a] || q_lo[a] == layout::BOX_STEPS, "axis {a}: low side not tight");
            assert!(hi1 < inner.1[a] || q_hi[a] == layout::BOX_STEPS, "axis {a}: high side not tight");
        }
        // The leaf itself: its own sides (some steps round to nothing at 1000).
        let (q_lo, q_hi) = box_steps(leaf, leaf).unwrap();
        for a in 0..3 {
            assert_eq!(stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a]), (leaf.0[a], leaf.1[a]), "axis {a}");
        }
        assert_eq!(box_steps(leaf, ([-4.0, 1000.0, 0.0, 0.0], [0.0, 1000.5, 0.0, 0.0])), None, "outside the leaf");
        let huge = ([-3e38f32, 0.0, 0.0, 0.0], [3e38f32, 1.0, 1.0, 0.0]);
        assert_eq!(box_steps(huge, huge), None, "a span beyond f32");
    }

    /// Leaves without instances hold their primitives and nothing else: the
    /// padding before instance records is only where records follow.
    #[test]
    fn flat_leaves_are_not_padded() {
        let mut xml = String::from("<scenefile><object type=\"tree\" name=\"root\">");
        for k in 0..20 {
            xml.push_str(&format!("<transblock><translate x=\"{}\" y=\"0\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/></transblock>", 3 * k));
        }
        xml.push_str("</object></scenefile>");
        let scene = crate::scene::from_xml(xml, "t.xml");
        let data = build(&scene, &RenderSettings::default()).unwrap();
        assert!(data.frame.node_count > 1, "20 primitives get a hierarchy");
        assert_eq!(data.leaf_items.len(), 20);
    }

    #[test]
    fn settings_reject_zero_and_absurd_sizes() {
        let mut s = RenderSettings { width: 0, ..RenderSettings::default() };
        assert!(s.validate().unwrap_err().0.contains("--width 0"));
        s.width = 10;
        s.height = MAX_IMAGE_SIDE + 1;
        assert!(s.validate().unwrap_err().0.contains("--height"));
        s.height = 10;
        assert!(s.validate().is_ok());
    }

    /// Materials written the same on several primitives are one material;
    /// each primitive still gets the values it wrote.
    #[test]
    fn repeated_materials_are_folded() {
        let xml = r#"<scenefile><object type="tree" name="root">
            <transblock><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/></object></transblock>
            <transblock><translate x="2" y="0" z="0"/><object type="primitive" name="cube"><diffuse r="0" g="1" b="0"/></object></transblock>
            <transblock><translate x="4" y="0" z="0"/><object type="primitive" name="cone"><diffuse r="1" g="0" b="0"/></object></transblock>
            <transblock><translate x="6" y="0" z="0"/><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/><shininess v="3"/></object></transblock>
          </object></scenefile>"#;
        let scene = crate::scene::from_xml(xml, "t.xml");
        assert_eq!(scene.materials.len(), 4, "the file writes four");
        let data = build(&scene, &RenderSettings::default()).unwrap();
        assert_eq!(data.materials.len(), 3, "red, green, red with a highlight");
        // Every primitive's packed material holds the values its element wrote.
        for (k, p) in scene.groups.iter().flat_map(|g| &g.primitives).enumerate() {
            let wrote = &scene.materials[p.material as usize];
            let got = &data.materials[data.primitives[k].material as usize];
            assert_eq!(got.diffuse[..3], wrote.diffuse, "primitive {k}");
            assert_eq!(got.shininess, wrote.shininess, "primitive {k}");
        }
        let first_red = data.primitives.iter().map(|p| p.material).collect::<Vec<_>>();
        assert_eq!(first_red[0], first_red[2], "the two plain red ones share one");
    }

    /// A texture is measured from its header before it is decoded: one
    /// whose header claims 60000x60000 texels is refused with its size (it
    /// was the image crate's "Memory limit exceeded"); a truncated one names
    /// the file (and its size, where its header was whole); small ones load,
    /// their format told by their content.
    #[test]
    fn textures_are_measured_before_they_are_decoded() {
        let dir = std::env::temp_dir().join(format!("raycast-frame-tex-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let texture = |name: &str, bytes: &[u8]| {
            let path = dir.join(name);
            std::fs::write(&path, bytes).unwrap();
            let loc = crate::scene::SourceLoc { file: std::sync::Arc::new("t.xml".into()), line: 3, col: 7 };
            TextureRef { file: name.into(), resolved: Some(path), repeat_u: 1.0, repeat_v: 1.0, loc }
        };
        let mut table = TextureTable::default();
        // A PPM header alone: its size is read, its pixels never.
        let e = table.add(&texture("huge.ppm", b"P6\n60000 60000\n255\n")).unwrap_err().to_string();
        assert!(
            e.starts_with("t.xml:3:7: error: texture ") && e.contains("huge.ppm (60000x60000) does not fit"),
            "{e}"
        );
        let e = table.add(&texture("header.ppm", b"P6\n4")).unwrap_err().to_string();
        assert!(e.starts_with("t.xml:3:7: error: cannot read texture ") && e.contains("header.ppm"), "{e}");
        // Its header whole, its pixels cut short: told with the size.
        let e = table.add(&texture("cut.ppm", b"P6\n4 4\n255\n\x01\x02")).unwrap_err().to_string();
        assert!(
            e.starts_with("t.xml:3:7: error: cannot read texture ") && e.contains("cut.ppm") && e.ends_with("(4x4)"),
            "{e}"
        );
        let small = dir.join("small.png");
        image::RgbImage::from_pixel(3, 2, image::Rgb([1, 2, 3])).save(&small).unwrap();
        let small = std::fs::read(&small).unwrap();
        assert_eq!(table.add(&texture("small2.png", &small)).ok(), Some(0));
        assert_eq!((table.textures[0].width, table.textures[0].height, table.texels.len()), (3, 2, 6));
        // Other formats, told by their content: a BMP under a .png name.
        let bmp = dir.join("small.bmp");
        image::RgbImage::from_pixel(2, 2, image::Rgb([4, 5, 6])).save(&bmp).unwrap();
        assert_eq!(table.add(&texture("bmp.png", &std::fs::read(&bmp).unwrap())).ok(), Some(1));
        assert_eq!(
            table.texels[6..].iter().map(|t| t.rgba).collect::<Vec<_>>(),
            vec![u32::from_le_bytes([4, 5, 6, 255]); 4]
        );
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// `--aov`'s help (render's, check's and the preview's) tells the cost
    /// views' default scales as they are.
    #[test]
    fn aov_help_tells_the_cost_scales() {
        use clap::ValueEnum;
        let help = |v: Aov| v.to_possible_value().unwrap().get_help().unwrap().to_string();
        assert!(help(Aov::Cost).contains(&format!("from {} passes on", Aov::Cost.default_cost_max())));
        assert!(help(Aov::CostAll).contains(&format!("from {} passes on", Aov::CostAll.default_cost_max())));
    }

    /// A camera whose rows are closer than the floats resolve is refused,
    /// by its angle a row (the picture's height counts): heightangle 1e-5
    /// degrees at 384 rows, at its `<heightangle>`; 0.01 degrees there
    /// renders, as 1e-5 at 1 row.
    #[test]
    fn rows_narrower_than_the_floats_resolve_are_refused() {
        let scene = |degrees: &str| {
            crate::scene::from_xml(
                format!(
                    r#"<scenefile><cameradata><pos x="0" y="0" z="1e7"/><focus x="0" y="0" z="0"/><up x="0" y="1" z="0"/><heightangle v="{degrees}"/></cameradata>
<object type="tree" name="root"><transblock><object type="primitive" name="sphere"/></transblock></object></scenefile>"#
                ),
                "t.xml",
            )
        };
        let e = build(&scene("1e-5"), &RenderSettings::default()).map(|_| ()).unwrap_err().to_string();
        assert!(
            e.starts_with(
                "t.xml:1:99: error: the camera's heightangle of 1e-5° over 384 rows is 4.5e-10 radians a row"
            ),
            "{e}"
        );
        build(&scene("0.01"), &RenderSettings::default()).unwrap();
        build(&scene("1e-5"), &RenderSettings { width: 1, height: 1, ..RenderSettings::default() }).unwrap();
    }

    /// Lights whose distance the renderer's f32 cannot square are errors at
    /// the element, not a light that lights nothing; just inside, they
    /// render, as do transforms and a camera just inside f32 (beyond it:
    /// flatten's `singular_transforms_are_errors_at_the_transblock` and the parser's
    /// `camera_errors`).
    #[test]
    fn far_lights_are_errors_and_f32_extremes_render() {
        let scene_with = |camera: &str, light: &str, block: &str| {
            format!(
                r#"<scenefile><cameradata>{camera}<look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="45"/></cameradata>
<lightdata><id v="0"/><color r="1" g="1" b="1"/>{light}</lightdata>
<object type="tree" name="inner"><transblock><object type="primitive" name="cube"/></transblock></object>
<object type="tree" name="root">{block}</object></scenefile>"#
            )
        };
        let near_camera = r#"<pos x="0" y="0" z="5"/>"#;
        let near_light = r#"<position x="1" y="2" z="3"/>"#;
        let sphere = |transform: &str| {
            format!(r#"<transblock>{transform}<object type="primitive" name="sphere"/></transblock>"#)
        };
        let master =
            |transform: &str| format!(r#"<transblock>{transform}<object type="master" name="inner"/></transblock>"#);
        let outcome = |xml: String| {
            build(&crate::scene::from_xml(&xml, "t.xml"), &RenderSettings::default())
                .map(|_| ())
                .map_err(|e| e.to_string())
        };
        // Just inside: a translation of 1e38, a master scaled by 2e-15 and a
        // sphere by 5e14 (MAX_SCALING), a light 1e18 away, a camera at 1e38.
        for ok in [
            scene_with(near_camera, near_light, &sphere(r#"<translate x="1e38" y="0" z="0"/>"#)),
            scene_with(near_camera, near_light, &master(r#"<scale x="2e-15" y="1" z="1"/>"#)),
            scene_with(near_camera, near_light, &sphere(r#"<scale x="5e14" y="5e14" z="5e14"/>"#)),
            scene_with(near_camera, r#"<position x="1e18" y="0" z="0"/>"#, &sphere("")),
            scene_with(r#"<pos x="0" y="0" z="1e38"/>"#, near_light, &sphere("")),
        ] {
            outcome(ok).unwrap_or_else(|e| panic!("{e}"));
        }
        let e = outcome(scene_with(near_camera, r#"<position x="0" y="0" z="-2e19"/>"#, &sphere("")))
            .expect_err("a light 2e19 away");
        assert!(e.starts_with("t.xml:2:") && e.contains("this light is 2.000e19 units from the origin"), "{e}");
        // Beyond MAX_SCALING, an error at the element (a sphere scaled by
        // 1e20 drew as a ring; a master scaled by 1e-16; one scaled by 3e22
        // placing one scaled by 1e-23, 0.3 in all, drew nothing with the
        // hierarchy and the sphere with --no-bvh).
        let beyond = |xml: String, at: &str, scale: &str| {
            let e = outcome(xml).expect_err(at);
            assert!(e.starts_with(at) && e.contains(&format!("is scaled by {scale} in all")), "{e}");
        };
        beyond(
            scene_with(near_camera, near_light, &sphere(r#"<scale x="1e20" y="1e20" z="1e20"/>"#)),
            "t.xml:4:",
            "up to 1.0e20",
        );
        beyond(
            scene_with(near_camera, near_light, &master(r#"<scale x="1e-16" y="1" z="1"/>"#)),
            "t.xml:4:",
            "down to 1.0e-16",
        );
        let chain = r#"<scenefile><cameradata><pos x="0" y="0" z="5"/><look x="0" y="0" z="-1"/></cameradata>
<object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>
<object type="tree" name="m1"><transblock><scale x="1e-23" y="1e-23" z="1e-23"/><object type="master" name="m0"/></transblock></object>
<object type="tree" name="root"><transblock><scale x="3e22" y="3e22" z="3e22"/><object type="master" name="m1"/></transblock></object></scenefile>"#;
        beyond(chain.to_string(), "t.xml:4:", "up to 3.0e22");
        // The ranges compound down a chain of masters, each within the bound.
        let compound = chain.replace("3e22", "1e8").replace("1e-23", "1e8");
        beyond(compound, "t.xml:3:", "up to 1.0e16");
    }
}
