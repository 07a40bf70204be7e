//! How well a kernel's rays keep SIMT lanes busy, from a picture drawn with
//! AOV_LANES: the model GPU traversal papers use (Aila and Laine 2009). The
//! lanes of a warp (a tile of pixels) step together, so a warp costs as
//! many passes as its slowest lane; its use is the passes its lanes need
//! over those it pays. Per kind of ray (camera, shadow, mirror) and for all
//! of a pixel's rays, over tiles of 8x4 pixels (a 32-wide warp) or 8x1
//! (lavapipe's 8 lanes of AVX2); and the bytes of hierarchy and primitives
//! the walks fetched per ray.

use super::Picture;
use serde::Serialize;

/// The lane use of one picture, for one warp shape.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LaneUse {
    /// Lanes a warp: its tile's width times height.
    pub lanes: u32,
    /// Σ passes / Σ (lanes × the tile's most passes), over the tiles with
    /// any such ray; None where the picture has none of that kind.
    pub camera: Option<f64>,
    pub shadow: Option<f64>,
    pub mirror: Option<f64>,
    /// Every ray of each pixel, in the order the kernel traces them, as if
    /// a lane went on to its next ray as soon as its walk ended.
    pub all: Option<f64>,
    /// The same rays as the kernel steps them (`in_step`): a warp's lanes
    /// take the tracing loop's turns together, and a turn's ray and its
    /// light points' shadow rays one slot at a time, each slot costing its
    /// slowest lane's passes. None where it was not counted (the course's
    /// sampling).
    pub all_in_step: Option<f64>,
    /// The same rays compacted by kind (`compacted`), as a wavefront
    /// kernel would take them: each turn's rays of one kind from every
    /// pixel in one queue, `lanes` at a time. None where not counted.
    pub all_compacted: Option<f64>,
    /// Bytes of the hierarchy (nodes, instance records, instances) and of
    /// primitives fetched, per ray traced.
    pub node_bytes_per_ray: f64,
    pub primitive_bytes_per_ray: f64,
}

/// The warps of the two widths `bench --lanes` reports, as tile_pixel
/// lays a workgroup's invocations out: the first 32 cover 8x4 pixels, each
/// 8 of them 4x2.
pub const WARPS: [(u32, u32); 2] = [(8, 4), (4, 2)];

/// A `width` x `height` picture's tiles of `tile_w` x `tile_h` pixels, row
/// by row, each as its pixels' indices (row by row); tiles past the
/// picture's edge are partial.
fn tiles(width: u32, height: u32, (tile_w, tile_h): (u32, u32)) -> impl Iterator<Item = impl Iterator<Item = usize>> {
    (0..height).step_by(tile_h as usize).flat_map(move |ty| {
        (0..width).step_by(tile_w as usize).map(move |tx| {
            (ty..(ty + tile_h).min(height))
                .flat_map(move |y| (tx..(tx + tile_w).min(width)).map(move |x| (y * width + x) as usize))
        })
    })
}

impl LaneUse {
    /// The lane use of `picture` (drawn with AOV_LANES) in warps of
    /// `tile_w` x `tile_h` pixels (tiles past the picture's edge are
    /// partial, their missing lanes idle, as a dispatch's are).
    pub fn of(picture: &Picture, (tile_w, tile_h): (u32, u32)) -> LaneUse {
        let (w, h) = (picture.width, picture.height);
        let lanes = tile_w * tile_h;
        // For camera, shadow, mirror, all: passes needed, passes paid.
        let mut needed = [0u64; 4];
        let mut paid = [0u64; 4];
        for tile in tiles(w, h, (tile_w, tile_h)) {
            let mut most = [0u64; 4];
            for i in tile {
                for (k, &p) in picture.pixels[i].normal.iter().enumerate() {
                    let p = p as u64;
                    needed[k] += p;
                    most[k] = most[k].max(p);
                }
            }
            for k in 0..4 {
                paid[k] += u64::from(lanes) * most[k];
            }
        }
        let share = |k: usize| (paid[k] > 0).then(|| needed[k] as f64 / paid[k] as f64);
        let rays = picture.rays().max(1) as f64;
        let node: f64 = picture.pixels.iter().map(|p| f64::from(p.t)).sum();
        let prim: f64 = picture.pixels.iter().map(|p| f64::from(p.id)).sum();
        LaneUse {
            lanes,
            camera: share(0),
            shadow: share(1),
            mirror: share(2),
            all: share(3),
            all_in_step: None,
            all_compacted: None,
            node_bytes_per_ray: node / rays,
            primitive_bytes_per_ray: prim / rays,
        }
    }
}

/// One walk of a pixel's sample as the kernels step it (trace.glsl): in
/// `turn` of the tracing loop (its camera, mirror or refracted ray, from
/// 0), at `slot` of that turn (0 the turn's ray; 1 + j the light loop's
/// j-th light point, whose shadow ray it is), taking `passes`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub struct Walk {
    pub turn: u32,
    pub slot: u32,
    pub passes: u32,
}

impl Walk {
    /// The walks of one sample's `raycast trace` steps: each camera,
    /// mirror or refracted ray starts a turn, each light the light loop
    /// takes (layout.h TRACE_LIGHT, needed or not) a slot.
    pub fn of_steps(steps: &[crate::layout::TraceStep]) -> Vec<Walk> {
        use crate::layout::{TRACE_CAMERA, TRACE_LIGHT, TRACE_MIRROR, TRACE_REFRACT, TRACE_SHADOW};
        let (mut walks, mut turn, mut slot) = (Vec::new(), None::<u32>, 0u32);
        for s in steps {
            match s.kind {
                TRACE_CAMERA | TRACE_MIRROR | TRACE_REFRACT => {
                    let t = turn.map_or(0, |t| t + 1);
                    (turn, slot) = (Some(t), 0);
                    walks.push(Walk { turn: t, slot: 0, passes: s.passes });
                }
                TRACE_LIGHT => slot += 1,
                TRACE_SHADOW => walks.push(Walk { turn: turn.unwrap_or(0), slot, passes: s.passes }),
                _ => {}
            }
        }
        walks
    }
}

/// Lane use with every pixel's rays taken as the kernels take them: a
/// vector's lanes step through the tracing loop's turns together, and
/// through each turn's slots (its ray's walk, then the light loop's, a
/// light point each); a slot ends when its slowest lane's walk does.
/// `walks` holds each pixel's walks (row by row), sample by sample
/// (`CpuRenderer::walks`); `width` x `height` its picture, in warps of
/// `tile_w` x `tile_h` pixels as in `LaneUse::of`. Σ passes / Σ over the
/// warps' slots of (lanes × the slot's most).
pub fn in_step(walks: &[Vec<Vec<Walk>>], width: u32, height: u32, (tile_w, tile_h): (u32, u32)) -> Option<f64> {
    let lanes = u64::from(tile_w * tile_h);
    let (mut needed, mut paid) = (0u64, 0u64);
    let mut most = std::collections::BTreeMap::<(usize, u32, u32), u64>::new();
    for tile in tiles(width, height, (tile_w, tile_h)) {
        most.clear();
        for i in tile {
            for (sample, sample_walks) in walks[i].iter().enumerate() {
                for w in sample_walks {
                    needed += u64::from(w.passes);
                    let m = most.entry((sample, w.turn, w.slot)).or_default();
                    *m = (*m).max(u64::from(w.passes));
                }
            }
        }
        paid += lanes * most.values().sum::<u64>();
    }
    (paid > 0).then(|| needed as f64 / paid as f64)
}

/// Lane use with every pixel's rays compacted by kind, as a wavefront
/// kernel (a pass or a queue for each kind of ray) would take them: for
/// each sample and turn, the turn's rays (camera, mirror or refracted) of
/// every pixel in one queue and its shadow rays in one a light point (a
/// light's rays leave alike: one queue for every light's mixed them, and
/// read 0.70 for the teapot where in step reads 0.78), each queue in the
/// order the warps' tiles take the pixels and walked `lanes` rays at a
/// time, a group paying its slowest. Not built:
/// what such a kernel could save in passes (not what its queues cost).
/// Arguments as `in_step`.
pub fn compacted(walks: &[Vec<Vec<Walk>>], width: u32, height: u32, (tile_w, tile_h): (u32, u32)) -> Option<f64> {
    let lanes = (tile_w * tile_h) as usize;
    let mut queues = std::collections::BTreeMap::<(usize, u32, u32), Vec<u64>>::new();
    let mut needed = 0u64;
    for i in tiles(width, height, (tile_w, tile_h)).flatten() {
        for (sample, sample_walks) in walks[i].iter().enumerate() {
            for w in sample_walks {
                needed += u64::from(w.passes);
                queues.entry((sample, w.turn, w.slot)).or_default().push(u64::from(w.passes));
            }
        }
    }
    let slowest = |group: &[u64]| group.iter().copied().max().unwrap_or(0);
    let paid: u64 = queues.values().flat_map(|q| q.chunks(lanes)).map(|g| lanes as u64 * slowest(g)).sum();
    (paid > 0).then(|| needed as f64 / paid as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::layout::{self, PixelOut};

    fn pixel(camera: f32, shadow: f32, mirror: f32) -> PixelOut {
        PixelOut { normal: [camera, shadow, mirror, camera + shadow + mirror], t: 96.0, id: 160, rgba: 0, rays: 2 }
    }

    /// One tile whose lanes all take as long is used whole; one lane of 32
    /// taking 4 passes where the rest take 1 uses (31 + 4) / (32 × 4); a
    /// kind no pixel traces is None; bytes are a ray's mean. Rule: exact.
    #[test]
    fn lanes_pay_for_the_slowest() {
        let even = Picture { width: 8, height: 4, pixels: vec![pixel(2.0, 1.0, 0.0); 32] };
        let u = LaneUse::of(&even, (8, 4));
        assert_eq!((u.camera, u.shadow, u.mirror, u.all), (Some(1.0), Some(1.0), None, Some(1.0)));
        assert_eq!((u.node_bytes_per_ray, u.primitive_bytes_per_ray), (48.0, 80.0));
        let mut one = even.clone();
        one.pixels = vec![pixel(1.0, 0.0, 0.0); 32];
        one.pixels[5] = pixel(4.0, 0.0, 0.0);
        let u = LaneUse::of(&one, (8, 4));
        assert_eq!(u.camera, Some(35.0 / 128.0));
        // In 4x2 warps only the slow lane's pays: 3 whole, then (7 + 4) / 32.
        let u = LaneUse::of(&one, (4, 2));
        assert_eq!(u.camera, Some((24.0 + 11.0) / (24.0 + 32.0)));
    }

    /// In step, a lane that ends its walk early waits for the slot's
    /// slowest: two lanes of turns' rays (1, 3) and (3, 1) pay 3 + 3 where
    /// the pixels' sums (4 and 4) would pay 4; a shadow ray waits only for
    /// the same light's in the same turn; samples start afresh; missing
    /// lanes of a partial tile idle. Rule: exact.
    #[test]
    fn lanes_in_step_wait_for_each_slot() {
        let w = |turn, slot, passes| Walk { turn, slot, passes };
        let walks = vec![vec![vec![w(0, 0, 1), w(1, 0, 3)]], vec![vec![w(0, 0, 3), w(1, 0, 1)]]];
        assert_eq!(in_step(&walks, 2, 1, (2, 1)), Some(8.0 / 12.0));
        // Light 1's shadow ray beside light 2's: two slots, each paid whole.
        let walks = vec![vec![vec![w(0, 0, 2), w(0, 1, 2)]], vec![vec![w(0, 0, 2), w(0, 2, 2)]]];
        assert_eq!(in_step(&walks, 2, 1, (2, 1)), Some(8.0 / (2.0 * 6.0)));
        // Two samples: each sample's turns paid apart.
        let walks = vec![vec![vec![w(0, 0, 2)], vec![w(0, 0, 1)]], vec![vec![w(0, 0, 1)], vec![w(0, 0, 2)]]];
        assert_eq!(in_step(&walks, 2, 1, (2, 1)), Some(6.0 / (2.0 * 4.0)));
        // A 4x1 warp over a 2x1 picture: its two missing lanes are paid for.
        let walks = vec![vec![vec![w(0, 0, 2)]], vec![vec![w(0, 0, 2)]]];
        assert_eq!(in_step(&walks, 2, 1, (4, 1)), Some(4.0 / 8.0));
        assert_eq!(in_step(&[], 0, 0, (4, 2)), None);
    }

    /// Compacted, a kind's rays from every tile queue together: camera
    /// rays 4, 1 | 1, 4 in two 2-lane warps pay 4 + 4 in step, and as the
    /// queue 4, 1, 1, 4 pays the same; the shadow rays of the two slow
    /// lanes (light 1's, in different warps) each wait in step, but queue
    /// as one group; light 2's queue apart. A partial group pays its
    /// missing lanes; samples and turns queue apart. Rule: exact.
    #[test]
    fn compacted_rays_queue_by_kind() {
        let w = |turn, slot, passes| Walk { turn, slot, passes };
        let walks = vec![
            vec![vec![w(0, 0, 4), w(0, 1, 2)]],
            vec![vec![w(0, 0, 1)]],
            vec![vec![w(0, 0, 1)]],
            vec![vec![w(0, 0, 4), w(0, 1, 2), w(0, 2, 1)]],
        ];
        assert_eq!(in_step(&walks, 4, 1, (2, 1)), Some(15.0 / (2.0 * (4.0 + 2.0 + 4.0 + 2.0 + 1.0))));
        assert_eq!(compacted(&walks, 4, 1, (2, 1)), Some(15.0 / (2.0 * (4.0 + 4.0 + 2.0 + 1.0))));
        // A 4-lane queue of one shadow ray pays 4 lanes; turn 1 is a queue of its own.
        let walks = vec![vec![vec![w(0, 0, 1), w(0, 1, 3), w(1, 0, 2)]], vec![vec![w(0, 0, 1)]]];
        assert_eq!(compacted(&walks, 2, 1, (4, 1)), Some(7.0 / (4.0 * (1.0 + 3.0 + 2.0))));
        assert_eq!(compacted(&[], 0, 0, (4, 2)), None);
    }

    /// A trace's steps as walks: the camera ray turn 0, its lights' slots
    /// 1 and 2 (the first needing no shadow ray), the mirror ray turn 1.
    #[test]
    fn walks_of_a_trace() {
        use crate::layout::{TraceStep, TRACE_CAMERA, TRACE_LIGHT, TRACE_MIRROR, TRACE_SHADOW, TRACE_SURFACE};
        let step = |kind, passes| TraceStep { kind, passes, ..TraceStep::default() };
        let steps = [
            step(TRACE_CAMERA, 3),
            step(TRACE_SURFACE, 0),
            step(TRACE_LIGHT, 0),
            step(TRACE_LIGHT, 0),
            step(TRACE_SHADOW, 5),
            step(TRACE_MIRROR, 2),
        ];
        let w = |turn, slot, passes| Walk { turn, slot, passes };
        assert_eq!(Walk::of_steps(&steps), vec![w(0, 0, 3), w(0, 2, 5), w(1, 0, 2)]);
    }

    /// The walk's byte counts (traversal.glsl NODE_BYTES and the rest) are
    /// the structs' sizes.
    #[test]
    fn fetched_bytes_are_the_structs() {
        use std::mem::size_of;
        assert_eq!(size_of::<layout::BvhNode>(), 48);
        assert_eq!(size_of::<layout::Instance>(), 80);
        assert_eq!(size_of::<layout::Primitive>(), 80);
        assert_eq!(size_of::<layout::MeshVertex>(), 32, "a vertex's position is half of it");
        let text = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../shaders/traversal.glsl")).unwrap();
        for (name, size) in [
            ("NODE_BYTES", size_of::<layout::BvhNode>()),
            ("NODE_BOX_BYTES", 2 * 16),
            ("RECORD_BYTES", 16),
            ("INSTANCE_BYTES", size_of::<layout::Instance>()),
            ("PRIMITIVE_BYTES", size_of::<layout::Primitive>()),
            ("TRIANGLE_BYTES", size_of::<layout::MeshTriangle>() + 3 * size_of::<[f32; 4]>()),
        ] {
            assert!(text.contains(&format!("const uint {name} = {size}u;")), "{name} is not {size} in traversal.glsl");
        }
    }
}
