//! Tests of tree.rs: transforms, matrices, transblocks, trees and masters.

use super::*;

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
