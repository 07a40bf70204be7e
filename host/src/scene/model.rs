//! The scene model: what a CS1230 scene file means, independent of XML and of
//! Vulkan. `parse` builds a [`SceneFile`] (the tree, masters kept as masters);
//! `flatten` expands it into a [`Scene`] (one entry per drawn primitive).

pub use super::shape::Shape;
use glam::{DMat4, DVec3};
use std::fmt;
use std::path::PathBuf;
use std::sync::Arc;

/// A place in a scene file, for messages: `file:line:col`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SourceLoc {
    pub file: Arc<PathBuf>,
    pub line: u32,
    pub col: u32,
}

impl fmt::Display for SourceLoc {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}", self.file.display(), self.line, self.col)
    }
}

/// A fatal problem with a scene file. Displays as `file:line:col: error: message`.
#[derive(Clone, Debug)]
pub struct SceneError {
    /// None when the problem is the file as a whole (cannot be read).
    pub loc: Option<SourceLoc>,
    pub file: Arc<PathBuf>,
    pub message: String,
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.loc {
            Some(loc) => write!(f, "{loc}: error: {}", self.message),
            None => write!(f, "{}: error: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for SceneError {}

/// Something tolerated, reported and worked around. Displays as
/// `file:line:col: warning: message`.
#[derive(Clone, Debug)]
pub struct Warning {
    pub loc: SourceLoc,
    pub message: String,
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: warning: {}", self.loc, self.message)
    }
}

/// The warnings as lines to print, each message once: where the same
/// message comes from several places (a missing texture named by every
/// level of a generated scene), its first place's line ends with the
/// others' (`also at 65:5, 105:5 (same file)`, up to 8 of them, then how many more).
pub fn warning_lines(warnings: &[Warning]) -> Vec<String> {
    const LISTED: usize = 8;
    let mut order: Vec<(&Warning, Vec<&SourceLoc>)> = Vec::new();
    for w in warnings {
        match order.iter_mut().find(|(first, _)| first.message == w.message) {
            Some((_, more)) => more.push(&w.loc),
            None => order.push((w, Vec::new())),
        }
    }
    order
        .into_iter()
        .map(|(first, more)| {
            if more.is_empty() {
                return first.to_string();
            }
            let place = |l: &SourceLoc| {
                if l.file == first.loc.file {
                    format!("{}:{}", l.line, l.col)
                } else {
                    l.to_string()
                }
            };
            let listed: Vec<String> = more.iter().take(LISTED).map(|l| place(l)).collect();
            let rest = if more.len() > LISTED { format!(" and {} more", more.len() - LISTED) } else { String::new() };
            format!("{first} (also at {}{rest})", listed.join(", "))
        })
        .collect()
}

/// `<globaldata>`: the global Phong coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Globals {
    pub ka: f32,
    pub kd: f32,
    pub ks: f32,
    pub kt: f32,
}

impl Default for Globals {
    fn default() -> Self {
        Globals { ka: 0.5, kd: 0.5, ks: 0.5, kt: 0.0 }
    }
}

/// `<cameradata>`. `look` is always a direction: a `<focus>` point is turned
/// into `focus - pos` by the parser.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    pub pos: DVec3,
    pub look: DVec3,
    pub up: DVec3,
    /// Full vertical field of view, degrees.
    pub height_angle_deg: f64,
    /// Its `<heightangle>` (None: the default), for messages about it.
    pub height_angle_loc: Option<SourceLoc>,
    pub aspect_ratio: Option<f64>,
    pub aperture: Option<f64>,
    pub focal_length: Option<f64>,
}

impl Default for Camera {
    fn default() -> Self {
        Camera {
            pos: DVec3::new(5.0, 5.0, 5.0),
            look: DVec3::new(-1.0, -1.0, -1.0),
            up: DVec3::new(0.0, 1.0, 0.0),
            height_angle_deg: 45.0,
            height_angle_loc: None,
            aspect_ratio: None,
            aperture: None,
            focal_length: None,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    Point,
    Directional,
    Spot,
    Area,
}

impl LightKind {
    /// As `<type v=…>` writes it.
    pub fn name(self) -> &'static str {
        match self {
            LightKind::Point => "point",
            LightKind::Directional => "directional",
            LightKind::Spot => "spot",
            LightKind::Area => "area",
        }
    }
}

/// `<lightdata>`, with the documented defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub id: i32,
    pub kind: LightKind,
    pub color: [f32; 3],
    pub position: DVec3,
    /// The direction the light travels (not normalised).
    pub direction: DVec3,
    /// Constant, linear, quadratic.
    pub attenuation: [f32; 3],
    /// Spot: outer half-angle, degrees.
    pub angle_deg: f32,
    /// Spot: width of the falloff band inside the outer angle, degrees.
    pub penumbra_deg: f32,
    /// Area lights.
    pub width: f32,
    pub height: f32,
    pub loc: SourceLoc,
}

/// A texture reference of a material (`<texture>` or `<bumpmap>`).
#[derive(Clone, Debug, PartialEq)]
pub struct TextureRef {
    /// The path as written in the file.
    pub file: String,
    /// Where it was found: the XML file's folder first, then each `--assets`
    /// folder. None when it was not found (a warning says so).
    pub resolved: Option<PathBuf>,
    pub repeat_u: f32,
    pub repeat_v: f32,
    pub loc: SourceLoc,
}

/// A primitive's material, with the documented defaults filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub diffuse: [f32; 3],
    pub ambient: [f32; 3],
    pub specular: [f32; 3],
    pub reflective: [f32; 3],
    pub transparent: [f32; 3],
    pub emissive: [f32; 3],
    pub shininess: f32,
    pub ior: f32,
    pub blend: f32,
    pub texture: Option<TextureRef>,
    pub bumpmap: Option<TextureRef>,
}

impl Material {
    /// Every field on one line, as the preview's pick and `raycast trace` print it.
    pub fn describe(&self) -> String {
        let c3 = |c: [f32; 3]| format!("({}, {}, {})", c[0], c[1], c[2]);
        format!(
            "diffuse {} ambient {} specular {} shininess {} reflective {} transparent {} emissive {} ior {} blend {}{}",
            c3(self.diffuse),
            c3(self.ambient),
            c3(self.specular),
            self.shininess,
            c3(self.reflective),
            c3(self.transparent),
            c3(self.emissive),
            self.ior,
            self.blend,
            self.texture
                .as_ref()
                .map(|t| format!(" texture {} (repeat {} {})", t.file, t.repeat_u, t.repeat_v))
                .unwrap_or_default()
        )
    }
}

impl Default for Material {
    fn default() -> Self {
        Material {
            diffuse: [1.0; 3],
            ambient: [0.0; 3],
            specular: [0.0; 3],
            reflective: [0.0; 3],
            transparent: [0.0; 3],
            emissive: [0.0; 3],
            shininess: 0.0,
            ior: 1.0,
            blend: 0.0,
            texture: None,
            bumpmap: None,
        }
    }
}

/// One transform of a `<transblock>`, in file order.
#[derive(Clone, Debug, PartialEq)]
pub enum Transform {
    Translate(DVec3),
    /// Axis (not necessarily unit) and angle in degrees, right-handed.
    Rotate {
        axis: DVec3,
        angle_deg: f64,
    },
    Scale(DVec3),
    /// Row-major as written; stored as a glam (column-major) matrix. Boxed:
    /// inline it made every transform 136 bytes, where the others take 32.
    Matrix(Box<DMat4>),
}

/// A node of an object tree.
// Primitive is the large variant (its material inline) and most nodes are
// one (every leaf of a flat file): boxing it would add an allocation to
// each and save nothing.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq)]
pub enum Node {
    Primitive {
        shape: Shape,
        material: Material,
        loc: SourceLoc,
    },
    /// An inline `type="tree"`: its transblocks.
    Tree {
        blocks: Vec<TransBlock>,
        loc: SourceLoc,
    },
    /// `type="master" name=…`: index into `SceneFile::trees`.
    Master {
        tree: usize,
        loc: SourceLoc,
    },
}

/// `<transblock>`: its transforms in file order and its one object.
#[derive(Clone, Debug, PartialEq)]
pub struct TransBlock {
    pub transforms: Vec<Transform>,
    /// The product T1 · T2 ⋯ Tk of `transforms`, in listed order.
    pub matrix: DMat4,
    pub object: Node,
    pub loc: SourceLoc,
}

/// A top-level named tree.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedTree {
    pub name: String,
    pub blocks: Vec<TransBlock>,
    pub loc: SourceLoc,
}

/// A parsed scene file, trees and masters as written.
#[derive(Clone, Debug)]
pub struct SceneFile {
    pub path: Arc<PathBuf>,
    pub globals: Globals,
    pub camera: Camera,
    pub lights: Vec<Light>,
    /// Every top-level tree, in file order.
    pub trees: Vec<NamedTree>,
    /// Index of the tree named "root" in `trees`.
    pub root: usize,
    pub warnings: Vec<Warning>,
}

/// A drawn primitive. In a [`Group`] its matrices map between the group's
/// space and the primitive's object space; from [`Scene::flat_primitives`]
/// and [`Scene::primitive`], between the world and object space.
#[derive(Clone, Debug, PartialEq)]
pub struct Primitive {
    pub shape: Shape,
    /// Index into `Scene::materials`.
    pub material: u32,
    pub world_from_object: DMat4,
    pub object_from_world: DMat4,
    /// Its id among its group's expanded primitives (depth first in file
    /// order); in the world, its scene-wide id.
    pub id_offset: u64,
    pub loc: SourceLoc,
}

/// A group placed in its parent group's space (a `type="master"` object).
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    /// Index into `Scene::groups`.
    pub group: u32,
    pub parent_from_group: DMat4,
    pub group_from_parent: DMat4,
    /// The id of its first primitive among the parent group's.
    pub id_offset: u64,
    pub loc: SourceLoc,
}

/// One tree as drawn: its primitives (inline trees merged in) and its
/// placed copies of other groups. Memory grows with the file, not with the
/// expansion.
#[derive(Clone, Debug, PartialEq)]
pub struct Group {
    pub name: String,
    pub primitives: Vec<Primitive>,
    pub instances: Vec<Instance>,
    /// How many primitives it expands to.
    pub expanded: u64,
}

/// A scene ready to draw: groups[0] is the root tree (in world space), the
/// others the master trees it places through instances.
#[derive(Clone, Debug)]
pub struct Scene {
    pub path: Arc<PathBuf>,
    pub globals: Globals,
    pub camera: Camera,
    pub lights: Vec<Light>,
    pub groups: Vec<Group>,
    /// Materials, deduplicated by source location (an instanced primitive
    /// shares one material).
    pub materials: Vec<Material>,
    /// Each mesh file its primitives draw, loaded once (`Shape::Mesh`'s
    /// canonical `resolved` path names it).
    pub meshes: Vec<Arc<Mesh>>,
    pub warnings: Vec<Warning>,
}

impl Scene {
    /// The mesh a `Shape::Mesh` primitive draws: its index in `meshes`.
    pub fn mesh_index(&self, shape: &Shape) -> Option<usize> {
        let Shape::Mesh { resolved: Some(path), .. } = shape else { return None };
        self.meshes.iter().position(|m| &m.path == path)
    }

    /// The box that holds a primitive of this shape in its object space:
    /// its entry's (`SHAPES`), or a mesh's own.
    pub fn object_box(&self, shape: &Shape) -> crate::bvh::Aabb {
        match (self.mesh_index(shape), shape.kind()) {
            (Some(i), _) => self.meshes[i].bounds,
            (None, Some(k)) => crate::bvh::Aabb { lo: k.lo.into(), hi: k.hi.into() },
            // A mesh whose file was not loaded holds nothing.
            (None, None) => crate::bvh::Aabb::UNIT,
        }
    }

    /// How many primitives the scene draws (every instance expanded).
    pub fn primitive_count(&self) -> u64 {
        self.groups.first().map_or(0, |g| g.expanded)
    }

    /// Every drawn primitive in world space, in id order. Expands every
    /// instance: for small scenes and tests.
    pub fn flat_primitives(&self) -> Vec<Primitive> {
        let mut out = Vec::new();
        // Explicit stack: masters can nest thousands deep.
        let mut todo = if self.groups.is_empty() { vec![] } else { vec![(0usize, DMat4::IDENTITY, 0u64)] };
        while let Some((group, world_from_group, first_id)) = todo.pop() {
            let g = &self.groups[group];
            for p in &g.primitives {
                let world_from_object = world_from_group * p.world_from_object;
                out.push(Primitive {
                    world_from_object,
                    object_from_world: world_from_object.inverse(),
                    id_offset: first_id + p.id_offset,
                    ..p.clone()
                });
            }
            for i in &g.instances {
                todo.push((i.group as usize, world_from_group * i.parent_from_group, first_id + i.id_offset));
            }
        }
        out.sort_by_key(|p| p.id_offset);
        out
    }

    /// Every group reachable from the root, each after every group it
    /// places (children first), the root last.
    pub fn groups_children_first(&self) -> Vec<usize> {
        let mut order = Vec::with_capacity(self.groups.len());
        if self.groups.is_empty() {
            return order;
        }
        let mut done = vec![false; self.groups.len()];
        let mut stack = vec![(0usize, 0usize)];
        while let Some(&mut (g, ref mut next)) = stack.last_mut() {
            if let Some(i) = self.groups[g].instances.get(*next) {
                *next += 1;
                let c = i.group as usize;
                // flatten() only places trees declared earlier: no cycles.
                if c < done.len() && !done[c] && !stack.iter().any(|&(s, _)| s == c) {
                    stack.push((c, 0));
                }
                continue;
            }
            done[g] = true;
            order.push(g);
            stack.pop();
        }
        order
    }

    /// The image files its materials' textures were found in (what a watch
    /// follows beside the scene file).
    pub fn texture_files(&self) -> Vec<PathBuf> {
        self.materials.iter().filter_map(|m| m.texture.as_ref()?.resolved.clone()).collect()
    }

    /// The primitive with scene-wide id `id`, in world space, found without
    /// expanding the scene.
    pub fn primitive(&self, id: u64) -> Option<Primitive> {
        let (mut group, mut world_from_group, mut rest) = (0usize, DMat4::IDENTITY, id);
        loop {
            let g = self.groups.get(group)?;
            if let Some(p) = g.primitives.iter().find(|p| p.id_offset == rest) {
                let world_from_object = world_from_group * p.world_from_object;
                return Some(Primitive {
                    world_from_object,
                    object_from_world: world_from_object.inverse(),
                    id_offset: id,
                    ..p.clone()
                });
            }
            let i = g
                .instances
                .iter()
                .find(|i| rest >= i.id_offset && rest < i.id_offset + self.groups[i.group as usize].expanded)?;
            rest -= i.id_offset;
            world_from_group *= i.parent_from_group;
            group = i.group as usize;
        }
    }
}

/// A unit vector along `v`, or None when `v` is zero or not finite. Scales
/// first so large components do not overflow.
pub(crate) fn unit(v: DVec3) -> Option<DVec3> {
    let m = v.abs().max_element();
    if m.is_nan() || m <= 0.0 || !m.is_finite() {
        return None;
    }
    let w = v / m;
    Some(w / w.length())
}

/// Why a transform cannot be inverted reliably.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NotInvertible {
    /// An entry is not finite.
    NotFinite,
    /// The determinant is zero, or the columns are so nearly dependent that
    /// the determinant of the normalised columns is below 1e-12.
    Singular,
    /// The determinant or the inverse overflows or underflows.
    OutOfRange,
}

impl std::fmt::Display for NotInvertible {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            NotInvertible::NotFinite => "transform is not finite (an overflow?)",
            NotInvertible::Singular => "transform is singular (a scale of 0?)",
            NotInvertible::OutOfRange => "transform is out of range (a scale too large or too small?)",
        })
    }
}

/// Why a transform cannot be inverted reliably, if it cannot: entries not
/// finite; a determinant that is zero, overflows or underflows; or columns
/// so nearly dependent that the determinant of the normalised columns is
/// below 1e-12. Else the inverse.
pub(crate) fn check_invertible(m: &DMat4) -> Result<DMat4, NotInvertible> {
    if !m.is_finite() {
        return Err(NotInvertible::NotFinite);
    }
    let det = m.determinant();
    if det == 0.0 {
        return Err(NotInvertible::Singular);
    }
    if !det.is_finite() || det.abs() < f64::MIN_POSITIVE {
        return Err(NotInvertible::OutOfRange);
    }
    let conditioning = if m.row(3) == glam::DVec4::new(0.0, 0.0, 0.0, 1.0) {
        match (unit(m.x_axis.truncate()), unit(m.y_axis.truncate()), unit(m.z_axis.truncate())) {
            (Some(a), Some(b), Some(c)) => a.dot(b.cross(c)).abs(),
            _ => 0.0,
        }
    } else {
        let u = |v: glam::DVec4| {
            let s = v.abs().max_element();
            let w = v / s;
            w / w.length()
        };
        DMat4::from_cols(u(m.x_axis), u(m.y_axis), u(m.z_axis), u(m.w_axis)).determinant().abs()
    };
    if conditioning.is_nan() || conditioning < 1e-12 {
        return Err(NotInvertible::Singular);
    }
    let inverse = m.inverse();
    if !inverse.is_finite() {
        return Err(NotInvertible::OutOfRange);
    }
    Ok(inverse)
}

/// One OBJ file's triangles (read by `mesh::load`).
#[derive(Clone, Debug, PartialEq)]
pub struct Mesh {
    /// Canonical path: a file drawn by many primitives is loaded once.
    pub path: PathBuf,
    pub positions: Vec<[f32; 3]>,
    /// One a position where the file gives normals, else empty.
    pub normals: Vec<[f32; 3]>,
    /// One a position where the file gives texture coordinates, else empty.
    pub uvs: Vec<[f32; 2]>,
    /// Corners (indices into `positions`), counter-clockwise from outside.
    pub triangles: Vec<[u32; 3]>,
    /// Per triangle: its corners' normals are interpolated.
    pub smooth: Vec<bool>,
    /// The box of its positions (empty without triangles).
    pub bounds: crate::bvh::Aabb,
    /// The file's size in bytes.
    pub file_bytes: u64,
}

impl Mesh {
    /// The canonical shapes' radius-about-the-centre equivalent: the box's
    /// centre and the distance to its farthest corner.
    pub fn bounding_sphere(&self) -> (DVec3, f64) {
        let c = self.bounds.centroid();
        (c, (self.bounds.hi - c).length())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn warning(file: &Arc<PathBuf>, line: u32, message: &str) -> Warning {
        Warning { loc: SourceLoc { file: file.clone(), line, col: 5 }, message: message.to_string() }
    }

    /// Each message once, at its first place, the others listed after it
    /// (line:col in the same file, the whole place in another), eight at
    /// most and then a count; different messages in their first order.
    #[test]
    fn a_repeated_warning_is_printed_once_with_its_places() {
        let (f, g) = (Arc::new(PathBuf::from("a.xml")), Arc::new(PathBuf::from("b.xml")));
        let ws = [warning(&f, 1, "A"), warning(&f, 2, "B"), warning(&f, 3, "A"), warning(&g, 4, "A")];
        assert_eq!(warning_lines(&ws), ["a.xml:1:5: warning: A (also at 3:5, b.xml:4:5)", "a.xml:2:5: warning: B"]);
        let many: Vec<Warning> = (1..=12).map(|l| warning(&f, l, "T")).collect();
        assert_eq!(
            warning_lines(&many),
            ["a.xml:1:5: warning: T (also at 2:5, 3:5, 4:5, 5:5, 6:5, 7:5, 8:5, 9:5 and 3 more)"]
        );
        assert!(warning_lines(&[]).is_empty());
    }
}
