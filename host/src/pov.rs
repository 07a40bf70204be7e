//! `raycast pov`: a scene written in POV-Ray 3.7's scene description
//! language, so that raycast can be timed beside POV-Ray on one machine in
//! one run (the peer issue 7 names, whose own numbers came from another
//! machine) and a scene can be looked at in a second renderer.
//!
//! The geometry is the scene's exactly: the four canonical shapes at their
//! canonical sizes, each transblock's matrix as written (POV-Ray's `matrix`
//! takes the same affine map), and every master a `#declare`d object placed
//! by `object { … matrix … }`, so the file stays as small as the XML while
//! POV-Ray expands every instance as it parses (as the issue's numbers
//! were measured). The camera is the format's: the same eye, direction and
//! film size, one ray through each pixel's centre. Lights and materials are
//! carried over as near as POV-Ray's model allows, and what differs is
//! listed in the file's head (`Export::notes`): POV-Ray has no
//! `1/(c1 + c2·d + c3·d²)` attenuation, a highlight in the light's colour,
//! its own texture projections, and no clamping between mirror bounces, so
//! the colours are alike, not the same, and the pictures are not compared
//! for colour anywhere. Shadows, mirror depth and picture size follow the
//! render's settings, so both renderers trace the same kinds of rays.

use crate::frame::RenderSettings;
use crate::scene::mesh::Mesh;
use crate::scene::{Camera, Globals, Light, LightKind, Material, Node, SceneFile, Shape, SourceLoc, TransBlock};
use glam::{DMat4, DVec3};
use std::fmt::Write as _;

/// A scene in POV-Ray's language, and what it could not carry over.
pub struct Export {
    pub sdl: String,
    /// One line each: what the POV-Ray scene draws otherwise than raycast
    /// (also written as comments at the head of `sdl`).
    pub notes: Vec<String>,
}

/// The command line that renders an exported scene as raycast renders it:
/// the picture's size, no anti-aliasing (one ray through each pixel's
/// centre), `threads` render threads, no display window.
pub fn povray_command(pov: &str, png: &str, settings: &RenderSettings, threads: usize) -> String {
    format!("povray +I{pov} +O{png} +W{} +H{} -A +WT{threads} -D File_Gamma=1.0", settings.width, settings.height)
}

/// `file` (its tree from the root, masters as declared objects) in POV-Ray
/// 3.7's language, for a picture rendered with `settings` (size, shadows,
/// mirror depth, textures). `source` names the scene in the file's head.
pub fn export(file: &SceneFile, settings: &RenderSettings, source: &str) -> Export {
    let mut w = Writer {
        globals: file.globals,
        settings,
        notes: Vec::new(),
        declared: Vec::new(),
        meshes: Vec::new(),
        mesh_decls: String::new(),
        refracts: false,
    };
    let mut body = String::new();
    // Every tree the root reaches, each after the masters it places (the
    // format declares a master before its use, so there are no cycles).
    let mut order = Vec::new();
    let mut seen = vec![false; file.trees.len()];
    reached(file, file.root, &mut seen, &mut order);
    w.declared = vec![false; file.trees.len()];
    for &t in &order {
        if t == file.root {
            continue;
        }
        if let Some(object) = w.tree(&file.trees[t].blocks) {
            let _ = writeln!(body, "// <object type=\"tree\" name=\"{}\">", file.trees[t].name.replace('\n', " "));
            let _ = writeln!(body, "#declare {} = {object}\n", tree_name(t));
            w.declared[t] = true;
        }
    }
    let root = w.tree(&file.trees[file.root].blocks);
    match root {
        Some(object) => {
            let _ = writeln!(body, "{object}");
        }
        None => w.notes.push("the root tree draws nothing POV-Ray can draw".into()),
    }
    // The lights before the head, whose notes it lists.
    let lights: String = file.lights.iter().map(|l| w.light(l)).collect();
    let counts = crate::gen::count_primitives(file);
    if counts.expanded > POV_EXPANSION_NOTED {
        w.note(format!(
            "POV-Ray expands every instance as it parses: {} primitives, about {:.1} GiB of its memory (it took \
             {POV_BYTES_A_PRIMITIVE} bytes a sphere at depth 8 of the recursive spheres, BENCHMARKS.md)",
            crate::units::thousands(counts.expanded),
            counts.expanded as f64 * POV_BYTES_A_PRIMITIVE as f64 / f64::from(1u32 << 30)
        ));
    }
    let mut head = String::new();
    let _ =
        writeln!(head, "// {}, written by `raycast pov` in POV-Ray 3.7's scene language.", source.replace('\n', " "));
    let _ = writeln!(
        head,
        "// {} primitives when every instance is expanded, {} written in the file.",
        crate::units::thousands(counts.expanded),
        crate::units::thousands(counts.unique)
    );
    let _ = writeln!(
        head,
        "// Render it as raycast renders the scene ({}x{}, one ray a pixel):",
        settings.width, settings.height
    );
    let _ = writeln!(head, "//   {}", povray_command("FILE.pov", "FILE.png", settings, 2));
    if !w.notes.is_empty() {
        let _ = writeln!(head, "// Drawn otherwise than by raycast:");
        for n in &w.notes {
            let _ = writeln!(head, "//   - {n}");
        }
    }
    let _ = writeln!(head, "\n#version 3.7;");
    // POV-Ray counts the camera ray as the first level; raycast's depth
    // counts the bounces after it.
    let trace_level = if settings.reflections || w.refracts { settings.max_depth + 1 } else { 1 };
    let _ = writeln!(
        head,
        "global_settings {{ assumed_gamma 1.0 ambient_light rgb 1 max_trace_level {} }}",
        trace_level.max(1)
    );
    let _ = writeln!(head, "background {{ rgb 0 }}");
    head.push_str(&camera(&file.camera, settings));
    head.push_str(&lights);
    head.push('\n');
    Export { sdl: head + &w.mesh_decls + &body, notes: w.notes }
}

/// Past this many expanded primitives the notes say what POV-Ray's
/// expansion will take.
const POV_EXPANSION_NOTED: u64 = 1_000_000;
/// POV-Ray's memory a primitive: 266 MiB for the 117,187 spheres of
/// `gen:recursive-spheres:8` (`ci/benchmarks.sh povray`, 2026-11-28).
const POV_BYTES_A_PRIMITIVE: u64 = 2_400;

/// The trees reached from `t` through master references, each after those it places.
fn reached(file: &SceneFile, t: usize, seen: &mut [bool], order: &mut Vec<usize>) {
    if std::mem::replace(&mut seen[t], true) {
        return;
    }
    fn masters(blocks: &[TransBlock], out: &mut Vec<usize>) {
        for b in blocks {
            match &b.object {
                Node::Master { tree, .. } => out.push(*tree),
                Node::Tree { blocks, .. } => masters(blocks, out),
                Node::Primitive { .. } => {}
            }
        }
    }
    let mut placed = Vec::new();
    masters(&file.trees[t].blocks, &mut placed);
    for m in placed {
        if m < seen.len() {
            reached(file, m, seen, order);
        }
    }
    order.push(t);
}

fn tree_name(t: usize) -> String {
    format!("Raycast_tree_{t}")
}

/// A number as POV-Ray reads it: the shortest decimal that reads back as
/// the same double (never `inf` or `NaN`: the parser refuses those).
fn num(x: f64) -> String {
    format!("{}", x + 0.0)
}

fn vector(v: DVec3) -> String {
    format!("<{}, {}, {}>", num(v.x), num(v.y), num(v.z))
}

/// An f32 of the scene (a colour, a coefficient) in its own shortest digits.
fn num32(x: f32) -> String {
    format!("{}", x + 0.0)
}

fn rgb(c: [f32; 3]) -> String {
    format!("rgb <{}, {}, {}>", num32(c[0]), num32(c[1]), num32(c[2]))
}

/// POV-Ray's `matrix`: the affine map's columns in turn (it multiplies a
/// row vector on the left; glam's columns are those rows).
fn matrix(m: &DMat4) -> String {
    let cols = [m.x_axis, m.y_axis, m.z_axis, m.w_axis];
    let entries: Vec<String> = cols.iter().flat_map(|c| [c.x, c.y, c.z]).map(num).collect();
    format!("matrix <{}>", entries.join(", "))
}

/// The renderer's camera (`frame::world_from_film`: the film at distance 1
/// along -w spans ±tan of half each angle along u and v) in POV-Ray's terms,
/// which shoots each pixel's ray through direction + x·right + y·up, x and
/// y from -½ to ½.
fn camera(c: &Camera, s: &RenderSettings) -> String {
    let m = crate::frame::world_from_film(c, s.width, s.height);
    // The thin lens (docs/scene-format.md#depth-of-field): POV-Ray's
    // aperture is the lens's diameter, its focal point a point in focus,
    // its blur samples the rays a pixel (raycast's --spp). At one sample
    // raycast's lens point is the lens's centre, the pinhole picture, and
    // so is POV-Ray's without focal blur.
    let lens = match crate::frame::lens(c).filter(|_| s.dof && s.spp > 1) {
        Some((radius, focal)) => format!(
            "  aperture {}\n  focal_point {}\n  blur_samples {}\n",
            num32(2.0 * radius),
            vector(c.pos + f64::from(focal) * c.look.normalize()),
            s.spp
        ),
        None => String::new(),
    };
    format!(
        "camera {{\n  perspective\n  location {}\n  direction {}\n  right {}\n  up {}\n{lens}}}\n",
        vector(m.w_axis.truncate()),
        vector(-m.z_axis.truncate()),
        vector(2.0 * m.x_axis.truncate()),
        vector(2.0 * m.y_axis.truncate())
    )
}

struct Writer<'a> {
    globals: Globals,
    settings: &'a RenderSettings,
    notes: Vec<String>,
    /// Which trees have been declared (a tree that draws nothing is not).
    declared: Vec<bool>,
    /// Each mesh file met (as the parser found it), declared once as a
    /// `mesh2` in `mesh_decls`: its number, None where it cannot be read.
    meshes: Vec<(std::path::PathBuf, Option<usize>)>,
    mesh_decls: String,
    /// Whether a transparent material was written (refracted rays need trace levels).
    refracts: bool,
}

/// A mesh's triangles as POV-Ray's `mesh2`: its vertices, its normals
/// where the file gives them (a flat triangle of a file with normals gets
/// its face's normal, (b − a) × (c − a), as raycast draws it), its texture
/// coordinates where the file gives them (POV-Ray's v runs up as OBJ's
/// does), its faces.
pub fn mesh2(mesh: &Mesh) -> String {
    let v3 = |p: [f32; 3]| format!("<{}, {}, {}>", num32(p[0]), num32(p[1]), num32(p[2]));
    let list =
        |name: &str, items: Vec<String>| format!("  {name} {{ {},\n    {}\n  }}\n", items.len(), items.join(",\n    "));
    let mut out = String::from("mesh2 {\n");
    out += &list("vertex_vectors", mesh.positions.iter().map(|&p| v3(p)).collect());
    let faces = || mesh.triangles.iter().map(|t| format!("<{}, {}, {}>", t[0], t[1], t[2]));
    if !mesh.normals.is_empty() {
        let mut normals: Vec<String> = mesh.normals.iter().map(|&n| v3(n)).collect();
        let mut indices = Vec::new();
        for (t, &smooth) in mesh.triangles.iter().zip(&mesh.smooth) {
            if smooth {
                indices.push(format!("<{}, {}, {}>", t[0], t[1], t[2]));
            } else {
                let [a, b, c] = t.map(|i| glam::Vec3::from(mesh.positions[i as usize]));
                let k = normals.len();
                normals.push(v3((b - a).cross(c - a).to_array()));
                indices.push(format!("<{k}, {k}, {k}>"));
            }
        }
        out += &list("normal_vectors", normals);
        if !mesh.uvs.is_empty() {
            out += &list(
                "uv_vectors",
                mesh.uvs.iter().map(|uv| format!("<{}, {}>", num32(uv[0]), num32(uv[1]))).collect(),
            );
        }
        out += &list("face_indices", faces().collect());
        if mesh.smooth.iter().any(|&s| !s) {
            out += &list("normal_indices", indices);
        }
    } else {
        if !mesh.uvs.is_empty() {
            out += &list(
                "uv_vectors",
                mesh.uvs.iter().map(|uv| format!("<{}, {}>", num32(uv[0]), num32(uv[1]))).collect(),
            );
        }
        out += &list("face_indices", faces().collect());
    }
    out.push('}');
    out
}

impl Writer<'_> {
    fn note(&mut self, note: String) {
        if !self.notes.contains(&note) {
            self.notes.push(note);
        }
    }

    /// A tree's blocks as one object (a union of two or more), None when
    /// none of them draws anything.
    fn tree(&mut self, blocks: &[TransBlock]) -> Option<String> {
        let objects: Vec<String> = blocks.iter().filter_map(|b| self.block(b)).collect();
        match objects.len() {
            0 => None,
            1 => objects.into_iter().next(),
            _ => Some(format!("union {{\n{}\n}}", objects.join("\n"))),
        }
    }

    fn block(&mut self, b: &TransBlock) -> Option<String> {
        let placed = |object: String| {
            if b.matrix == DMat4::IDENTITY {
                object
            } else {
                format!("object {{ {object} {} }}", matrix(&b.matrix))
            }
        };
        match &b.object {
            Node::Primitive { shape, material, loc } => {
                // A canonical shape's object is its entry's (`scene::SHAPES`).
                let geometry = match (shape.kind(), shape) {
                    (Some(kind), _) => kind.pov.to_string(),
                    (None, Shape::Mesh { file, resolved }) => match self.mesh(file, resolved.as_deref(), loc) {
                        Some(k) => format!("object {{ Raycast_mesh_{k}"),
                        None => return None,
                    },
                    (None, _) => return None,
                };
                let texture = self.texture(shape, material);
                let transform =
                    if b.matrix == DMat4::IDENTITY { String::new() } else { format!(" {}", matrix(&b.matrix)) };
                Some(format!("{geometry} {texture}{transform} }}"))
            }
            Node::Tree { blocks, .. } => self.tree(blocks).map(placed),
            Node::Master { tree, .. } => {
                let declared = self.declared.get(*tree).copied().unwrap_or(false);
                declared.then(|| placed(tree_name(*tree)))
            }
        }
    }

    /// The number of the `mesh2` declared for a mesh file, declaring it the
    /// first time; None (with a note) where it cannot be read.
    fn mesh(&mut self, file: &str, resolved: Option<&std::path::Path>, loc: &SourceLoc) -> Option<usize> {
        let Some(path) = resolved else {
            self.note(format!("a mesh whose file ({file}) was not found is left out (at {loc})"));
            return None;
        };
        if let Some((_, k)) = self.meshes.iter().find(|(p, _)| p == path) {
            return *k;
        }
        let k = match crate::scene::mesh::load(path, loc) {
            Ok(mesh) => {
                let k = self.meshes.iter().filter(|(_, k)| k.is_some()).count();
                let _ = writeln!(
                    self.mesh_decls,
                    "// {} ({} triangles)\n#declare Raycast_mesh_{k} = {}\n",
                    file.replace('\n', " "),
                    mesh.triangles.len(),
                    mesh2(&mesh)
                );
                Some(k)
            }
            Err(e) => {
                self.note(format!("a mesh that cannot be read is left out ({e})"));
                None
            }
        };
        self.meshes.push((path.to_path_buf(), k));
        k
    }

    /// The course's `k_a·O_a + emissive + Σ I·(D·N·L + k_s·O_s·(R·V)^n)` and
    /// `k_s·O_r` mirror as POV-Ray's finish: the pigment is D = k_d·O_d, so
    /// the ambient (multiplied by the pigment there) is divided by it; the
    /// highlight is `phong` in the light's colour.
    fn texture(&mut self, shape: &Shape, m: &Material) -> String {
        let g = self.globals;
        let d = m.diffuse.map(|c| g.kd * c);
        let a: [f32; 3] = std::array::from_fn(|i| g.ka * m.ambient[i] + m.emissive[i]);
        let textured = m.texture.is_some() && self.settings.textures && m.blend > 0.0;
        // The pigment's plain colour and the finish's first terms.
        let (base, mut finish) = if d == [0.0; 3] && !textured {
            // No diffuse term at all: the pigment is the ambient colour, drawn as it is.
            (a, "ambient 1 diffuse 0".to_string())
        } else {
            let ambient: [f32; 3] = std::array::from_fn(|i| {
                if d[i] > 0.0 {
                    a[i] / d[i]
                } else {
                    if a[i] > 0.0 {
                        self.note("an ambient or emissive channel where the diffuse colour's is 0 is left out (POV-Ray's ambient scales the pigment)".into());
                    }
                    0.0
                }
            });
            (d, format!("ambient {} diffuse 1", rgb(ambient)))
        };
        let specular = m.specular.iter().fold(0.0f32, |a, &b| a.max(b)) * g.ks;
        if m.shininess > 0.0 && specular > 0.0 {
            if m.specular[0] != m.specular[1] || m.specular[1] != m.specular[2] {
                self.note("a coloured specular colour is drawn in the light's colour at its largest channel".into());
            }
            let _ = write!(finish, " phong {} phong_size {}", num32(specular), num32(m.shininess));
        }
        let mirror = m.reflective.map(|c| g.ks * c);
        if self.settings.reflections && mirror.iter().any(|&c| c > 0.0) {
            let _ = write!(finish, " reflection {{ {} }}", rgb(mirror));
        }
        // Refraction: k_t O_t as POV-Ray's transmit, one number (their
        // mean), and the index of refraction as the object's interior.
        let transmit = m.transparent.map(|c| g.kt * c);
        let see_through = if self.settings.refraction && transmit.iter().any(|&c| c > 0.0) {
            self.refracts = true;
            self.note("transparency is POV-Ray's: transmit (the mean of k_t O_t) through the pigment, filtered shadows, no colour of its own left out".into());
            (transmit[0] + transmit[1] + transmit[2]) / 3.0
        } else {
            0.0
        };
        let color = |c: [f32; 3]| {
            if see_through > 0.0 {
                format!("rgbt <{}, {}, {}, {}>", num32(c[0]), num32(c[1]), num32(c[2]), num32(see_through))
            } else {
                rgb(c)
            }
        };
        let pigment = match (&m.texture, textured) {
            (Some(t), true) => match (&t.resolved, image_kind(&t.file)) {
                (Some(path), Some(kind)) => {
                    self.note("textures are projected by POV-Ray's image maps (spherical, cylindrical or planar), near the format's u, v but not the same".into());
                    // A mesh: its own texture coordinates (uv_vectors).
                    let (map_type, place) = shape.kind().map_or((0, ""), |k| k.pov_map);
                    let repeat = format!(
                        " scale <{}, {}, 1>",
                        num32(1.0 / t.repeat_u.max(1e-6)),
                        num32(1.0 / t.repeat_v.max(1e-6))
                    );
                    let transmit_all =
                        if see_through > 0.0 { format!(" transmit all {}", num32(see_through)) } else { String::new() };
                    format!(
                        "pigment {{ average pigment_map {{ [{} color {}] [{} {}image_map {{ {kind} \"{}\" gamma 1.0 map_type {map_type}{transmit_all} }}{repeat}{place}] }} }}",
                        num32(1.0 - m.blend),
                        color(d),
                        num32(m.blend),
                        if matches!(shape, Shape::Mesh { .. }) { "uv_mapping " } else { "" },
                        // Absolute: POV-Ray resolves a file against its own working folder.
                        pov_string(&std::path::absolute(path).unwrap_or_else(|_| path.clone()).to_string_lossy())
                    )
                }
                _ => {
                    self.note(format!("a texture POV-Ray cannot read or that was not found ({}) is left out", t.file));
                    format!("pigment {{ color {} }}", color(d))
                }
            },
            _ => format!("pigment {{ color {} }}", color(base)),
        };
        let interior = if see_through > 0.0 { format!(" interior {{ ior {} }}", num32(m.ior)) } else { String::new() };
        format!("texture {{ {pigment} finish {{ {finish} }} }}{interior}")
    }

    fn light(&mut self, l: &Light) -> String {
        let mut color = l.color;
        let [c1, c2, c3] = l.attenuation;
        if l.kind != LightKind::Directional && (c2 != 0.0 || c3 != 0.0) {
            self.note(format!(
                "light {} ({}): POV-Ray has no 1/(c1 + c2·d + c3·d²) attenuation; its light is unattenuated",
                l.id, l.loc
            ));
        } else if l.kind != LightKind::Directional && c1 > 1.0 {
            color = color.map(|c| c / c1);
        }
        let shadowless = if self.settings.shadows { "" } else { " shadowless" };
        match l.kind {
            LightKind::Directional => {
                // A parallel light from far along -direction (POV-Ray needs
                // a place for it; its shadows are cast by what lies before it).
                let from = -l.direction.normalize() * 1e6;
                format!(
                    "light_source {{ {} color {} parallel point_at <0, 0, 0>{shadowless} }}\n",
                    vector(from),
                    rgb(color)
                )
            }
            LightKind::Spot => format!(
                "light_source {{ {} color {} spotlight point_at {} radius {} falloff {} tightness 0{shadowless} }}\n",
                vector(l.position),
                rgb(color),
                vector(l.position + l.direction),
                num32((l.angle_deg - l.penumbra_deg).max(0.0)),
                num32(l.angle_deg)
            ),
            LightKind::Point => format!("light_source {{ {} color {}{shadowless} }}\n", vector(l.position), rgb(color)),
            LightKind::Area => {
                // The rectangle's edges (frame::area_edges) and a square
                // grid of about --light-samples lights over it.
                let (e_u, e_v) = crate::frame::area_edges(l.direction.normalize());
                let n = f64::from(self.settings.light_samples).sqrt().ceil();
                format!(
                    "light_source {{ {} color {} area_light {}, {}, {n}, {n}{shadowless} }}\n",
                    vector(l.position),
                    rgb(color),
                    vector(e_u * f64::from(l.width)),
                    vector(e_v * f64::from(l.height))
                )
            }
        }
    }
}

/// POV-Ray's image type keyword for a texture file, by its name.
fn image_kind(file: &str) -> Option<&'static str> {
    let ext = std::path::Path::new(file).extension()?.to_str()?.to_ascii_lowercase();
    match ext.as_str() {
        "png" => Some("png"),
        "jpg" | "jpeg" => Some("jpeg"),
        "ppm" | "pnm" => Some("ppm"),
        "pgm" => Some("pgm"),
        "bmp" => Some("bmp"),
        _ => None,
    }
}

/// A string literal's contents: backslashes and quotes escaped.
fn pov_string(s: &str) -> String {
    s.replace('\\', "\\\\").replace('"', "\\\"")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{parse_str, ParseOptions};
    use std::path::Path;

    fn exported(xml: &str) -> Export {
        let file = parse_str(xml, Path::new("t.xml"), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        export(&file, &RenderSettings::default(), "t.xml")
    }

    #[test]
    fn masters_are_declared_before_use_and_placed_by_their_matrix() {
        let e = exported(
            r#"<scenefile>
              <object type="tree" name="leaf"><transblock><object type="primitive" name="cube"/></transblock></object>
              <object type="tree" name="pair">
                <transblock><object type="master" name="leaf"/></transblock>
                <transblock><translate x="1" y="2" z="3"/><object type="master" name="leaf"/></transblock>
              </object>
              <object type="tree" name="unused"><transblock><object type="primitive" name="sphere"/></transblock></object>
              <object type="tree" name="root"><transblock><scale x="2" y="2" z="2"/><object type="master" name="pair"/></transblock></object>
            </scenefile>"#,
        );
        let (leaf, pair) =
            (e.sdl.find("#declare Raycast_tree_0 =").unwrap(), e.sdl.find("#declare Raycast_tree_1 =").unwrap());
        assert!(leaf < pair && e.sdl.find("object { Raycast_tree_0").unwrap() > leaf, "{}", e.sdl);
        // A tree the root does not reach is not written.
        assert!(!e.sdl.contains("Raycast_tree_2") && !e.sdl.contains("sphere {"), "{}", e.sdl);
        // POV-Ray's matrix: the columns in turn, the translation last.
        assert!(e.sdl.contains("object { Raycast_tree_0 matrix <1, 0, 0, 0, 1, 0, 0, 0, 1, 1, 2, 3> }"), "{}", e.sdl);
        assert!(e.sdl.contains("object { Raycast_tree_1 matrix <2, 0, 0, 0, 2, 0, 0, 0, 2, 0, 0, 0> }"), "{}", e.sdl);
        assert!(e.notes.is_empty(), "{:?}", e.notes);
    }

    /// A mesh is one `mesh2`, declared once however many primitives draw
    /// it: its vertices, faces, texture coordinates, and normals where the
    /// file gives them (the flat quad's two triangles get their face's
    /// normal, (b − a) × (c − a) = (0, 0, 1), through normal_indices; the
    /// smooth triangle its corners').
    #[test]
    fn a_mesh_is_one_declared_mesh2() {
        let dir = std::env::temp_dir().join(format!("raycast-pov-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let obj = "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\no smooth\nv 0 0 1\nv 1 0 1\nv 0 1 1\n\
                   vn 0 0.6 0.8\nvt 0.25 0.75\nf 5/1/1 6/1/1 7/1/1\n";
        std::fs::write(dir.join("m.obj"), obj).unwrap();
        let xml = r#"<scenefile><object type="tree" name="root">
              <transblock><object type="primitive" name="mesh" meshfile="m.obj"/></transblock>
              <transblock><translate x="2" y="0" z="0"/><object type="primitive" name="mesh" meshfile="m.obj"/></transblock>
            </object></scenefile>"#;
        let file = parse_str(xml, &dir.join("t.xml"), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let e = export(&file, &RenderSettings::default(), "t.xml");
        let sdl = &e.sdl;
        assert_eq!(sdl.matches("= mesh2 {").count(), 1, "{sdl}");
        assert_eq!(sdl.matches("object { Raycast_mesh_0 texture {").count(), 2, "{sdl}");
        assert!(sdl.find("#declare Raycast_mesh_0").unwrap() < sdl.find("object { Raycast_mesh_0").unwrap());
        assert!(sdl.contains("matrix <1, 0, 0, 0, 1, 0, 0, 0, 1, 2, 0, 0> }"), "{sdl}");
        let mesh = crate::scene::mesh::load(
            &dir.join("m.obj"),
            &SourceLoc { file: std::sync::Arc::new(dir.join("t.xml")), line: 1, col: 1 },
        )
        .unwrap();
        let m = mesh2(&mesh);
        for want in [
            "vertex_vectors { 7,\n    <0, 0, 0>,",
            "normal_vectors { 9,",
            "<0, 0.6, 0.8>,\n    <0, 0, 1>,\n    <0, 0, 1>\n  }",
            "uv_vectors { 7,",
            "<0.25, 0.75>",
            "face_indices { 3,\n    <0, 1, 2>,\n    <0, 2, 3>,\n    <4, 5, 6>\n  }",
            "normal_indices { 3,\n    <7, 7, 7>,\n    <8, 8, 8>,\n    <4, 5, 6>\n  }",
        ] {
            assert!(m.contains(want), "{want:?} not in\n{m}");
        }
        // Without normals in the file: no normal_vectors (POV-Ray draws flat triangles).
        std::fs::write(dir.join("flat.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let loc = SourceLoc { file: std::sync::Arc::new(dir.join("t.xml")), line: 1, col: 1 };
        let m = mesh2(&crate::scene::mesh::load(&dir.join("flat.obj"), &loc).unwrap());
        assert!(!m.contains("normal") && !m.contains("uv_vectors") && m.contains("face_indices { 1,"), "{m}");
    }

    /// POV-Ray's torus lies about y as raycast's does: ring radius, then tube radius, placed by the matrix.
    #[test]
    fn a_torus_is_povrays_torus() {
        let e = exported(
            r#"<scenefile><object type="tree" name="root"><transblock><scale x="2" y="1" z="2"/>
              <object type="primitive" name="torus"/></transblock></object></scenefile>"#,
        );
        assert!(e.sdl.contains("torus { 0.375, 0.125 texture {"), "{}", e.sdl);
        assert!(e.sdl.contains("matrix <2, 0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0> }"), "{}", e.sdl);
        assert!(e.notes.is_empty(), "{:?}", e.notes);
    }

    #[test]
    fn materials_as_povray_finishes() {
        let e = exported(
            r#"<scenefile>
              <globaldata><ambientcoeff v="0.5"/><diffusecoeff v="0.5"/><specularcoeff v="0.5"/></globaldata>
              <object type="tree" name="root">
                <transblock><object type="primitive" name="sphere">
                  <diffuse r="0" g="0" b="0"/><ambient r="1" g="0.5" b="0"/><reflective r="1" g="1" b="1"/>
                </object></transblock>
                <transblock><object type="primitive" name="cube">
                  <diffuse r="1" g="0.5" b="0"/><ambient r="0.5" g="0.5" b="0.5"/><specular r="1" g="1" b="1"/><shininess v="20"/>
                </object></transblock>
              </object>
            </scenefile>"#,
        );
        // No diffuse term: the ambient colour is the pigment, drawn as it is; the mirror is k_s·O_r.
        assert!(
            e.sdl.contains("pigment { color rgb <0.5, 0.25, 0> } finish { ambient 1 diffuse 0 reflection { rgb <0.5, 0.5, 0.5> } }"),
            "{}",
            e.sdl
        );
        // Else the pigment is k_d·O_d and the ambient divided by it; a channel without diffuse loses its ambient, said.
        assert!(
            e.sdl.contains("pigment { color rgb <0.5, 0.25, 0> } finish { ambient rgb <0.5, 1, 0> diffuse 1 phong 0.5 phong_size 20 }"),
            "{}",
            e.sdl
        );
        assert_eq!(e.notes.len(), 1, "{:?}", e.notes);
        assert!(e.notes[0].starts_with("an ambient or emissive channel"), "{:?}", e.notes);
    }

    /// A transparent material: k_t O_t's mean as the pigment's transmit, its
    /// ior as the interior, and trace levels for the refracted rays even
    /// without mirrors; opaque (and said nothing of) under --no-refraction.
    #[test]
    fn transparency_as_transmit_and_interior() {
        let xml = r#"<scenefile>
              <globaldata><diffusecoeff v="1"/><transparentcoeff v="0.5"/></globaldata>
              <object type="tree" name="root">
                <transblock><object type="primitive" name="sphere">
                  <diffuse r="0.2" g="0.4" b="0.6"/><transparent r="0.8" g="0.6" b="0.4"/><ior v="1.5"/>
                </object></transblock>
              </object>
            </scenefile>"#;
        let file = parse_str(xml, Path::new("t.xml"), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
        let settings = RenderSettings { reflections: false, ..RenderSettings::default() };
        let e = export(&file, &settings, "t.xml");
        assert!(e.sdl.contains("pigment { color rgbt <0.2, 0.4, 0.6, 0.3> } finish { ambient rgb <0, 0, 0> diffuse 1 } } interior { ior 1.5 }"), "{}", e.sdl);
        assert!(e.sdl.contains("max_trace_level 5"), "{}", e.sdl);
        assert!(e.notes.iter().any(|n| n.starts_with("transparency is POV-Ray's")), "{:?}", e.notes);
        let opaque = RenderSettings { refraction: false, ..settings };
        let e = export(&file, &opaque, "t.xml");
        assert!(
            e.sdl.contains("pigment { color rgb <0.2, 0.4, 0.6> } finish { ambient rgb <0, 0, 0> diffuse 1 } }"),
            "{}",
            e.sdl
        );
        assert!(!e.sdl.contains("interior") && e.sdl.contains("max_trace_level 1"), "{}", e.sdl);
        assert!(e.notes.is_empty(), "{:?}", e.notes);
    }
}
