//! Every shape a primitive can be, once. A canonical shape is a variant of
//! [`Shape`] and an entry of [`SHAPES`]: how a scene file names it, its id
//! in the kernels (shapes.glsl SHAPE_*) and the specialization constant that
//! keeps its code, the box and sphere that hold it, and what the exporters
//! write of it. Every part of the host that meets shapes reads the table
//! rather than matching on them, so a new shape is its GLSL and an entry
//! here (docs/architecture.md, "Adding a shape").

use crate::layout;
use glam::DVec3;
use std::path::PathBuf;

/// The shape of a `<object type="primitive" name=…>`.
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    Cube,
    Cone,
    Cylinder,
    Sphere,
    /// About the y axis, ring radius 0.375, tube radius 0.125 (docs/scene-format.md#torus).
    Torus,
    /// A triangle mesh: the OBJ path as written, and where it was found
    /// (the parser looks it up as a texture's image; flatten() makes it
    /// canonical and loads each file once into `Scene::meshes`).
    Mesh {
        file: String,
        resolved: Option<PathBuf>,
    },
}

/// What the host knows of one canonical shape, in its object space (the
/// canonical shapes fill [-0.5, 0.5]³ about the origin).
pub struct ShapeKind {
    pub shape: Shape,
    /// As `<object type="primitive" name=…>` writes it.
    pub name: &'static str,
    /// Primitive.shape in the kernels (shapes.glsl SHAPE_*).
    pub code: u32,
    /// The specialization constant that keeps its test (shapes.glsl SPEC_*),
    /// and the words `Specialization::describe` says of it.
    pub spec: u32,
    pub spec_name: &'static str,
    /// The shader's test of it is its last resort: a primitive of a shape
    /// no other entry names reaches it (raycast.glsl intersect_shape).
    pub fallback: bool,
    /// The box that holds it.
    pub lo: [f64; 3],
    pub hi: [f64; 3],
    /// The square of the radius of a sphere about the origin that holds it
    /// (squared so that the table holds exact numbers; `radius` takes the root).
    pub radius_squared: f64,
    /// Its volume, which its tessellation must keep (the exporters' tests).
    pub volume: f64,
    /// POV-Ray 3.7's object for it, open for its texture and transform.
    pub pov: &'static str,
    /// POV-Ray's image map for its texture: the map type and what moves the
    /// map onto the shape.
    pub pov_map: (u32, &'static str),
    /// The Mitsuba 3 shape that draws it where its placement allows one.
    pub mitsuba: MitsubaShape,
    /// Its surface in patches, for a mesh of it (`surface_mesh`).
    pub surface: &'static [Patch],
    /// The part of it an object-space point on its surface lies on, as
    /// `explain` names it: "top cap", "+x face"; "" for a shape of one part.
    pub part: fn(DVec3) -> &'static str,
}

/// How near a flat part an object-space point must be to count as on it
/// (the hit's distance is a float of the world's scale).
const ON_PART: f64 = 1e-3;

fn one_part(_: DVec3) -> &'static str {
    ""
}

fn cube_face(p: DVec3) -> &'static str {
    let a = p.abs();
    match (a.x >= a.y && a.x >= a.z, a.y >= a.z) {
        (true, _) if p.x > 0.0 => "+x face",
        (true, _) => "-x face",
        (false, true) if p.y > 0.0 => "+y face",
        (false, true) => "-y face",
        _ if p.z > 0.0 => "+z face",
        _ => "-z face",
    }
}

fn cylinder_part(p: DVec3) -> &'static str {
    if (p.y - 0.5).abs() < ON_PART {
        "top cap"
    } else if (p.y + 0.5).abs() < ON_PART {
        "bottom cap"
    } else {
        "body"
    }
}

fn cone_part(p: DVec3) -> &'static str {
    if (p.y + 0.5).abs() < ON_PART {
        "cap"
    } else {
        "body"
    }
}

/// A Mitsuba 3 shape that draws a canonical shape as it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MitsubaShape {
    /// `cube`, under any placement.
    Cube,
    /// `sphere`, where the placement scales alike on every axis.
    Sphere,
    /// `cylinder` and two `disk`s, where the placement scales alike.
    Cylinder,
    /// None: always a mesh of it.
    Mesh,
}

/// A piece of a shape's surface, for a mesh of it.
#[derive(Clone, Copy, Debug)]
pub enum Patch {
    /// A grid of rows by segments around y: `at(r, t)` is the point and the
    /// outward normal at r in [0, 1] down the rows and t in [0, 1) around;
    /// `half_rows`: half as many rows as segments, else one row.
    Grid { half_rows: bool, at: fn(f64, f64) -> (DVec3, DVec3) },
    /// A disk of radius ½ at height `y`, facing away from the centre.
    Cap { y: f64 },
}

/// A point around the y axis at t in [0, 1) of a turn (t = 0 on +x, a
/// quarter on -z), radius 1.
pub fn around(t: f64) -> DVec3 {
    let tau = std::f64::consts::TAU;
    DVec3::new((tau * t).cos(), 0.0, -(tau * t).sin())
}

fn sphere_at(r: f64, t: f64) -> (DVec3, DVec3) {
    let phi = std::f64::consts::PI * (1.0 - r);
    let p = around(t) * phi.sin() + DVec3::new(0.0, -phi.cos(), 0.0);
    (0.5 * p, p)
}

fn torus_at(r: f64, t: f64) -> (DVec3, DVec3) {
    let a = -std::f64::consts::TAU * r;
    let out = around(t) * a.cos() + DVec3::new(0.0, a.sin(), 0.0);
    (0.375 * around(t) + 0.125 * out, out)
}

/// The side of the cylinder, from the top rim down to the bottom one, as
/// the sphere's rows run, so its triangles face out.
fn cylinder_side(r: f64, t: f64) -> (DVec3, DVec3) {
    (around(t) * 0.5 + DVec3::new(0.0, 0.5 - r, 0.0), around(t))
}

/// The side of the cone, from the tip down to the rim.
fn cone_side(r: f64, t: f64) -> (DVec3, DVec3) {
    (around(t) * (0.5 * r) + DVec3::new(0.0, 0.5 - r, 0.0), around(t) * 2.0 + DVec3::new(0.0, 1.0, 0.0))
}

const UNIT_LO: [f64; 3] = [-0.5; 3];
const UNIT_HI: [f64; 3] = [0.5; 3];

/// Every canonical shape (not the mesh), in the kernels' order of ids.
pub static SHAPES: [ShapeKind; 5] = [
    ShapeKind {
        shape: Shape::Cube,
        name: "cube",
        code: layout::SHAPE_CUBE,
        spec: layout::SPEC_CUBES,
        spec_name: "cubes",
        fallback: false,
        lo: UNIT_LO,
        hi: UNIT_HI,
        radius_squared: 0.75,
        volume: 1.0,
        pov: "box { <-0.5, -0.5, -0.5>, <0.5, 0.5, 0.5>",
        pov_map: (0, " translate <-0.5, -0.5, 0>"),
        mitsuba: MitsubaShape::Cube,
        surface: &[],
        part: cube_face,
    },
    ShapeKind {
        shape: Shape::Cone,
        name: "cone",
        code: layout::SHAPE_CONE,
        spec: layout::SPEC_CONES,
        spec_name: "cones",
        fallback: false,
        lo: UNIT_LO,
        hi: UNIT_HI,
        radius_squared: 0.5,
        volume: std::f64::consts::PI / 12.0,
        pov: "cone { <0, -0.5, 0>, 0.5, <0, 0.5, 0>, 0",
        pov_map: (2, " translate <0, -0.5, 0>"),
        mitsuba: MitsubaShape::Mesh,
        surface: &[Patch::Grid { half_rows: false, at: cone_side }, Patch::Cap { y: -0.5 }],
        part: cone_part,
    },
    ShapeKind {
        shape: Shape::Cylinder,
        name: "cylinder",
        code: layout::SHAPE_CYLINDER,
        spec: layout::SPEC_CYLINDERS,
        spec_name: "cylinders",
        fallback: false,
        lo: UNIT_LO,
        hi: UNIT_HI,
        radius_squared: 0.5,
        volume: std::f64::consts::PI / 4.0,
        pov: "cylinder { <0, -0.5, 0>, <0, 0.5, 0>, 0.5",
        pov_map: (2, " translate <0, -0.5, 0>"),
        mitsuba: MitsubaShape::Cylinder,
        surface: &[Patch::Grid { half_rows: false, at: cylinder_side }, Patch::Cap { y: -0.5 }, Patch::Cap { y: 0.5 }],
        part: cylinder_part,
    },
    ShapeKind {
        shape: Shape::Sphere,
        name: "sphere",
        code: layout::SHAPE_SPHERE,
        spec: layout::SPEC_SPHERES,
        spec_name: "spheres",
        fallback: true,
        lo: UNIT_LO,
        hi: UNIT_HI,
        radius_squared: 0.25,
        volume: std::f64::consts::PI / 6.0,
        pov: "sphere { <0, 0, 0>, 0.5",
        pov_map: (1, ""),
        mitsuba: MitsubaShape::Sphere,
        surface: &[Patch::Grid { half_rows: true, at: sphere_at }],
        part: one_part,
    },
    ShapeKind {
        shape: Shape::Torus,
        name: "torus",
        code: layout::SHAPE_TORUS,
        spec: layout::SPEC_TORI,
        spec_name: "tori",
        fallback: false,
        // The ring's radius and the tube's: y spans only the tube.
        lo: [-0.5, -0.125, -0.5],
        hi: [0.5, 0.125, 0.5],
        radius_squared: 0.25,
        volume: 2.0 * std::f64::consts::PI * std::f64::consts::PI * 0.375 * 0.125 * 0.125,
        // POV-Ray's torus lies about y too: major radius (the ring), then minor (the tube).
        pov: "torus { 0.375, 0.125",
        pov_map: (0, " translate <-0.5, -0.5, 0>"),
        mitsuba: MitsubaShape::Mesh,
        surface: &[Patch::Grid { half_rows: true, at: torus_at }],
        part: one_part,
    },
];

/// A mesh as the parser and `info` name it.
pub const MESH_NAME: &str = "mesh";

impl Shape {
    /// The canonical shape `name` names (`<object type="primitive" name=…>`);
    /// None for any other (a mesh is not one: it needs its file).
    pub fn canonical(name: &str) -> Option<Shape> {
        SHAPES.iter().find(|k| k.name == name).map(|k| k.shape.clone())
    }

    /// Its entry in [`SHAPES`]; None for a mesh.
    pub fn kind(&self) -> Option<&'static ShapeKind> {
        SHAPES.iter().find(|k| k.shape == *self)
    }

    /// As `<object type="primitive" name=…>` writes it.
    pub fn name(&self) -> &'static str {
        self.kind().map_or(MESH_NAME, |k| k.name)
    }

    /// Primitive.shape in the kernels (shapes.glsl SHAPE_*).
    pub fn code(&self) -> u32 {
        self.kind().map_or(layout::SHAPE_MESH, |k| k.code)
    }
}

impl ShapeKind {
    /// The radius of a sphere about the origin that holds it.
    pub fn radius(&self) -> f64 {
        self.radius_squared.sqrt()
    }

    /// Whether a primitive of kernel shape id `code` reaches this shape's
    /// test: its own id, or, for the fallback, an id no entry (nor the mesh) has.
    pub fn reached_by(&self, code: u32) -> bool {
        code == self.code || (self.fallback && code != layout::SHAPE_MESH && SHAPES.iter().all(|k| k.code != code))
    }
}

/// Every name `<object type="primitive" name=…>` takes, as the parser's
/// messages list them: "cube, cone, cylinder, sphere, torus or mesh".
pub fn primitive_names() -> Vec<&'static str> {
    SHAPES.iter().map(|k| k.name).chain([MESH_NAME]).collect()
}

/// A mesh of `kind`'s surface with `segments` around: positions, outward
/// normals (unit) and triangles by index, outward by the right hand.
pub fn surface_mesh(kind: &ShapeKind, segments: usize) -> (Vec<DVec3>, Vec<DVec3>, Vec<[usize; 3]>) {
    let n = segments;
    let (mut v, mut vn, mut faces): (Vec<DVec3>, Vec<DVec3>, Vec<[usize; 3]>) = (Vec::new(), Vec::new(), Vec::new());
    for patch in kind.surface {
        match *patch {
            Patch::Grid { half_rows, at } => {
                // (rows + 1) × (n + 1) vertices, each quad two triangles.
                let rows = if half_rows { n / 2 } else { 1 };
                let base = v.len();
                for r in 0..=rows {
                    for k in 0..=n {
                        let (p, normal) = at(r as f64 / rows as f64, k as f64 / n as f64);
                        v.push(p);
                        vn.push(normal.normalize());
                    }
                }
                for r in 0..rows {
                    for k in 0..n {
                        let a = base + r * (n + 1) + k;
                        let b = a + n + 1;
                        faces.push([a, b, a + 1]);
                        faces.push([a + 1, b, b + 1]);
                    }
                }
            }
            Patch::Cap { y } => {
                // A fan about the centre.
                let up = DVec3::new(0.0, y.signum(), 0.0);
                let centre = v.len();
                v.push(DVec3::new(0.0, y, 0.0));
                vn.push(up);
                for k in 0..=n {
                    v.push(around(k as f64 / n as f64) * 0.5 + DVec3::new(0.0, y, 0.0));
                    vn.push(up);
                }
                for k in 0..n {
                    let (a, b) = (centre + 1 + k, centre + 2 + k);
                    faces.push(if y > 0.0 { [centre, a, b] } else { [centre, b, a] });
                }
            }
        }
    }
    (v, vn, faces)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One entry a canonical shape and its variant, each id and constant
    /// once, the fallback the sphere alone; the names the parser lists.
    #[test]
    fn the_table_holds_each_shape_once() {
        for (i, k) in SHAPES.iter().enumerate() {
            assert_eq!(k.shape.kind().map(|k| k.name), Some(k.name));
            assert_eq!(Shape::canonical(k.name), Some(k.shape.clone()));
            assert!(SHAPES[..i].iter().all(|o| o.code != k.code && o.spec != k.spec && o.name != k.name));
            assert!(k.radius() * k.radius() >= k.lo.iter().chain(&k.hi).map(|x| x * x).fold(0.0, f64::max));
        }
        assert_eq!(SHAPES.iter().filter(|k| k.fallback).map(|k| k.name).collect::<Vec<_>>(), ["sphere"]);
        assert_eq!(primitive_names(), ["cube", "cone", "cylinder", "sphere", "torus", "mesh"]);
        let mesh = Shape::Mesh { file: "a.obj".into(), resolved: None };
        assert_eq!((mesh.kind().is_none(), mesh.name(), mesh.code()), (true, "mesh", layout::SHAPE_MESH));
        assert_eq!(Shape::canonical("mesh"), None);
        // An id no entry has reaches the sphere's test, as in the shader.
        let sphere = Shape::Sphere.kind().unwrap();
        assert!(
            sphere.reached_by(layout::SHAPE_SPHERE) && sphere.reached_by(99) && !sphere.reached_by(layout::SHAPE_MESH)
        );
        assert!(!Shape::Cube.kind().unwrap().reached_by(99));
        // Parts by the object-space point.
        let part = |s: Shape, x: f64, y: f64, z: f64| (s.kind().unwrap().part)(DVec3::new(x, y, z));
        assert_eq!(part(Shape::Cone, 0.1, -0.5, 0.2), "cap");
        assert_eq!(part(Shape::Cone, 0.2, 0.1, 0.0), "body");
        assert_eq!(part(Shape::Cylinder, 0.1, 0.5, 0.0), "top cap");
        assert_eq!(part(Shape::Cylinder, 0.1, -0.49995, 0.0), "bottom cap");
        assert_eq!(part(Shape::Cube, 0.2, -0.5, 0.3), "-y face");
        assert_eq!(part(Shape::Cube, 0.5, 0.1, -0.3), "+x face");
        assert_eq!(part(Shape::Sphere, 0.5, 0.0, 0.0), "");
    }
}
