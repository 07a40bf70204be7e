//! `raycast gen`: scale-test scenes of the corpus's recursive construction
//! (`test_efficiency/recursiveSpheres4.xml`, `recursiveCones4.xml`,
//! `recursiveCubes4.xml`), any number of levels deep, and counting a scene
//! file's primitives without expanding it.
//!
//! The corpus has the recursive spheres at depths 1 to 4 only; deeper
//! members (the course's "almost impossible to render with a baseline ray
//! tracer" ones) are generated here, one master level per step, so that a
//! few kilobytes of XML expand to millions of primitives.

use crate::error::Error;
use crate::scene::{Material, Node, SceneFile, Shape, TransBlock};
use glam::DMat4;
use std::fmt::Write as _;

/// Depths `gen` accepts: depth 12 already expands to 73 million primitives.
pub const MIN_DEPTH: u32 = 1;
pub const MAX_DEPTH: u32 = 12;

/// Deepest scene `gen --flat` writes: depth 8 is 117,187 primitives, about
/// 70 MB of XML (about 700 MB to load); depth 9 would be five times that.
pub const MAX_FLAT_DEPTH: u32 = 8;

/// The texture every generated primitive carries, as the corpus writes it
/// (relative to the corpus root: render with `--assets <corpus>`).
pub const CORPUS_TEXTURE: &str = "image/marsTexture.png";

/// Which corpus scene a generated scene extends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Family {
    /// recursiveSpheres1..4: masters, each level rotated to grow outwards.
    RecursiveSpheres,
    /// recursiveCones4: the same placements, every cone upright.
    RecursiveCones,
    /// recursiveCubes4: the same placements, every cube axis-aligned.
    RecursiveCubes,
}

impl Family {
    pub const ALL: [Family; 3] = [Family::RecursiveSpheres, Family::RecursiveCones, Family::RecursiveCubes];

    /// The name on the command line (`recursive-spheres`).
    pub fn name(self) -> &'static str {
        match self {
            Family::RecursiveSpheres => "recursive-spheres",
            Family::RecursiveCones => "recursive-cones",
            Family::RecursiveCubes => "recursive-cubes",
        }
    }

    fn shape(self) -> &'static str {
        match self {
            Family::RecursiveSpheres => "sphere",
            Family::RecursiveCones => "cone",
            Family::RecursiveCubes => "cube",
        }
    }

    /// Primitives the scene of `depth` expands to: 1 + 6·(5^(depth−1) − 1)/4
    /// (the root, six level-1 copies, five children under every other node).
    pub fn expanded_count(self, depth: u32) -> u64 {
        1 + 6 * (5u64.pow(depth - 1) - 1) / 4
    }

    /// Distinct primitives written in the file: one per tree.
    pub fn unique_count(self, depth: u32) -> u64 {
        match self {
            Family::RecursiveSpheres => u64::from(depth),
            // One master per level and direction (six per level below the root).
            Family::RecursiveCones | Family::RecursiveCubes => 1 + 6 * u64::from(depth - 1),
        }
    }
}

/// Triangles `gen mesh-sphere` accepts: 8 (an octahedron's count) to 16
/// million (an OBJ file of about 1.2 GB).
pub const MIN_MESH_TRIANGLES: u64 = 8;
pub const MAX_MESH_TRIANGLES: u64 = 16_000_000;

/// The mesh sphere's latitude bands for at least `triangles` triangles:
/// with s bands and 2s meridians it has 4s(s − 1) triangles (2s at each
/// pole, two a quad between).
pub fn mesh_sphere_bands(triangles: u64) -> u32 {
    let mut s = ((triangles as f64 / 4.0).sqrt() as u32).max(2);
    while 4 * u64::from(s) * u64::from(s - 1) < triangles {
        s += 1;
    }
    while s > 2 && 4 * u64::from(s - 1) * u64::from(s - 2) >= triangles {
        s -= 1;
    }
    s
}

/// A sphere of radius 0.5 about the origin (the canonical sphere's size)
/// as an OBJ file of at least `triangles` triangles: `bands` =
/// `mesh_sphere_bands` latitude bands of equal angle, 2·bands meridians, a
/// vertex at each pole; smooth (each vertex's `vn` is its direction from
/// the centre), counter-clockwise from outside, every edge shared by two
/// triangles. Returns the file's text and its triangle count.
pub fn mesh_sphere_obj(triangles: u64) -> Result<(String, u64), Error> {
    if !(MIN_MESH_TRIANGLES..=MAX_MESH_TRIANGLES).contains(&triangles) {
        return Err(Error::Usage(format!(
            "--triangles {triangles} is out of range: {MIN_MESH_TRIANGLES} to {MAX_MESH_TRIANGLES}"
        )));
    }
    let bands = mesh_sphere_bands(triangles);
    let meridians = 2 * bands;
    let count = 4 * u64::from(bands) * u64::from(bands - 1);
    let mut obj = String::with_capacity(75 * count as usize);
    let _ = writeln!(
        obj,
        "# raycast gen mesh-sphere --triangles {triangles}: radius 0.5, {bands} bands, {meridians} meridians, {count} triangles"
    );
    let mut vertex = |d: [f64; 3]| {
        let unit = d.map(|c| c as f32);
        let p = d.map(|c| (0.5 * c) as f32);
        let _ = writeln!(obj, "v {} {} {}\nvn {} {} {}", p[0], p[1], p[2], unit[0], unit[1], unit[2]);
    };
    // Vertex 1 the north pole, then each ring from the north, then the south pole.
    vertex([0.0, 1.0, 0.0]);
    for i in 1..bands {
        let theta = std::f64::consts::PI * f64::from(i) / f64::from(bands);
        for j in 0..meridians {
            let phi = 2.0 * std::f64::consts::PI * f64::from(j) / f64::from(meridians);
            vertex([theta.sin() * phi.cos(), theta.cos(), -theta.sin() * phi.sin()]);
        }
    }
    vertex([0.0, -1.0, 0.0]);
    let ring = |i: u32, j: u32| 2 + (i - 1) * meridians + j % meridians;
    let south = 2 + (bands - 1) * meridians;
    let mut face = |a: u32, b: u32, c: u32| {
        let _ = writeln!(obj, "f {a}//{a} {b}//{b} {c}//{c}");
    };
    for j in 0..meridians {
        face(1, ring(1, j), ring(1, j + 1));
    }
    for i in 1..bands - 1 {
        for j in 0..meridians {
            let (a, b, c, d) = (ring(i, j), ring(i + 1, j), ring(i + 1, j + 1), ring(i, j + 1));
            face(a, b, c);
            face(a, c, d);
        }
    }
    for j in 0..meridians {
        face(ring(bands - 1, j), south, ring(bands - 1, j + 1));
    }
    Ok((obj, count))
}

/// The scene of `gen mesh-sphere`: the mesh file `obj` (as the XML names
/// it, beside the scene) at the origin, lit by a point and a directional
/// light, seen from above and to the side.
pub fn mesh_sphere_xml(obj: &str, triangles: u64) -> String {
    format!(
        "<scenefile>\n\
         \t<!-- raycast gen mesh-sphere: {triangles} triangles, radius 0.5 (the canonical sphere's size) -->\n\
         \t<globaldata>\n\t\t<diffusecoeff v=\"0.7\"/>\n\t\t<specularcoeff v=\"0.5\"/>\n\t\t<ambientcoeff v=\"0.3\"/>\n\t</globaldata>\n\
         \t<cameradata>\n\t\t<pos x=\"1.2\" y=\"0.9\" z=\"1.6\"/>\n\t\t<focus x=\"0\" y=\"0\" z=\"0\"/>\n\
         \t\t<up x=\"0\" y=\"1\" z=\"0\"/>\n\t\t<heightangle v=\"35\"/>\n\t</cameradata>\n\
         \t<lightdata>\n\t\t<id v=\"0\"/>\n\t\t<type v=\"point\"/>\n\t\t<color r=\"1\" g=\"1\" b=\"1\"/>\n\
         \t\t<position x=\"2\" y=\"3\" z=\"1\"/>\n\t\t<function v1=\"1\" v2=\"0\" v3=\"0\"/>\n\t</lightdata>\n\
         \t<lightdata>\n\t\t<id v=\"1\"/>\n\t\t<type v=\"directional\"/>\n\t\t<color r=\"0.3\" g=\"0.3\" b=\"0.4\"/>\n\
         \t\t<direction x=\"1\" y=\"-1\" z=\"-2\"/>\n\t</lightdata>\n\
         \t<object type=\"tree\" name=\"root\">\n\t\t<transblock>\n\
         \t\t\t<object type=\"primitive\" name=\"mesh\" meshfile=\"{}\">\n\
         \t\t\t\t<diffuse r=\"0.3\" g=\"0.5\" b=\"0.9\"/>\n\t\t\t\t<ambient r=\"0.3\" g=\"0.5\" b=\"0.9\"/>\n\
         \t\t\t\t<specular r=\"1\" g=\"1\" b=\"1\"/>\n\t\t\t\t<shininess v=\"30\"/>\n\
         \t\t\t</object>\n\t\t</transblock>\n\t</object>\n</scenefile>\n",
        escape_attr(obj)
    )
}

/// How `gen` describes its construction (`raycast gen --help`).
pub const CONSTRUCTION: &str = "\
Construction (corpus test_efficiency/recursiveSpheres1..4.xml; --depth N has N levels):
  root    a primitive scaled 6 at the origin, and six copies of level1 at 4.5 along
          -x, +x, +y, -y, -z, +z.
  level k (k = 1 .. N-1) a primitive scaled 6/2^k and, unless k = N-1, five copies of
          level k+1 at 4.5/2^k along its own -x, +x, +y, -z, +z.
  Each copy is rotated so that its +y points away from its parent (-x: 90 degrees about
  z, +x: -90 about z, +y: none, -y: 180 about z, -z: -90 about x, +z: 90 about x), so it
  grows outwards and never back into its parent. Each level is one master, declared
  deepest first; the file is a few KB at any depth.
  Expands to 1 + 6*(5^(N-1) - 1)/4 primitives: depth 1: 1, 2: 7, 3: 37, 4: 187 (the
  corpus scenes), 6: 4,687, 8: 117,187, 10: 2,929,687, 12: 73,242,187.
  Camera, the three lights and the global coefficients are the corpus's. Level k's
  material: diffuse = reflective = (1, .75, .75), (.75, 1, .75), (.75, .75, 1) for
  k mod 3 = 0, 1, 2; specular 1, shininess 25, texture image/marsTexture.png
  (relative to the corpus root: render with --assets <corpus>) blended 0.75.
  recursive-spheres --depth 1..4 writes the corpus files recursiveSpheres1..4.xml
  (depth 4 byte for byte but a final newline the corpus file lacks; 1..3 add the
  aperture and focal length of depth 4).

  recursive-cones, recursive-cubes: the same placements with no rotation, every cone
  upright and every cube axis-aligned, as the corpus's recursiveCones4 and
  recursiveCubes4. Those write their 187 primitives out flat, each with a colour (one
  of the three) and shininess (15 to 25) drawn at random, which masters cannot repeat.
  Here each level has six masters, one per direction it grows in, each with five
  children (every direction but back towards its parent, in the corpus's order +x, +y,
  +z, -x, -y, -z), and level k's material is the spheres' level k material. Depth 4
  has the corpus's 187 primitives with the same transforms in the same order; only the
  materials differ.

  mesh-sphere --triangles N (with -o FILE.xml): FILE.obj, a sphere of radius 0.5 about
  the origin in s latitude bands of equal angle and 2s meridians, the fewest with
  4s(s-1) >= N triangles (10,000: 10,200; 1,000,000: 1,002,000), smooth normals, every
  edge shared; and FILE.xml, that mesh lit by a point and a directional light.";

/// What `generate` writes besides the construction itself.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct GenOptions {
    /// The texture file of every material; None: untextured.
    pub texture: Option<String>,
}

impl Default for GenOptions {
    fn default() -> Self {
        GenOptions { texture: Some(CORPUS_TEXTURE.to_string()) }
    }
}

/// A generated scene name as `bench` takes it, `gen:recursive-spheres:6`:
/// None when `name` does not start with `gen:`, else the family and depth
/// or what is wrong with them.
pub fn parse_scene_name(name: &str) -> Option<Result<(Family, u32), Error>> {
    let rest = name.strip_prefix("gen:")?;
    let usage = || {
        Error::Failed(format!(
            "{name}: a generated scene is gen:FAMILY:DEPTH with FAMILY recursive-spheres, recursive-cones or recursive-cubes and DEPTH {MIN_DEPTH} to {MAX_DEPTH}"
        ))
    };
    let Some((family, depth)) = rest.split_once(':') else { return Some(Err(usage())) };
    let Some(family) = Family::ALL.into_iter().find(|f| f.name() == family) else { return Some(Err(usage())) };
    match depth.parse::<u32>() {
        Ok(d) if (MIN_DEPTH..=MAX_DEPTH).contains(&d) => Some(Ok((family, d))),
        _ => Some(Err(usage())),
    }
}

/// The six directions of the construction, as (axis, sign).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct Dir {
    axis: usize,
    sign: i8,
}

impl Dir {
    const fn new(axis: usize, sign: i8) -> Dir {
        Dir { axis, sign }
    }

    fn opposite(self) -> Dir {
        Dir { axis: self.axis, sign: -self.sign }
    }

    /// `+x`, `-z`, …: part of a master's name.
    fn label(self) -> String {
        format!("{}{}", if self.sign > 0 { '+' } else { '-' }, ['x', 'y', 'z'][self.axis])
    }

    /// `x="4.5" y="0" z="0"` for this direction at `distance`.
    fn translate(self, distance: f64) -> String {
        let mut v = [0.0f64; 3];
        v[self.axis] = f64::from(self.sign) * distance;
        format!("x=\"{}\" y=\"{}\" z=\"{}\"", num(v[0]), num(v[1]), num(v[2]))
    }
}

const PX: Dir = Dir::new(0, 1);
const NX: Dir = Dir::new(0, -1);
const PY: Dir = Dir::new(1, 1);
const NY: Dir = Dir::new(1, -1);
const PZ: Dir = Dir::new(2, 1);
const NZ: Dir = Dir::new(2, -1);

/// The spheres' children, in the corpus's order, with the rotation that
/// turns the child's +y outwards. The root has all six; a level below it
/// has no -y child (its -y points back at its parent).
const SPHERE_CHILDREN: [(Dir, &str); 6] = [
    (NX, "x=\"0\" y=\"0\" z=\"1\" angle=\"90\""),
    (PX, "x=\"0\" y=\"0\" z=\"1\" angle=\"-90\""),
    (PY, "x=\"1\" y=\"0\" z=\"0\" angle=\"0\""),
    (NY, "x=\"0\" y=\"0\" z=\"1\" angle=\"180\""),
    (NZ, "x=\"1\" y=\"0\" z=\"0\" angle=\"-90\""),
    (PZ, "x=\"1\" y=\"0\" z=\"0\" angle=\"90\""),
];

/// The cones' and cubes' children, in recursiveCones4.xml's order.
const AXIS_ALIGNED_CHILDREN: [Dir; 6] = [PX, PY, PZ, NX, NY, NZ];

/// The corpus's three colours, by level mod 3.
const COLOURS: [&str; 3] =
    ["r=\"1\" g=\"0.75\" b=\"0.75\"", "r=\"0.75\" g=\"1\" b=\"0.75\"", "r=\"0.75\" g=\"0.75\" b=\"1\""];

/// A number as the corpus writes it: shortest round-trip decimal, `0` for zero.
fn num(v: f64) -> String {
    if v == 0.0 {
        "0".to_string()
    } else {
        format!("{v}")
    }
}

/// Level k's primitive scale, written as the corpus does (`6` at the root,
/// then `3.0`, `1.5`, `0.75`, …).
fn scale_text(level: u32) -> String {
    let s = 6.0 / f64::from(1u32 << level);
    if level == 0 {
        num(s)
    } else {
        format!("{s:?}")
    }
}

/// Distance from a level-k node to its children: 4.5/2^k.
fn child_distance(level: u32) -> f64 {
    4.5 / f64::from(1u32 << level)
}

fn escape_attr(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// The scene file of `family` at `depth` (1 to 12).
pub fn generate(family: Family, depth: u32, options: &GenOptions) -> Result<String, Error> {
    if !(MIN_DEPTH..=MAX_DEPTH).contains(&depth) {
        return Err(Error::Usage(format!(
            "--depth {depth} is out of range: {MIN_DEPTH} to {MAX_DEPTH} (depth 12 already expands to {} primitives)",
            family.expanded_count(MAX_DEPTH)
        )));
    }
    let mut xml = String::with_capacity(4096);
    header(&mut xml, family == Family::RecursiveSpheres);
    match family {
        Family::RecursiveSpheres => spheres(&mut xml, family, depth, options),
        Family::RecursiveCones | Family::RecursiveCubes => axis_aligned(&mut xml, family, depth, options),
    }
    xml.push_str("</scenefile>\n");
    Ok(xml)
}

/// `generate`'s scene with every master written out: each primitive a
/// transblock of its own under the root, its `<matrix>` the product the
/// renderer composes (in f64, in shortest round-trip digits, so the file
/// reads back as exactly that product) and its material as written. The
/// same primitives in the same order; pictures agree with the instanced
/// file's up to the rounding of the f32 matrices (one composed matrix where
/// the instanced walk applies a chain).
pub fn generate_flat(family: Family, depth: u32, options: &GenOptions) -> Result<String, Error> {
    if depth > MAX_FLAT_DEPTH {
        return Err(Error::Usage(format!(
            "--depth {depth} --flat would write {} primitives out one by one; --flat goes to depth {MAX_FLAT_DEPTH} ({})",
            family.expanded_count(depth),
            family.expanded_count(MAX_FLAT_DEPTH)
        )));
    }
    let instanced = generate(family, depth, options)?;
    let file =
        crate::scene::parse_str(&instanced, std::path::Path::new("gen.xml"), &crate::scene::ParseOptions::default())
            .map_err(|e| Error::Failed(e.to_string()))?;
    let mut xml = String::with_capacity(600 * family.expanded_count(depth) as usize);
    header(&mut xml, family == Family::RecursiveSpheres);
    xml.push_str("\t<object type=\"tree\" name=\"root\">\n");
    for (shape, m, material) in expand(&file) {
        xml.push_str("\t\t<transblock>\n\t\t\t<matrix>\n");
        for r in 0..4 {
            let row = m.row(r);
            let _ =
                writeln!(xml, "\t\t\t\t<row{r} v1=\"{}\" v2=\"{}\" v3=\"{}\" v4=\"{}\"/>", row.x, row.y, row.z, row.w);
        }
        let _ = writeln!(xml, "\t\t\t</matrix>\n\t\t\t<object type=\"primitive\" name=\"{}\">", shape.name());
        material_xml(&mut xml, &material);
        xml.push_str("\t\t\t</object>\n\t\t</transblock>\n");
    }
    xml.push_str("\t</object>\n</scenefile>\n");
    Ok(xml)
}

/// The elements of `m` that differ from the defaults, in shortest
/// round-trip digits (what `generate` writes, read back).
fn material_xml(xml: &mut String, m: &Material) {
    let d = Material::default();
    for (name, c, default) in [
        ("diffuse", m.diffuse, d.diffuse),
        ("ambient", m.ambient, d.ambient),
        ("specular", m.specular, d.specular),
        ("reflective", m.reflective, d.reflective),
        ("transparent", m.transparent, d.transparent),
        ("emissive", m.emissive, d.emissive),
    ] {
        if c != default {
            let _ = writeln!(xml, "\t\t\t\t<{name} r=\"{}\" g=\"{}\" b=\"{}\"/>", c[0], c[1], c[2]);
        }
    }
    for (name, v, default) in
        [("shininess", m.shininess, d.shininess), ("ior", m.ior, d.ior), ("blend", m.blend, d.blend)]
    {
        if v != default {
            let _ = writeln!(xml, "\t\t\t\t<{name} v=\"{v}\"/>");
        }
    }
    for (name, t) in [("texture", &m.texture), ("bumpmap", &m.bumpmap)] {
        if let Some(t) = t {
            let _ = writeln!(
                xml,
                "\t\t\t\t<{name} file=\"{}\" u=\"{}\" v=\"{}\"/>",
                escape_attr(&t.file),
                t.repeat_u,
                t.repeat_v
            );
        }
    }
}

/// Every drawn primitive of `file` in the renderer's order (depth first,
/// file order), with its world_from_object in f64 as the flattener
/// composes it.
fn expand(file: &SceneFile) -> Vec<(Shape, DMat4, Material)> {
    fn go(file: &SceneFile, blocks: &[TransBlock], parent: DMat4, out: &mut Vec<(Shape, DMat4, Material)>) {
        for b in blocks {
            let ctm = parent * b.matrix;
            match &b.object {
                Node::Primitive { shape, material, .. } => out.push((shape.clone(), ctm, material.clone())),
                Node::Tree { blocks, .. } => go(file, blocks, ctm, out),
                Node::Master { tree, .. } => go(file, &file.trees[*tree].blocks, ctm, out),
            }
        }
    }
    let mut out = Vec::new();
    go(file, &file.trees[file.root].blocks, DMat4::IDENTITY, &mut out);
    out
}

/// Globals, camera and lights of the corpus scenes.
fn header(xml: &mut String, aperture: bool) {
    xml.push_str(
        "<scenefile>\n\
         \t<globaldata>\n\
         \t\t<diffusecoeff v=\"0.7\"/>\n\
         \t\t<specularcoeff v=\"0.54\"/>\n\
         \t\t<ambientcoeff v=\"0.5\"/>\n\
         \t</globaldata>\n\
         \n\
         \t<cameradata>\n\
         \t\t<pos x=\"10\" y=\"4.1\" z=\"16\"/>\n\
         \t\t<up x=\"0\" y=\"1\" z=\"0\"/>\n\
         \t\t\n\
         \t\t<heightangle v=\"49.5\"/>\n\
         \t\t<look x=\"-9\" y=\"-3.2\" z=\"-16\"/>\n",
    );
    if aperture {
        xml.push_str("\t\t<aperture v=\"0.08\"/>\n\t\t<focallength v=\"15.0\"/>\n");
    }
    xml.push_str("\t</cameradata>\n\n");
    let lights = [
        ("", "<position x=\"10\" y=\"10\" z=\"10\"/>"),
        ("\t\t<type v=\"directional\"/>\n", "<direction x=\"0.25\" y=\"1\" z=\"-1\"/>"),
        ("\t\t<type v=\"directional\"/>\n", "<direction x=\"1\" y=\"-1.8\" z=\"-2\"/>"),
    ];
    for (id, (kind, place)) in lights.iter().enumerate() {
        let _ = write!(
            xml,
            "\t<lightdata>\n\
             \t\t<id v=\"{id}\"/>\n\
             \t\t<color r=\"1\" g=\"1\" b=\"1\"/>\n\
             \t\t<function v1=\"1.5\" v2=\"0\" v3=\"0\"/>\n\
             {kind}\t\t{place}\n\
             \t</lightdata>\n\n"
        );
    }
}

/// The transblock of level `level`'s own primitive.
fn primitive_block(xml: &mut String, family: Family, level: u32, options: &GenOptions) {
    let s = scale_text(level);
    let colour = COLOURS[(level % 3) as usize];
    let _ = write!(
        xml,
        "\t\t<transblock>\n\
         \t\t\t<translate x=\"0\" y=\"0\" z=\"0\"/>\n\
         \t\t\t<scale x=\"{s}\" y=\"{s}\" z=\"{s}\"/>\n\
         \t\t\t<object type=\"primitive\" name=\"{}\">\n\
         \t\t\t\t<reflective {colour}/>\n\
         \t\t\t\t<diffuse {colour}/>\n\
         \t\t\t\t<shininess v=\"25\"/>\n\
         \t\t\t\t<specular r=\"1\" g=\"1\" b=\"1\"/>\n",
        family.shape()
    );
    if let Some(t) = &options.texture {
        let _ = write!(
            xml,
            "\t\t\t\t<texture file=\"{}\" u=\"1\" v=\"1\"/>\n\t\t\t\t<blend v=\"0.75\"/>\n",
            escape_attr(t)
        );
    }
    xml.push_str("\t\t\t</object>\n\t\t</transblock>\n");
}

fn master_block(xml: &mut String, translate: &str, rotate: Option<&str>, master: &str) {
    let _ = writeln!(xml, "\t\t<transblock>\n\t\t\t<translate {translate}/>");
    if let Some(r) = rotate {
        let _ = writeln!(xml, "\t\t\t<rotate {r}/>");
    }
    let _ = writeln!(xml, "\t\t\t<object type=\"master\" name=\"{master}\" />\n\t\t</transblock>");
}

/// recursiveSpheres: one master per level, `level{k}`, deepest first.
fn spheres(xml: &mut String, family: Family, depth: u32, options: &GenOptions) {
    for level in (0..depth).rev() {
        let name = if level == 0 { "root".to_string() } else { format!("level{level}") };
        let _ = writeln!(xml, "\t<object type=\"tree\" name=\"{name}\">");
        primitive_block(xml, family, level, options);
        if level + 1 < depth {
            let child = format!("level{}", level + 1);
            for (dir, rotate) in SPHERE_CHILDREN {
                // Below the root, the -y side faces the parent.
                if level > 0 && dir == NY {
                    continue;
                }
                master_block(xml, &dir.translate(child_distance(level)), Some(rotate), &child);
            }
        }
        xml.push_str("\t</object>\n");
        if level > 0 {
            xml.push('\n');
        }
    }
}

/// recursiveCones / recursiveCubes: no rotation; a master per level and
/// direction of growth, `level{k}{+x|-x|…}`, each without the child that
/// would grow back into its parent.
fn axis_aligned(xml: &mut String, family: Family, depth: u32, options: &GenOptions) {
    for level in (0..depth).rev() {
        let dirs: Vec<Option<Dir>> =
            if level == 0 { vec![None] } else { AXIS_ALIGNED_CHILDREN.iter().copied().map(Some).collect() };
        for grown in dirs {
            let name = match grown {
                None => "root".to_string(),
                Some(d) => format!("level{level}{}", d.label()),
            };
            let _ = writeln!(xml, "\t<object type=\"tree\" name=\"{name}\">");
            primitive_block(xml, family, level, options);
            if level + 1 < depth {
                for dir in AXIS_ALIGNED_CHILDREN {
                    if grown.is_some_and(|g| g.opposite() == dir) {
                        continue;
                    }
                    let child = format!("level{}{}", level + 1, dir.label());
                    master_block(xml, &dir.translate(child_distance(level)), None, &child);
                }
            }
            xml.push_str("\t</object>\n");
            if level > 0 {
                xml.push('\n');
            }
        }
    }
}

/// Primitives of a scene file, counted without expanding it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PrimitiveCounts {
    /// Drawn primitives after expanding every master (what a flat renderer draws).
    pub expanded: u64,
    /// Drawn primitives written in the file and reachable from the root:
    /// each master's counted once.
    pub unique: u64,
}

/// Counts the drawn primitives (cube, cone, cylinder, sphere, torus; a
/// mesh is not drawn) of `file`'s root: each tree's expansion once,
/// memoised, so a scene of billions costs as much as its file.
pub fn count_primitives(file: &SceneFile) -> PrimitiveCounts {
    // Per tree: the drawn primitives written in it (inline trees included)
    // and the masters it places.
    fn walk(blocks: &[TransBlock], own: &mut u64, masters: &mut Vec<usize>) {
        for b in blocks {
            match &b.object {
                // Every shape is drawn.
                Node::Primitive { .. } => *own += 1,
                Node::Tree { blocks, .. } => walk(blocks, own, masters),
                Node::Master { tree, .. } => masters.push(*tree),
            }
        }
    }
    let n = file.trees.len();
    if file.root >= n {
        return PrimitiveCounts { expanded: 0, unique: 0 };
    }
    let summary: Vec<(u64, Vec<usize>)> = file
        .trees
        .iter()
        .map(|t| {
            let (mut own, mut masters) = (0, Vec::new());
            walk(&t.blocks, &mut own, &mut masters);
            (own, masters)
        })
        .collect();
    // Depth first with an explicit stack (masters can nest deeply), each
    // tree's expansion computed once. A master met while its tree is still
    // open (a cycle, which the parser rules out) counts as empty.
    const NEW: u8 = 0;
    const OPEN: u8 = 1;
    let mut state = vec![NEW; n];
    let mut expanded: Vec<u64> = vec![0; n];
    let mut stack: Vec<(usize, usize)> = vec![(file.root, 0)];
    state[file.root] = OPEN;
    while let Some(top) = stack.last_mut() {
        let t = top.0;
        if let Some(&child) = summary[t].1.get(top.1) {
            top.1 += 1;
            if child < n && state[child] == NEW {
                state[child] = OPEN;
                stack.push((child, 0));
            }
            continue;
        }
        let children = summary[t].1.iter().filter(|&&c| c < n).fold(0u64, |sum, &c| sum.saturating_add(expanded[c]));
        expanded[t] = summary[t].0.saturating_add(children);
        stack.pop();
    }
    let unique = (0..n).filter(|&t| state[t] != NEW).map(|t| summary[t].0).sum();
    PrimitiveCounts { expanded: expanded[file.root], unique }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{self, RenderSettings};
    use crate::gpu::GpuRenderer;
    use crate::gpu::{DeviceSelector, GpuOptions};
    use crate::scene::{self, parse_str, FlattenLimits, ParseOptions};
    use std::path::{Path, PathBuf};

    use crate::test_support::corpus;

    fn corpus_file(family: Family, depth: u32) -> &'static str {
        match (family, depth) {
            (Family::RecursiveSpheres, 1) => "recursiveSpheres1.xml",
            (Family::RecursiveSpheres, 2) => "recursiveSpheres2.xml",
            (Family::RecursiveSpheres, 3) => "recursiveSpheres3.xml",
            (Family::RecursiveSpheres, 4) => "recursiveSpheres4.xml",
            (Family::RecursiveCones, 4) => "recursiveCones4.xml",
            (Family::RecursiveCubes, 4) => "recursiveCubes4.xml",
            _ => unreachable!(),
        }
    }

    /// Parses a generated scene as if it sat in the corpus's test_efficiency
    /// folder (so its texture resolves as the corpus file's does).
    fn parse_generated(family: Family, depth: u32, assets: Vec<PathBuf>) -> SceneFile {
        let xml = generate(family, depth, &GenOptions::default()).unwrap();
        let path = assets.first().map_or(PathBuf::from("gen.xml"), |c| c.join("test_efficiency/gen.xml"));
        parse_str(&xml, &path, &ParseOptions { assets, ..ParseOptions::default() })
            .unwrap_or_else(|e| panic!("{} --depth {depth}: {e}", family.name()))
    }

    /// `--flat`: every family at depths 1 to 3 reads back as the instanced
    /// file's primitives, in order, with the same shapes, the same f64
    /// matrices bit for bit and the same materials (texture names and
    /// repeats; where they were found is not compared); no masters, one
    /// tree. Beyond MAX_FLAT_DEPTH, a clear error.
    #[test]
    fn flat_files_hold_the_expanded_primitives() {
        let texture = |m: &Material| m.texture.as_ref().map(|t| (t.file.clone(), t.repeat_u, t.repeat_v));
        for family in Family::ALL {
            for depth in 1..=3 {
                let options = GenOptions::default();
                let instanced = expand(
                    &parse_str(
                        &generate(family, depth, &options).unwrap(),
                        Path::new("i.xml"),
                        &ParseOptions::default(),
                    )
                    .unwrap(),
                );
                let flat_xml = generate_flat(family, depth, &options).unwrap();
                let flat_file = parse_str(&flat_xml, Path::new("f.xml"), &ParseOptions::default()).unwrap();
                assert_eq!(flat_file.trees.len(), 1, "{} {depth}: one tree", family.name());
                assert!(!flat_xml.contains("master"), "{} {depth}", family.name());
                let flat = expand(&flat_file);
                assert_eq!(flat.len() as u64, family.expanded_count(depth));
                assert_eq!(flat.len(), instanced.len());
                for (k, (a, b)) in flat.iter().zip(&instanced).enumerate() {
                    assert_eq!(a.0, b.0, "{} {depth}: primitive {k}'s shape", family.name());
                    let (ma, mb) = (a.1.to_cols_array().map(f64::to_bits), b.1.to_cols_array().map(f64::to_bits));
                    assert_eq!(ma, mb, "{} {depth}: primitive {k}'s matrix", family.name());
                    let strip = |m: &Material| Material { texture: None, bumpmap: None, ..m.clone() };
                    assert_eq!(strip(&a.2), strip(&b.2), "{} {depth}: primitive {k}'s material", family.name());
                    assert_eq!(texture(&a.2), texture(&b.2), "{} {depth}: primitive {k}'s texture", family.name());
                }
            }
        }
        let e = generate_flat(Family::RecursiveSpheres, MAX_FLAT_DEPTH + 1, &GenOptions::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("--flat goes to depth 8"), "{e}");
    }

    #[test]
    fn counts_follow_the_formula_at_every_depth() {
        // 1 + 6·(5^(d−1) − 1)/4: the corpus's 1, 7, 37, 187, and ~2.9 million at 10.
        let expect = [1u64, 7, 37, 187, 937, 4_687, 23_437, 117_187, 585_937, 2_929_687, 14_648_437, 73_242_187];
        for family in Family::ALL {
            for depth in MIN_DEPTH..=MAX_DEPTH {
                let file = parse_generated(family, depth, vec![]);
                let counts = count_primitives(&file);
                let rule = format!("{} --depth {depth}: counted over the file's trees", family.name());
                assert_eq!(counts.expanded, expect[depth as usize - 1], "{rule}: expanded");
                assert_eq!(counts.expanded, family.expanded_count(depth), "{rule}: expanded_count()");
                assert_eq!(counts.unique, family.unique_count(depth), "{rule}: unique");
            }
        }
    }

    #[test]
    fn the_count_agrees_with_a_full_expansion_at_small_depths() {
        for family in Family::ALL {
            for depth in 1..=5 {
                let file = parse_generated(family, depth, vec![]);
                assert_eq!(
                    expand(&file).len() as u64,
                    count_primitives(&file).expanded,
                    "{} --depth {depth}",
                    family.name()
                );
            }
        }
    }

    /// The mesh sphere: at least the triangles asked for and fewer than
    /// the next band would give; every vertex at radius 0.5 (within 3e-8,
    /// f32 rounding), its normal its direction; closed (every directed
    /// edge once, its reverse once: watertight, consistently wound); every
    /// face's normal (b − a) × (c − a) outward.
    #[test]
    fn mesh_spheres_are_closed_and_wound_outwards() {
        let dir = std::env::temp_dir().join(format!("raycast-gen-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for asked in [8u64, 100, 10_000] {
            let (obj, count) = mesh_sphere_obj(asked).unwrap();
            let s = u64::from(mesh_sphere_bands(asked));
            assert!(count >= asked && 4 * (s - 1) * (s - 2) < asked, "{asked}: {count}");
            let path = dir.join(format!("s{asked}.obj"));
            std::fs::write(&path, &obj).unwrap();
            let at = crate::scene::SourceLoc { file: std::sync::Arc::new(dir.join("s.xml")), line: 1, col: 1 };
            let mesh = crate::scene::mesh::load(&path, &at).unwrap();
            assert_eq!(mesh.triangles.len() as u64, count);
            assert!(mesh.smooth.iter().all(|&s| s));
            for (p, n) in mesh.positions.iter().zip(&mesh.normals) {
                let r = p.iter().map(|&c| f64::from(c) * f64::from(c)).sum::<f64>().sqrt();
                assert!((r - 0.5).abs() < 3e-8, "{asked}: radius {r}");
                assert!((0..3).all(|k| (f64::from(n[k]) - f64::from(p[k]) / r).abs() < 1e-6), "{p:?} {n:?}");
            }
            let mut edges = std::collections::HashMap::new();
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| glam::DVec3::from(mesh.positions[i as usize].map(f64::from)));
                assert!((b - a).cross(c - a).dot(a + b + c) > 0.0, "{asked}: a face turned inwards");
                for (u, v) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                    // tobj gives each position once here (v and vn share indices).
                    *edges.entry((u, v)).or_insert(0) += 1;
                }
            }
            for (&(u, v), &n) in &edges {
                assert_eq!((n, edges.get(&(v, u))), (1, Some(&1)), "{asked}: edge {u}-{v}");
            }
        }
        assert_eq!(mesh_sphere_obj(1_000_000).map(|(_, n)| n).ok(), Some(1_002_000));
        assert!(matches!(mesh_sphere_obj(7), Err(Error::Usage(_))));
        let xml = mesh_sphere_xml("s100.obj", 112);
        std::fs::write(dir.join("s.xml"), &xml).unwrap();
        let scene = crate::scene::load(&dir.join("s.xml"), &crate::scene::ParseOptions::default(), &Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(scene.meshes.len(), 1);
    }

    #[test]
    fn depth_out_of_range_is_a_clear_error() {
        for depth in [0, 13, 100] {
            let e = generate(Family::RecursiveSpheres, depth, &GenOptions::default()).unwrap_err().to_string();
            assert!(e.contains(&format!("--depth {depth} is out of range: 1 to 12")), "{e}");
        }
    }

    #[test]
    fn generated_scene_names() {
        assert_eq!(
            parse_scene_name("gen:recursive-spheres:6").map(Result::ok),
            Some(Some((Family::RecursiveSpheres, 6)))
        );
        assert_eq!(
            parse_scene_name("gen:recursive-cubes:12").map(Result::ok),
            Some(Some((Family::RecursiveCubes, 12)))
        );
        assert!(parse_scene_name("scenes/default.xml").is_none());
        for bad in [
            "gen:recursive-spheres:13",
            "gen:recursive-spheres:0",
            "gen:recursive-tori:4",
            "gen:recursive-cones",
            "gen:",
        ] {
            let e = parse_scene_name(bad).unwrap().unwrap_err().to_string();
            assert!(e.contains("gen:FAMILY:DEPTH"), "{bad}: {e}");
        }
    }

    #[test]
    fn untextured_and_other_textures() {
        let xml = generate(Family::RecursiveCones, 3, &GenOptions { texture: None }).unwrap();
        assert!(!xml.contains("<texture") && !xml.contains("<blend"));
        let xml = generate(Family::RecursiveCones, 2, &GenOptions { texture: Some("a&b.png".into()) }).unwrap();
        let file = parse_str(&xml, Path::new("gen.xml"), &ParseOptions::default()).unwrap();
        let (_, _, m) = &expand(&file)[0];
        assert_eq!(m.texture.as_ref().unwrap().file, "a&b.png");
    }

    /// recursive-spheres 1..4 are the corpus files: depth 4 byte for byte
    /// (the corpus file lacks the final newline), 1..3 once the aperture and
    /// focal length lines (depth 4 has them, 1..3 do not) are taken out.
    #[test]
    fn spheres_reproduce_the_corpus_text() {
        let Some(corpus) = corpus("gen recursive-spheres against the corpus text") else { return };
        for depth in 1..=4 {
            let ours = generate(Family::RecursiveSpheres, depth, &GenOptions::default()).unwrap();
            let path = corpus.join("test_efficiency").join(corpus_file(Family::RecursiveSpheres, depth));
            let theirs = std::fs::read_to_string(&path).unwrap();
            let ours = if depth == 4 {
                ours
            } else {
                ours.lines()
                    .filter(|l| !l.contains("<aperture") && !l.contains("<focallength"))
                    .collect::<Vec<_>>()
                    .join("\n")
            };
            let (a, b) = (ours.trim_end(), theirs.trim_end());
            if a != b {
                let line = a
                    .lines()
                    .zip(b.lines())
                    .position(|(x, y)| x != y)
                    .unwrap_or(a.lines().count().min(b.lines().count()));
                panic!(
                    "gen recursive-spheres --depth {depth} differs from {} (rule: identical text but the final newline) at line {}:\n  ours:   {:?}\n  corpus: {:?}",
                    path.display(),
                    line + 1,
                    a.lines().nth(line),
                    b.lines().nth(line)
                );
            }
        }
    }

    /// Every family at depths 1..4 parses and expands to the corpus's count;
    /// at the corpus's depths the expansion has the corpus's shapes and
    /// transforms (f64, bit for bit, in the same order) and, for the spheres,
    /// its materials. The cones' and cubes' corpus materials are random per
    /// primitive, so only their count, shapes and transforms are compared.
    #[test]
    fn families_match_the_corpus_construction() {
        let Some(corpus) = corpus("gen's families against the corpus construction") else { return };
        let assets = vec![corpus.clone()];
        for family in Family::ALL {
            for depth in 1..=4 {
                let ours = parse_generated(family, depth, assets.clone());
                assert!(ours.warnings.is_empty(), "{} --depth {depth}: {:?}", family.name(), ours.warnings);
                let counts = count_primitives(&ours);
                assert_eq!(counts.expanded, [1, 7, 37, 187][depth as usize - 1], "{} --depth {depth}", family.name());
                if family != Family::RecursiveSpheres && depth != 4 {
                    continue;
                }
                let path = corpus.join("test_efficiency").join(corpus_file(family, depth));
                let theirs =
                    scene::parse_file(&path, &ParseOptions { assets: assets.clone(), ..ParseOptions::default() })
                        .unwrap();
                assert_eq!(count_primitives(&theirs).expanded, counts.expanded, "{}", path.display());
                let (a, b) = (expand(&ours), expand(&theirs));
                for (i, ((sa, ma, mata), (sb, mb, matb))) in a.iter().zip(&b).enumerate() {
                    let what = format!("{} --depth {depth} against {}, primitive {i}", family.name(), path.display());
                    assert_eq!(sa, sb, "{what}: shape");
                    assert_eq!(
                        ma.to_cols_array(),
                        mb.to_cols_array(),
                        "{what}: world_from_object (rule: f64 bit for bit)"
                    );
                    if family == Family::RecursiveSpheres {
                        let key = |m: &Material| {
                            (
                                m.diffuse,
                                m.reflective,
                                m.specular,
                                m.shininess,
                                m.blend,
                                m.texture.as_ref().map(|t| t.resolved.clone()),
                            )
                        };
                        assert_eq!(key(mata), key(matb), "{what}: material");
                    }
                }
            }
        }
    }

    /// gen recursive-spheres --depth 4 renders the corpus's
    /// recursiveSpheres4.xml identically. Rule: bit-exact, every pixel's
    /// colour, t, hit id and normal; 128×96, shadows, reflections and
    /// textures on, on lavapipe.
    #[test]
    fn spheres_depth_4_renders_as_the_corpus_scene() {
        let Some(corpus) = corpus("gen recursive-spheres 4 rendered against the corpus scene") else { return };
        let opts = ParseOptions { assets: vec![corpus.clone()], ..ParseOptions::default() };
        let settings = RenderSettings { width: 128, height: 96, ..RenderSettings::default() };
        let limits = FlattenLimits::default();
        let ours =
            scene::flatten(&parse_generated(Family::RecursiveSpheres, 4, vec![corpus.clone()]), &limits).unwrap();
        let path = corpus.join("test_efficiency/recursiveSpheres4.xml");
        let theirs = scene::load(&path, &opts, &limits).unwrap();
        let renderer = GpuRenderer::new(&GpuOptions {
            device: Some(DeviceSelector::Name("llvmpipe".into())),
            validation: true,
            ..GpuOptions::default()
        })
        .unwrap_or_else(|e| panic!("{e}"));
        let (a, _) = renderer.render(&frame::build(&ours, &settings).unwrap()).unwrap();
        let (b, _) = renderer.render(&frame::build(&theirs, &settings).unwrap()).unwrap();
        let messages = renderer.context().take_validation_messages();
        assert!(messages.is_empty(), "validation: {messages:?}");
        let differing: Vec<usize> = (0..a.pixels.len())
            .filter(|&i| bytemuck::bytes_of(&a.pixels[i]) != bytemuck::bytes_of(&b.pixels[i]))
            .collect();
        if let Some(&first) = differing.first() {
            let out = std::env::temp_dir().join("raycast-gen-test");
            std::fs::create_dir_all(&out).unwrap();
            for (name, p) in [("generated", &a), ("corpus", &b)] {
                let image = p.rgb8().unwrap();
                crate::image_io::write_png(&out.join(format!("{name}.png")), &image).unwrap();
            }
            panic!(
                "{} of {} pixels differ (rule: bit-exact); first at ({}, {}): generated {:?}, corpus {:?}; pictures in {}",
                differing.len(),
                a.pixels.len(),
                first % 128,
                first / 128,
                a.pixels[first],
                b.pixels[first],
                out.display()
            );
        }
    }
}
