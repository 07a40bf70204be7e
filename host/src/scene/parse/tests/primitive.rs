//! Tests of primitive.rs: shapes, meshes and materials.

use super::*;

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
