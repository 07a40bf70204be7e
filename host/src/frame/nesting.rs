//! Masters nested deeper than the shader's levels: the deepest levels
//! written out into the masters that place them.

use crate::error::Error;
use crate::layout;
use crate::scene::Primitive;
use crate::scene::{Group, Instance, Scene};

/// The most primitives `fit_nesting` stores in all before it gives up
/// (each about 300 bytes on the host, 80 on the device, before the
/// hierarchy).
pub(super) const MAX_WRITTEN_OUT: usize = 1_000_000;

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
