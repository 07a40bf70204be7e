//! Tests of values.rs: missing attributes and bad numbers, each an error at
//! its place.

use super::*;

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
