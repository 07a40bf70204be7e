//! Turns a flattened [`Scene`] and the render settings into the buffers of
//! `shaders/layout.h`: what both the GPU kernel and the CPU build consume.
//! Everything computed here (camera matrix, light directions) is computed
//! once, in f64, and handed to both backends as the same f32 bits.

use crate::layout::{self, Mat4, Vec4};
use crate::scene::{LightKind, Scene, Shape, TextureRef};
use glam::{DMat4, DVec3, DVec4};
use std::collections::HashMap;
use std::path::PathBuf;

/// Largest width or height accepted (the pixel buffer of 16384² is 8 GiB).
pub const MAX_IMAGE_SIDE: u32 = 16384;
/// Most samples per pixel accepted.
pub const MAX_SPP: u32 = 4096;
/// Most texels of all textures together (4 bytes each).
pub const MAX_TEXELS: u64 = 1 << 28;

/// What the picture shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Aov {
    /// Shaded colour.
    #[default]
    Color,
    /// floor(255·clamp((n+1)/2)) of the world-space normal, black on a miss.
    Normal,
}

/// How textures are sampled.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TextureFilter {
    /// The texel the point falls in, as the official renders.
    #[default]
    Nearest,
    /// The four nearest texels, weighted.
    Bilinear,
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
    /// Samples per pixel (the fixed pattern of raycast.glsl's sample_offset).
    pub spp: u32,
    pub texture_filter: TextureFilter,
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
            spp: 1,
            texture_filter: TextureFilter::Nearest,
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

impl RenderSettings {
    pub fn validate(&self) -> Result<(), SettingsError> {
        for (name, v) in [("--width", self.width), ("--height", self.height)] {
            if v == 0 || v > MAX_IMAGE_SIDE {
                return Err(SettingsError(format!(
                    "{name} {v} is out of range: an image side must be between 1 and {MAX_IMAGE_SIDE} pixels"
                )));
            }
        }
        if self.spp == 0 || self.spp > MAX_SPP {
            return Err(SettingsError(format!("--spp {} is out of range: between 1 and {MAX_SPP} samples per pixel", self.spp)));
        }
        if self.max_depth > layout::MAX_DEPTH {
            return Err(SettingsError(format!(
                "--depth {} is out of range: at most {} mirror bounces",
                self.max_depth,
                layout::MAX_DEPTH
            )));
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
    /// Things about the scene the renderer does not draw as written.
    pub notes: Vec<String>,
}

impl FrameData {
    /// The scene's storage buffers other than the frame itself, as
    /// (binding, what it is for messages, bytes): the one list every kernel
    /// that includes raycast.glsl binds (shaders/scene_buffers.glsl).
    pub fn scene_buffers(&self) -> [(u32, &'static str, &[u8]); 5] {
        [
            (layout::BINDING_PRIMITIVES, "the primitives", bytemuck::cast_slice(&self.primitives)),
            (layout::BINDING_MATERIALS, "the materials", bytemuck::cast_slice(&self.materials)),
            (layout::BINDING_LIGHTS, "the lights", bytemuck::cast_slice(&self.lights)),
            (layout::BINDING_TEXTURES, "the textures", bytemuck::cast_slice(&self.textures)),
            (layout::BINDING_TEXELS, "the texels", bytemuck::cast_slice(&self.texels)),
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
    fn add(&mut self, t: &TextureRef) -> Result<i32, String> {
        let Some(path) = &t.resolved else {
            return Err(format!(
                "{}: error: texture \"{}\" not found; pass the folder that holds it with --assets DIR, or render with --no-textures",
                t.loc, t.file
            ));
        };
        if let Some(&i) = self.index.get(path) {
            return Ok(i);
        }
        let image = image::open(path)
            .map_err(|e| format!("{}: error: cannot read texture {}: {e}", t.loc, path.display()))?
            .to_rgba8();
        let (width, height) = image.dimensions();
        let total = self.texels.len() as u64 + u64::from(width) * u64::from(height);
        if width == 0 || height == 0 || total > MAX_TEXELS {
            return Err(format!(
                "{}: error: texture {} ({width}x{height}) does not fit: all textures together may hold at most {MAX_TEXELS} texels",
                t.loc,
                path.display()
            ));
        }
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

fn mat4(m: &DMat4) -> Mat4 {
    let c = m.to_cols_array_2d();
    c.map(|col| col.map(|x| x as f32))
}

/// world_from_film = translate(eye) · rotation(u, v, w) · scale⁻¹ (the seed
/// handout), where w = -look/|look|, u = (up × w)/|up × w|, v = w × u, and
/// scale⁻¹ = diag(tan(θw/2), tan(θh/2), 1) with θh the scene's height angle
/// and tan(θw/2) = tan(θh/2)·width/height.
pub fn world_from_film(scene: &Scene, width: u32, height: u32) -> DMat4 {
    let cam = &scene.camera;
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

/// Packs `scene` for rendering with `settings`. With textures on, loads
/// every texture; one that cannot be found or read is an error naming the
/// scene element.
pub fn build(scene: &Scene, settings: &RenderSettings) -> Result<FrameData, String> {
    let mut notes = Vec::new();
    let mut table = TextureTable::default();

    let primitives: Vec<layout::Primitive> = scene
        .primitives
        .iter()
        .filter_map(|p| {
            let shape = match p.shape {
                Shape::Cube => layout::SHAPE_CUBE,
                Shape::Cone => layout::SHAPE_CONE,
                Shape::Cylinder => layout::SHAPE_CYLINDER,
                Shape::Sphere => layout::SHAPE_SPHERE,
                // flatten() already dropped these with a warning.
                Shape::Torus | Shape::Mesh { .. } => return None,
            };
            Some(layout::Primitive {
                object_from_world: mat4(&p.object_from_world),
                shape,
                material: p.material,
                ..Default::default()
            })
        })
        .collect();

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
        .collect::<Result<Vec<_>, String>>()?;

    let lights = scene
        .lights
        .iter()
        .map(|l| {
            let kind = match l.kind {
                LightKind::Point => layout::LIGHT_POINT,
                LightKind::Directional => layout::LIGHT_DIRECTIONAL,
                LightKind::Spot => layout::LIGHT_SPOT,
                LightKind::Area => {
                    notes.push(format!(
                        "{}: area light drawn as a point light at its position",
                        l.loc
                    ));
                    layout::LIGHT_POINT
                }
            };
            // Directions are unit vectors only when they are not zero; the
            // parser rejects a zero direction where the light uses it.
            let axis = if l.direction.length_squared() > 0.0 { l.direction.normalize() } else { DVec3::ZERO };
            layout::Light {
                color: rgb(l.color),
                position: vec4(l.position, 1.0),
                direction_to_light: vec4(-axis, 0.0),
                spot_axis: vec4(axis, 0.0),
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
    if settings.shadows {
        flags |= layout::FLAG_SHADOWS;
    }
    if settings.reflections {
        flags |= layout::FLAG_REFLECTIONS;
    }
    if settings.textures {
        flags |= layout::FLAG_TEXTURES;
    }
    let frame = layout::Frame {
        world_from_film: mat4(&world_from_film(scene, settings.width, settings.height)),
        eye: vec4(scene.camera.pos, 1.0),
        k: [g.ka, g.kd, g.ks, g.kt],
        width: settings.width,
        height: settings.height,
        primitive_count: primitives.len() as u32,
        light_count: lights.len() as u32,
        aov: match settings.aov {
            Aov::Color => layout::AOV_COLOR,
            Aov::Normal => layout::AOV_NORMAL,
        },
        flags,
        max_depth: settings.max_depth,
        spp: settings.spp,
        texture_filter: match settings.texture_filter {
            TextureFilter::Nearest => layout::FILTER_NEAREST,
            TextureFilter::Bilinear => layout::FILTER_BILINEAR,
        },
        ..Default::default()
    };
    Ok(FrameData { frame, primitives, materials, lights, textures: table.textures, texels: table.texels, notes })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Camera, Globals};
    use std::path::PathBuf;
    use std::sync::Arc;

    fn scene_with_camera(camera: Camera) -> Scene {
        Scene {
            path: Arc::new(PathBuf::from("test.xml")),
            globals: Globals::default(),
            camera,
            lights: vec![],
            primitives: vec![],
            materials: vec![],
            warnings: vec![],
        }
    }

    /// The film corner (1, 1, -1) must map to the direction of the top-right
    /// pixel edge given by SCENE_FORMAT.md: U/2·u + V/2·v - w.
    #[test]
    fn world_from_film_matches_the_documented_camera() {
        let cam = Camera {
            pos: DVec3::new(1.0, 2.0, 3.0),
            look: DVec3::new(0.0, 0.0, -2.0),
            up: DVec3::new(0.0, 1.0, 0.0),
            height_angle_deg: 90.0,
            ..Camera::default()
        };
        let m = world_from_film(&scene_with_camera(cam), 200, 100);
        // Looking down -z with y up: u = +x, v = +y, w = +z. V = 2, U = 4.
        let p = m.transform_point3(DVec3::new(1.0, 1.0, -1.0));
        let expect = DVec3::new(1.0 + 2.0, 2.0 + 1.0, 3.0 - 1.0);
        assert!((p - expect).length() < 1e-12, "film corner went to {p}, expected {expect}");
        let eye = m.transform_point3(DVec3::ZERO);
        assert!((eye - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12, "film origin went to {eye}, expected the eye");
    }

    #[test]
    fn settings_reject_zero_and_absurd_sizes() {
        let mut s = RenderSettings::default();
        s.width = 0;
        assert!(s.validate().unwrap_err().0.contains("--width 0"));
        s.width = 10;
        s.height = MAX_IMAGE_SIDE + 1;
        assert!(s.validate().unwrap_err().0.contains("--height"));
        s.height = 10;
        assert!(s.validate().is_ok());
    }
}
