//! Shader tests through the harness (host/src/harness), on lavapipe with the
//! validation layer on:
//!
//! - Property tests of the five primitives through `trace`, over seeded
//!   random transforms (scale 1e-4 to 1e4 per object with per-axis factors
//!   up to 2, any rotation, translations 1e-4 to 1e4) and random rays at a
//!   point inside the primitive. For each hit: the hit point lies on the
//!   surface, the normal is unit and faces out, and a ray leaving from the
//!   hit point does not hit the primitive again. The device's results must
//!   equal the C++ build's bit for bit. The seed is printed on failure and
//!   set with RAYCAST_SHADER_SEED.
//! - Every kernel of shaders/ and every generated harness kernel validates
//!   with naga, and their layouts match the host's.
//! - `raycast shader-test` passes on tests/shaders/*.toml, and catches a
//!   planted bug (the cone's slope) with a readable failure.
//!
//! The bounds, and why:
//!
//! SURFACE: the f32 hit point p = o + t d (computed in f32, as the renderer
//! does) lies within N ULPs of R, the largest world coordinate of the eye
//! and the hit point, measured as the first-order world distance
//! |g(M p)| / |M^T grad g| to the surface g = 0 of the primitive as stored
//! (M = its f32 object_from_world, evaluated in f64). Every step of the f32
//! pipeline rounds relative to the magnitudes it handles: the world
//! coordinates and p = o + t d (a few ULP(R)), and the object-space ray
//! (the eye is 2 to 10 object sizes away). N = 16 for every shape, with the
//! worst measured: cube 3 (50 seeds of 6400 cases: one division per
//! face); sphere 4.6, cylinder 3.0 and cone 2.5 (14, 14 and 16 seeds of 128
//! cases); torus 3.4 (25 seeds of 128: a root of the quartic refined by
//! Newton's steps to F's own rounding). The quadrics are solved from the ray's closest approach to the
//! centre (the sphere's and the cone's) or the axis (the cylinder's body),
//! and the cone's quadratic_roots adds like signs: a quadratic's
//! c = |o|^2 - r^2 straight from a far origin lost (|o| / r)^2 against r,
//! and -b + sqrt(b^2 - 4ac) cancelled for a cone's rays along its side,
//! which measured 45 (sphere, cylinder) and 170 (cone) over 50 seeds, under
//! bounds of 128 and 512.
//!
//! NORMAL: | |n| - 1 | <= 2^-22 (2 ULP of 1.0): unit() divides by a
//! correctly rounded sqrt of a three-term dot product, each step within
//! half an ULP; measured worst 1.14 * 2^-23.
//!
//! LEAVING: from p, offset along a direction d_out leaving the surface (the
//! mirror direction, or a random one where the mirror is within 6 degrees
//! of the tangent plane: n . d_out >= 0.1) by the renderer's own rule for
//! shadow and mirror rays (traversal.glsl ray_offset: 0.001, or 2^-14 of the
//! largest coordinate of the point and the eye when larger), no hit: a hit means a ray the
//! renderer would cast re-enters the convex primitive it leaves.
//!
//! The torus (ring radius 0.375, tube radius 0.125) is not convex: a ray
//! may meet it four times, and one leaving it may meet it again. Its cases
//! aim at a point at most 0.075 from the tube's centre line, and two more
//! rules compare it with an f64 reference (the tube's exact distance
//! sampled at 8192 steps along the object-space ray across the bounding
//! sphere, each sign change bisected to f64 precision):
//! FIRST: the primary ray's hit is the reference's first crossing, within
//! TORUS_ALONG (1e-3 of the torus's size along the object-space ray, far
//! below the tube's 0.25 diameter: a later root would be off by a chord;
//! measured worst 8.7e-5 over 25 seeds, primary and leaving rays).
//! LEAVING (torus): a leaving ray hits again only where the reference
//! crosses, within TORUS_ALONG, and misses only where the reference finds
//! no crossing that dips deeper than TORUS_ALONG into the tube. Where the
//! renderer's offset (0.001 in world units: up to a third of the torus's
//! size for the smallest here) carries the origin into another part of the
//! tube, the crossing is the way out.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3, DVec4};
use raycast::gpu::{self, reflect};
use raycast::harness::{self, Case, CaseResult, Harness, HarnessOptions, Rule, SceneBuffers, Value};
use raycast::layout::{self, Frame, Primitive};

const CASES_PER_SHAPE: usize = 128;
/// The SURFACE bound in ULP(R), every shape (see the top of the file).
const SURFACE_ULPS: f64 = 16.0;
const NORMAL_BOUND: f64 = 1.0 / (1u64 << 22) as f64;
/// traversal.glsl ray_offset: max(0.001, 2^-14 max(|p_i|, |eye_i|)).
fn leave_offset(p: DVec3, eye: DVec3) -> f64 {
    (p.abs().max_element().max(eye.abs().max_element()) * (1.0 / 16384.0)).max(1e-3)
}
const LEAVE_MIN_COS: f64 = 0.1;
/// The torus's FIRST and LEAVING rules, object-space distance along the ray (see the top of the file).
const TORUS_ALONG: f64 = 1e-3;
const DEFAULT_SEED: u64 = 0x5eed_2024_0004;

mod common;
use common::{repo, text};

/// `raycast ARGS`, validation on.
fn raycast(args: &[&str]) -> Output {
    common::raycast(args, &[])
}

fn harness_on_lavapipe() -> Harness {
    let opts = HarnessOptions {
        shaders: None,
        device: Some(gpu::DeviceSelector::Name("llvmpipe".into())),
        validation: true,
        timeout: gpu::GpuOptions::default().timeout,
    };
    Harness::new(&opts).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_no_validation_messages(h: &Harness) {
    let m = h.take_validation_messages();
    assert!(m.is_empty(), "{} validation message(s):\n{}", m.len(), m.join("\n"));
}

/// RAYCAST_SHADER_SEED (decimal or 0x hex), else the fixed default.
fn seed() -> u64 {
    match std::env::var("RAYCAST_SHADER_SEED") {
        Ok(s) => {
            let s = s.trim();
            let parsed = match s.strip_prefix("0x") {
                Some(h) => u64::from_str_radix(h, 16),
                None => s.parse(),
            };
            parsed.unwrap_or_else(|_| panic!("RAYCAST_SHADER_SEED={s:?} is not a number"))
        }
        Err(_) => DEFAULT_SEED,
    }
}

/// SplitMix64: small, seedable, the same everywhere.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
    fn uniform(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.uniform()
    }
    fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        10f64.powf(self.range(lo.log10(), hi.log10()))
    }
    fn gaussian(&mut self) -> f64 {
        let (u, v) = (self.uniform().max(1e-300), self.uniform());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    }
    fn unit_vector(&mut self) -> DVec3 {
        loop {
            let v = DVec3::new(self.gaussian(), self.gaussian(), self.gaussian());
            if v.length() > 1e-6 {
                return v.normalize();
            }
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Shape {
    Cube,
    Cone,
    Cylinder,
    Sphere,
    Torus,
}

impl Shape {
    fn code(self) -> u32 {
        match self {
            Shape::Cube => layout::SHAPE_CUBE,
            Shape::Cone => layout::SHAPE_CONE,
            Shape::Cylinder => layout::SHAPE_CYLINDER,
            Shape::Sphere => layout::SHAPE_SPHERE,
            Shape::Torus => layout::SHAPE_TORUS,
        }
    }

    /// A point inside the shape, at least 10% of its size from the surface.
    fn interior_point(self, rng: &mut Rng) -> DVec3 {
        loop {
            let p = DVec3::new(rng.range(-0.4, 0.4), rng.range(-0.4, 0.4), rng.range(-0.4, 0.4));
            let r = (p.x * p.x + p.z * p.z).sqrt();
            let inside = match self {
                Shape::Cube => true,
                Shape::Sphere => p.length() <= 0.4,
                Shape::Cylinder => r <= 0.4,
                Shape::Cone => r <= 0.8 * (0.5 - p.y) / 2.0,
                Shape::Torus => (r - 0.375).hypot(p.y) <= 0.075,
            };
            if inside {
                return p;
            }
        }
    }

    /// The object-space distance estimate g(p) (< 0 inside, 0 on the
    /// surface) of the convex shape as the largest of its normalised
    /// constraint functions, and the unit object-space gradient of that one.
    fn distance(self, p: DVec3) -> (f64, DVec3) {
        let r = (p.x * p.x + p.z * p.z).sqrt();
        let radial = if r > 0.0 { DVec3::new(p.x / r, 0.0, p.z / r) } else { DVec3::X };
        let candidates: Vec<(f64, DVec3)> = match self {
            Shape::Cube => (0..3)
                .map(|k| {
                    let mut g = DVec3::ZERO;
                    g[k] = p[k].signum();
                    (p[k].abs() - 0.5, g)
                })
                .collect(),
            Shape::Sphere => vec![(p.length() - 0.5, if p.length() > 0.0 { p.normalize() } else { DVec3::Y })],
            // The tube's exact distance, from the ring's nearest point.
            Shape::Torus => {
                let d = (r - 0.375).hypot(p.y);
                vec![(d - 0.125, (radial * (r - 0.375) + DVec3::new(0.0, p.y, 0.0)) / d)]
            }
            Shape::Cylinder => vec![(r - 0.5, radial), (p.y.abs() - 0.5, DVec3::new(0.0, p.y.signum(), 0.0))],
            Shape::Cone => {
                // Body: r - (0.5 - y) / 2, gradient (radial, 1/2), length sqrt(5/4).
                let k = 1.25f64.sqrt();
                vec![
                    ((r - (0.5 - p.y) / 2.0) / k, (radial + DVec3::new(0.0, 0.5, 0.0)) / k),
                    (-p.y - 0.5, DVec3::NEG_Y),
                ]
            }
        };
        candidates.into_iter().fold((f64::NEG_INFINITY, DVec3::ZERO), |a, b| if b.0 > a.0 { b } else { a })
    }
}

/// One generated primitive and primary ray.
struct Setup {
    /// object_from_world as stored (f32), in f64 for the checks.
    m: DMat4,
    origin: [f32; 3],
    direction: [f32; 3],
    scene: Arc<SceneBuffers>,
    what: String,
}

fn f32x3(v: DVec3) -> [f32; 3] {
    [v.x as f32, v.y as f32, v.z as f32]
}

fn f64x3(v: [f32; 3]) -> DVec3 {
    DVec3::new(v[0].into(), v[1].into(), v[2].into())
}

fn scene_of(shape: Shape, object_from_world: [[f32; 4]; 4]) -> Arc<SceneBuffers> {
    let frame = Frame { primitive_count: 1, ..Default::default() };
    let prim = Primitive { object_from_world, shape: shape.code(), ..Default::default() };
    Arc::new(SceneBuffers::new().frame(&frame).primitives(&[prim]))
}

fn generate(shape: Shape, rng: &mut Rng) -> Setup {
    // Scale: one magnitude in [1e-4, 1e4] and per-axis factors in [1/2, 2].
    let s0 = rng.log_uniform(1e-4, 1e4);
    let scale = DVec3::new(
        s0 * 2f64.powf(rng.range(-1.0, 1.0)),
        s0 * 2f64.powf(rng.range(-1.0, 1.0)),
        s0 * 2f64.powf(rng.range(-1.0, 1.0)),
    );
    // Rotation: a quarter of the cases an exact signed axis permutation (axis-parallel rays, 0/0 in the slab tests), else uniform.
    let rotation = if rng.uniform() < 0.25 {
        let perms = [[0, 1, 2], [1, 2, 0], [2, 0, 1], [0, 2, 1], [2, 1, 0], [1, 0, 2]];
        let perm = perms[(rng.next() % 6) as usize];
        let mut cols = [DVec3::ZERO; 3];
        for (c, &axis) in perm.iter().enumerate() {
            let mut v = DVec3::ZERO;
            v[axis] = if rng.next() & 1 == 0 { 1.0 } else { -1.0 };
            cols[c] = v;
        }
        DMat4::from_cols(cols[0].extend(0.0), cols[1].extend(0.0), cols[2].extend(0.0), DVec4::W)
    } else {
        DMat4::from_quat(DQuat::from_xyzw(rng.gaussian(), rng.gaussian(), rng.gaussian(), rng.gaussian()).normalize())
    };
    // Translation: magnitude in [1e-4, 1e4], at most 1e3 object sizes (a
    // smaller object is under a thousand ULPs wide where it stands, not renderable in f32).
    let smallest = scale.min_element();
    let magnitude = loop {
        let m = rng.log_uniform(1e-4, 1e4);
        if m <= 1e3 * smallest {
            break m;
        }
    };
    let translation = if rng.uniform() < 0.1 { DVec3::ZERO } else { rng.unit_vector() * magnitude };
    let world_from_object = DMat4::from_translation(translation) * rotation * DMat4::from_scale(scale);

    // The primitive as stored: object_from_world rounded to f32. The checks
    // use exactly that matrix, and the rays are aimed through its inverse.
    let ofw = world_from_object.inverse().to_cols_array_2d().map(|c| c.map(|x| x as f32));
    let m = DMat4::from_cols_array_2d(&ofw.map(|c| c.map(f64::from)));
    let wfo = m.inverse();

    // The ray: from 2 to 10 object sizes away, through a point inside.
    let q = shape.interior_point(rng);
    let eye = q + rng.unit_vector() * rng.range(2.0, 10.0);
    let origin = f32x3(wfo.transform_point3(eye));
    let length = rng.log_uniform(1e-2, 1e2);
    let direction = f32x3((wfo.transform_point3(q) - f64x3(origin)) * length);
    Setup {
        m,
        origin,
        direction,
        scene: scene_of(shape, ofw),
        what: format!(
            "scale {:.3e} x ({:.3}, {:.3}, {:.3}), translation {:.3e} {:?}, ray {:?} + t {:?}",
            s0,
            scale.x / s0,
            scale.y / s0,
            scale.z / s0,
            translation.length(),
            f32x3(translation),
            origin,
            direction
        ),
    }
}

fn max_abs(v: [f32; 3]) -> f64 {
    v.iter().map(|x| f64::from(x.abs())).fold(0.0, f64::max)
}

/// The ULP of the float binade of x (x > 0).
fn ulp_of(x: f64) -> f64 {
    2f64.powi(x.max(f64::from(f32::MIN_POSITIVE)).log2().floor() as i32 - 23)
}

/// The torus's f64 reference (see the top of the file) for the ray o + s u,
/// u unit, s >= 0, in object space: its first crossing of the surface and,
/// for a ray from outside, how deep it goes before it leaves again (the
/// least distance, negative; -inf for a ray from inside, which always
/// crosses), or None where it never crosses.
fn torus_reference(o: DVec3, u: DVec3) -> Option<(f64, f64)> {
    let distance = |s: f64| Shape::Torus.distance(o + u * s).0;
    let b = o.dot(u);
    let disc = b * b - (o.length_squared() - 0.25);
    if disc < 0.0 {
        return None;
    }
    let (s0, s1) = ((-b - disc.sqrt()).max(0.0), -b + disc.sqrt());
    const STEPS: usize = 8192;
    let at = |i: usize| s0 + (s1 - s0) * i as f64 / STEPS as f64;
    let inside = |s: f64| distance(s) <= 0.0;
    let from_inside = inside(s0);
    let first = (1..=STEPS).find(|&i| inside(at(i)) != from_inside)?;
    let (mut lo, mut hi) = (at(first - 1), at(first));
    for _ in 0..100 {
        let mid = 0.5 * (lo + hi);
        if inside(mid) == from_inside {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    if from_inside {
        return Some((hi, f64::NEG_INFINITY));
    }
    let deepest = (first..=STEPS).map(|i| distance(at(i))).take_while(|&g| g <= 0.0).fold(0.0, f64::min);
    Some((hi, deepest))
}

/// A ray from world into object space through `m`: its origin, unit direction and length.
fn object_ray(m: &DMat4, origin: [f32; 3], direction: [f32; 3]) -> (DVec3, DVec3, f64) {
    let d = m.transform_vector3(f64x3(direction));
    (m.transform_point3(f64x3(origin)), d.normalize(), d.length())
}

fn ray_value(o: [f32; 3], d: [f32; 3]) -> Value {
    Value::ray(o, d)
}

/// t, id and normal of a `trace` result.
fn hit_of(r: &CaseResult) -> Option<(f32, u32, [f32; 3])> {
    let v = r.device.as_ref()?;
    let n = v.get("normal")?.as_floats()?;
    Some((v.get("t")?.as_f32()?, v.get("id")?.as_u32()?, [n[0], n[1], n[2]]))
}

#[derive(Default)]
struct Worst {
    surface_ulps: f64,
    normal: f64,
    /// The torus's FIRST and LEAVING rules: the farthest from the reference's crossing.
    along: f64,
}

// `!(x <= bound)` on purpose: a NaN fails the bound, where `x > bound` would pass it.
#[allow(clippy::neg_cmp_op_on_partial_ord)]
fn property_test(shape: Shape) {
    let seed = seed();
    let mut rng = Rng(seed ^ (shape.code() as u64).wrapping_mul(0x9e37_79b9));
    let setups: Vec<Setup> = (0..CASES_PER_SHAPE).map(|_| generate(shape, &mut rng)).collect();
    let mut h = harness_on_lavapipe();
    let cases: Vec<Case> = setups
        .iter()
        .enumerate()
        .map(|(k, s)| {
            Case::new("trace")
                .named(format!("{shape:?} case {k}: primary ray"))
                .input("r", ray_value(s.origin, s.direction))
                .same_as_cpu(Rule::Exact)
                .scene(s.scene.clone())
        })
        .collect();
    let results = h.run(&cases);

    let mut failures: Vec<String> = Vec::new();
    let mut worst = Worst::default();
    // Each leaving ray: its case, with its origin and direction.
    let mut leaving: Vec<(usize, Case, [f32; 3], [f32; 3])> = Vec::new();
    for (k, (s, r)) in setups.iter().zip(&results).enumerate() {
        let fail = |why: String| format!("{shape:?} case {k} ({}): {why}", s.what);
        if !r.passed {
            failures.push(fail(format!("device and CPU differ:\n{}", r.report)));
            continue;
        }
        let Some((t, id, n)) = hit_of(r) else {
            failures.push(fail("no result".into()));
            continue;
        };
        if id != 0 {
            failures.push(fail(format!("the ray through an interior point missed (id {id:#x}, t {t:?})")));
            continue;
        }
        // The hit point as the renderer computes it, in f32.
        let p: [f32; 3] = std::array::from_fn(|i| s.origin[i] + t * s.direction[i]);
        let big = max_abs(s.origin).max(max_abs(p));
        let (g, grad_o) = shape.distance(s.m.transform_point3(f64x3(p)));
        // World gradient M^T grad: world distance |g| / |M^T grad|.
        let grad_w = s.m.transpose().transform_vector3(grad_o);
        let surface_ulps = g.abs() / grad_w.length() / ulp_of(big);
        worst.surface_ulps = worst.surface_ulps.max(surface_ulps);
        if !(surface_ulps <= SURFACE_ULPS) {
            failures.push(fail(format!(
                "the hit point {p:?} (t {t:?}) is {surface_ulps:.1} ULP({big:.3e}) from the surface (bound {})",
                SURFACE_ULPS
            )));
        }
        if shape == Shape::Torus {
            let (o, u, len) = object_ray(&s.m, s.origin, s.direction);
            match torus_reference(o, u) {
                Some((s_ref, _)) => {
                    let off = (f64::from(t) * len - s_ref).abs();
                    worst.along = worst.along.max(off);
                    if !(off <= TORUS_ALONG) {
                        failures.push(fail(format!(
                            "the hit at t {t:?} is {off:.3e} along the ray from the reference's first crossing (bound {TORUS_ALONG})"
                        )));
                    }
                }
                None => failures.push(fail("the reference finds no crossing".into())),
            }
        }
        let nn = f64x3(n);
        let unit_error = (nn.length() - 1.0).abs();
        worst.normal = worst.normal.max(unit_error);
        if !(unit_error <= NORMAL_BOUND) {
            failures.push(fail(format!(
                "the normal {n:?} has length 1 {:+.3e} (bound {NORMAL_BOUND:.3e})",
                nn.length() - 1.0
            )));
        }
        let d = f64x3(s.direction);
        if !(nn.dot(d) < 0.0) {
            failures.push(fail(format!(
                "the normal {n:?} does not face out: n . d = {:e} for a hit from outside",
                nn.dot(d)
            )));
            continue;
        }
        // Leave: the mirror direction, or a random one well off the tangent plane.
        let (dn, nu) = (d.normalize(), nn.normalize());
        let mirror = dn - 2.0 * nu.dot(dn) * nu;
        let out = if nu.dot(mirror) >= LEAVE_MIN_COS {
            mirror
        } else {
            loop {
                let v = rng.unit_vector();
                if nu.dot(v) >= LEAVE_MIN_COS {
                    break v;
                }
            }
        };
        let origin = f32x3(f64x3(p) + out * leave_offset(f64x3(p), f64x3(s.origin)));
        let case = Case::new("trace")
            .named(format!("{shape:?} case {k}: leaving ray"))
            .input("r", ray_value(origin, f32x3(out)))
            .same_as_cpu(Rule::Exact)
            .scene(s.scene.clone());
        leaving.push((k, case, origin, f32x3(out)));
    }
    let leave_cases: Vec<Case> = leaving.iter().map(|(_, c, _, _)| c.clone()).collect();
    let leave_results = h.run(&leave_cases);
    for ((k, case, origin, direction), r) in leaving.iter().zip(&leave_results) {
        let fail = |why: String| format!("{shape:?} case {k} ({}): {why}", setups[*k].what);
        if !r.passed {
            failures.push(fail(format!("device and CPU differ on the leaving ray:\n{}", r.report)));
        } else if shape == Shape::Torus {
            let Some((t, id, _)) = hit_of(r) else {
                failures.push(fail("no result for the leaving ray".into()));
                continue;
            };
            let (o, u, len) = object_ray(&setups[*k].m, *origin, *direction);
            match (id != layout::NO_HIT, torus_reference(o, u)) {
                (true, Some((s_ref, _))) => {
                    let off = (f64::from(t) * len - s_ref).abs();
                    worst.along = worst.along.max(off);
                    if !(off <= TORUS_ALONG) {
                        failures.push(fail(format!(
                            "the leaving ray {} (from {:.3e} off the tube's surface) hits again at t {t:?} ({:.3e} along it), {off:.3e} from the reference's crossing at {s_ref:.3e} (bound {TORUS_ALONG})",
                            case.inputs[0].1.text(),
                            Shape::Torus.distance(o).0,
                            f64::from(t) * len
                        )));
                    }
                }
                (true, None) => failures.push(fail(format!(
                    "the leaving ray {} hits again at t {t:?} where the reference never enters",
                    case.inputs[0].1.text()
                ))),
                (false, Some((s_ref, deepest))) if deepest < -TORUS_ALONG => failures.push(fail(format!(
                    "the leaving ray {} misses where the reference enters at {s_ref:.6} and goes {:.3e} deep",
                    case.inputs[0].1.text(),
                    -deepest
                ))),
                (false, _) => {}
            }
        } else if let Some((t, id, _)) = hit_of(r) {
            if id != layout::NO_HIT {
                failures.push(fail(format!(
                    "the leaving ray {} hits the primitive again at t {t:?}",
                    case.inputs[0].1.text()
                )));
            }
        }
    }
    assert_no_validation_messages(&h);
    println!(
        "{shape:?}: {} cases, {} leaving rays; worst surface distance {:.1} ULP (bound {}), worst | |n| - 1 | {:.2e} (bound {NORMAL_BOUND:.2e}){}; seed {seed:#x}",
        setups.len(),
        leaving.len(),
        worst.surface_ulps,
        SURFACE_ULPS,
        worst.normal,
        if shape == Shape::Torus {
            format!(", worst distance from the reference's crossing {:.2e} (bound {TORUS_ALONG})", worst.along)
        } else {
            String::new()
        }
    );
    if !failures.is_empty() {
        let shown: Vec<&String> = failures.iter().take(10).collect();
        panic!(
            "{} property failure(s) in {} {shape:?} cases, seed {seed:#x} (rerun with RAYCAST_SHADER_SEED={seed:#x}); the first {}:\n{}",
            failures.len(),
            setups.len(),
            shown.len(),
            shown.iter().map(|s| s.as_str()).collect::<Vec<_>>().join("\n")
        );
    }
}

#[test]
fn cube_properties() {
    property_test(Shape::Cube);
}

#[test]
fn cone_properties() {
    property_test(Shape::Cone);
}

#[test]
fn cylinder_properties() {
    property_test(Shape::Cylinder);
}

#[test]
fn sphere_properties() {
    property_test(Shape::Sphere);
}

#[test]
fn torus_properties() {
    property_test(Shape::Torus);
}

/// The reference surfaces of the checks: 0 on points of each surface, not 0 off them.
#[test]
fn the_reference_surfaces_are_the_canonical_shapes() {
    let on = [
        (Shape::Cube, DVec3::new(0.5, 0.1, -0.2)),
        (Shape::Cube, DVec3::new(0.3, -0.5, 0.5)),
        (Shape::Sphere, DVec3::new(0.3, 0.4, 0.0)),
        (Shape::Cylinder, DVec3::new(0.0, 0.2, -0.5)),
        (Shape::Cylinder, DVec3::new(0.1, 0.5, 0.2)),
        (Shape::Cone, DVec3::new(0.0, 0.0, 0.25)),
        (Shape::Cone, DVec3::new(0.3, -0.5, 0.1)),
        (Shape::Torus, DVec3::new(0.5, 0.0, 0.0)),
        (Shape::Torus, DVec3::new(0.0, 0.125, -0.375)),
        (Shape::Torus, DVec3::new(0.3, 0.0, -0.4)),
    ];
    for (shape, p) in on {
        let (g, grad) = shape.distance(p);
        assert!(g.abs() < 1e-12, "{shape:?} at {p}: {g}");
        assert!((grad.length() - 1.0).abs() < 1e-12);
        let (outside, _) = shape.distance(p * 1.1);
        assert!(outside > 0.01, "{shape:?} at 1.1 {p}: {outside}");
    }
}

/// Every kernel of shaders/ compiles, validates with naga and matches the
/// host's layouts; so does the harness kernel of every function of raycast.glsl.
#[test]
fn every_kernel_validates_with_naga_and_matches_the_host_layouts() {
    let dir = repo().join("shaders");
    let mut kernels: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("comp"))
        .collect();
    kernels.sort();
    assert!(!kernels.is_empty());
    let mut errors = Vec::new();
    // Each as it is and corrected (a GPU's kernels): every Division.
    for (path, division) in kernels.iter().flat_map(|p| gpu::Division::ALL.map(|d| (p, d))) {
        let stem = path.file_stem().unwrap().to_string_lossy().into_owned();
        let spirv = match gpu::compile_kernel(path, division) {
            Ok(s) => s,
            Err(e) => {
                errors.push(e);
                continue;
            }
        };
        // The host's expected layout of each kernel (buffers, storage images).
        let expected = match stem.as_str() {
            "render" => Some((layout::render_bindings(), Vec::new())),
            "render_uniform" => Some((layout::render_uniform_bindings(), layout::uniform_kernel_images())),
            "preview" => Some((raycast::layout::preview_bindings(), raycast::layout::preview_images())),
            "fma_probe" => Some((layout::fma_probe_bindings(), Vec::new())),
            "preview_uniform" => {
                Some((raycast::layout::preview_uniform_bindings(), raycast::layout::preview_uniform_images()))
            }
            _ => None,
        };
        match expected {
            Some((buffers, images)) => {
                if let Err(e) = reflect::check_layouts_with_images(&stem, &spirv, &buffers, &images) {
                    errors.push(e.to_string());
                }
            }
            None => errors.push(format!(
                "shaders/{stem}.comp: this test does not know the host's layout of the kernel; add it above"
            )),
        }
    }
    // The embedded render kernels too (what the binary runs), both variants.
    for suffix in gpu::Division::ALL.map(gpu::Division::suffix) {
        let storage = raycast::gpu::kernel_spirv(&format!("render{suffix}")).expect("embedded");
        if let Err(e) =
            reflect::check_layouts(&format!("render{suffix} (embedded)"), storage, &layout::render_bindings())
        {
            errors.push(e.to_string());
        }
        let uniform = raycast::gpu::kernel_spirv(&format!("render_uniform{suffix}")).expect("embedded");
        let (buffers, images) = (layout::render_uniform_bindings(), layout::uniform_kernel_images());
        if let Err(e) = reflect::check_layouts_with_images(
            &format!("render_uniform{suffix} (embedded)"),
            uniform,
            &buffers,
            &images,
        ) {
            errors.push(e.to_string());
        }
    }
    let uniform_spirv = raycast::gpu::kernel_spirv("render_uniform").expect("embedded");
    // Each kernel against the other's layout: the storage / uniform mismatch is named.
    match reflect::check_layouts("render_uniform", uniform_spirv, &layout::render_bindings()) {
        Ok(()) => errors.push("render_uniform.comp passed as a storage-buffer kernel".into()),
        Err(e) => {
            let text = e.to_string();
            if !text.contains("binding 0 (FrameBlock) is a uniform buffer in the shader, a storage buffer on the host")
            {
                errors.push(format!("the storage / uniform mismatch is not named: {text}"));
            }
        }
    }
    // Every generated harness kernel.
    let info = harness::ShaderInfo::load(&dir).unwrap();
    for f in &info.functions {
        match harness::kernel_spirv(&dir, f) {
            Ok(spirv) => {
                if let Err(e) = reflect::check_layouts(&harness::kernel_name(f), &spirv, &harness::kernel_bindings()) {
                    errors.push(e.to_string());
                }
            }
            Err(e) => errors.push(e),
        }
    }
    assert!(errors.is_empty(), "{} kernel(s) failed:\n{}", errors.len(), errors.join("\n"));
    println!("{} kernels of shaders/ and {} harness kernels validated", kernels.len(), info.functions.len());
}

#[test]
fn every_shader_test_file_passes() {
    let o = raycast(&["shader-test", "--device", "llvmpipe"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "stdout:\n{out}\nstderr:\n{err}");
    let last = out.lines().last().unwrap_or("");
    let (passed, failed) = last.split_once(" passed, ").unwrap_or_else(|| panic!("last line {last:?}"));
    assert_eq!(failed, "0 failed", "{out}");
    assert!(passed.parse::<usize>().unwrap() >= 80, "{out}");
}

/// `--only` keeps the cases whose function or name holds its text, over
/// every file; matching none is a usage error.
#[test]
fn only_picks_cases_by_function_or_name() {
    let o = raycast(&["shader-test", "--device", "llvmpipe", "--only", "div_rn", "--only", "sqrt_rn"]);
    let (out, err) = text(&o);
    assert!(o.status.success(), "stdout:\n{out}\nstderr:\n{err}");
    // div_rn's three cases (its vec3 overload among them) and sqrt_rn's one, all in one file.
    assert!(out.contains("shader-test: 4 cases from 1 file;") && out.ends_with("4 passed, 0 failed\n"), "{out}");
    let o = raycast(&["shader-test", "--only", "no-such-function"]);
    assert_eq!(o.status.code(), Some(2), "{:?}", text(&o));
    assert!(text(&o).1.contains("matches --only no-such-function"), "{:?}", text(&o));
}

/// A copy of the shaders whose cone has the wrong slope (dy^2/2 for dy^2/4
/// in cone_quadratic): the cone's cases must fail, readably.
#[test]
fn a_planted_cone_bug_is_caught_readably() {
    let planted = common::copy_of_shaders(&Path::new(env!("CARGO_TARGET_TMPDIR")).join("planted-cone-slope"));
    let glsl = planted.join("shape_cone.glsl");
    let source = std::fs::read_to_string(&glsl).unwrap();
    let right = "0.25f * (r.direction.y * r.direction.y)";
    assert_eq!(
        source.matches(right).count(),
        1,
        "cone_quadratic's a no longer reads `{right}`: update this test's planted bug"
    );
    std::fs::write(&glsl, source.replace(right, "0.5f * (r.direction.y * r.direction.y)")).unwrap();

    let cone = repo().join("tests/shaders/cone.toml");
    let o = raycast(&[
        "shader-test",
        cone.to_str().unwrap(),
        "--shaders",
        planted.to_str().unwrap(),
        "--device",
        "llvmpipe",
    ]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "exit status\nstdout:\n{out}\nstderr:\n{err}");
    assert!(!err.contains("panicked"), "{err}");
    for needle in [
        // The case, where it is, its inputs, expected and actual in decimal and hex, the ULP distance.
        "FAIL cone_quadratic: sloped ray, slope dy^2/4 (tests/shaders/cone.toml:",
        "function: vec3 cone_quadratic(Ray r)",
        "r.direction = (-1.0, -1.0, 0.0) [0xbf800000 0xbf800000 0x00000000]",
        "0.75 (0x3f400000)",
        "0.5 (0x3f000000)",
        "4194304",
        "of 21 cases failed; the first: cone_quadratic: sloped ray",
    ] {
        assert!(out.contains(needle), "stdout lacks {needle:?}:\n{out}");
    }
    let last = out.lines().last().unwrap_or("");
    assert!(last.ends_with(" failed") && !last.ends_with(" 0 failed"), "last line {last:?}");
}
