//! Tests of camera.rs.

use super::*;

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
