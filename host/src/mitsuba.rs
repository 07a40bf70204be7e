//! `raycast mitsuba`: a scene written in Mitsuba 3's XML scene format
//! (version 3.0.0), so that raycast's CPU build can be timed beside Mitsuba
//! 3 `scalar_rgb` (issue 45's second peer, `ci/benchmarks.sh mitsuba`) and
//! a scene can be looked at in a physically based renderer.
//!
//! The geometry is the scene's: a sphere is Mitsuba's `sphere` (its centre
//! and radius) where its matrix is a similarity (rotation, uniform scale,
//! translation), a cube is `cube` (Mitsuba's spans ±1: scaled by ½), a
//! cylinder is `cylinder` with two `disk` caps where its matrix is a
//! similarity; cones, tori, and spheres and cylinders under a non-uniform
//! matrix are triangle meshes written as `.obj` files beside the XML
//! ([`Export::files`], [`MESH_SEGMENTS`] segments around), placed by their
//! matrix; a mesh is `obj` with its file. The camera is the format's
//! (`perspective`, the vertical field of view, `lookat`), one sample a
//! pixel by default through a box filter (Mitsuba's samples fall anywhere
//! in the pixel, raycast's first one at its centre).
//!
//! **Instancing.** Mitsuba 3 cannot nest instances: a `shapegroup` holds
//! shapes, never an `instance`. So the masters are split at one level:
//! every group (crate::scene::Group) that expands to at most
//! [`SHAPEGROUP_MAX`] primitives becomes ONE `shapegroup` holding all of
//! them, every level below it expanded with composed matrices, placed by
//! `instance` shapes; the groups above (more primitives) are expanded into
//! the world: their own primitives as plain shapes at each placement (one
//! `shapegroup` of them, placed by an instance, where a group has
//! [`OWN_SHAPEGROUP_MIN`] or more of its own) and their instances followed
//! down with composed matrices. A scene of at most [`SHAPEGROUP_MAX`]
//! primitives, or one without masters, is plain shapes. For
//! `gen:recursive-spheres:10` that is the issue's run: one shape group of
//! 3,906 spheres placed 750 times, and 187 plain spheres.
//!
//! **Light and colour are near, not the same** (the pictures are never
//! compared): every material is a two-sided `diffuse` of reflectance
//! k_d·O_d (each channel clamped to 1); the ambient, emissive, specular,
//! mirror and transparent terms and textures are left out (said in the
//! notes). Mitsuba's lights fall off as 1/d² where raycast's follow
//! 1/(c₁ + c₂d + c₃d²) (at most 1): a point or spot light's intensity is
//! π·I·a(d)·d² for d its distance to the centre of the scene's box, so the
//! two agree there; a directional light's irradiance is π·I; an area light
//! is a one-sided, visible `rectangle` facing the scene's centre, of
//! radiance π·I·a(d)·d²/(w·h); point, spot and directional lights are
//! divided by the number of emitter samples (Mitsuba adds each sample of
//! a delta light at full weight). The integrator is `direct` with
//! `emitter_samples` = the number of lights and `bsdf_samples` = 0: each
//! hit casts about one shadow ray a light, as raycast does with mirrors
//! off (Mitsuba picks a light at random for each sample).

use crate::frame::RenderSettings;
use crate::scene::shape::{surface_mesh, MitsubaShape};
use crate::scene::{Camera, Light, LightKind, Scene, Shape};
use glam::{DMat4, DVec3};
use std::fmt::Write as _;

/// The most primitives one `shapegroup` holds (the split rule above).
pub const SHAPEGROUP_MAX: u64 = 4096;

/// An upper group with at least this many primitives of its own writes
/// them once, as a shapegroup, rather than at each placement.
pub const OWN_SHAPEGROUP_MIN: usize = 64;

/// Segments around the generated meshes (the tube of a torus has half as many).
pub const MESH_SEGMENTS: usize = 48;

/// How the exporter writes: the split rule's limit and the stem of the
/// generated mesh files' names.
#[derive(Clone, Debug)]
pub struct Options {
    pub shapegroup_max: u64,
    /// The generated meshes are `{stem}-cone.obj` and so on, beside the XML.
    pub stem: String,
}

impl Default for Options {
    fn default() -> Self {
        Options { shapegroup_max: SHAPEGROUP_MAX, stem: "scene".into() }
    }
}

/// What the XML holds, counted as it was written.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    /// `shape` elements that are not `instance`s (in shapegroups or not; a
    /// cylinder's caps count).
    pub shapes: u64,
    pub shapegroups: u64,
    pub instances: u64,
    pub emitters: u64,
}

/// A scene in Mitsuba 3's XML, the files it names beside it, and what it
/// could not carry over.
pub struct Export {
    pub xml: String,
    /// (file name, contents): the generated meshes the XML names by a path
    /// relative to its own folder.
    pub files: Vec<(String, String)>,
    /// One line each: what Mitsuba draws otherwise than raycast (also
    /// comments at the head of `xml`).
    pub notes: Vec<String>,
    pub counts: Counts,
}

/// The Python line that renders an exported scene with Mitsuba 3 (the
/// `mitsuba` pip package) as `scalar_rgb` and writes its linear values to
/// a PNG, as raycast writes them (no sRGB curve).
pub fn mitsuba_command(xml: &str, png: &str) -> String {
    format!(
        "python3 -c 'import mitsuba as mi; mi.set_variant(\"scalar_rgb\"); \
         mi.Bitmap(mi.render(mi.load_file(\"{xml}\"))).convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.UInt8, \
         False).write(\"{png}\")'"
    )
}

/// `scene` (its groups as flatten made them) in Mitsuba 3's XML for a
/// picture of `settings` (size, samples). `source` names the scene in the
/// file's head.
pub fn export(scene: &Scene, settings: &RenderSettings, source: &str, options: &Options) -> Export {
    let center = crate::scene::scene_bounds(scene).map_or(DVec3::ZERO, |b| b.center());
    let mut w = Writer {
        scene,
        options,
        notes: Vec::new(),
        files: Vec::new(),
        counts: Counts::default(),
        defs: String::new(),
        body: String::new(),
        shapegroup_of: vec![None; scene.groups.len()],
        own_shapegroup_of: vec![None; scene.groups.len()],
    };
    w.materials();
    if let Some(root) = scene.groups.first() {
        if root.expanded <= options.shapegroup_max {
            w.expanded(0, DMat4::IDENTITY, Target::Body);
        } else {
            w.placed(0, DMat4::IDENTITY);
        }
    }
    let mut lights = String::new();
    for l in &scene.lights {
        lights += &w.light(l, center);
    }
    let counts = w.counts;
    let mut head = String::new();
    let _ = writeln!(head, "<?xml version=\"1.0\" encoding=\"utf-8\"?>");
    let _ = writeln!(head, "<!-- {}, written by raycast mitsuba in Mitsuba 3's scene format. -->", comment(source));
    let _ = writeln!(
        head,
        "<!-- {} primitives when every instance is expanded; {} shapes, {} shape groups, {} instances, {} emitters \
         written. -->",
        crate::units::thousands(scene.groups.first().map_or(0, |g| g.expanded)),
        counts.shapes,
        counts.shapegroups,
        counts.instances,
        counts.emitters
    );
    if !w.notes.is_empty() {
        let _ = writeln!(head, "<!-- Drawn otherwise than by raycast:");
        for n in &w.notes {
            let _ = writeln!(head, "       - {}", comment(n));
        }
        let _ = writeln!(head, "-->");
    }
    let _ = writeln!(head, "<scene version=\"3.0.0\">");
    let emitter_samples = scene.lights.len().max(1);
    let _ = writeln!(
        head,
        "  <integrator type=\"direct\">\n    <integer name=\"emitter_samples\" value=\"{emitter_samples}\"/>\n    \
         <integer name=\"bsdf_samples\" value=\"0\"/>\n  </integrator>"
    );
    head += &sensor(&scene.camera, settings);
    let xml = head + &w.defs + &w.body + &lights + "</scene>\n";
    Export { xml, files: w.files, notes: w.notes, counts }
}

/// Where a shape goes: the scene's body or a shapegroup being written.
#[derive(Clone, Copy, PartialEq)]
enum Target {
    Body,
    Group,
}

struct Writer<'a> {
    scene: &'a Scene,
    options: &'a Options,
    notes: Vec<String>,
    files: Vec<(String, String)>,
    counts: Counts,
    /// Materials and shapegroups, before the shapes that use them.
    defs: String,
    body: String,
    /// The id of the shapegroup holding each small group whole.
    shapegroup_of: Vec<Option<String>>,
    /// The id of the shapegroup holding an upper group's own primitives.
    own_shapegroup_of: Vec<Option<String>>,
}

impl Writer<'_> {
    fn note(&mut self, note: String) {
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    fn out(&mut self, target: Target) -> &mut String {
        match target {
            Target::Body => &mut self.body,
            Target::Group => &mut self.defs,
        }
    }

    fn materials(&mut self) {
        let g = self.scene.globals;
        for (i, m) in self.scene.materials.iter().enumerate() {
            let d = m.diffuse.map(|c| g.kd * c);
            if d.iter().any(|&c| c > 1.0) {
                self.note("a diffuse reflectance k_d·O_d above 1 is clamped to 1".into());
            }
            if m.ambient.iter().any(|&c| c * g.ka > 0.0) || m.emissive.iter().any(|&c| c > 0.0) {
                self.note("ambient and emissive terms are left out (Mitsuba's light comes from its emitters)".into());
            }
            if m.specular.iter().any(|&c| c * g.ks > 0.0) && m.shininess > 0.0 {
                self.note("specular highlights are left out (every material is diffuse)".into());
            }
            if m.reflective.iter().any(|&c| c * g.ks > 0.0) || m.transparent.iter().any(|&c| c * g.kt > 0.0) {
                self.note("mirror and transparent terms are left out (every material is diffuse)".into());
            }
            if m.texture.is_some() {
                self.note("textures are left out (the diffuse colour alone)".into());
            }
            let d = d.map(|c| c.clamp(0.0, 1.0));
            let _ = writeln!(
                self.defs,
                "  <bsdf type=\"twosided\" id=\"mat{i}\">\n    <bsdf type=\"diffuse\">\n      <rgb name=\"reflectance\" \
                 value=\"{}, {}, {}\"/>\n    </bsdf>\n  </bsdf>",
                num32(d[0]),
                num32(d[1]),
                num32(d[2])
            );
        }
    }

    /// An upper group (more than the limit) placed at `m`: its own
    /// primitives, then each instance, small groups as instances of their
    /// shapegroup, larger ones followed down.
    fn placed(&mut self, g: usize, m: DMat4) {
        let group = &self.scene.groups[g];
        if g != 0 && group.primitives.len() >= OWN_SHAPEGROUP_MIN {
            let id = match &self.own_shapegroup_of[g] {
                Some(id) => id.clone(),
                None => {
                    let id = format!("own{g}");
                    let _ = writeln!(self.defs, "  <shape type=\"shapegroup\" id=\"{id}\">");
                    for p in &group.primitives {
                        self.primitive(&p.shape, p.material, &p.world_from_object, Target::Group);
                    }
                    let _ = writeln!(self.defs, "  </shape>");
                    self.counts.shapegroups += 1;
                    self.own_shapegroup_of[g] = Some(id.clone());
                    id
                }
            };
            self.instance(&id, &m);
        } else {
            for p in &group.primitives {
                self.primitive(&p.shape, p.material, &(m * p.world_from_object), Target::Body);
            }
        }
        for inst in &group.instances {
            let child = inst.group as usize;
            let at = m * inst.parent_from_group;
            if self.scene.groups[child].expanded <= self.options.shapegroup_max {
                let id = match &self.shapegroup_of[child] {
                    Some(id) => id.clone(),
                    None => {
                        let id = format!("group{child}");
                        let _ = writeln!(self.defs, "  <shape type=\"shapegroup\" id=\"{id}\">");
                        self.expanded(child, DMat4::IDENTITY, Target::Group);
                        let _ = writeln!(self.defs, "  </shape>");
                        self.counts.shapegroups += 1;
                        self.shapegroup_of[child] = Some(id.clone());
                        id
                    }
                };
                self.instance(&id, &at);
            } else {
                self.placed(child, at);
            }
        }
    }

    fn instance(&mut self, id: &str, m: &DMat4) {
        let _ =
            writeln!(self.body, "  <shape type=\"instance\">\n    <ref id=\"{id}\"/>\n    {}\n  </shape>", to_world(m));
        self.counts.instances += 1;
    }

    /// Every primitive of group `g` and the groups below it, at `m`.
    fn expanded(&mut self, g: usize, m: DMat4, target: Target) {
        let group = &self.scene.groups[g];
        for p in &group.primitives {
            self.primitive(&p.shape, p.material, &(m * p.world_from_object), target);
        }
        for inst in &group.instances {
            self.expanded(inst.group as usize, m * inst.parent_from_group, target);
        }
    }

    fn primitive(&mut self, shape: &Shape, material: u32, m: &DMat4, target: Target) {
        let bsdf = format!("<ref id=\"mat{material}\"/>");
        let similar = uniform_scale(m);
        // A canonical shape as Mitsuba's own shape where its entry names one
        // and the placement allows it (`scene::SHAPES`), else as a mesh.
        let builtin = shape.kind().map(|k| k.mitsuba);
        let text = match (builtin, similar, shape) {
            (Some(MitsubaShape::Sphere), Some(s), _) => {
                self.counts.shapes += 1;
                format!(
                    "    <shape type=\"sphere\">\n      <point name=\"center\" value=\"{}\"/>\n      <float name=\"radius\" \
                     value=\"{}\"/>\n      {bsdf}\n    </shape>\n",
                    triple(m.transform_point3(DVec3::ZERO)),
                    num(0.5 * s)
                )
            }
            (Some(MitsubaShape::Cube), _, _) => {
                self.counts.shapes += 1;
                format!(
                    "    <shape type=\"cube\">\n      {}\n      {bsdf}\n    </shape>\n",
                    to_world(&(*m * DMat4::from_scale(DVec3::splat(0.5))))
                )
            }
            (Some(MitsubaShape::Cylinder), Some(s), _) => {
                self.counts.shapes += 3;
                let cap = |y: f64, angle: f64| {
                    let local = DMat4::from_translation(DVec3::new(0.0, y, 0.0))
                        * DMat4::from_rotation_x(angle.to_radians())
                        * DMat4::from_scale(DVec3::splat(0.5));
                    format!(
                        "    <shape type=\"disk\">\n      {}\n      {bsdf}\n    </shape>\n",
                        to_world(&(*m * local))
                    )
                };
                format!(
                    "    <shape type=\"cylinder\">\n      <point name=\"p0\" value=\"{}\"/>\n      <point name=\"p1\" \
                     value=\"{}\"/>\n      <float name=\"radius\" value=\"{}\"/>\n      {bsdf}\n    </shape>\n{}{}",
                    triple(m.transform_point3(DVec3::new(0.0, -0.5, 0.0))),
                    triple(m.transform_point3(DVec3::new(0.0, 0.5, 0.0))),
                    num(0.5 * s),
                    cap(0.5, -90.0),
                    cap(-0.5, 90.0)
                )
            }
            (None, _, Shape::Mesh { file, resolved }) => {
                let Some(path) = resolved else {
                    self.note(format!("a mesh whose file ({file}) was not found is left out"));
                    return;
                };
                self.counts.shapes += 1;
                let path = std::path::absolute(path).unwrap_or_else(|_| path.clone());
                format!(
                    "    <shape type=\"obj\">\n      <string name=\"filename\" value=\"{}\"/>\n      {}\n      \
                     {bsdf}\n    </shape>\n",
                    attr(&path.to_string_lossy()),
                    to_world(m)
                )
            }
            (None, _, _) => return,
            (Some(builtin), _, _) => {
                let kind = shape.name();
                let name = format!("{}-{kind}.obj", self.options.stem);
                if !self.files.iter().any(|(n, _)| *n == name) {
                    self.files.push((name.clone(), mesh_obj(shape)));
                }
                if builtin != MitsubaShape::Mesh {
                    self.note(format!(
                        "a {kind} under a non-uniform scale or shear is a mesh of {MESH_SEGMENTS} segments around"
                    ));
                } else {
                    self.note(format!("a {kind} is a mesh of {MESH_SEGMENTS} segments around"));
                }
                self.counts.shapes += 1;
                format!(
                    "    <shape type=\"obj\">\n      <string name=\"filename\" value=\"{}\"/>\n      {}\n      \
                     {bsdf}\n    </shape>\n",
                    attr(&name),
                    to_world(m)
                )
            }
        };
        let text = if target == Target::Body { text.replacen("    ", "  ", 1).replace("\n    ", "\n  ") } else { text };
        self.out(target).push_str(&text);
    }

    fn light(&mut self, l: &Light, center: DVec3) -> String {
        let attenuation = |d: f64| {
            let [c1, c2, c3] = l.attenuation.map(f64::from);
            let denominator = c1 + c2 * d + c3 * d * d;
            if denominator > 1.0 {
                1.0 / denominator
            } else {
                1.0
            }
        };
        let pi = std::f64::consts::PI;
        // Mitsuba 3.9's `direct` integrator adds every emitter sample that
        // lands on a delta light (point, spot, directional) at full weight,
        // not 1/emitter_samples of it (measured: 1, 2, 3 and 6 samples
        // draw a pixel 1, 2, 3 and 6 times as bright): so those lights are
        // divided by the number of samples, as if each were one sample.
        let samples = self.scene.lights.len().max(1) as f64;
        let delta = if l.kind == LightKind::Area { 1.0 } else { 1.0 / samples };
        let scaled = |k: f64| {
            let k = k * delta;
            let c = l.color.map(|c| f64::from(c) * k);
            format!("{}, {}, {}", num(c[0]), num(c[1]), num(c[2]))
        };
        self.counts.emitters += 1;
        let d = (l.position - center).length().max(1e-6);
        match l.kind {
            LightKind::Point => format!(
                "  <emitter type=\"point\">\n    <point name=\"position\" value=\"{}\"/>\n    <rgb name=\"intensity\" \
                 value=\"{}\"/>\n  </emitter>\n",
                triple(l.position),
                scaled(pi * attenuation(d) * d * d)
            ),
            LightKind::Directional => format!(
                "  <emitter type=\"directional\">\n    <vector name=\"direction\" value=\"{}\"/>\n    <rgb \
                 name=\"irradiance\" value=\"{}\"/>\n  </emitter>\n",
                triple(l.direction),
                scaled(pi)
            ),
            LightKind::Spot => format!(
                "  <emitter type=\"spot\">\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" \
                 up=\"{}\"/>\n    </transform>\n    <rgb name=\"intensity\" value=\"{}\"/>\n    <float \
                 name=\"cutoff_angle\" value=\"{}\"/>\n    <float name=\"beam_width\" value=\"{}\"/>\n  </emitter>\n",
                triple(l.position),
                triple(l.position + l.direction),
                triple(any_perpendicular(l.direction)),
                scaled(pi * attenuation(d) * d * d),
                num32(l.angle_deg),
                num32((l.angle_deg - l.penumbra_deg).max(0.0))
            ),
            LightKind::Area => {
                let mut n = l.direction.normalize();
                if n.dot(center - l.position) < 0.0 {
                    n = -n;
                }
                let (e_u, e_v) = crate::frame::area_edges(n);
                let (w, h) = (f64::from(l.width), f64::from(l.height));
                let m = DMat4::from_cols(
                    (e_u * 0.5 * w).extend(0.0),
                    (e_v * 0.5 * h).extend(0.0),
                    n.extend(0.0),
                    l.position.extend(1.0),
                );
                self.note("an area light is a one-sided, visible rectangle facing the scene's centre".into());
                self.counts.shapes += 1;
                format!(
                    "  <shape type=\"rectangle\">\n    {}\n    <emitter type=\"area\">\n      <rgb name=\"radiance\" \
                     value=\"{}\"/>\n    </emitter>\n  </shape>\n",
                    to_world(&m),
                    scaled(pi * attenuation(d) * d * d / (w * h).max(1e-12))
                )
            }
        }
    }
}

/// The scale s where `m`'s linear part is s times a rotation (within a
/// relative 1e-9), else None.
fn uniform_scale(m: &DMat4) -> Option<f64> {
    let cols = [m.x_axis.truncate(), m.y_axis.truncate(), m.z_axis.truncate()];
    let s = cols[0].length();
    let tolerance = 1e-9 * s;
    let lengths_agree = cols.iter().all(|c| (c.length() - s).abs() <= tolerance);
    let square = s * s * 1e-9;
    let orthogonal = cols[0].dot(cols[1]).abs() <= square
        && cols[1].dot(cols[2]).abs() <= square
        && cols[0].dot(cols[2]).abs() <= square;
    (s > 0.0 && lengths_agree && orthogonal).then_some(s)
}

/// A unit vector perpendicular to `d` (a spot light's up).
fn any_perpendicular(d: DVec3) -> DVec3 {
    let d = d.normalize();
    let a = if d.y.abs() < 0.9 { DVec3::Y } else { DVec3::X };
    (a - a.dot(d) * d).normalize()
}

/// The camera: the vertical field of view, eye, look and up as `lookat`;
/// the film at the picture's size, one sample a pixel unless --spp says more.
fn sensor(c: &Camera, s: &RenderSettings) -> String {
    format!(
        "  <sensor type=\"perspective\">\n    <string name=\"fov_axis\" value=\"y\"/>\n    <float name=\"fov\" \
         value=\"{}\"/>\n    <transform name=\"to_world\">\n      <lookat origin=\"{}\" target=\"{}\" up=\"{}\"/>\n    \
         </transform>\n    <sampler type=\"independent\">\n      <integer name=\"sample_count\" value=\"{}\"/>\n    \
         </sampler>\n    <film type=\"hdrfilm\">\n      <integer name=\"width\" value=\"{}\"/>\n      <integer \
         name=\"height\" value=\"{}\"/>\n      <string name=\"pixel_format\" value=\"rgb\"/>\n      <rfilter \
         type=\"box\"/>\n    </film>\n  </sensor>\n",
        num(c.height_angle_deg),
        triple(c.pos),
        triple(c.pos + c.look.normalize()),
        triple(c.up),
        s.spp,
        s.width,
        s.height
    )
}

/// A canonical shape as a triangle mesh in OBJ (positions, normals,
/// faces) in raycast's object space, from its entry's surface
/// (`scene::shape::surface_mesh`, MESH_SEGMENTS around); normals out.
pub fn mesh_obj(shape: &Shape) -> String {
    let (v, vn, faces) = shape.kind().map_or_else(Default::default, |k| surface_mesh(k, MESH_SEGMENTS));
    let mut out = String::from("# written by raycast mitsuba\n");
    for p in &v {
        let _ = writeln!(out, "v {} {} {}", num(p.x), num(p.y), num(p.z));
    }
    for p in &vn {
        let _ = writeln!(out, "vn {} {} {}", num(p.x), num(p.y), num(p.z));
    }
    for f in &faces {
        let [a, b, c] = f.map(|i| i + 1);
        let _ = writeln!(out, "f {a}//{a} {b}//{b} {c}//{c}");
    }
    out
}

/// A number as Mitsuba reads it (the shortest decimal that reads back the same).
fn num(x: f64) -> String {
    format!("{}", x + 0.0)
}

fn num32(x: f32) -> String {
    format!("{}", x + 0.0)
}

fn triple(v: DVec3) -> String {
    format!("{}, {}, {}", num(v.x), num(v.y), num(v.z))
}

/// Mitsuba's `to_world` as a row-major 4×4 matrix.
fn to_world(m: &DMat4) -> String {
    let rows: Vec<String> = (0..4).flat_map(|r| m.row(r).to_array()).map(num).collect();
    format!("<transform name=\"to_world\"><matrix value=\"{}\"/></transform>", rows.join(" "))
}

/// Text in an XML attribute.
fn attr(s: &str) -> String {
    s.replace('&', "&amp;").replace('"', "&quot;").replace('<', "&lt;").replace('>', "&gt;")
}

/// Text inside an XML comment (never `--`).
fn comment(s: &str) -> String {
    s.replace('\n', " ").replace("--", "- -")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{flatten, parse_str, FlattenLimits, ParseOptions};
    use std::path::Path;

    fn exported(xml: &str, options: &Options) -> Export {
        let file = parse_str(xml, Path::new("t.xml"), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let scene = flatten(&file, &FlattenLimits::default()).unwrap_or_else(|e| panic!("{e}"));
        export(&scene, &RenderSettings::default(), "t.xml", options)
    }

    #[test]
    fn shapes_and_their_fallbacks() {
        let e = exported(
            r#"<scenefile><object type="tree" name="root">
              <transblock><translate x="1" y="2" z="3"/><scale x="2" y="2" z="2"/><object type="primitive" name="sphere"/></transblock>
              <transblock><scale x="2" y="1" z="1"/><object type="primitive" name="sphere"/></transblock>
              <transblock><object type="primitive" name="cylinder"/></transblock>
              <transblock><object type="primitive" name="cube"/></transblock>
              <transblock><object type="primitive" name="cone"/></transblock>
              <transblock><object type="primitive" name="torus"/></transblock>
            </object></scenefile>"#,
            &Options::default(),
        );
        assert!(e.xml.contains("<point name=\"center\" value=\"1, 2, 3\"/>"), "{}", e.xml);
        assert!(e.xml.contains("<float name=\"radius\" value=\"1\"/>"), "{}", e.xml);
        assert!(e.xml.contains("<matrix value=\"0.5 0 0 0 0 0.5 0 0 0 0 0.5 0 0 0 0 1\"/>"), "{}", e.xml);
        // The non-uniform sphere, the cone and the torus are meshes beside the XML.
        let names: Vec<&str> = e.files.iter().map(|(n, _)| n.as_str()).collect();
        assert_eq!(names, ["scene-sphere.obj", "scene-cone.obj", "scene-torus.obj"]);
        // 2 spheres, a cylinder with its 2 caps, a cube, a cone, a torus.
        // No <lightdata>: no light.
        assert_eq!(e.counts, Counts { shapes: 8, shapegroups: 0, instances: 0, emitters: 0 });
        assert_eq!(e.xml.matches("type=\"disk\"").count(), 2);
        assert!(roxmltree::Document::parse(&e.xml).is_ok());
    }

    #[test]
    fn generated_meshes_are_closed_and_face_out() {
        // Every shape Mitsuba draws as a mesh somewhere: its entry has a surface.
        for kind in crate::scene::SHAPES.iter().filter(|k| !k.surface.is_empty()) {
            let obj = mesh_obj(&kind.shape);
            let v: Vec<DVec3> = obj
                .lines()
                .filter_map(|l| l.strip_prefix("v "))
                .map(|l| {
                    let x: Vec<f64> = l.split(' ').map(|t| t.parse().unwrap()).collect();
                    DVec3::new(x[0], x[1], x[2])
                })
                .collect();
            // The signed volume of a closed outward mesh is positive (the
            // entry's: the canonical sphere's π/6, the cylinder's π/4, the
            // cone's π/12, the torus's 2π²·0.375·0.125²), within 2% at 48
            // segments around (the torus's, the farthest, 1.4% short when written).
            let mut volume = 0.0;
            for f in obj.lines().filter_map(|l| l.strip_prefix("f ")) {
                let i: Vec<usize> =
                    f.split(' ').map(|t| t.split("//").next().unwrap().parse::<usize>().unwrap() - 1).collect();
                volume += v[i[0]].dot(v[i[1]].cross(v[i[2]])) / 6.0;
            }
            let want = kind.volume;
            assert!((volume - want).abs() < 0.02 * want, "{}: {volume} against {want}", kind.name);
        }
        // Each shape the exporter does not draw with Mitsuba's own has a surface.
        assert!(crate::scene::SHAPES.iter().all(|k| k.mitsuba == MitsubaShape::Cube || !k.surface.is_empty()));
    }
}
