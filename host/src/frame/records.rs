//! Instance records as a hierarchy leaf holds them (layout.h, BvhNode): a
//! placed group's bound, as a box quantised in steps of the leaf's box or
//! as a sphere, computed in f32 exactly as the shader reads it back, and
//! always holding what it bounds.

use crate::bvh::Aabb;
use crate::layout;
use crate::scene::{Scene, Shape};
use glam::{DMat4, DVec3};

/// One axis of a box as an instance record holds it (layout.h, BvhNode):
/// `q_lo` and `q_hi` steps in from the low and high sides `lo`, `hi` of the
/// leaf's box, computed in f32 exactly as the shader computes them.
pub(super) fn stepped(lo: f32, hi: f32, q_lo: u32, q_hi: u32) -> (f32, f32) {
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
pub(super) fn most_steps(estimate: u32, holds: impl Fn(u32) -> bool) -> u32 {
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
pub(super) fn instance_record(q_lo: [u32; 3], q_hi: [u32; 3], item: u32) -> [u32; 4] {
    [q_lo[0] | q_lo[1] << 16, q_lo[2] | q_hi[0] << 16, q_hi[1] | q_hi[2] << 16, item]
}

/// A sphere that holds everything `m` places of a group whose primitives
/// and instances lie within `radius` of `centre` (group space): its centre
/// and radius in the space `m` maps to. The radius grows by the largest
/// stretch of m's linear part, bounded above by the square root of the
/// largest row sum of |MᵀM| (exact for rotations and uniform scales).
pub(super) fn placed_sphere(m: &DMat4, (centre, radius): (DVec3, f64)) -> (DVec3, f64) {
    let l = glam::DMat3::from_mat4(*m);
    let g = l.transpose() * l;
    let rows = (0..3).map(|r| g.row(r).abs().element_sum()).fold(0.0, f64::max);
    (m.transform_point3(centre), radius * rows.sqrt())
}

/// A shape's bounding sphere in object space: a canonical shape's about
/// the origin, a mesh's about its box's centre.
pub(super) fn shape_sphere(scene: &Scene, shape: &Shape) -> (DVec3, f64) {
    if let Some(i) = scene.mesh_index(shape) {
        return scene.meshes[i].bounding_sphere();
    }
    // A mesh whose file was not loaded draws nothing: the unit box's sphere holds it.
    (DVec3::ZERO, shape.kind().map_or(0.75f64.sqrt(), |k| k.radius()))
}

/// The farthest any point of a primitive (a shape placed by `m`, within
/// its object box) lies from `c`: the nearer of the box's farthest corner
/// and the shape's own bounding sphere placed by m.
pub(super) fn primitive_reach(scene: &Scene, shape: &Shape, m: &DMat4, c: DVec3) -> f64 {
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
pub(super) fn bounding_sphere(
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
pub(super) fn sphere_record(leaf: ([f32; 4], [f32; 4]), (c, radius): (DVec3, f64), item: u32) -> Option<[u32; 4]> {
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
pub(super) fn record_steps(w: [u32; 4]) -> ([u32; 3], [u32; 3]) {
    ([w[0] & 0xffff, w[0] >> 16, w[1] & 0xffff], [w[1] >> 16, w[2] & 0xffff, w[2] >> 16])
}
