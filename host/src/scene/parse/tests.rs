//! The parser's tests: every element and attribute of the format, the
//! errors and warnings at their `file:line:col`, and files broken every
//! way the course's files in the wild are.

use super::*;

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
fn camera_all_elements() {
    let f = camera(
        "<pos x=\"1\" y=\"2\" z=\"3\"/><look x=\"0\" y=\"0\" z=\"-2\"/><up x=\"0\" y=\"3\" z=\"0\"/><heightangle v=\"60\"/>\
         <aspectratio v=\"1.5\"/><aperture v=\"0.08\"/><focallength v=\"15\"/>",
    )
    .unwrap();
    let c = f.camera;
    assert_eq!(c.pos, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(c.look, DVec3::new(0.0, 0.0, -2.0));
    assert_eq!(c.up, DVec3::new(0.0, 3.0, 0.0));
    assert_eq!(c.height_angle_deg, 60.0);
    assert_eq!(c.aspect_ratio, Some(1.5));
    assert_eq!(c.aperture, Some(0.08));
    assert_eq!(c.focal_length, Some(15.0));
}

#[test]
fn camera_focus_becomes_look() {
    let f = camera("<pos x=\"0\" y=\"0\" z=\"6\"/><focus x=\"1\" y=\"2\" z=\"0\"/>").unwrap();
    assert_eq!(f.camera.look, DVec3::new(1.0, 2.0, -6.0));
    // Order does not matter: focus before pos.
    let f = camera("<focus x=\"1\" y=\"2\" z=\"0\"/><pos x=\"0\" y=\"0\" z=\"6\"/>").unwrap();
    assert_eq!(f.camera.look, DVec3::new(1.0, 2.0, -6.0));
    // Only pos: the default look direction stays.
    let f = camera("<pos x=\"0\" y=\"0\" z=\"6\"/>").unwrap();
    assert_eq!(f.camera.look, DVec3::splat(-1.0));
}

#[test]
fn camera_errors() {
    // Lines: 1 <scenefile>, 2 <cameradata>, 3 the inner text.
    let e = camera("<focus x=\"0\" y=\"0\" z=\"0\"/><look x=\"0\" y=\"0\" z=\"-1\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 27));
    assert!(e.message.contains("both <focus> (at 3:1) and <look>"), "{e}");
    let e = camera("<look x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1));
    assert!(e.message.contains("<look> is the zero vector"), "{e}");
    let e = camera("<pos x=\"1\" y=\"1\" z=\"1\"/><focus x=\"1\" y=\"1\" z=\"1\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 25));
    assert!(e.message.contains("same point as <pos>"), "{e}");
    let e = camera("<up x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1));
    assert!(e.message.contains("<up> is the zero vector"), "{e}");
    let e = camera("<look x=\"0\" y=\"-2\" z=\"0\"/><up x=\"0\" y=\"1\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 27));
    assert!(e.message.starts_with("<up>: the up vector") && e.message.contains("parallel"), "{e}");
    // Parallel to the default up: the look element is blamed.
    let e = camera("<look x=\"0\" y=\"-2\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1));
    assert!(e.message.starts_with("<look>:"), "{e}");
    for (bad, shown) in [("0", "0"), ("180", "180"), ("-5", "-5"), ("200", "200"), ("1e30", "1e30")] {
        let e = camera(&format!("<heightangle v=\"{bad}\"/>")).unwrap_err();
        assert_eq!(at(&e), (3, 14), "{e}");
        assert!(
            e.message.starts_with(&format!("<heightangle> is {shown} degrees (expected more than 0 and less than 180")),
            "{e}"
        );
    }
    let e = camera("<aspectratio v=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 14));
    // A position finite here but beyond the renderer's f32: at its attribute.
    let e = camera("<pos x=\"0\" y=\"-1e39\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 12), "{e}");
    assert!(e.message.contains("attribute `y` of <pos> is too large"), "{e}");
    let e = camera("<pos x=\"0\" y=\"1e-300\" z=\"1e38\"/><look x=\"0\" y=\"1e-300\" z=\"0\"/>").unwrap_err();
    assert!(e.message.contains("parallel to the look direction (0, 1e-300, 0)"), "numbers short: {e}");
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
fn light_defaults() {
    let f = light("").unwrap();
    let l = &f.lights[0];
    assert_eq!(l.id, 0);
    assert_eq!(l.kind, LightKind::Point);
    assert_eq!(l.color, [1.0; 3]);
    assert_eq!(l.position, DVec3::splat(3.0));
    assert_eq!(l.attenuation, [1.0, 0.0, 0.0]);
    assert_eq!((l.angle_deg, l.penumbra_deg, l.width, l.height), (0.0, 0.0, 0.0, 0.0));
    assert_eq!((l.loc.line, l.loc.col), (2, 1));
}

#[test]
fn light_all_elements() {
    let f = light(
        "<id v=\"7\"/><type v=\"spot\"/><color r=\"0.1\" g=\"0.2\" b=\"0.3\"/><position x=\"1\" y=\"2\" z=\"3\"/>\
         <direction x=\"0\" y=\"-1\" z=\"0\"/><function v1=\"0.8\" v2=\"0.05\" v3=\"0.01\"/><angle v=\"30\"/>\
         <penumbra v=\"20\"/><width v=\"2\"/><height v=\"3\"/>",
    )
    .unwrap();
    let l = &f.lights[0];
    assert_eq!(l.id, 7);
    assert_eq!(l.kind, LightKind::Spot);
    assert_eq!(l.color, [0.1, 0.2, 0.3]);
    assert_eq!(l.position, DVec3::new(1.0, 2.0, 3.0));
    assert_eq!(l.direction, DVec3::new(0.0, -1.0, 0.0));
    assert_eq!(l.attenuation, [0.8, 0.05, 0.01]);
    assert_eq!((l.angle_deg, l.penumbra_deg, l.width, l.height), (30.0, 20.0, 2.0, 3.0));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    for (v, k) in [
        ("point", LightKind::Point),
        ("directional", LightKind::Directional),
        ("spot", LightKind::Spot),
        ("area", LightKind::Area),
    ] {
        let size = "<width v=\"1\"/><height v=\"1\"/>"; // an area light's; the others ignore it
        let f = light(&format!("<type v=\"{v}\"/><direction x=\"1\" y=\"0\" z=\"0\"/><angle v=\"1\"/>{size}")).unwrap();
        assert_eq!(f.lights[0].kind, k);
    }
    // Non-unique ids are fine; more than 8 lights are fine.
    let many = "<lightdata><id v=\"0\"/></lightdata>".repeat(12);
    let f = ok(&with_top(&many));
    assert_eq!(f.lights.len(), 12);
}

#[test]
fn light_function_spellings() {
    for attrs in ["v1=\"1\" v2=\"2\" v3=\"3\"", "x=\"1\" y=\"2\" z=\"3\"", "a=\"1\" b=\"2\" c=\"3\""] {
        let f = light(&format!("<function {attrs}/>")).unwrap();
        assert_eq!(f.lights[0].attenuation, [1.0, 2.0, 3.0]);
    }
    let e = light("<function v1=\"1\" y=\"2\" z=\"3\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1));
    assert!(e.message.contains("mixes spellings"), "{e}");
    let e = light("<function v1=\"1\" v2=\"2\"/>").unwrap_err();
    assert!(e.message.contains("missing attribute `v3`"), "{e}");
    let e = light("<function/>").unwrap_err();
    assert!(e.message.contains("has no values (expected v1 v2 v3, x y z or a b c)"), "{e}");
}

#[test]
fn light_errors_and_warnings() {
    let e = light("<type v=\"laser\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 7));
    assert!(e.message.contains("unknown light type \"laser\" (expected point, directional, spot or area)"), "{e}");
    let e = light("<type v=\"directonal\"/>").unwrap_err();
    assert!(e.message.contains("did you mean \"directional\"?"), "{e}");
    let e = light("<type v=\"directional\"/><direction x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 24));
    assert!(e.message.contains("directional light's <direction> is the zero vector"), "{e}");
    let e = light("<type v=\"directional\"/>").unwrap_err();
    assert_eq!(at(&e), (2, 1));
    assert!(e.message.contains("has no <direction>"), "{e}");
    let e = light("<id v=\"1.5\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 5));
    // Numbers in messages are written short.
    let e = light("<id v=\"1e-38\"/>").unwrap_err();
    assert!(e.message.starts_with("light <id> is 1e-38 (expected a whole number)"), "{e}");
    let f = light("<type v=\"spot\"/><direction x=\"0\" y=\"-1\" z=\"0\"/>").unwrap();
    warned_at(&f, 2, 1, "spot light has no <angle>");
    // Light type absent means point.
    let f = light("<position x=\"1\" y=\"1\" z=\"1\"/>").unwrap();
    assert_eq!(f.lights[0].kind, LightKind::Point);
}

#[test]
fn material_all_elements() {
    let f = ok(&prim(
        "sphere",
        "<diffuse r=\"0.1\" g=\"0.2\" b=\"0.3\"/><ambient r=\"0.4\" g=\"0.5\" b=\"0.6\"/>\
         <specular r=\"1\" g=\"1\" b=\"1\"/><reflective r=\"0.7\" g=\"0.7\" b=\"0.7\"/>\
         <transparent r=\"0.2\" g=\"0.2\" b=\"0.2\"/><emissive r=\"0.05\" g=\"0\" b=\"0\"/>\
         <shininess v=\"25\"/><ior v=\"1.5\"/><blend v=\"0.75\"/>\
         <texture file=\"a.png\" u=\"2\" v=\"3\"/><bumpmap file=\"b.png\"/>",
    ));
    let (_, m) = first_prim(&f);
    assert_eq!(m.diffuse, [0.1, 0.2, 0.3]);
    assert_eq!(m.ambient, [0.4, 0.5, 0.6]);
    assert_eq!(m.specular, [1.0; 3]);
    assert_eq!(m.reflective, [0.7; 3]);
    assert_eq!(m.transparent, [0.2; 3]);
    assert_eq!(m.emissive, [0.05, 0.0, 0.0]);
    assert_eq!((m.shininess, m.ior, m.blend), (25.0, 1.5, 0.75));
    let t = m.texture.as_ref().unwrap();
    assert_eq!((t.file.as_str(), t.repeat_u, t.repeat_v), ("a.png", 2.0, 3.0));
    assert_eq!((t.loc.line, t.loc.col), (5, 1 + "<diffuse r=\"0.1\" g=\"0.2\" b=\"0.3\"/><ambient r=\"0.4\" g=\"0.5\" b=\"0.6\"/><specular r=\"1\" g=\"1\" b=\"1\"/><reflective r=\"0.7\" g=\"0.7\" b=\"0.7\"/><transparent r=\"0.2\" g=\"0.2\" b=\"0.2\"/><emissive r=\"0.05\" g=\"0\" b=\"0\"/><shininess v=\"25\"/><ior v=\"1.5\"/><blend v=\"0.75\"/>".len() as u32));
    let b = m.bumpmap.as_ref().unwrap();
    assert_eq!((b.file.as_str(), b.repeat_u, b.repeat_v), ("b.png", 1.0, 1.0));
    // The texture does not exist: a warning, no error. The bump map is
    // ignored (a warning that says so), its image not looked for.
    assert_eq!(f.warnings.iter().filter(|w| w.message.contains("not found")).count(), 1);
    assert!(f.warnings.iter().any(|w| w.message.contains("<bumpmap> is ignored")), "{:?}", f.warnings);
}

#[test]
fn material_duplicate_and_unknown_children() {
    let f =
        ok(&prim("cube", "<diffuse r=\"1\" g=\"0\" b=\"0\"/>\n<diffuse r=\"0\" g=\"1\" b=\"0\"/>\n<glow v=\"1\"/>"));
    assert_eq!(first_prim(&f).1.diffuse, [0.0, 1.0, 0.0]);
    warned_at(&f, 6, 1, "second <diffuse> in <object> (the first is at 5:1); the later one is used");
    warned_at(&f, 7, 1, "unknown element <glow> in <object>");
}

#[test]
fn texture_resolution() {
    let dir = std::env::temp_dir().join(format!("raycast-parse-tex-{}", std::process::id()));
    let scene_dir = dir.join("scenes");
    let assets = dir.join("assets");
    std::fs::create_dir_all(scene_dir.join("img")).unwrap();
    std::fs::create_dir_all(assets.join("image")).unwrap();
    std::fs::write(scene_dir.join("img/local.png"), b"x").unwrap();
    std::fs::write(assets.join("image/a.png"), b"x").unwrap();
    std::fs::write(assets.join("x.png"), b"x").unwrap();
    let o = ParseOptions { assets: vec![assets.clone()], ..ParseOptions::default() };
    let xml_path = scene_dir.join("s.xml");
    let abs_ok = scene_dir.join("img/local.png");
    let tex = |file: &str| {
        let xml = prim("cube", &format!("<texture file=\"{file}\"/>"));
        let f = parse_str(&xml, &xml_path, &o).unwrap();
        let t = first_prim(&f).1.texture.clone().unwrap();
        (t.resolved, f.warnings)
    };
    // Relative to the XML file's folder.
    let (r, w) = tex("img/local.png");
    assert_eq!(r, Some(scene_dir.join("img/local.png")));
    assert!(w.is_empty());
    // Relative to an assets folder.
    let (r, w) = tex("image/a.png");
    assert_eq!(r, Some(assets.join("image/a.png")));
    assert!(w.is_empty());
    // Absolute and present.
    let (r, w) = tex(&abs_ok.display().to_string());
    assert_eq!(r, Some(abs_ok.clone()));
    assert!(w.is_empty());
    // Absolute and absent: its file name in the folders, with a warning.
    let (r, w) = tex("/course/cs123/data/image/x.png");
    assert_eq!(r, Some(assets.join("x.png")));
    assert_eq!(w.len(), 1);
    assert!(w[0].message.contains("does not exist; using"), "{}", w[0]);
    assert_eq!(wat(&w[0]), (5, 1));
    // Not found anywhere: None and a warning naming the places tried.
    let (r, w) = tex("image/missing.png");
    assert_eq!(r, None);
    assert_eq!(w.len(), 1);
    let m = &w[0].message;
    assert!(m.contains("not found") && m.contains(&scene_dir.join("image/missing.png").display().to_string()));
    assert!(m.contains(&assets.join("image/missing.png").display().to_string()), "{m}");
    assert!(m.contains("and the 3 folders above the scene's)"), "{m}");
    // In a folder above the scene's (a corpus root: paths relative to it),
    // after the scene's folder and the assets: used, with a warning
    // naming the folder; the scene's own folder and the assets first.
    let root = dir.canonicalize().unwrap();
    std::fs::create_dir_all(root.join("image")).unwrap();
    std::fs::write(root.join("image/up.png"), b"x").unwrap();
    std::fs::write(root.join("image/a.png"), b"x").unwrap();
    let (r, w) = tex("image/up.png");
    assert_eq!(r, Some(root.join("image/up.png")));
    assert_eq!(w.len(), 1);
    let m = &w[0].message;
    assert!(m.contains(&format!("found 1 folder above the scene's, in \"{}\"", root.display())), "{m}");
    assert!(m.contains(&format!("--assets {} says so", root.display())), "{m}");
    let (r, w) = tex("image/a.png");
    assert_eq!((r, w.len()), (Some(assets.join("image/a.png")), 0));
    // Absolute and absent, its trailing folders in a folder above the
    // scene's: the longest that is there wins, with a warning.
    let (r, w) = tex("/course/cs123/data/image/up.png");
    assert_eq!(r, Some(root.join("image/up.png")));
    assert!(w[0].message.contains(&format!("using \"{}\" instead", root.join("image/up.png").display())), "{}", w[0]);
    let (r, w) = tex("/course/cs123/data/image/a.png");
    assert_eq!(r, Some(assets.join("image/a.png")), "the assets before the folders above: {w:?}");
    let typo = ParseOptions { assets: vec![assets.clone(), dir.join("asets")], ..ParseOptions::default() };
    let f = parse_str(&prim("cube", "<texture file=\"image/gone.png\"/>"), &xml_path, &typo).unwrap();
    let m = &f.warnings[0].message;
    assert!(m.contains(&format!("; --assets {} is not a folder:", dir.join("asets").display())), "{m}");
    assert!(!m.contains(&format!("--assets {} is not", assets.display())), "{m}");
    let (r, w) = tex("/course/cs123/data/image/gone.png");
    assert_eq!(r, None);
    assert!(w[0].message.contains("and its trailing folders in those and the 3 folders above the scene's"), "{}", w[0]);
    assert!(w[0].message.contains(&assets.join("gone.png").display().to_string()), "{}", w[0]);
    // No further than FOLDERS_ABOVE: a scene four folders below the image.
    let deep = root.join("scenes/a/b/c");
    std::fs::create_dir_all(&deep).unwrap();
    let xml = prim("cube", "<texture file=\"image/up.png\"/>");
    let f = parse_str(&xml, &deep.join("s.xml"), &opts()).unwrap();
    assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
    let f = parse_str(&xml, &root.join("scenes/a/b/s.xml"), &opts()).unwrap();
    assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, Some(root.join("image/up.png")));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The torus has one canonical size (docs/scene-format.md#torus): a
/// radius written on it is warned about and ignored, a misspelling is
/// an error with a suggestion, and it takes a material as any shape.
#[test]
fn torus_takes_no_size_and_a_material() {
    let f = ok(&block("<object type=\"primitive\" name=\"torus\" radius=\"2\" tube=\"0.1\"/>"));
    assert_eq!(*first_prim(&f).0, Shape::Torus);
    warned_at(&f, 4, 39, "unknown attribute `radius` on <object>");
    warned_at(&f, 4, 50, "unknown attribute `tube` on <object>");
    bad_at(&block("<object type=\"primitive\" name=\"tours\"/>"), 4, 26, "did you mean \"torus\"?");
    bad_at(&block("<object type=\"primitive\" name=\"Torus\"/>"), 4, 26, "unknown primitive \"Torus\"");
    let f = ok(&prim("torus", "<diffuse r=\"0.5\" g=\"0.25\" b=\"1\"/><reflective r=\"1\" g=\"1\" b=\"1\"/>"));
    let (shape, m) = first_prim(&f);
    assert_eq!((shape, m.diffuse, m.reflective), (&Shape::Torus, [0.5, 0.25, 1.0], [1.0, 1.0, 1.0]));
    bad_at(&prim("torus", "<diffuse r=\"x\" g=\"0\" b=\"0\"/>"), 5, 10, "");
}

#[test]
fn primitive_shapes() {
    for (name, shape) in [
        ("cube", Shape::Cube),
        ("cone", Shape::Cone),
        ("cylinder", Shape::Cylinder),
        ("sphere", Shape::Sphere),
        ("torus", Shape::Torus),
    ] {
        assert_eq!(*first_prim(&ok(&prim(name, ""))).0, shape);
    }
    let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\"/>"));
    assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "a.obj".into(), resolved: None });
    let f = ok(&block("<object type=\"primitive\" name=\"mesh\" filename=\"b.obj\"/>"));
    assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "b.obj".into(), resolved: None });
    bad_at(&block("<object type=\"primitive\" name=\"mesh\"/>"), 4, 1, "needs meshfile=");
    bad_at(
        &block("<object type=\"primitive\" name=\"triangle\"/>"),
        4,
        26,
        "unknown primitive \"triangle\" (expected cube, cone, cylinder, sphere, torus or mesh)",
    );
    bad_at(&block("<object type=\"primitive\" name=\"shpere\"/>"), 4, 26, "did you mean \"sphere\"?");
    bad_at(&block("<object type=\"primitive\"/>"), 4, 1, "<object> is missing attribute `name`");
    bad_at(&block("<object type=\"thing\" name=\"cube\"/>"), 4, 9, "unknown object type \"thing\"");
    bad_at(&block("<object name=\"cube\"/>"), 4, 1, "<object> is missing attribute `type`");
}

/// The mesh element: meshfile= or filename=, both (a warning, meshfile
/// wins), neither (an error at the element), a misspelt attribute, and
/// meshfile= on another shape (ignored with a warning).
#[test]
fn mesh_element_cases() {
    let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\" filename=\"b.obj\"/>"));
    assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "a.obj".into(), resolved: None });
    warned_at(&f, 4, 1, "mesh has both meshfile= and filename=; using meshfile");
    let e = bad_at(&block("<object type=\"primitive\" name=\"mesh\"/>"), 4, 1, "needs meshfile=\"file.obj\"");
    assert!(e.to_string().contains("test.xml:4:1: error:"), "{e}");
    bad_at(&block("<object type=\"primitive\" name=\"mesh\" meshfle=\"a.obj\"/>"), 4, 1, "needs meshfile=");
    let xml = block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\" meshfle=\"b.obj\"/>");
    let (line, col) = pos_of(&xml, "meshfle=");
    warned_at(&ok(&xml), line, col, "unknown attribute `meshfle` on <object> (did you mean `meshfile`?)");
    let xml = block("<object type=\"primitive\" name=\"sphere\" meshfile=\"a.obj\"/>");
    let f = ok(&xml);
    assert_eq!(*first_prim(&f).0, Shape::Sphere);
    let (line, col) = pos_of(&xml, "meshfile=");
    warned_at(&f, line, col, "unknown attribute `meshfile` on <object>");
    // An empty name parses; flatten() refuses it as a file not found.
    let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"\"/>"));
    assert_eq!(*first_prim(&f).0, Shape::Mesh { file: String::new(), resolved: None });
}

#[test]
fn transforms_parse() {
    let f = ok(&block(
        "<translate x=\"1\" y=\"2\" z=\"3\"/><rotate x=\"0\" y=\"2\" z=\"0\" angle=\"90\"/><scale x=\"4\" y=\"5\" z=\"6\"/>\
         <object type=\"primitive\" name=\"cube\"/>",
    ));
    let b = &f.trees[f.root].blocks[0];
    assert_eq!(
        b.transforms,
        vec![
            Transform::Translate(DVec3::new(1.0, 2.0, 3.0)),
            Transform::Rotate { axis: DVec3::new(0.0, 2.0, 0.0), angle_deg: 90.0 },
            Transform::Scale(DVec3::new(4.0, 5.0, 6.0)),
        ]
    );
    let expect = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
        * DMat4::from_rotation_y(90f64.to_radians())
        * DMat4::from_scale(DVec3::new(4.0, 5.0, 6.0));
    assert!(b.matrix.abs_diff_eq(expect, 1e-12));
}

#[test]
fn object_may_come_before_transforms() {
    let f = ok(&block("<object type=\"primitive\" name=\"cube\"/><translate x=\"1\" y=\"0\" z=\"0\"/>"));
    let b = &f.trees[f.root].blocks[0];
    assert_eq!(b.transforms.len(), 1);
    assert_eq!(b.matrix.transform_point3(DVec3::ZERO), DVec3::X);
}

#[test]
fn rotate_axis_need_not_be_unit() {
    let f = ok(&block("<rotate x=\"0\" y=\"0\" z=\"5\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"));
    let m = f.trees[f.root].blocks[0].matrix;
    assert!(m.transform_point3(DVec3::X).abs_diff_eq(DVec3::Y, 1e-12));
    bad_at(
        &block("<rotate x=\"0\" y=\"0\" z=\"0\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        1,
        "<rotate> has the zero vector as its axis",
    );
}

#[test]
fn matrix_is_row_major_with_translation_in_fourth_column() {
    let f = ok(&block(
        "<matrix>\
         <row0 v1=\"2\" v2=\"0\" v3=\"0\" v4=\"10\"/>\
         <row1 v1=\"0\" v2=\"3\" v3=\"0\" v4=\"20\"/>\
         <row2 a=\"0\" b=\"0\" c=\"4\" d=\"30\"/>\
         <row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/>\
         </matrix><object type=\"primitive\" name=\"cube\"/>",
    ));
    let b = &f.trees[f.root].blocks[0];
    assert_eq!(b.matrix.transform_point3(DVec3::ONE), DVec3::new(12.0, 23.0, 34.0));
    assert_eq!(b.matrix.w_axis, glam::DVec4::new(10.0, 20.0, 30.0, 1.0));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    // A shear entry lands where it is written: row 0, column 1.
    let f = ok(&block(
        "<matrix><row0 v1=\"1\" v2=\"5\" v3=\"0\" v4=\"0\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
         <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/></matrix>\
         <object type=\"primitive\" name=\"cube\"/>",
    ));
    assert_eq!(f.trees[f.root].blocks[0].matrix.transform_point3(DVec3::Y), DVec3::new(5.0, 1.0, 0.0));
    bad_at(
        &block(
            "<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"0\"/></matrix><object type=\"primitive\" name=\"cube\"/>",
        ),
        4,
        1,
        "<matrix> has no <row1>",
    );
    // The last row is ignored, with a warning at it: the renderer's
    // transforms are affine (matrix_last_row_is_ignored_with_a_warning).
    let xml = block(
        "<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"0\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
         <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"1\"/></matrix>\
         <object type=\"primitive\" name=\"cube\"/>",
    );
    let f = ok(&xml);
    let (line, col) = pos_of(&xml, "<row3");
    warned_at(
        &f,
        line,
        col,
        "<matrix> row3 is 0 0 1 1, not 0 0 0 1: raycast's transforms are affine; the last row is ignored",
    );
    assert_eq!(f.trees[f.root].blocks[0].matrix, DMat4::IDENTITY);
}

#[test]
fn transblock_needs_an_object_and_takes_several_with_a_warning() {
    bad_at(&block("<translate x=\"1\" y=\"0\" z=\"0\"/>"), 3, 1, "<transblock> has no <object>");
    // Several, as the course's parser takes them: each drawn with the
    // transblock's transforms, the same as a transblock apiece.
    let two = "<object type=\"primitive\" name=\"cube\"/>\n<object type=\"primitive\" name=\"sphere\"/>";
    let f = ok(&block(&format!("<translate x=\"1\" y=\"2\" z=\"3\"/>\n{two}")));
    warned_at(&f, 6, 1, "a second <object> in one <transblock> (the first is at 5:1); each is drawn");
    let apart = ok(&root(
        "<transblock><translate x=\"1\" y=\"2\" z=\"3\"/><object type=\"primitive\" name=\"cube\"/></transblock>\n\
         <transblock><translate x=\"1\" y=\"2\" z=\"3\"/><object type=\"primitive\" name=\"sphere\"/></transblock>",
    ));
    let flat = |f: &SceneFile| {
        let s = crate::scene::flatten(f, &crate::scene::FlattenLimits::default()).unwrap();
        s.flat_primitives().into_iter().map(|p| (format!("{:?}", p.shape), p.world_from_object)).collect::<Vec<_>>()
    };
    assert_eq!(flat(&f), flat(&apart), "two objects in one transblock, against a transblock each");
    assert_eq!(flat(&f).len(), 2);
    let f = ok(&block("<object type=\"primitive\" name=\"cube\"/>\n<frobnicate/>"));
    warned_at(
        &f,
        5,
        1,
        "unknown element <frobnicate> in <transblock> (expected translate, rotate, scale, matrix or object); skipped",
    );
}

#[test]
fn missing_attributes_are_errors() {
    bad_at(
        &block("<translate x=\"1\" y=\"2\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        1,
        "<translate> is missing attribute `z` (expected x, y and z)",
    );
    bad_at(
        &block("<rotate x=\"0\" y=\"1\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        1,
        "<rotate> is missing attribute `angle`",
    );
    bad_at(&prim("cube", "<diffuse r=\"1\" g=\"1\"/>"), 5, 1, "<diffuse> is missing attribute `b`");
    bad_at(&prim("cube", "<shininess/>"), 5, 1, "<shininess> is missing attribute `v`");
    bad_at(&prim("cube", "<texture u=\"1\"/>"), 5, 1, "<texture> is missing attribute `file`");
}

#[test]
fn bad_numbers_are_errors_at_the_attribute() {
    for (v, msg) in [
        ("=0.1", "is \"=0.1\", which is not a number"),
        ("abc", "is \"abc\", which is not a number"),
        ("1,5", "which is not a number"),
        ("nan", "is \"nan\" (expected a finite number)"),
        ("NaN", "expected a finite number"),
        ("inf", "expected a finite number"),
        ("-infinity", "expected a finite number"),
        ("1e400", "expected a finite number"),
    ] {
        let e = bad_at(
            &block(&format!("<translate x=\"0\" y=\"{v}\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>")),
            4,
            18,
            msg,
        );
        assert!(e.message.starts_with("attribute `y` of <translate>"), "{e}");
    }
    // f32 fields: finite in f64 but not in f32.
    bad_at(&prim("cube", "<shininess v=\"1e39\"/>"), 5, 12, "too large");
    // An empty number reads as 0, as the course's parser reads it, with a warning there.
    for v in ["", "  "] {
        let f =
            ok(&block(&format!("<translate x=\"0\" y=\"{v}\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>")));
        warned_at(&f, 4, 18, "attribute `y` of <translate> is empty; read as 0");
    }
    let f = ok(&block("<rotate x=\"0\" y=\"1\" z=\"\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"));
    warned_at(&f, 4, 21, "attribute `z` of <rotate> is empty; read as 0");
    // Whitespace around a number is tolerated.
    let f = ok(&prim("cube", "<shininess v=\" 12 \"/>"));
    assert_eq!(first_prim(&f).1.shininess, 12.0);
}

#[test]
fn unknown_attributes_warn_with_suggestions() {
    let f = ok(&prim("cube", "<diffuse r=\"1\" g=\"1\" b=\"1\" alpha=\"1\"/>\n<shininess v=\"1\" V=\"2\"/>"));
    warned_at(&f, 5, 28, "unknown attribute `alpha` on <diffuse> (expected r, g or b); ignored");
    warned_at(&f, 6, 18, "unknown attribute `V` on <shininess> (did you mean `v`?); ignored");
    let f = ok(&block("<object type=\"primitive\" name=\"cube\" colour=\"red\"/>"));
    warned_at(&f, 4, 38, "unknown attribute `colour` on <object> (expected type or name)");
}

#[test]
fn misspelled_type_warns_then_errors() {
    // Wild file: `typr="tree"` on the top-level tree.
    let xml = "<scenefile>\n  <object typr=\"tree\" name=\"root\">\n  </object>\n</scenefile>";
    let e = bad_at(xml, 2, 11, "<object> is missing attribute `type` (found `typr`: did you mean `type`?)");
    let _ = e;
    // Inside a transblock as well.
    bad_at(&block("<object typr=\"primitive\" name=\"cube\"/>"), 4, 9, "did you mean `type`?");
    // The warning is emitted on its own where the attribute is optional.
    let f = ok(&block("<object type=\"primitive\" name=\"cube\" nmae=\"x\"/>"));
    warned_at(&f, 4, 38, "unknown attribute `nmae` on <object> (did you mean `name`?)");
}

#[test]
fn unknown_elements_warn_and_are_skipped() {
    let xml = "<scenefile>\n  <fog density=\"1\"/>\n  <lightdata><colour r=\"1\" g=\"1\" b=\"1\"/></lightdata>\n\
               <object type=\"tree\" name=\"root\"><cube/><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object>\n</scenefile>";
    let f = ok(xml);
    warned_at(
        &f,
        2,
        3,
        "unknown top-level element <fog> (expected globaldata, cameradata, lightdata or object); skipped",
    );
    warned_at(&f, 3, 14, "unknown element <colour> in <lightdata> (did you mean <color>?); skipped");
    warned_at(&f, 4, 33, "unknown element <cube> in <object> (expected transblock)");
    assert_eq!(f.trees[f.root].blocks.len(), 1);
    let f = ok("<scenefile>\n<camreadata/>\n<object type=\"tree\" name=\"root\"/></scenefile>");
    warned_at(&f, 2, 1, "did you mean <cameradata>?");
}

#[test]
fn trees_and_masters() {
    let xml = "<scenefile>\n\
        <object type=\"tree\" name=\"m\"><transblock><object type=\"primitive\" name=\"cone\"/></transblock></object>\n\
        <object type=\"tree\" name=\"root\">\n\
        <transblock><object type=\"master\" name=\"m\"/></transblock>\n\
        <transblock><object type=\"tree\"><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>\n\
        </object>\n</scenefile>";
    let f = ok(xml);
    assert_eq!(f.trees.len(), 2);
    assert_eq!(f.root, 1);
    let blocks = &f.trees[1].blocks;
    assert!(matches!(blocks[0].object, Node::Master { tree: 0, .. }));
    match &blocks[1].object {
        Node::Tree { blocks, loc } => {
            assert_eq!((loc.line, loc.col), (5, 13));
            assert!(matches!(blocks[0].object, Node::Primitive { shape: Shape::Cube, .. }));
        }
        o => panic!("{o:?}"),
    }
}

#[test]
fn master_errors() {
    let used_before = "<scenefile>\n\
        <object type=\"tree\" name=\"root\"><transblock><object type=\"master\" name=\"later\"/></transblock></object>\n\
        <object type=\"tree\" name=\"later\"><transblock><object type=\"primitive\" name=\"cone\"/></transblock></object>\n\
        </scenefile>";
    bad_at_str(used_before, "name=\"later\"/>", "master \"later\" is used before its tree is declared (at 3:1)");
    let unknown = root("<transblock><object type=\"master\" name=\"nope\"/></transblock>");
    bad_at(&unknown, 3, 35, "unknown master \"nope\"");
    let selfref = root("<transblock><object type=\"master\" name=\"root\"/></transblock>");
    bad_at(&selfref, 3, 35, "uses itself as a master");
    bad_at(&root("<transblock><object type=\"master\"/></transblock>"), 3, 13, "missing attribute `name`");
}

#[test]
fn top_level_tree_errors() {
    bad_at(
        "<scenefile>\n<object type=\"primitive\" name=\"cube\"/>\n</scenefile>",
        2,
        9,
        "a top-level <object> has type=\"primitive\" (expected type=\"tree\"",
    );
    bad_at("<scenefile>\n<object type=\"tree\"/>\n</scenefile>", 2, 1, "missing attribute `name`");
    let dup = "<scenefile>\n<object type=\"tree\" name=\"a\"/>\n<object type=\"tree\" name=\"root\"/>\n  <object type=\"tree\" name=\"a\"/>\n</scenefile>";
    bad_at(dup, 4, 23, "a second tree named \"a\" (the first is at 2:1)");
    let e = bad_at("<scenefile>\n<object type=\"tree\" name=\"main\"/>\n</scenefile>", 1, 1, "no tree named \"root\"");
    assert!(e.message.contains("trees found: main"), "{e}");
    bad_at("<scenefile/>", 1, 1, "no tree named \"root\" (the file has no trees)");
}

#[test]
fn xml_and_file_errors() {
    let e = bad_at(
        "<scenefile>\n<object type=\"tree\" name=\"root\">\n<transblock>\n</object>\n</scenefile>",
        4,
        1,
        "malformed XML",
    );
    assert!(e.message.contains("found </object> while <transblock> is still open"), "{e}");
    bad_at("<scenefile>\n<object", 2, 8, "malformed XML");
    bad_at("<scenefile>\n", 2, 1, "malformed XML: the file ends");
    bad_at("", 1, 1, "malformed XML");
    bad_at("<scene>\n</scene>", 1, 1, "the root element is <scene>, expected <scenefile>");
    bad_at("<scenefile><a x=\"1\" x=\"2\"/></scenefile>", 1, 21, "malformed XML: attribute 'x'");
    // A byte-order mark does not shift columns.
    let f = p(&format!("\u{feff}{}", prim("cube", "<glow/>"))).unwrap();
    warned_at(&f, 5, 1, "<glow>");

    let dir = std::env::temp_dir().join(format!("raycast-parse-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing.xml");
    let e = parse_file(&missing, &opts()).unwrap_err();
    assert!(e.loc.is_none());
    assert!(e.message.contains("missing.xml") && e.message.contains("cannot read"), "{e}");
    let latin1 = dir.join("latin1.xml");
    std::fs::write(&latin1, b"<scenefile>\n<!-- caf\xe9 -->\n</scenefile>").unwrap();
    let e = parse_file(&latin1, &opts()).unwrap_err();
    assert_eq!(at(&e), (2, 9));
    assert!(e.message.contains("not valid UTF-8"), "{e}");
    let good = dir.join("good.xml");
    std::fs::write(&good, prim("cube", "")).unwrap();
    let f = parse_file(&good, &opts()).unwrap();
    assert_eq!(*f.path, good);
    let _ = std::fs::remove_dir_all(&dir);
}

fn nested(depth: usize) -> String {
    let mut s = String::from("<scenefile><object type=\"tree\" name=\"root\">");
    for _ in 0..depth - 1 {
        s.push_str("<transblock><object type=\"tree\">");
    }
    s.push_str("<transblock><object type=\"primitive\" name=\"cube\"/></transblock>");
    for _ in 0..depth - 1 {
        s.push_str("</object></transblock>");
    }
    s.push_str("</object></scenefile>");
    s
}

#[test]
fn nesting_is_limited() {
    ok(&nested(MAX_NESTING));
    let e = bad(&nested(MAX_NESTING + 1));
    assert!(e.message.contains("nested more than 256 deep"), "{e}");
    // Far deeper: still an error, not a stack overflow.
    let e = bad(&nested(50_000));
    assert!(e.message.contains("elements are nested more than 1024 deep"), "{e}");
    let pile = format!("<scenefile>\n{}", "<a>".repeat(100_000));
    bad_at(&pile, 2, 3070, "elements are nested more than 1024 deep");
    // Markup that does not nest is not counted.
    let flat = format!(
        "<scenefile><!-- <a><a> -->{}<![CDATA[<a><a>]]><?pi <a> ?></scenefile>",
        "<b x='<<' y=\"/>\"/><c></c>".repeat(5000)
    );
    assert_eq!(too_deep(&flat, 3), None);
    assert_eq!(too_deep("<a><b><c><d>", 3), Some(9));
    bad_at("<!DOCTYPE s [<!ENTITY e \"<a/>\">]>\n<scenefile/>", 1, 1, "a DTD with declarations is not supported");
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

#[test]
fn never_panics_on_mangled_input() {
    let base = with_top(
        "<globaldata><ambientcoeff v=\"0.5\"/></globaldata><cameradata><pos x=\"1\" y=\"2\" z=\"3\"/><focus x=\"0\" y=\"0\" z=\"0\"/></cameradata>\
         <lightdata><type v=\"spot\"/><direction x=\"0\" y=\"-1\" z=\"0\"/><function a=\"1\" b=\"0\" c=\"0\"/></lightdata>\
         <object type=\"tree\" name=\"m\"><transblock><rotate x=\"1\" y=\"0\" z=\"0\" angle=\"30\"/><object type=\"primitive\" name=\"sphere\"><diffuse r=\"1\" g=\"0\" b=\"0\"/><texture file=\"t.png\"/></object></transblock></object>",
    );
    // Every prefix.
    for (i, _) in base.char_indices() {
        let _ = p(&base[..i]);
    }
    // Deterministic byte edits.
    let chars: Vec<char> = base.chars().collect();
    let alphabet: Vec<char> = "<>/=\" x0.-e\u{e9}\n".chars().collect();
    let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
    for _ in 0..3000 {
        let mut c = chars.clone();
        for _ in 0..3 {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            let at = (seed as usize) % c.len();
            let ch = alphabet[(seed >> 32) as usize % alphabet.len()];
            match (seed >> 40) % 3 {
                0 => c[at] = ch,
                1 => c.insert(at, ch),
                _ => {
                    c.remove(at);
                }
            }
        }
        let s: String = c.into_iter().collect();
        if let Ok(f) = p(&s) {
            let _ = crate::scene::flatten(&f, &Default::default());
        }
    }
}

#[test]
fn one_long_line_is_fast_and_positions_exact() {
    let blocks = "<transblock><object type=\"primitive\" name=\"cube\"/></transblock>".repeat(20_000);
    let xml = format!("<scenefile><object type=\"tree\" name=\"root\">{blocks}<transblock><object type=\"primitive\" name=\"cub\"/></transblock></object></scenefile>");
    let t = std::time::Instant::now();
    bad_at_str(&xml, "name=\"cub\"", "did you mean \"cube\"?");
    assert!(t.elapsed().as_secs_f64() < 2.0);
    // Positions asked for out of order are still right.
    let xml = "<scenefile><object type=\"tree\" name=\"a\"/><object type=\"tree\" name=\"a\"/></scenefile>";
    bad_at_str(xml, "name=\"a\"/></scenefile>", "a second tree named \"a\" (the first is at 1:12)");
}

#[test]
fn edit_distance_and_suggestions() {
    assert_eq!(edit_distance("typr", "type"), 1);
    assert_eq!(edit_distance("", "abc"), 3);
    assert_eq!(suggest("typr", &["type", "name"]), Some("type"));
    assert_eq!(suggest("X", &["x", "y"]), Some("x"));
    assert_eq!(suggest("w", &["x", "y", "z"]), None);
    assert_eq!(suggest("colour", &["type", "name"]), None);
}

#[test]
fn missing_attribute_suggests_only_names_the_element_does_not_take() {
    // `v1` is one of <function>'s own attributes, not a misspelt `v2`.
    let e = light("<function v1=\"1\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1), "{e}");
    assert_eq!(e.message, "<function> is missing attribute `v2` (expected v1, v2 and v3)");
    let e = bad_at(
        &block("<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\"/></matrix><object type=\"primitive\" name=\"cube\"/>"),
        4,
        9,
        "<row0> is missing attribute `v4` (expected v1, v2, v3 and v4)",
    );
    assert!(!e.message.contains("did you mean"), "{e}");
    let e = bad_at(
        &block("<translate x=\"1\" y=\"2\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        1,
        "<translate> is missing attribute `z` (expected x, y and z)",
    );
    assert!(!e.message.contains("did you mean"), "{e}");
    // A name the element does not take is still offered.
    let e = light("<function v1=\"1\" v2=\"2\" v33=\"3\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 25), "{e}");
    assert!(e.message.contains("missing attribute `v3` (found `v33`: did you mean `v3`?)"), "{e}");
    bad_at(
        &block("<rotate x=\"1\" y=\"0\" z=\"0\" angel=\"90\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        27,
        "<rotate> is missing attribute `angle` (found `angel`: did you mean `angle`?)",
    );
}

#[test]
fn object_type_misspelt_or_in_the_wrong_case_gets_a_suggestion() {
    bad_at(
        &block("<object type=\"Primitive\" name=\"cube\"/>"),
        4,
        9,
        "unknown object type \"Primitive\" (expected primitive, tree or master; did you mean \"primitive\"?)",
    );
    bad_at(&block("<object type=\"mastr\" name=\"m\"/>"), 4, 9, "did you mean \"master\"?");
    let e = bad_at(&block("<object type=\"thing\" name=\"cube\"/>"), 4, 9, "unknown object type \"thing\"");
    assert!(!e.message.contains("did you mean"), "{e}");
}

#[test]
fn what_follows_the_root_element_is_named() {
    let doc = "<scenefile>\n<object type=\"tree\" name=\"root\"/>\n</scenefile>\n";
    bad_at(
        &format!("{doc}<x a=\"1\"/>\n"),
        4,
        1,
        "malformed XML: a second root element <x> after </scenefile>: a scene file has one <scenefile>",
    );
    bad_at(&format!("{doc}  hello\n"), 4, 3, "malformed XML: text \"hello\" after the root element </scenefile>");
    bad_at(&format!("{doc}</scenefile>\n"), 4, 1, "malformed XML: a close tag </scenefile> after the root element");
    // Comments after the root are fine.
    ok(&format!("{doc}<!-- end -->\n"));
    // Inside the root, an unknown token is still reported as one.
    bad_at("<scenefile>\n<!x>\n</scenefile>", 2, 1, "malformed XML: unknown token");
}

#[test]
fn a_lone_carriage_return_ends_a_line() {
    // Old Mac files end lines with CR alone; XML reads it as a line break.
    let cr = "<scenefile>\r\r<cameradata><heightangle v=\"x\"/></cameradata>\r</scenefile>";
    bad_at(cr, 3, 26, "attribute `v` of <heightangle> is \"x\"");
    bad_at(&cr.replace('\r', "\r\n"), 3, 26, "attribute `v` of <heightangle> is \"x\"");
    bad_at(&cr.replacen('\r', "\r\n", 1), 3, 26, "attribute `v` of <heightangle> is \"x\"");
    // Warnings, and the XML parser's own positions.
    let f = ok(&prim("cube", "<glow/>").replace('\n', "\r"));
    warned_at(&f, 5, 1, "<glow>");
    bad_at(
        "<scenefile>\r<object type=\"tree\" name=\"root\">\r<transblock>\r</object>\r</scenefile>",
        4,
        1,
        "found </object> while <transblock> is still open",
    );
    bad_at("<scenefile>\r<object", 2, 8, "malformed XML");
    bad_at("<scenefile>\r<a x=\"1\" x=\"2\"/></scenefile>", 2, 10, "malformed XML: attribute 'x'");
    // Bytes that are not UTF-8.
    let dir = std::env::temp_dir().join(format!("raycast-parse-cr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let latin1 = dir.join("latin1.xml");
    std::fs::write(&latin1, b"<scenefile>\r<!-- caf\xe9 -->\r</scenefile>").unwrap();
    let e = parse_file(&latin1, &opts()).unwrap_err();
    assert_eq!(at(&e), (2, 9), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn singular_transforms_are_errors_at_their_element() {
    bad_at(
        &block("<translate x=\"1\" y=\"0\" z=\"0\"/>\n  <scale x=\"1\" y=\"0\" z=\"1\"/>\n<object type=\"primitive\" name=\"cube\"/>"),
        5,
        3,
        "<scale> has a zero factor (y = 0): the transform is singular",
    );
    // Rotated, so the zero is not on the diagonal of the product.
    bad_at(
        &block("<rotate x=\"1\" y=\"1\" z=\"0\" angle=\"37\"/><scale x=\"0\" y=\"1\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>"),
        4,
        39,
        "<scale> has zero factors (x = 0, z = 0)",
    );
    // In an enclosing transblock.
    bad_at(
        &root("<transblock><scale x=\"0\" y=\"0\" z=\"0\"/><object type=\"tree\">\n<transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>"),
        3,
        13,
        "<scale> has zero factors (x = 0, y = 0, z = 0)",
    );
    // A degenerate shear (dependent columns) in a matrix.
    bad_at(
        &block(
            "<rotate x=\"0\" y=\"1\" z=\"0\" angle=\"10\"/>\n<matrix><row0 v1=\"1\" v2=\"1\" v3=\"0\" v4=\"0\"/><row1 v1=\"1\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
             <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/></matrix><object type=\"primitive\" name=\"cube\"/>",
        ),
        5,
        1,
        "<matrix> is singular",
    );
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
fn misplaced_known_elements_say_where_they_go() {
    let f = ok(&root(
        "<transblock><object type=\"tree\">\n<object type=\"primitive\" name=\"cube\"/>\n\
         <transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>",
    ));
    warned_at(&f, 4, 1, "<object> cannot be inside <object>: objects go in a <transblock>");
    let f = ok(&prim("cube", "<translate x=\"1\" y=\"0\" z=\"0\"/>"));
    warned_at(&f, 5, 1, "<translate> cannot be inside <object>: transforms go in a <transblock>; skipped");
    let f = ok(&block("<diffuse r=\"1\" g=\"0\" b=\"0\"/><object type=\"primitive\" name=\"cube\"/>"));
    warned_at(
        &f,
        4,
        1,
        "<diffuse> cannot be inside <transblock>: material elements go in an <object type=\"primitive\">; skipped",
    );
    let f = ok(&with_top("<cameradata><color r=\"1\" g=\"1\" b=\"1\"/></cameradata>"));
    warned_at(&f, 2, 13, "<color> cannot be inside <cameradata>: it goes in a <lightdata>; skipped");
    let f = ok(&with_top("<transblock/>"));
    warned_at(
        &f,
        2,
        1,
        "<transblock> cannot be at the top level: transblocks go in an <object type=\"tree\">; skipped",
    );
    let f = ok(&with_top("<globaldata><lightdata/></globaldata>"));
    warned_at(&f, 2, 13, "<lightdata> cannot be inside <globaldata>: it goes at the top level, in <scenefile>");
    // Unknown names keep their suggestion.
    let f = ok(&with_top("<lightdata><colour r=\"1\" g=\"1\" b=\"1\"/></lightdata>"));
    warned_at(&f, 2, 12, "unknown element <colour> in <lightdata> (did you mean <color>?); skipped");
}

#[test]
fn matrix_last_row_is_ignored_with_a_warning() {
    let rows = |row3: &str| {
        block(&format!(
            "<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"5\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
             <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/>\n  <row3 {row3}/></matrix>\
             <object type=\"primitive\" name=\"cube\"/>"
        ))
    };
    let affine = DMat4::from_translation(DVec3::new(5.0, 0.0, 0.0));
    for (row3, shown) in [
        ("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"2\"", "0 0 0 2"),
        ("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"0\"", "0 0 0 0"),
        ("a=\"0.5\" b=\"0\" c=\"1\" d=\"1\"", "0.5 0 1 1"),
    ] {
        let f = ok(&rows(row3));
        warned_at(
            &f,
            5,
            3,
            &format!(
                "<matrix> row3 is {shown}, not 0 0 0 1: raycast's transforms are affine; the last row is ignored (taken as 0 0 0 1)"
            ),
        );
        let b = &f.trees[f.root].blocks[0];
        assert_eq!(b.matrix, affine, "{row3}");
        assert_eq!(b.transforms, vec![Transform::Matrix(Box::new(affine))]);
    }
    let f = ok(&rows("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\""));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
}

#[test]
fn elements_raycast_does_not_render_are_noted() {
    let f = ok(&prim(
        "sphere",
        "<transparent r=\"0.5\" g=\"0.5\" b=\"0.5\"/>\n<ior v=\"1.5\"/>\n<bumpmap file=\"bump.png\"/>",
    ));
    // Transparency and refraction are drawn (docs/scene-format.md#refraction).
    warned_at(&f, 7, 1, "raycast does no bump mapping; <bumpmap> is ignored");
    assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
    // Values that change nothing are not worth a word.
    let f = ok(&prim("sphere", "<transparent r=\"0\" g=\"0\" b=\"0\"/><ior v=\"1.33\"/>"));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let f = camera("<aperture v=\"0.08\"/>\n<focallength v=\"15\"/>\n<aspectratio v=\"1.5\"/>").unwrap();
    warned_at(
        &f,
        5,
        1,
        "raycast takes the aspect ratio from the picture's size (--width and --height); <aspectratio> is ignored",
    );
    // Depth of field: the course's renders draw none either (corpus
    // files carry an aperture), so no word.
    assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
    let f = ok(&with_top("<globaldata><transparentcoeff v=\"0.3\"/></globaldata>"));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    assert_eq!(f.globals.kt, 0.3);
}

/// Refraction's inputs: `<transparent>`, `<ior>` and `<transparentcoeff>`
/// are read as written; an index of refraction must be above 0 (NaN,
/// infinity and a number 32-bit floats cannot hold are refused as for
/// every number).
#[test]
fn refraction_inputs_and_bad_indices_of_refraction() {
    let f = ok(&prim("sphere", "<transparent r=\"0.8\" g=\"0.6\" b=\"0.4\"/><ior v=\"1.5\"/>"));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    let (_, m) = first_prim(&f);
    assert_eq!((m.transparent, m.ior), ([0.8, 0.6, 0.4], 1.5));
    // An index below 1 (a medium faster than air) is taken.
    assert_eq!(first_prim(&ok(&prim("sphere", "<ior v=\"0.5\"/>"))).1.ior, 0.5);
    for (v, shown) in [("0", "0"), ("-1.5", "-1.5"), ("-0", "-0"), ("1e-50", "0")] {
        let xml = prim("sphere", &format!("<ior v=\"{v}\"/>"));
        bad_at_str(&xml, &format!("v=\"{v}\""), &format!("<ior> is {shown} (expected an index of refraction above 0"));
    }
    for v in ["NaN", "inf", "1e39"] {
        let xml = prim("sphere", &format!("<ior v=\"{v}\"/>"));
        let e = bad(&xml);
        assert_eq!(at(&e).0, 5, "{e}");
    }
    // The course's empty number reads as 0, which no index can be.
    let xml = prim("sphere", "<ior v=\"\"/>");
    bad_at_str(&xml, "v=\"\"", "<ior> is 0");
    let e = bad(&prim("sphere", "<transparent r=\"0.5\" g=\"x\" b=\"0.5\"/>"));
    assert_eq!(at(&e).0, 5, "{e}");
}

#[test]
fn an_area_light_needs_a_positive_width_height_and_direction() {
    let area = |rest: &str| light(&format!("<type v=\"area\"/>\n{rest}"));
    let f = area("<direction x=\"0\" y=\"-1\" z=\"0\"/><width v=\"2\"/><height v=\"0.5\"/>").unwrap();
    let l = &f.lights[0];
    assert_eq!((l.kind, l.width, l.height), (LightKind::Area, 2.0, 0.5));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    // Missing: named at the <lightdata>.
    for (rest, missing) in [
        ("<direction x=\"0\" y=\"-1\" z=\"0\"/><height v=\"1\"/>", "<width>"),
        ("<direction x=\"0\" y=\"-1\" z=\"0\"/><width v=\"1\"/>", "<height>"),
        ("<width v=\"1\"/><height v=\"1\"/>", "<direction>"),
    ] {
        let e = area(rest).unwrap_err();
        assert_eq!(at(&e), (2, 1), "{e}");
        assert!(e.message.contains(&format!("an area light has no {missing}")), "{e}");
    }
    let e = area("<direction x=\"0\" y=\"0\" z=\"0\"/><width v=\"1\"/><height v=\"1\"/>").unwrap_err();
    assert!(e.message.contains("an area light's <direction> is the zero vector"), "{e}");
    // Bad sizes: named at the value.
    for (v, says) in [
        ("-1", "an area light's <width> is -1 (expected a positive size in world units)"),
        ("0", "an area light's <width> is 0 (expected a positive size in world units)"),
        ("nan", "is \"nan\" (expected a finite number)"),
        ("1e39", "too large"),
    ] {
        let e =
            area(&format!("<direction x=\"0\" y=\"-1\" z=\"0\"/>\n<width v=\"{v}\"/><height v=\"1\"/>")).unwrap_err();
        assert_eq!(at(&e), (5, 8), "{v}: {e}");
        assert!(e.message.contains(says), "{v}: {e}");
    }
}

#[test]
fn a_lens_needs_a_size_of_0_or_more_and_a_distance_in_focus() {
    let f = camera("<aperture v=\"0.008\"/>\n<focallength v=\"3\"/>").unwrap();
    assert_eq!((f.camera.aperture, f.camera.focal_length), (Some(0.008), Some(3.0)));
    assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    // An aperture of 0 is a pinhole and needs no focal length.
    let f = camera("<aperture v=\"0\"/>").unwrap();
    assert_eq!(f.camera.aperture, Some(0.0));
    let e = camera("<aperture v=\"0.1\"/>").unwrap_err();
    assert_eq!(at(&e), (3, 1), "{e}");
    assert!(e.message.contains("<aperture> without a <focallength>"), "{e}");
    for (element, v, says) in [
        ("aperture", "-0.5", "<aperture> is -0.5 (expected a lens size of 0 or more, 0 for a pinhole)"),
        ("focallength", "0", "<focallength> is 0 (expected the positive distance in focus, in world units)"),
        ("focallength", "-2", "<focallength> is -2 (expected the positive distance in focus"),
        ("focallength", "nan", "is \"nan\" (expected a finite number)"),
    ] {
        let e = camera(&format!("<aperture v=\"1\"/>\n<{element} v=\"{v}\"/>")).unwrap_err();
        assert_eq!(at(&e).0, 4, "{element} {v}: {e}");
        assert!(e.message.contains(says), "{element} {v}: {e}");
    }
}
