//! The parser's tests: the helpers every file of tests/ shares, and the
//! document as a whole; tests/ holds one file for each file of the parser.

mod assets;
mod camera;
mod light;
mod names;
mod primitive;
mod tree;
mod values;
mod xml;

use super::*;
use glam::{DMat4, DVec3};
use std::path::PathBuf;

fn opts() -> ParseOptions {
    ParseOptions::default()
}

fn p(xml: &str) -> Result<SceneFile, SceneError> {
    parse_str(xml, Path::new("/nonexistent-dir/test.xml"), &opts())
}

fn ok(xml: &str) -> SceneFile {
    match p(xml) {
        Ok(f) => f,
        Err(e) => panic!("unexpected error: {e}\n{xml}"),
    }
}

fn bad(xml: &str) -> SceneError {
    match p(xml) {
        Ok(_) => panic!("expected an error:\n{xml}"),
        Err(e) => e,
    }
}

/// `line:col` of an error.
fn at(e: &SceneError) -> (u32, u32) {
    let l = e.loc.as_ref().expect("error has a location");
    (l.line, l.col)
}

/// 1-based line and column (in characters) of the only occurrence of
/// `needle` in `text`, counted independently of the parser.
fn pos_of(text: &str, needle: &str) -> (u32, u32) {
    assert_eq!(text.matches(needle).count(), 1, "{needle:?} must occur once");
    let i = text.find(needle).unwrap();
    let before = &text[..i];
    let line = before.matches('\n').count() + 1;
    let col = before.rsplit('\n').next().unwrap().chars().count() + 1;
    (line as u32, col as u32)
}

/// An error at the only occurrence of `needle` whose message contains `msg`.
fn bad_at_str(xml: &str, needle: &str, msg: &str) -> SceneError {
    let (l, c) = pos_of(xml, needle);
    bad_at(xml, l, c, msg)
}

fn wat(w: &Warning) -> (u32, u32) {
    (w.loc.line, w.loc.col)
}

/// An error at `line:col` whose message contains `msg`.
fn bad_at(xml: &str, line: u32, col: u32, msg: &str) -> SceneError {
    let e = bad(xml);
    assert_eq!(at(&e), (line, col), "wrong position for: {e}");
    assert!(e.message.contains(msg), "message {:?} lacks {msg:?}", e.message);
    e
}

/// The only warning containing `msg`, at `line:col`.
fn warned_at(f: &SceneFile, line: u32, col: u32, msg: &str) {
    let ws: Vec<&Warning> = f.warnings.iter().filter(|w| w.message.contains(msg)).collect();
    assert_eq!(ws.len(), 1, "warnings with {msg:?}: {:?}", f.warnings);
    assert_eq!(wat(ws[0]), (line, col), "{}", ws[0]);
}

/// A scene whose root tree holds `body` (transblocks); line 1 is
/// `<scenefile>`, line 2 the root tree, `body` starts on line 3.
fn root(body: &str) -> String {
    format!("<scenefile>\n<object type=\"tree\" name=\"root\">\n{body}\n</object>\n</scenefile>\n")
}

/// A root tree with one transblock holding `inner` (line 4 onwards).
fn block(inner: &str) -> String {
    root(&format!("<transblock>\n{inner}\n</transblock>"))
}

fn prim(name: &str, material: &str) -> String {
    block(&format!("<object type=\"primitive\" name=\"{name}\">\n{material}\n</object>"))
}

fn first_prim(f: &SceneFile) -> (&Shape, &Material) {
    match &f.trees[f.root].blocks[0].object {
        Node::Primitive { shape, material, .. } => (shape, material),
        other => panic!("not a primitive: {other:?}"),
    }
}

/// A scenefile with `top` before the root tree.
fn with_top(top: &str) -> String {
    format!(
        "<scenefile>\n{top}\n<object type=\"tree\" name=\"root\"><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object>\n</scenefile>"
    )
}

fn camera(inner: &str) -> Result<SceneFile, SceneError> {
    p(&with_top(&format!("<cameradata>\n{inner}\n</cameradata>")))
}

fn light(inner: &str) -> Result<SceneFile, SceneError> {
    p(&with_top(&format!("<lightdata>\n{inner}\n</lightdata>")))
}

#[test]
fn minimal_scene_has_all_defaults() {
    let f = ok(&prim("cube", ""));
    assert_eq!(f.globals, Globals { ka: 0.5, kd: 0.5, ks: 0.5, kt: 0.0 });
    assert_eq!(f.camera, Camera::default());
    assert_eq!(f.camera.pos, DVec3::splat(5.0));
    assert_eq!(f.camera.look, DVec3::splat(-1.0));
    assert_eq!(f.camera.up, DVec3::Y);
    assert_eq!(f.camera.height_angle_deg, 45.0);
    assert!(f.lights.is_empty());
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let (shape, m) = first_prim(&f);
    assert_eq!(*shape, Shape::Cube);
    assert_eq!(*m, Material::default());
    assert_eq!(m.diffuse, [1.0; 3]);
    assert_eq!(m.ambient, [0.0; 3]);
    assert_eq!(m.specular, [0.0; 3]);
    assert_eq!(m.shininess, 0.0);
    assert_eq!(m.ior, 1.0);
    assert_eq!(m.blend, 0.0);
    assert!(m.texture.is_none() && m.bumpmap.is_none());
    let b = &f.trees[f.root].blocks[0];
    assert!(b.transforms.is_empty());
    assert_eq!(b.matrix, DMat4::IDENTITY);
    assert_eq!((b.loc.line, b.loc.col), (3, 1));
    assert_eq!(f.trees[f.root].name, "root");
}

#[test]
fn globaldata_all_coefficients() {
    let f = ok(&with_top(
        "<globaldata><ambientcoeff v=\"0.1\"/><diffusecoeff v=\"0.2\"/><specularcoeff v=\"0.3\"/><transparentcoeff v=\"0.4\"/></globaldata>",
    ));
    assert_eq!(f.globals, Globals { ka: 0.1, kd: 0.2, ks: 0.3, kt: 0.4 });
    let f = ok(&with_top("<globaldata><diffusecoeff v=\"0.7\"/></globaldata>"));
    assert_eq!(f.globals, Globals { ka: 0.5, kd: 0.7, ks: 0.5, kt: 0.0 });
}

#[test]
fn second_camera_and_globals_are_ignored_with_warning() {
    let f = ok(&with_top(
        "<cameradata><heightangle v=\"30\"/></cameradata>\n<cameradata><heightangle v=\"60\"/></cameradata>",
    ));
    assert_eq!(f.camera.height_angle_deg, 30.0);
    warned_at(&f, 3, 1, "second <cameradata> (the first is at 2:1); ignored");
    let f = ok(&with_top("<globaldata/>\n<globaldata><ambientcoeff v=\"1\"/></globaldata>"));
    assert_eq!(f.globals.ka, 0.5);
    warned_at(&f, 3, 1, "second <globaldata>");
}

#[test]
fn duplicates_name_the_first_by_line_and_column() {
    let first = "<diffuse r=\"1\" g=\"0\" b=\"0\"/>";
    let f = ok(&prim("cube", &format!("{first}<diffuse r=\"0\" g=\"1\" b=\"0\"/>")));
    let col = first.len() as u32 + 1;
    warned_at(&f, 5, col, "second <diffuse> in <object> (the first is at 5:1); the later one is used");
    let f = ok(&with_top("<cameradata/> <cameradata/>"));
    warned_at(&f, 2, 15, "second <cameradata> (the first is at 2:1); ignored");
    let f = ok(&with_top(" <globaldata/><globaldata/>"));
    warned_at(&f, 2, 15, "second <globaldata> (the first is at 2:2); ignored");
    let f = ok(&block("<object type=\"primitive\" name=\"cube\"/><object type=\"primitive\" name=\"sphere\"/>"));
    warned_at(&f, 4, 39, "a second <object> in one <transblock> (the first is at 4:1)");
}

#[test]
fn wild_file_problems() {
    // Each problem of docs/scene-format.md#files-in-the-wild.
    // Misspelled attribute: see misspelled_type_warns_then_errors.
    // Unknown top-level element: a warning, the rest is read.
    let f = ok(&with_top("<include file=\"x.xml\"/>"));
    warned_at(&f, 2, 1, "unknown top-level element <include>");
    // A primitive named triangle.
    bad_at(&prim("triangle", ""), 4, 26, "unknown primitive \"triangle\"");
    // Numbers written "" (read as 0, as the course's parser reads it, with a warning) or "=0.1" (an error).
    let f = ok(&prim("cube", "<blend v=\"\"/>"));
    warned_at(&f, 5, 8, "attribute `v` of <blend> is empty; read as 0");
    bad_at(&prim("cube", "<blend v=\"=0.1\"/>"), 5, 8, "attribute `v` of <blend> is \"=0.1\", which is not a number");
    // No root tree.
    bad_at("<scenefile>\n<object type=\"tree\" name=\"scene\"/>\n</scenefile>", 1, 1, "no tree named \"root\"");
    // Absolute texture path: a warning (not found), the scene still loads.
    let f = ok(&prim("cube", "<texture file=\"/course/cs123/data/image/x.png\"/>"));
    assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
    warned_at(&f, 5, 1, "<texture> file \"/course/cs123/data/image/x.png\" not found (tried \"/course/cs123/data/image/x.png\", \"/nonexistent-dir/x.png\", and its trailing folders in those and the 3 folders above the scene's)");
    // A texture that names a folder or a device: said so, not "not found".
    for (there, what) in [(std::env::temp_dir(), "a folder"), (PathBuf::from("/dev/null"), "not a regular file")] {
        let f = ok(&prim("cube", &format!("<texture file=\"{}\"/>", there.display())));
        assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
        warned_at(&f, 5, 1, &format!("<texture> file \"{0}\" is {what} (\"{0}\"), not a picture", there.display()));
    }
    // A rotate without angle.
    bad_at(
        &block("  <rotate x=\"1\" y=\"0\" z=\"0\"/>\n<object type=\"primitive\" name=\"cube\"/>"),
        4,
        3,
        "<rotate> is missing attribute `angle`",
    );
}
