//! Tests of names.rs: suggestions for misspelt names, unknown and misplaced
//! elements and attributes.

use super::*;
use crate::scene::parse::names::{edit_distance, suggest};

#[test]
fn edit_distance_and_suggestions() {
    assert_eq!(edit_distance("typr", "type"), 1);
    assert_eq!(edit_distance("", "abc"), 3);
    // Case aside, and a swap of two letters is two edits (Levenshtein's, not Damerau's).
    assert_eq!(edit_distance("Type", "tYPE"), 0);
    assert_eq!(edit_distance("clyinder", "cylinder"), 2);
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
