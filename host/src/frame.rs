//! Turns a flattened [`Scene`] and the render settings into the buffers of
//! `shaders/layout.h`: what both the GPU kernel and the CPU build consume.
//! Everything computed here (camera matrix, light directions) is computed
//! once, in f64, and handed to both backends as the same f32 bits.
//!
//! | file | owns |
//! |---|---|
//! | `settings.rs` | the render settings and their ranges |
//! | `checks.rs` | scenes the 32-bit floats cannot draw, refused at their element |
//! | `camera.rs` | the film-to-world matrix, the lens, an area light's axes |
//! | `groups.rs` | each group's hierarchy, primitives, leaf items and instances |
//! | `records.rs` | instance records: quantised boxes and bounding spheres |
//! | `meshes.rs` | each triangle mesh's own hierarchy |
//! | `nesting.rs` | masters nested deeper than the shader's levels, written out |

use crate::error::Error;
use crate::image_io;
use crate::layout::{self, Vec4};
use crate::scene::{scene_bounds, LightKind, Scene, TextureRef};
use glam::DVec3;
use std::collections::HashMap;
use std::path::PathBuf;

mod camera;
mod checks;
mod groups;
mod meshes;
mod nesting;
mod records;
mod settings;
#[cfg(test)]
mod tests;

pub use camera::{area_edges, lens, set_camera, world_from_film, LENS_RADIUS_PER_APERTURE};
pub(crate) use nesting::fit_nesting;
pub use settings::*;

use checks::{check_light_reach, check_row_angle, check_scaling};
use groups::{pack_groups, unique_materials};
use meshes::pack_meshes;

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

pub(crate) fn vec4(v: DVec3, w: f32) -> Vec4 {
    [v.x as f32, v.y as f32, v.z as f32, w]
}

fn rgb(c: [f32; 3]) -> Vec4 {
    [c[0], c[1], c[2], 0.0]
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

/// Whether a material lets light through: k_t O_t, the refracted ray's
/// weight (lighting.glsl surface_at), has a channel other than 0. Without
/// one FLAG_REFRACTION stays off and the picture is an opaque scene's.
pub fn transmits(materials: &[layout::Material], kt: f32) -> bool {
    materials.iter().any(|m| m.transparent[..3].iter().any(|&t| kt * t != 0.0))
}
