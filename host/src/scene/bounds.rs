//! The world-space box around a scene, found group by group through its
//! instances without expanding them: what the preview frames and orbits
//! about, and what the depth AOV's default range spans (`frame::depth_range`).

use glam::DVec3;

use super::Scene;

/// An axis-aligned box in world space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Bounds {
    pub fn center(&self) -> DVec3 {
        (self.min + self.max) * 0.5
    }

    /// Radius of the sphere through the corners.
    pub fn radius(&self) -> f64 {
        (self.max - self.min).length() * 0.5
    }

    pub fn corners(&self) -> [DVec3; 8] {
        let (a, b) = (self.min, self.max);
        [
            DVec3::new(a.x, a.y, a.z),
            DVec3::new(b.x, a.y, a.z),
            DVec3::new(a.x, b.y, a.z),
            DVec3::new(b.x, b.y, a.z),
            DVec3::new(a.x, a.y, b.z),
            DVec3::new(b.x, a.y, b.z),
            DVec3::new(a.x, b.y, b.z),
            DVec3::new(b.x, b.y, b.z),
        ]
    }
}

/// The world-space box around every primitive: each primitive's
/// world_from_object applied to the corners of its object box
/// (`Scene::object_box`: the canonical shape's, or a mesh's), group by group
/// through the instances without expanding them. None without primitives.
pub fn scene_bounds(scene: &Scene) -> Option<Bounds> {
    use crate::bvh::Aabb;
    if scene.groups.is_empty() {
        return None;
    }
    let mut boxes = vec![Aabb::EMPTY; scene.groups.len()];
    for g in scene.groups_children_first() {
        let group = &scene.groups[g];
        let mut b = Aabb::EMPTY;
        for p in &group.primitives {
            b = b.union(scene.object_box(&p.shape).transformed(&p.world_from_object));
        }
        for i in &group.instances {
            b = b.union(boxes[i.group as usize].transformed(&i.parent_from_group));
        }
        boxes[g] = b;
    }
    let b = boxes[0];
    (!b.is_empty() && b.lo.is_finite() && b.hi.is_finite()).then_some(Bounds { min: b.lo, max: b.hi })
}
