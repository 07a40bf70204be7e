//! A scene's groups packed for the kernels: each group's hierarchy (built
//! by bvh.rs), its primitives, leaf items and instance records, with
//! global indices; materials folded where the same bytes repeat.

use super::camera::mat4;
use super::records::{bounding_sphere, box_steps, instance_record, placed_sphere, sphere_record};
use crate::bvh::{self, Aabb};
use crate::error::Error;
use crate::layout;
use crate::scene::Scene;
use glam::DVec3;

/// Scenes of one group with at most this many primitives skip the hierarchy.
pub(super) const SMALL_SCENE: usize = 8;

/// The groups of a scene as the device buffers hold them.
pub(super) struct Packed {
    pub(super) primitives: Vec<layout::Primitive>,
    pub(super) nodes: Vec<layout::BvhNode>,
    pub(super) leaf_items: Vec<layout::LeafItem>,
    pub(super) instances: Vec<layout::Instance>,
    /// Each group's root node, the scene's root group first; empty without a hierarchy.
    pub(super) group_roots: Vec<u32>,
    /// The walk's levels: 1 and the deepest nesting of masters under the root.
    pub(super) levels: u32,
}

/// `materials` with repeats folded: each distinct material (bit for bit:
/// the same bytes shade the same) once, in order of first use, and where
/// each of the given ones went: a file that writes the same material on
/// many primitives uploads it once.
pub(super) fn unique_materials(materials: Vec<layout::Material>) -> (Vec<layout::Material>, Vec<u32>) {
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

/// Builds each group's hierarchy (children before the groups that place
/// them, so instance boxes are known) and packs primitives, nodes, leaf
/// items and instances, with global indices. Proves that traversal fits the
/// shader's fixed stack and level arrays.
/// The scene's groups packed for the device; an error names the file (and
/// the element, where one is to blame).
pub(super) fn pack_groups(scene: &Scene) -> Result<Packed, Error> {
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
            shape: p.shape.code(),
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
