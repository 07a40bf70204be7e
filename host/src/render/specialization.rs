//! What a kernel built for a scene keeps of the shaders' code: the
//! specialization constants (shaders/layout.h SPEC_*) that the scene and its
//! frame flags can reach. The device builds its kernels with them; the CPU
//! build chooses its lean copy by them.

use crate::frame::FrameData;
use crate::layout;
use crate::scene::SHAPES;

/// What a kernel built for a scene keeps of the shaders' code: one bool per
/// feature's specialization constant (shaders/layout.h SPEC_*, but for the
/// walk's form), false for what the scene and its frame flags can never
/// reach; and the walk's form (SPEC_LEVELS_IN_REGISTERS, SPEC_REGISTER_LEVELS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Specialization {
    /// By constant_id; the walk's form's two are unused here.
    keeps: [bool; SPEC_COUNT],
    /// The walk's levels kept in registers, so many, or None: in arrays.
    register_levels: Option<u32>,
    /// A leaf's met instance records as one stack entry (SPEC_RECORD_MASKS).
    record_masks: bool,
}

const SPEC_COUNT: usize = layout::SPEC_COUNT as usize;

/// Whether constant `id` turns a feature's code on or off: every one but the walk's form's three.
#[cfg(test)]
const fn is_feature(id: u32) -> bool {
    id != layout::SPEC_LEVELS_IN_REGISTERS && id != layout::SPEC_REGISTER_LEVELS && id != layout::SPEC_RECORD_MASKS
}

impl Specialization {
    /// Everything kept, the levels in arrays, an entry a record: the
    /// shaders' defaults, what the CPU build runs.
    pub const ALL: Specialization =
        Specialization { keeps: [true; SPEC_COUNT], register_levels: None, record_masks: false };

    /// What rendering `data` with `frame` can reach.
    pub fn of(data: &FrameData, frame: &layout::Frame) -> Specialization {
        SceneFeatures::of(data).specialization(frame)
    }

    /// Whether the CPU build's lean copy (raycast_cpu_lean.cpp) computes
    /// the frame: it leaves out what host/cpu/shared.hpp turns off under
    /// RAYCAST_CPU_LEAN (this list), so it runs only where the frame's
    /// specialization leaves all of that out too; `check` compares its
    /// bits with the device's.
    pub fn cpu_lean(&self) -> bool {
        // Every shape from SHAPE_LEAN_IDS on (shapes.glsl): the torus, the mesh, any added since.
        let shapes = layout::SPEC_SHAPES + layout::SHAPE_LEAN_IDS..layout::SPEC_SHAPES + layout::SHAPE_IDS;
        [
            layout::SPEC_AOVS,
            layout::SPEC_COURSE_SAMPLING,
            layout::SPEC_AREA_LIGHTS,
            layout::SPEC_REFRACTION,
            layout::SPEC_EXPLAIN,
        ]
        .into_iter()
        .chain(shapes)
        .all(|id| !self.keeps[id as usize])
    }

    /// The constants' values for `Kernel::specialized`, by constant_id.
    pub fn constants(&self) -> [u32; SPEC_COUNT] {
        let mut values = [0u32; SPEC_COUNT];
        for (value, &keep) in values.iter_mut().zip(&self.keeps) {
            *value = u32::from(keep);
        }
        values[layout::SPEC_LEVELS_IN_REGISTERS as usize] = u32::from(self.register_levels.is_some());
        values[layout::SPEC_REGISTER_LEVELS as usize] = self.register_levels.unwrap_or(1);
        values[layout::SPEC_RECORD_MASKS as usize] = u32::from(self.record_masks);
        values
    }

    /// What the kernel keeps and what it leaves out, for people:
    /// "keeps spheres, instances, …; leaves out cubes, …".
    pub fn describe(&self) -> String {
        let names = |on: bool| -> Vec<&str> {
            spec_names().into_iter().filter(|(id, _)| self.keeps[*id as usize] == on).map(|(_, name)| name).collect()
        };
        let (kept, out) = (names(true), names(false));
        let list = |v: &[&str]| if v.is_empty() { "nothing".to_string() } else { v.join(", ") };
        let levels = match self.register_levels {
            Some(1) => "; the walk's one level in registers".to_string(),
            Some(n) => format!("; the walk's {n} levels in registers"),
            None => String::new(),
        };
        let masks = if self.record_masks { "; a leaf's met instances one stack entry" } else { "" };
        format!("keeps {}; leaves out {}{levels}{masks}", list(&kept), list(&out))
    }
}

/// The specialization constants of what is not a shape, by name, for
/// `Specialization::describe` (the shapes' are in `scene::SHAPES`).
const SPEC_NAMES: &[(u32, &str)] = &[
    (layout::SPEC_INSTANCES, "instances"),
    (layout::SPEC_POSITIONED_LIGHTS, "point and spot lights"),
    (layout::SPEC_SPOT_LIGHTS, "spot falloff"),
    (layout::SPEC_TEXTURES, "textures"),
    (layout::SPEC_BILINEAR, "bilinear filtering"),
    (layout::SPEC_SPECULAR, "specular"),
    (layout::SPEC_SHADOWS, "shadows"),
    (layout::SPEC_REFLECTIONS, "mirrors"),
    (layout::SPEC_INNER_NODES, "inner hierarchy nodes"),
    (layout::SPEC_SEVERAL_PRIMITIVE_LEAVES, "leaves of several primitives"),
    (layout::SPEC_HIERARCHY, "the hierarchy walk"),
    (layout::SPEC_FLAT_LIST, "the flat primitive list"),
    (layout::SPEC_BOX_RECORDS, "instance boxes"),
    (layout::SPEC_SPHERE_RECORDS, "instance spheres"),
    (layout::SPEC_AOVS, "the normal, depth, id and cost AOVs"),
    (layout::SPEC_MESHES, "meshes"),
    (layout::SPEC_REFRACTION, "refraction"),
    (layout::SPEC_AREA_LIGHTS, "area lights"),
    (layout::SPEC_DOF, "depth of field"),
    (layout::SPEC_COURSE_SAMPLING, "the course's adaptive supersampling"),
    (layout::SPEC_EXPLAIN, "explain's variants"),
];

/// Every feature constant by name, in `listed_order`.
fn spec_names() -> Vec<(u32, &'static str)> {
    let mut names: Vec<(u32, &'static str)> =
        SHAPES.iter().map(|k| (k.spec, k.spec_name)).chain(SPEC_NAMES.iter().copied()).collect();
    names.sort_by_key(|&(id, _)| listed_order(id));
    names
}

/// The order `describe` lists constants in: the shapes' (`scene::SHAPES`,
/// and meshes), then the others (`SPEC_NAMES`), each by id.
fn listed_order(id: u32) -> (bool, u32) {
    (id < layout::SPEC_SHAPES, id)
}

/// What a scene has that the kernels may leave out when it is missing
/// (`Specialization`), apart from the frame's flags. Each test is the
/// shader's own condition over every primitive, light or material, or
/// looser, so a constant is only turned off where the shader never takes
/// that path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFeatures {
    /// Each of `scene::SHAPES`: whether a primitive reaches its test
    /// (`ShapeKind::reached_by`).
    shapes: [bool; SHAPES.len()],
    instances: bool,
    positioned_lights: bool,
    spot_lights: bool,
    area_lights: bool,
    textured: bool,
    specular: bool,
    /// A material with a reflective channel other than 0.
    reflective: bool,
    /// A hierarchy node with children: the walk's inner-node step.
    inner_nodes: bool,
    /// A leaf with more than one primitive: the walk's loop over them
    /// (without a hierarchy the walk tests one primitive a pass).
    several_primitive_leaves: bool,
    /// A hierarchy to walk (frame.node_count > 0); without one the walk
    /// tests the primitives in order.
    hierarchy: bool,
    /// Instance records holding a box, and holding a sphere
    /// (RECORD_SPHERE): the walk's two tests of an instance's bound.
    box_records: bool,
    sphere_records: bool,
    /// The levels the walk enters (FrameData::levels).
    levels: u32,
    /// Every instance record's texel below RECORD_MASKS_TEXELS: a leaf's
    /// met records fit one stack entry (SPEC_RECORD_MASKS).
    record_masks: bool,
    /// A mesh primitive (SHAPE_MESH).
    meshes: bool,
}

impl SceneFeatures {
    pub fn of(data: &FrameData) -> SceneFeatures {
        SceneFeatures {
            shapes: std::array::from_fn(|i| data.primitives.iter().any(|p| SHAPES[i].reached_by(p.shape))),
            meshes: data.primitives.iter().any(|p| p.shape == layout::SHAPE_MESH),
            instances: !data.instances.is_empty(),
            positioned_lights: data.lights.iter().any(|l| l.kind != layout::LIGHT_DIRECTIONAL),
            spot_lights: data.lights.iter().any(|l| l.kind == layout::LIGHT_SPOT),
            area_lights: data.lights.iter().any(|l| l.kind == layout::LIGHT_AREA),
            textured: data.materials.iter().any(|m| m.texture >= 0),
            specular: data.materials.iter().any(|m| m.shininess > 0.0),
            reflective: data.materials.iter().any(|m| m.reflective[..3].iter().any(|&r| r != 0.0)),
            inner_nodes: data.nodes.iter().any(|n| n.count == 0),
            // Every leaf counts its primitives (the walk reads `count`
            // instead where no instance makes them differ).
            several_primitive_leaves: data.nodes.iter().any(|n| n.count > 0 && n.primitives > 1),
            hierarchy: !data.nodes.is_empty(),
            box_records: record_kind(data, 0),
            sphere_records: record_kind(data, layout::RECORD_SPHERE),
            levels: data.levels,
            record_masks: !data.instances.is_empty() && records_fit_masks(data.leaf_items.len()),
        }
    }

    /// The kernel for this scene drawn with `frame`'s flags and coefficients.
    pub fn specialization(&self, frame: &layout::Frame) -> Specialization {
        let flag = |f: u32| frame.flags & f != 0;
        let textures = self.textured && flag(layout::FLAG_TEXTURES);
        let mut on = [false; SPEC_COUNT];
        for (kind, &reached) in SHAPES.iter().zip(&self.shapes) {
            on[kind.spec as usize] = reached;
        }
        for (id, value) in [
            (layout::SPEC_INSTANCES, self.instances),
            (layout::SPEC_POSITIONED_LIGHTS, self.positioned_lights),
            (layout::SPEC_SPOT_LIGHTS, self.spot_lights),
            (layout::SPEC_TEXTURES, textures),
            (layout::SPEC_BILINEAR, textures && frame.texture_filter != layout::FILTER_NEAREST),
            (layout::SPEC_SPECULAR, self.specular),
            (layout::SPEC_SHADOWS, flag(layout::FLAG_SHADOWS)),
            // radiance: a mirror weight k_s O_r with a channel other than 0
            // (kept, too, where the product underflows to 0).
            (layout::SPEC_REFLECTIONS, flag(layout::FLAG_REFLECTIONS) && self.reflective && frame.k[2] != 0.0),
            (layout::SPEC_INNER_NODES, self.inner_nodes),
            (layout::SPEC_SEVERAL_PRIMITIVE_LEAVES, self.several_primitive_leaves),
            (layout::SPEC_HIERARCHY, self.hierarchy),
            (layout::SPEC_FLAT_LIST, !self.hierarchy),
            (layout::SPEC_BOX_RECORDS, self.box_records),
            (layout::SPEC_SPHERE_RECORDS, self.sphere_records),
            (layout::SPEC_AOVS, frame.aov != layout::AOV_COLOR),
            (layout::SPEC_MESHES, self.meshes),
            (layout::SPEC_COURSE_SAMPLING, flag(layout::FLAG_COURSE_SAMPLING)),
            // frame.rs sets FLAG_REFRACTION only where a material transmits.
            (layout::SPEC_REFRACTION, flag(layout::FLAG_REFRACTION)),
            (layout::SPEC_AREA_LIGHTS, self.area_lights),
            (layout::SPEC_DOF, flag(layout::FLAG_DOF)),
            (layout::SPEC_EXPLAIN, flag(layout::FLAG_EXPLAIN_ALL)),
        ] {
            on[id as usize] = value;
        }
        // The walk's levels in registers, as many as the scene has (layout.h;
        // frame.rs refuses a scene nested MAX_LEVELS deep or more, and a
        // count below the scene's would drop its deeper levels).
        debug_assert!((1..=layout::MAX_LEVELS).contains(&self.levels), "{} levels", self.levels);
        let register_levels = Some(self.levels.max(1));
        Specialization { keeps: on, register_levels, record_masks: self.record_masks }
    }
}

/// Whether one stack entry can name the texel of any record of a scene
/// with `leaf_items` words (four a texel) beside a mask of a leaf's
/// records, a bit each (layout.h, SPEC_RECORD_MASKS).
fn records_fit_masks(leaf_items: usize) -> bool {
    const _: () = assert!(crate::bvh::MAX_LEAF_ITEMS <= 8, "a leaf's records fill 8 mask bits");
    leaf_items.div_ceil(4) <= layout::RECORD_MASKS_TEXELS as usize
}

/// Whether a leaf holds an instance record whose RECORD_SPHERE bit is
/// `bit` (layout.h, BvhNode: the records follow the leaf's primitives
/// from the next multiple of 4).
fn record_kind(data: &FrameData, bit: u32) -> bool {
    data.nodes.iter().filter(|n| n.count > n.primitives).any(|n| {
        let records = (n.first + n.primitives).next_multiple_of(4);
        (0..n.count - n.primitives)
            .any(|r| data.leaf_items[(records + 4 * r + 3) as usize].item & layout::RECORD_SPHERE == bit)
    })
}

#[cfg(test)]
mod tests;
