//! `raycast info`: what a scene holds and how raycast packs it, without a
//! device or a render: the camera, the primitives drawn and written, the
//! lights and materials, the world box, each group's hierarchy (nodes,
//! leaves, depth, items a leaf, its surface-area cost), the buffers'
//! sizes and what a default render's kernel keeps. For students checking
//! what their file says, and for anyone comparing hierarchies.

use crate::frame::{FrameData, RenderSettings};
use crate::layout::BvhNode;
use crate::render::Specialization;
use crate::scene::{scene_bounds, Bounds, Camera, Scene};
use crate::units::{fmt_bytes, thousands};
use glam::DVec3;
use serde::ser::SerializeMap;
use serde::Serialize;

/// The surface-area heuristic's cost of a pass through an inner node and
/// of testing one leaf item (a primitive, or an instance's bound), the
/// usual 1 and 1: a tree's cost is the sum over its nodes of the node's
/// share of the root's surface times its own cost, the expected work of a
/// ray that meets the root box.
pub const SAH_TRAVERSAL: f64 = 1.0;
pub const SAH_ITEM: f64 = 1.0;

/// One group's hierarchy, from its root node.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct TreeStats {
    pub nodes: u32,
    pub leaves: u32,
    /// Levels from the root (1: the root is a leaf).
    pub depth: u32,
    /// Items (primitives and instances) in all leaves, and in the fullest.
    pub items: u64,
    pub most_items: u32,
    /// The surface-area cost (SAH_TRAVERSAL, SAH_ITEM), relative to the root box.
    #[serde(serialize_with = "six_decimals")]
    pub sah: f64,
}

/// A box's surface area.
fn area(n: &BvhNode) -> f64 {
    let d = [0, 1, 2].map(|k| f64::from((n.hi[k] - n.lo[k]).max(0.0)));
    2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
}

/// The tree of `nodes` (layout.h: an inner node's children at `first` and
/// `first + 1`) from `root`. A root without surface weighs each node as 1.
pub fn tree_stats(nodes: &[BvhNode], root: u32) -> TreeStats {
    let root_area = area(&nodes[root as usize]);
    let mut s = TreeStats::default();
    let mut todo = vec![(root, 1u32)];
    while let Some((i, depth)) = todo.pop() {
        let n = &nodes[i as usize];
        s.nodes += 1;
        s.depth = s.depth.max(depth);
        let weight = if root_area > 0.0 { area(n) / root_area } else { 1.0 };
        if n.count == 0 {
            s.sah += SAH_TRAVERSAL * weight;
            todo.push((n.first, depth + 1));
            todo.push((n.first + 1, depth + 1));
        } else {
            s.leaves += 1;
            s.items += u64::from(n.count);
            s.most_items = s.most_items.max(n.count);
            s.sah += SAH_ITEM * f64::from(n.count) * weight;
        }
    }
    s
}

/// One group (the root tree, or a master placed through instances).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct GroupInfo {
    pub name: String,
    pub primitives: usize,
    pub instances: usize,
    pub expanded: u64,
    /// None: nothing to draw, or no hierarchy at all (a few primitives tested in order).
    pub tree: Option<TreeStats>,
}

/// One triangle mesh (an OBJ file, stored once however many primitives
/// draw it; docs/scene-format.md#triangle-meshes).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct MeshInfo {
    /// The file as found.
    pub file: String,
    pub triangles: usize,
    pub vertices: usize,
    /// Triangles drawn smooth (their corners' normals interpolated); the others are flat.
    pub smooth: usize,
    /// Whether the file gives texture coordinates (`vt`).
    pub uvs: bool,
    pub file_bytes: u64,
    /// Primitives written in the scene that draw it.
    pub primitives: usize,
    /// Its own hierarchy over its triangles.
    pub tree: TreeStats,
}

/// What `raycast info` says about a scene.
#[derive(Clone, Debug)]
pub struct Info {
    pub scene: String,
    pub camera: Camera,
    pub expanded: u64,
    pub unique: usize,
    /// Primitives written in the file, per shape drawn (in the order of the
    /// shapes, those with none left out).
    pub shapes: Vec<(&'static str, usize)>,
    pub groups: Vec<GroupInfo>,
    pub meshes: Vec<MeshInfo>,
    pub lights: Vec<(&'static str, usize)>,
    pub materials: usize,
    pub textured: usize,
    pub mirrors: usize,
    /// Materials that let light through (k_t O_t not 0: refraction).
    pub transparent: usize,
    pub bounds: Option<Bounds>,
    pub build_ms: f64,
    /// The device's scene buffers (frame::FrameData::scene_buffers): what, bytes.
    pub buffers: Vec<(&'static str, u64)>,
    /// What the kernel of a default render (`RenderSettings::default`) keeps.
    pub kernel: String,
    pub notes: Vec<String>,
}

/// `x` to 6 decimals at most, without trailing zeros: `-2.9`, not `-2.9000000000000004`.
fn number(x: f64) -> String {
    let s = format!("{x:.6}");
    let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
    if s == "-0" {
        "0".to_string()
    } else {
        s.to_string()
    }
}

fn vector(v: DVec3) -> String {
    format!("({}, {}, {})", number(v.x), number(v.y), number(v.z))
}

/// Counts of `names` in first-seen order.
fn tally(names: impl Iterator<Item = &'static str>) -> Vec<(&'static str, usize)> {
    let mut out: Vec<(&'static str, usize)> = Vec::new();
    for n in names {
        match out.iter_mut().find(|(k, _)| *k == n) {
            Some((_, c)) => *c += 1,
            None => out.push((n, 1)),
        }
    }
    out
}

impl Info {
    /// `scene` packed as a default render packs it (`data`, from `frame::build`).
    pub fn of(name: &str, scene: &Scene, data: &FrameData) -> Info {
        // The groups as packed: with masters written out where they nest too deeply.
        let written_out = crate::frame::fit_nesting(scene).ok().flatten().map(|(s, _)| s);
        let groups = written_out
            .as_ref()
            .unwrap_or(scene)
            .groups
            .iter()
            .enumerate()
            .map(|(g, group)| GroupInfo {
                name: group.name.clone(),
                primitives: group.primitives.len(),
                instances: group.instances.len(),
                expanded: group.expanded,
                tree: data
                    .group_roots
                    .get(g)
                    .filter(|&&root| root != u32::MAX)
                    .map(|&root| tree_stats(&data.nodes, root)),
            })
            .collect();
        // Each mesh's nodes follow the one before's (frame.rs's pack_meshes), its root first.
        let mut root = 0u32;
        let meshes = scene
            .meshes
            .iter()
            .enumerate()
            .map(|(i, m)| {
                let tree = tree_stats(&data.mesh_nodes, root);
                root += tree.nodes;
                MeshInfo {
                    file: m.path.display().to_string(),
                    triangles: m.triangles.len(),
                    vertices: m.positions.len(),
                    smooth: m.smooth.iter().filter(|&&s| s).count(),
                    uvs: !m.uvs.is_empty(),
                    file_bytes: m.file_bytes,
                    primitives: scene
                        .groups
                        .iter()
                        .flat_map(|g| &g.primitives)
                        .filter(|p| scene.mesh_index(&p.shape) == Some(i))
                        .count(),
                    tree,
                }
            })
            .collect();
        Info {
            scene: name.to_string(),
            camera: scene.camera.clone(),
            expanded: data.expanded,
            unique: scene.groups.iter().map(|g| g.primitives.len()).sum(),
            shapes: tally(scene.groups.iter().flat_map(|g| g.primitives.iter().map(|p| p.shape.name()))),
            groups,
            meshes,
            lights: tally(scene.lights.iter().map(|l| l.kind.name())),
            materials: scene.materials.len(),
            textured: scene.materials.iter().filter(|m| m.texture.is_some()).count(),
            mirrors: scene.materials.iter().filter(|m| m.reflective.iter().any(|&r| r != 0.0)).count(),
            transparent: scene
                .materials
                .iter()
                .filter(|m| m.transparent.iter().any(|&t| scene.globals.kt * t != 0.0))
                .count(),
            bounds: scene_bounds(scene),
            build_ms: data.build_time.as_secs_f64() * 1e3,
            buffers: data.scene_buffers().iter().map(|(_, what, bytes)| (*what, bytes.len() as u64)).collect(),
            kernel: Specialization::of(data, &data.frame).describe(),
            notes: data.notes.clone(),
        }
    }

    /// For people: a block of lines.
    pub fn text(&self) -> String {
        let list = |v: &[(&str, usize)]| v.iter().map(|(k, n)| format!("{n} {k}")).collect::<Vec<_>>().join(", ");
        let mut out = format!("scene: {}\n", self.scene);
        let c = &self.camera;
        // A thin lens (docs/scene-format.md#depth-of-field): its radius and the distance in focus.
        let lens = match crate::frame::lens(c) {
            Some((radius, focal)) => {
                format!(
                    "; a thin lens of radius {}, in focus at {}",
                    number(f64::from(radius)),
                    number(f64::from(focal))
                )
            }
            None => String::new(),
        };
        out += &format!(
            "  camera: eye {}, look {}, up {}, height angle {}°{lens}\n",
            vector(c.pos),
            vector(c.look),
            vector(c.up),
            number(c.height_angle_deg)
        );
        out += &format!(
            "  primitives: {} drawn, {} written in the file ({}), in {} group{}\n",
            thousands(self.expanded),
            thousands(self.unique as u64),
            if self.shapes.is_empty() { "none".to_string() } else { list(&self.shapes) },
            self.groups.len(),
            if self.groups.len() == 1 { "" } else { "s" }
        );
        for m in &self.meshes {
            let t = &m.tree;
            out += &format!(
                "  mesh: {}, {}: {} triangles ({} smooth, {} flat), {} vertices, {}; named by {} primitive{} of the file; \
                 its hierarchy {} nodes, {} leaves, depth {}, SAH cost {:.2}\n",
                m.file,
                fmt_bytes(m.file_bytes),
                thousands(m.triangles as u64),
                thousands(m.smooth as u64),
                thousands((m.triangles - m.smooth) as u64),
                thousands(m.vertices as u64),
                if m.uvs { "texture coordinates" } else { "no texture coordinates" },
                m.primitives,
                if m.primitives == 1 { "" } else { "s" },
                thousands(u64::from(t.nodes)),
                thousands(u64::from(t.leaves)),
                t.depth,
                t.sah
            );
        }
        out += &format!(
            "  lights: {}; materials: {} ({} textured, {} mirror{})\n",
            if self.lights.is_empty() { "none".to_string() } else { list(&self.lights) },
            self.materials,
            self.textured,
            self.mirrors,
            if self.transparent > 0 { format!(", {} transparent", self.transparent) } else { String::new() }
        );
        match &self.bounds {
            Some(b) => {
                out += &format!("  world box: {} to {}\n", vector(b.min), vector(b.max));
            }
            None => out += "  world box: none (nothing to draw)\n",
        }
        if self.groups.iter().all(|g| g.tree.is_none()) {
            out += &format!(
                "  hierarchy: none: {} primitive{} tested in order (a single group of at most a few skips it)\n",
                self.unique,
                if self.unique == 1 { "" } else { "s" }
            );
        } else {
            out += &format!(
                "  hierarchy: one per group, built in {:.2} ms; SAH cost with traversal {SAH_TRAVERSAL} and {SAH_ITEM} an item, over the group's root box\n",
                self.build_ms
            );
            out += "    group | primitives | instances | expands to | nodes | leaves | depth | items a leaf (mean, most) | SAH cost\n";
            for g in &self.groups {
                let tree = match &g.tree {
                    Some(t) => format!(
                        "{} | {} | {} | {:.2}, {} | {:.2}",
                        t.nodes,
                        t.leaves,
                        t.depth,
                        t.items as f64 / f64::from(t.leaves.max(1)),
                        t.most_items,
                        t.sah
                    ),
                    None => "- | - | - | - | -".to_string(),
                };
                out += &format!(
                    "    {} | {} | {} | {} | {tree}\n",
                    g.name,
                    thousands(g.primitives as u64),
                    thousands(g.instances as u64),
                    thousands(g.expanded)
                );
            }
        }
        let total: u64 = self.buffers.iter().map(|(_, b)| b).sum();
        let parts: Vec<String> =
            self.buffers.iter().filter(|(_, b)| *b > 0).map(|(what, b)| format!("{what} {}", fmt_bytes(*b))).collect();
        if parts.is_empty() {
            out += "  buffers: none (nothing to upload)\n";
        } else {
            out += &format!("  buffers: {} in all: {}\n", fmt_bytes(total), parts.join(", "));
        }
        out += &format!("  kernel of a default render: {}\n", self.kernel);
        for n in &self.notes {
            out += &format!("  note: {n}\n");
        }
        out
    }

    /// For machines: one JSON object.
    pub fn json(&self) -> String {
        let c = &self.camera;
        crate::units::to_json(&InfoJson {
            scene: &self.scene,
            camera: CameraJson {
                eye: c.pos.to_array(),
                look: c.look.to_array(),
                up: c.up.to_array(),
                height_angle_deg: c.height_angle_deg,
            },
            expanded: self.expanded,
            unique: self.unique,
            shapes: Pairs(&self.shapes),
            groups: &self.groups,
            meshes: &self.meshes,
            lights: Pairs(&self.lights),
            materials: self.materials,
            textured: self.textured,
            mirrors: self.mirrors,
            transparent: self.transparent,
            bounds: self.bounds.as_ref().map(|b| [b.min.to_array(), b.max.to_array()]),
            build_ms: crate::units::rounded(self.build_ms, 3),
            buffers: Pairs(&self.buffers),
            kernel: &self.kernel,
            notes: &self.notes,
        })
    }
}

/// What `info --json` says of a scene: [`Info`] with the camera's vectors
/// and the world box as arrays ([min, max]), counts as objects in their
/// order.
#[derive(Serialize)]
struct InfoJson<'a> {
    scene: &'a str,
    camera: CameraJson,
    expanded: u64,
    unique: usize,
    shapes: Pairs<'a, usize>,
    groups: &'a [GroupInfo],
    meshes: &'a [MeshInfo],
    lights: Pairs<'a, usize>,
    materials: usize,
    textured: usize,
    mirrors: usize,
    transparent: usize,
    bounds: Option<[[f64; 3]; 2]>,
    build_ms: f64,
    buffers: Pairs<'a, u64>,
    kernel: &'a str,
    notes: &'a [String],
}

#[derive(Serialize)]
struct CameraJson {
    eye: [f64; 3],
    look: [f64; 3],
    up: [f64; 3],
    height_angle_deg: f64,
}

/// Named counts as one JSON object, its keys in their order.
struct Pairs<'a, T>(&'a [(&'static str, T)]);

impl<T: Serialize> Serialize for Pairs<'_, T> {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        let mut map = serializer.serialize_map(Some(self.0.len()))?;
        for (k, v) in self.0 {
            map.serialize_entry(k, v)?;
        }
        map.end()
    }
}

/// A surface-area cost in JSON: to 6 decimals.
fn six_decimals<S: serde::Serializer>(x: &f64, serializer: S) -> Result<S::Ok, S::Error> {
    serializer.serialize_f64(crate::units::rounded(*x, 6))
}

/// The settings `info` packs a scene with: a default render's.
fn settings() -> RenderSettings {
    RenderSettings::default()
}

/// `scene` packed as a default render packs it; where that fails (a
/// texture file not found), packed without textures, with a note saying
/// why, so that the rest can still be described.
pub fn pack(scene: &Scene) -> Result<FrameData, crate::error::Error> {
    crate::frame::build(scene, &settings()).or_else(|e| {
        let mut data = crate::frame::build(scene, &RenderSettings { textures: false, ..settings() })?;
        data.notes.push(format!("packed without textures, as a default render fails: {e}"));
        Ok(data)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::Vec4;

    fn node(lo: [f32; 3], hi: [f32; 3], first: u32, count: u32) -> BvhNode {
        let v = |a: [f32; 3]| -> Vec4 { [a[0], a[1], a[2], 0.0] };
        BvhNode { lo: v(lo), hi: v(hi), first, count, ..BvhNode::default() }
    }

    /// A root of surface 6 (the unit cube) over two leaves of surface 4
    /// (half cubes: 2 (0.5 + 0.5 + 1)), holding 3 and 1 items. Rule,
    /// exact: SAH = 1 (root) + 3 * 4/6 + 1 * 4/6; 3 nodes, 2 leaves, depth
    /// 2, 4 items, at most 3.
    #[test]
    fn tree_stats_of_a_hand_built_tree() {
        let nodes = [
            node([0.0; 3], [1.0; 3], 1, 0),
            node([0.0; 3], [0.5, 1.0, 1.0], 0, 3),
            node([0.5, 0.0, 0.0], [1.0; 3], 3, 1),
        ];
        let s = tree_stats(&nodes, 0);
        assert_eq!((s.nodes, s.leaves, s.depth, s.items, s.most_items), (3, 2, 2, 4, 3));
        let want = 1.0 + 3.0 * 4.0 / 6.0 + 4.0 / 6.0;
        assert!((s.sah - want).abs() < 1e-12, "SAH {} against {want}", s.sah);
        // A leaf alone: its items.
        let s = tree_stats(&nodes, 1);
        assert_eq!((s.nodes, s.leaves, s.depth), (1, 1, 1));
        assert!((s.sah - 3.0).abs() < 1e-12);
    }

    /// Every group's tree reaches each of its items once: the leaves'
    /// items are its primitives plus its instances (the packed hierarchies
    /// of the generated recursive spheres, depth 5, a leaf a group, and of a
    /// row of twenty cubes, a binary tree; the default scene has none).
    #[test]
    fn info_of_packed_scenes() {
        let xml =
            crate::gen::generate(crate::gen::Family::RecursiveSpheres, 5, &crate::gen::GenOptions { texture: None })
                .unwrap();
        let scene = crate::scene::from_xml(xml, "gen.xml");
        let data = pack(&scene).unwrap();
        let info = Info::of("gen.xml", &scene, &data);
        assert_eq!(info.expanded, 937);
        assert_eq!(info.shapes, [("sphere", info.unique)]);
        for g in &info.groups {
            let t = g.tree.as_ref().unwrap_or_else(|| panic!("group {} has a tree", g.name));
            assert_eq!(t.items, (g.primitives + g.instances) as u64, "group {}", g.name);
            // Every node's box lies in its root's: each weighs at most 1.
            let most = f64::from(t.nodes - t.leaves) * SAH_TRAVERSAL + t.items as f64 * SAH_ITEM;
            assert!(t.sah > 0.0 && t.sah <= most + 1e-9, "group {}: SAH {} beyond {most}", g.name, t.sah);
        }
        let text = info.text();
        assert!(text.contains("primitives: 937 drawn"), "{text}");
        let json = info.json();
        assert!(json.starts_with("{\"scene\":\"gen.xml\"") && json.contains("\"expanded\":937"), "{json}");

        // Twenty cubes in a row: inner nodes, a binary tree over the twenty.
        let scene = crate::scene::from_xml(crate::scene::row_of_cubes_xml(20), "row.xml");
        let data = pack(&scene).unwrap();
        let t = Info::of("row.xml", &scene, &data).groups[0].tree.clone().expect("a hierarchy");
        assert_eq!(t.items, 20);
        assert_eq!(t.nodes, 2 * t.leaves - 1, "a binary tree");
        assert!(t.depth >= 2 && t.leaves >= 2 && t.sah < 20.0 + f64::from(t.nodes), "{t:?}");

        let scene = crate::scene::from_xml(crate::source::DEFAULT_SCENE, "default.xml");
        let data = pack(&scene).unwrap();
        let info = Info::of("default", &scene, &data);
        assert!(info.groups.iter().all(|g| g.tree.is_none()));
        assert!(info.text().contains("hierarchy: none: 5 primitives tested in order"), "{}", info.text());
    }

    /// A mesh drawn by two primitives is one mesh: its triangles (a quad
    /// fanned into two, flat; a smooth triangle with normals), its vertices,
    /// the two primitives, its own tree over its three triangles, in text
    /// and JSON.
    #[test]
    fn info_shows_meshes_and_their_triangles() {
        let dir = std::env::temp_dir().join(format!("raycast-info-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no smooth\nv 0 0 1\nv 1 0 1\nv 0 1 1\nvn 0 0 1\n\
                   f 5//1 6//1 7//1\n";
        std::fs::write(dir.join("two.obj"), obj).unwrap();
        let placed = |x: i32| {
            format!(
                "<transblock><translate x=\"{x}\" y=\"0\" z=\"0\"/>\
                 <object type=\"primitive\" name=\"mesh\" meshfile=\"two.obj\"/></transblock>"
            )
        };
        let xml =
            format!("<scenefile><object type=\"tree\" name=\"root\">{}{}</object></scenefile>", placed(0), placed(3));
        let scene = crate::scene::from_xml(xml, dir.join("s.xml").to_str().unwrap());
        let data = pack(&scene).unwrap();
        let info = Info::of("s.xml", &scene, &data);
        assert_eq!(info.meshes.len(), 1, "one file, stored once");
        let m = &info.meshes[0];
        assert_eq!((m.triangles, m.smooth, m.vertices, m.uvs, m.primitives), (3, 1, 7, false, 2));
        assert_eq!((m.tree.items, m.file_bytes), (3, obj.len() as u64));
        assert!(m.file.ends_with("two.obj"), "{}", m.file);
        let text = info.text();
        assert!(text.contains("two.obj") && text.contains(": 3 triangles (1 smooth, 2 flat), 7 vertices"), "{text}");
        assert!(text.contains("named by 2 primitives of the file"), "{text}");
        let json: serde_json::Value = serde_json::from_str(&info.json()).unwrap();
        let mesh = &json["meshes"][0];
        assert_eq!((mesh["triangles"].as_u64(), mesh["primitives"].as_u64()), (Some(3), Some(2)), "{json}");
        assert_eq!(mesh["tree"]["items"].as_u64(), Some(3), "{json}");
        assert_eq!(json["shapes"]["mesh"].as_u64(), Some(2), "{json}");
    }
}
