//! Tests of light.rs.

use super::*;

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
