//! Bounding volume hierarchies, built on the host over a group's items
//! (primitives and instances) with the binned surface-area heuristic, and
//! traversed by `trace` in shaders/raycast.glsl.
//!
//! Node layout (shaders/layout.h BvhNode): a leaf holds `count > 0` items
//! starting at `first` in the leaf-item order; an interior node has
//! `count = 0` and its children at `first` and `first + 1`.

use glam::{DMat4, DVec3};

/// Most primitives in a leaf.
pub const MAX_LEAF: usize = 4;
/// Most items in a leaf, instances included. An instance in a leaf costs
/// a box test (the shader pushes it only when the ray meets its box), a
/// primitive its whole intersection test, and on lavapipe a traversal pass
/// costs as much as several items: leaves of a group's few instances save
/// passes (recursiveSpheres4 12% faster than with 4), leaves of many
/// primitives do not (a flat grid of 900 primitives 5% slower with 8).
pub const MAX_LEAF_ITEMS: usize = 8;
/// SAH bins along the split axis.
const BINS: usize = 12;
/// Deepest hierarchy built; below it, splits fall back to the median.
const MAX_DEPTH: u32 = 48;

/// An axis-aligned box in f64.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: DVec3,
    pub hi: DVec3,
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb { lo: DVec3::splat(f64::INFINITY), hi: DVec3::splat(f64::NEG_INFINITY) };
    /// The canonical primitives' box: all four fit in [-0.5, 0.5]^3.
    pub const UNIT: Aabb = Aabb { lo: DVec3::splat(-0.5), hi: DVec3::splat(0.5) };

    pub fn union(self, o: Aabb) -> Aabb {
        Aabb { lo: self.lo.min(o.lo), hi: self.hi.max(o.hi) }
    }

    pub fn is_empty(&self) -> bool {
        self.lo.x > self.hi.x
    }

    /// Its eight corners.
    pub fn corners(&self) -> [DVec3; 8] {
        std::array::from_fn(|i| {
            DVec3::new(
                if i & 1 == 0 { self.lo.x } else { self.hi.x },
                if i & 2 == 0 { self.lo.y } else { self.hi.y },
                if i & 4 == 0 { self.lo.z } else { self.hi.z },
            )
        })
    }

    /// The box around this box's eight corners mapped by `m`.
    pub fn transformed(&self, m: &DMat4) -> Aabb {
        self.corners().iter().fold(Aabb::EMPTY, |out, &c| {
            let p = m.transform_point3(c);
            out.union(Aabb { lo: p, hi: p })
        })
    }

    pub fn centroid(&self) -> DVec3 {
        (self.lo + self.hi) * 0.5
    }

    fn half_area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let d = self.hi - self.lo;
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// The f32 box the device tests: rounded outward and padded by 2^-16 of
    /// its size and magnitude, so float rounding in the slab test can never
    /// cull a ray that hits what the box holds.
    pub fn padded_f32(&self) -> ([f32; 4], [f32; 4]) {
        let size = (self.hi - self.lo).max_element();
        let magnitude = self.lo.abs().max(self.hi.abs()).max_element();
        let pad = (size + magnitude) * (1.0 / 65536.0) + f64::from(f32::MIN_POSITIVE);
        let down = |x: f64| {
            let f = (x - pad) as f32;
            if f64::from(f) > x - pad {
                f.next_down()
            } else {
                f
            }
        };
        let up = |x: f64| {
            let f = (x + pad) as f32;
            if f64::from(f) < x + pad {
                f.next_up()
            } else {
                f
            }
        };
        ([down(self.lo.x), down(self.lo.y), down(self.lo.z), 0.0], [up(self.hi.x), up(self.hi.y), up(self.hi.z), 0.0])
    }
}

/// One node as built (f64 bounds; packing to the device layout is frame.rs's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Node {
    pub bounds: Aabb,
    pub first: u32,
    pub count: u32,
    pub axis: u32,
    /// A leaf: how many of its items are primitives (they come first in
    /// `order`, the instances after them).
    pub primitives: u32,
}

/// A built hierarchy: nodes (root at 0) and the items in leaf order.
#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<Node>,
    /// Item indices as the leaves hold them.
    pub order: Vec<u32>,
    /// Deepest leaf (the root is depth 0).
    pub depth: u32,
}

/// Builds a hierarchy over items with these bounds, those from
/// `instances_from` on instances (the rest primitives). Deterministic: the
/// same bounds give the same hierarchy. No items: no nodes.
pub fn build(bounds: &[Aabb], instances_from: usize) -> Bvh {
    let mut bvh = Bvh { nodes: Vec::new(), order: (0..bounds.len() as u32).collect(), depth: 0 };
    if bounds.is_empty() {
        return bvh;
    }
    let centroids: Vec<DVec3> = bounds.iter().map(Aabb::centroid).collect();
    bvh.nodes.push(Node { bounds: Aabb::EMPTY, first: 0, count: 0, axis: 0, primitives: 0 });
    // The right side of each partition, reused (`split`).
    let mut scratch = Vec::with_capacity(bounds.len());
    // Explicit stack of (node index, item range, depth).
    let mut todo = vec![(0usize, 0usize, bounds.len(), 0u32)];
    while let Some((node, begin, end, depth)) = todo.pop() {
        let items = &mut bvh.order[begin..end];
        // One pass: the node's box, its centroids' box, its primitives.
        let (mut box_, mut c_box, mut primitives) = (Aabb::EMPTY, Aabb::EMPTY, 0usize);
        for &i in items.iter() {
            box_ = box_.union(bounds[i as usize]);
            let c = centroids[i as usize];
            c_box = c_box.union(Aabb { lo: c, hi: c });
            primitives += usize::from((i as usize) < instances_from);
        }
        bvh.depth = bvh.depth.max(depth);
        let leaf = Node { bounds: box_, first: begin as u32, count: (end - begin) as u32, axis: 0, primitives: 0 };
        // A leaf's primitives first (the shader tests them in one loop and
        // the instances' boxes in another), each part in index order. SAH's
        // stable partitions keep index order, so this only reorders after a
        // median split (below MAX_DEPTH).
        let make_leaf = |items: &mut [u32]| {
            items.sort_by_key(|&i| ((i as usize) >= instances_from, i));
            Node { primitives: primitives as u32, ..leaf }
        };
        if primitives <= MAX_LEAF && items.len() <= MAX_LEAF_ITEMS {
            bvh.nodes[node] = make_leaf(items);
            continue;
        }
        let Some((axis, mid)) = split(items, bounds, &centroids, c_box, depth, &mut scratch) else {
            bvh.nodes[node] = make_leaf(&mut bvh.order[begin..end]);
            continue;
        };
        let left = bvh.nodes.len();
        bvh.nodes.push(leaf);
        bvh.nodes.push(leaf);
        bvh.nodes[node] = Node { bounds: box_, first: left as u32, count: 0, axis, primitives: 0 };
        todo.push((left + 1, begin + mid, end, depth + 1));
        todo.push((left, begin, begin + mid, depth + 1));
    }
    bvh
}

/// Partitions `items` for a split: (axis, items on the left). Binned SAH on
/// the axis where the centroids (their box: `c_box`) spread most; the median
/// when SAH finds no useful split or the tree is too deep. None: keep them
/// in one leaf (only when every centroid is the same point and there are
/// few enough). `scratch` holds the right side while partitioning.
fn split(
    items: &mut [u32],
    bounds: &[Aabb],
    centroids: &[DVec3],
    c_box: Aabb,
    depth: u32,
    scratch: &mut Vec<u32>,
) -> Option<(u32, usize)> {
    let extent = c_box.hi - c_box.lo;
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let n = items.len();
    let median = |items: &mut [u32]| {
        items.sort_by(|&a, &b| centroids[a as usize][axis].total_cmp(&centroids[b as usize][axis]).then(a.cmp(&b)));
        Some((axis as u32, n / 2))
    };
    if extent[axis] <= 0.0 {
        // All centroids coincide: halves by index (keeps the depth bounded).
        return if n <= 2 * MAX_LEAF { None } else { Some((axis as u32, n / 2)) };
    }
    if depth >= MAX_DEPTH {
        return median(items);
    }
    let lo = c_box.lo[axis];
    let scale = BINS as f64 / extent[axis];
    let bin_of = |i: u32| (((centroids[i as usize][axis] - lo) * scale) as usize).min(BINS - 1);
    let mut bin_box = [Aabb::EMPTY; BINS];
    let mut bin_count = [0usize; BINS];
    for &i in items.iter() {
        let b = bin_of(i);
        bin_box[b] = bin_box[b].union(bounds[i as usize]);
        bin_count[b] += 1;
    }
    // Cost of splitting after bin k: area-weighted counts on both sides.
    let mut best: Option<(f64, usize)> = None;
    for k in 0..BINS - 1 {
        let (mut lb, mut lc, mut rb, mut rc) = (Aabb::EMPTY, 0, Aabb::EMPTY, 0);
        for j in 0..=k {
            lb = lb.union(bin_box[j]);
            lc += bin_count[j];
        }
        for j in k + 1..BINS {
            rb = rb.union(bin_box[j]);
            rc += bin_count[j];
        }
        if lc == 0 || rc == 0 {
            continue;
        }
        let cost = lb.half_area() * lc as f64 + rb.half_area() * rc as f64;
        if best.is_none_or(|(c, _)| cost < c) {
            best = Some((cost, k));
        }
    }
    let Some((_, k)) = best else { return median(items) };
    // Stable partition: left bins first, each side in its former order (the
    // left side written over the items already read, the right kept aside).
    scratch.clear();
    let mut mid = 0;
    for n in 0..items.len() {
        let i = items[n];
        if bin_of(i) <= k {
            items[mid] = i;
            mid += 1;
        } else {
            scratch.push(i);
        }
    }
    items[mid..].copy_from_slice(scratch);
    Some((axis as u32, mid))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn unit_at(x: f64, y: f64, z: f64, s: f64) -> Aabb {
        Aabb { lo: DVec3::new(x - s, y - s, z - s), hi: DVec3::new(x + s, y + s, z + s) }
    }

    /// Invariants: every item is in exactly one leaf; every node's box holds
    /// its children's (interior) or its items' (leaf) boxes; leaves hold at
    /// most MAX_LEAF items unless their centroids coincide.
    fn check(bounds: &[Aabb], bvh: &Bvh) {
        let mut seen = vec![0u32; bounds.len()];
        let mut stack = vec![0usize];
        while let Some(n) = stack.pop() {
            let node = bvh.nodes[n];
            if node.count == 0 {
                for c in [node.first as usize, node.first as usize + 1] {
                    let child = bvh.nodes[c].bounds;
                    assert_eq!(node.bounds.union(child), node.bounds, "node {n} does not contain child {c}");
                    stack.push(c);
                }
            } else {
                for &i in &bvh.order[node.first as usize..(node.first + node.count) as usize] {
                    seen[i as usize] += 1;
                    assert_eq!(
                        node.bounds.union(bounds[i as usize]),
                        node.bounds,
                        "leaf {n} does not contain item {i}"
                    );
                }
            }
        }
        assert!(seen.iter().all(|&s| s == 1), "items reached other than once: {seen:?}");
    }

    /// Leaves hold at most MAX_LEAF primitives and MAX_LEAF_ITEMS items in
    /// all, their `primitives` primitives first: a primitive and six
    /// instances share one leaf, seven primitives are split, nine instances
    /// too.
    #[test]
    fn leaves_hold_more_instances_than_primitives() {
        let row = |n: usize| -> Vec<Aabb> { (0..n).map(|i| unit_at(i as f64 * 3.0, 0.0, 0.0, 0.4)).collect() };
        let seven = row(7);
        let mixed = build(&seven, 1);
        check(&seven, &mixed);
        assert_eq!(mixed.nodes.len(), 1, "one primitive and six instances: one leaf");
        assert_eq!(mixed.nodes[0].primitives, 1);
        let primitives = build(&seven, seven.len());
        check(&seven, &primitives);
        assert!(primitives.nodes.len() > 1 && primitives.nodes.iter().all(|n| n.count as usize <= MAX_LEAF));
        // Two primitives beyond nine instances on a line: the leaf at the
        // far end holds both kinds and lists its primitives first.
        let line: Vec<Aabb> =
            (0..11)
                .map(|i| {
                    if i < 2 {
                        unit_at(10.0 + i as f64, 0.0, 0.0, 0.4)
                    } else {
                        unit_at((i - 2) as f64, 0.0, 0.0, 0.4)
                    }
                })
                .collect();
        let far = build(&line, 2);
        check(&line, &far);
        let mixed_leaf = far
            .nodes
            .iter()
            .find(|n| n.count > 0 && n.primitives > 0 && n.primitives < n.count)
            .expect("a leaf of both kinds");
        let items = &far.order[mixed_leaf.first as usize..(mixed_leaf.first + mixed_leaf.count) as usize];
        assert_eq!(&items[..2], [0, 1], "leaf items {items:?}");
        // A grid whose first half are primitives: every leaf lists its own first.
        let mut grid = Vec::new();
        for i in 0..12 {
            for j in 0..12 {
                grid.push(unit_at(((i * 7 + j * 5) % 12) as f64, j as f64 * 2.0, 0.0, 0.4));
            }
        }
        let half = build(&grid, grid.len() / 2);
        check(&grid, &half);
        let mut leaves = 0;
        for node in half.nodes.iter().filter(|n| n.count > 0) {
            let items = &half.order[node.first as usize..(node.first + node.count) as usize];
            let (prims, insts) = items.split_at(node.primitives as usize);
            assert!(
                prims.iter().all(|&i| (i as usize) < grid.len() / 2),
                "leaf items {items:?}: primitives {}",
                node.primitives
            );
            assert!(
                insts.iter().all(|&i| (i as usize) >= grid.len() / 2),
                "leaf items {items:?}: primitives {}",
                node.primitives
            );
            leaves += 1;
        }
        assert!(leaves > 10);
        let nine = row(9);
        let instances = build(&nine, 0);
        check(&nine, &instances);
        assert!(instances.nodes.len() > 1 && instances.nodes.iter().all(|n| n.count as usize <= MAX_LEAF_ITEMS));
    }

    #[test]
    fn invariants_on_grids_lines_and_duplicates() {
        let mut grid = Vec::new();
        for i in 0..10 {
            for j in 0..10 {
                grid.push(unit_at(i as f64, j as f64 * 3.0, (i * j) as f64 * 0.1, 0.4));
            }
        }
        let bvh = build(&grid, grid.len());
        check(&grid, &bvh);
        assert!(bvh.depth < 20, "depth {}", bvh.depth);

        let line: Vec<Aabb> = (0..1000).map(|i| unit_at(i as f64 * 1e-3, 0.0, 0.0, 1e-4)).collect();
        check(&line, &build(&line, line.len()));

        let same = vec![unit_at(1.0, 2.0, 3.0, 0.5); 37];
        let bvh = build(&same, same.len());
        check(&same, &bvh);
        assert!(bvh.depth <= 6, "coincident items must still split: depth {}", bvh.depth);

        assert!(build(&[], 0).nodes.is_empty());
        let one = [unit_at(0.0, 0.0, 0.0, 1.0)];
        check(&one, &build(&one, one.len()));
    }

    #[test]
    fn deterministic() {
        let boxes: Vec<Aabb> =
            (0..500).map(|i| unit_at((i * 37 % 101) as f64, (i * 11 % 53) as f64, 0.0, 0.3)).collect();
        let (a, b) = (build(&boxes, boxes.len()), build(&boxes, boxes.len()));
        assert_eq!(a.nodes, b.nodes);
        assert_eq!(a.order, b.order);
    }

    #[test]
    fn padded_boxes_contain_the_f64_box() {
        for b in [unit_at(0.0, 0.0, 0.0, 0.5), unit_at(1e4, -3e3, 7.0, 1e-4), unit_at(1e-30, 0.0, 0.0, 1e-30)] {
            let (lo, hi) = b.padded_f32();
            for a in 0..3 {
                assert!(f64::from(lo[a]) < b.lo[a] && f64::from(hi[a]) > b.hi[a], "{b:?} -> {lo:?} {hi:?}");
            }
        }
    }

    #[test]
    fn transformed_box_holds_the_corners() {
        let m = DMat4::from_scale_rotation_translation(
            DVec3::new(2.0, 1.0, 0.5),
            glam::DQuat::from_axis_angle(DVec3::new(1.0, 1.0, 0.0).normalize(), 0.7),
            DVec3::new(3.0, -1.0, 2.0),
        );
        let t = Aabb::UNIT.transformed(&m);
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { -0.5 } else { 0.5 },
                if i & 2 == 0 { -0.5 } else { 0.5 },
                if i & 4 == 0 { -0.5 } else { 0.5 },
            );
            let p = m.transform_point3(c);
            assert!(p.cmpge(t.lo - 1e-12).all() && p.cmple(t.hi + 1e-12).all());
        }
    }
}
