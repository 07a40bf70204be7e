//! Each variant found in a picture drawn with it; a picture drawn right
//! gives no finding; the regions and the legend.

use super::*;
use crate::cpu::CpuRenderer;
use crate::frame::RenderSettings;

/// The default scene with a textured, scaled cube (so that every variant
/// has something to change), at 96x72.
fn scene() -> (Scene, FrameData) {
    let dir = std::env::temp_dir().join(format!("raycast-explain-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // A texture that is not the same mirrored either way.
    let data = (0..8 * 8).flat_map(|i| [(i * 31 % 256) as u8, (i * 7 % 256) as u8, (255 - i * 3) as u8]).collect();
    crate::image_io::write_png(&dir.join("t.png"), &Rgb8 { width: 8, height: 8, data }).unwrap();
    let xml = crate::source::DEFAULT_SCENE.replace(
        r#"<object type="primitive" name="cube">"#,
        r#"<object type="primitive" name="cube"><texture file="t.png" u="2" v="1"/><blend v="0.6"/>"#,
    );
    assert_ne!(xml, crate::source::DEFAULT_SCENE);
    let path = dir.join("s.xml");
    std::fs::write(&path, xml).unwrap();
    let scene = crate::scene::load(&path, &crate::scene::ParseOptions::default(), &Default::default()).unwrap();
    let settings = RenderSettings { width: 96, height: 72, ..RenderSettings::default() };
    let data = crate::frame::build(&scene, &settings).unwrap();
    (scene, data)
}

fn picture(data: &FrameData, cpu: &CpuRenderer) -> Rgb8 {
    cpu.render(data).unwrap().rgb8().unwrap()
}

/// Every variant that applies to the scene, drawn and explained, is the top
/// finding (or drawn the same as the one found); the scene as it is, none.
/// Rule: the cause, for every variant.
#[test]
fn each_variant_is_found_in_its_own_picture() {
    let (scene, data) = scene();
    let cpu = CpuRenderer::new().unwrap();
    let right = explain(&scene, &data, &picture(&data, &cpu), &cpu, Rule::default(), &|_, _| {}).unwrap();
    assert!(right.passes && right.findings.is_empty() && right.differing == 0, "{right:?}");
    let mut missed = Vec::new();
    for v in VARIANTS.iter().filter(|v| (v.applies)(&data)) {
        let mut wrong = data.clone();
        (v.apply)(&mut wrong);
        let mine = picture(&wrong, &cpu);
        let e = explain(&scene, &data, &mine, &cpu, Rule::default(), &|_, _| {}).unwrap();
        if e.passes {
            // Below the tolerance everywhere: the rounding alone may be.
            assert!(v.id == "rounded" || e.differing == 0, "{}: {e:?}", v.id);
            continue;
        }
        let top = e.findings.first();
        if !top.is_some_and(|f| f.cause == v.id || f.also.iter().any(|a| a == v.id)) {
            missed.push(format!("{}: {:?}", v.id, e.findings.iter().map(|f| &f.cause).collect::<Vec<_>>()));
        }
    }
    assert!(missed.is_empty(), "variants not found first in their own pictures: {missed:#?}");
}

/// A picture with a primitive left black where the scene has it: missing
/// geometry, on that primitive's shape, off its silhouette.
#[test]
fn background_where_a_surface_is_is_missing_geometry() {
    let (scene, data) = scene();
    let cpu = CpuRenderer::new().unwrap();
    let reference = cpu.render(&data).unwrap();
    let mut mine = reference.rgb8().unwrap();
    let sphere = (0..reference.pixels.len())
        .filter(|&i| scene.primitive(u64::from(reference.pixels[i].id)).is_some_and(|p| p.shape.name() == "sphere"))
        .collect::<Vec<_>>();
    assert!(sphere.len() > 50, "the sphere is in the picture");
    for &i in &sphere {
        mine.data[i * 3..][..3].copy_from_slice(&[0, 0, 0]);
    }
    let e = explain(&scene, &data, &mine, &cpu, Rule::default(), &|_, _| {}).unwrap();
    let top = &e.findings[0];
    assert_eq!(top.cause, "missing-geometry", "{e:?}");
    assert_eq!((top.on[0].shape.as_str(), top.on[0].part.as_str()), ("sphere", ""), "{e:?}");
    // The annotated picture: the size and a legend below, the finding's pixels in its colour.
    let a = annotated(&mine, &e);
    assert_eq!(a.width, 96);
    assert!(a.height > 72);
    let i = sphere[sphere.len() / 2];
    assert_eq!(&a.data[i * 3..][..3], &[230, 25, 75]);
}

/// Light that does not arrive. The scene's first light dark on every
/// other pixel it lights (a checkerboard: speckle) is shadow acne; dark
/// on a solid block of them, shadows where nothing blocks it; dark
/// everywhere, that light left out (the candidate raycast draws without
/// it). Rule: the top finding's cause.
#[test]
fn light_that_does_not_arrive_is_told_by_its_pattern() {
    let (scene, data) = scene();
    let cpu = CpuRenderer::new().unwrap();
    let ours = picture(&data, &cpu);
    let mut dark = data.clone();
    dark.lights[0].color = [0.0; 4];
    let without = picture(&dark, &cpu);
    let (w, h) = (ours.width as usize, ours.height as usize);
    let lit: Vec<usize> = (0..w * h).filter(|&i| ours.data[i * 3..][..3] != without.data[i * 3..][..3]).collect();
    assert!(lit.len() > 500, "the first light lights {} pixels", lit.len());
    let top = |dark_at: &dyn Fn(usize) -> bool| {
        let mut mine = ours.clone();
        for &i in lit.iter().filter(|&&i| dark_at(i)) {
            mine.data[i * 3..][..3].copy_from_slice(&without.data[i * 3..][..3]);
        }
        let e = explain(&scene, &data, &mine, &cpu, Rule::default(), &|_, _| {}).unwrap();
        e.findings.first().map(|f| (f.cause.clone(), f.what.clone())).unwrap_or_default()
    };
    let (cause, _) = top(&|i| (i % w + i / w).is_multiple_of(2));
    assert_eq!(cause, "shadow-acne");
    let (cause, _) = top(&|i| i / w < h / 2);
    assert_eq!(cause, "extra-shadows");
    let (cause, what) = top(&|_| true);
    assert_eq!(cause, "no-light");
    assert!(what.contains("light at") && what.contains("s.xml"), "{what}");
}

/// Mirror acne: a reflective sphere's pixels off on a checkerboard (speckle
/// among right pixels of the same surface) is mirror acne; the same pixels
/// off as one block are not. Rule: the top finding's cause.
#[test]
fn speckled_reflections_are_mirror_acne() {
    let dir = std::env::temp_dir().join(format!("raycast-explain-mirror-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let xml = crate::source::DEFAULT_SCENE.replace(
        r#"<object type="primitive" name="sphere">"#,
        r#"<object type="primitive" name="sphere"><reflective r="0.5" g="0.5" b="0.5"/>"#,
    );
    assert_ne!(xml, crate::source::DEFAULT_SCENE);
    std::fs::write(dir.join("m.xml"), xml).unwrap();
    let scene = crate::scene::load(&dir.join("m.xml"), &Default::default(), &Default::default()).unwrap();
    let settings = RenderSettings { width: 192, height: 144, ..RenderSettings::default() };
    let data = crate::frame::build(&scene, &settings).unwrap();
    let cpu = CpuRenderer::new().unwrap();
    let reference = cpu.render(&data).unwrap();
    let ours = reference.rgb8().unwrap();
    let w = ours.width as usize;
    let sphere: Vec<usize> = (0..reference.pixels.len())
        .filter(|&i| scene.primitive(u64::from(reference.pixels[i].id)).is_some_and(|p| p.shape.name() == "sphere"))
        .collect();
    assert!(sphere.len() > 50, "the sphere is in the picture");
    let top = |off: &dyn Fn(usize) -> bool| {
        let mut mine = ours.clone();
        for &i in sphere.iter().filter(|&&i| off(i)) {
            for c in &mut mine.data[i * 3..][..3] {
                *c = c.saturating_add(60);
            }
        }
        let e = explain(&scene, &data, &mine, &cpu, Rule::default(), &|_, _| {}).unwrap();
        e.findings.first().map(|f| f.cause.clone()).unwrap_or_default()
    };
    assert_eq!(top(&|i| (i % w + i / w).is_multiple_of(2)), "mirror-acne");
    assert_ne!(top(&|_| true), "mirror-acne");
}

/// A gamma correction of 2.2 over raycast's picture is a tone curve of
/// power 0.45. Rule: the top finding's cause and its fitted power.
#[test]
fn a_gamma_correction_is_a_tone_curve() {
    let (scene, data) = scene();
    let cpu = CpuRenderer::new().unwrap();
    let mut mine = picture(&data, &cpu);
    for c in &mut mine.data {
        *c = (255.0 * (f64::from(*c) / 255.0).powf(1.0 / 2.2)).floor() as u8;
    }
    let e = explain(&scene, &data, &mine, &cpu, Rule::default(), &|_, _| {}).unwrap();
    let top = e.findings.first().expect("a finding");
    assert_eq!(top.cause, "tone-curve", "{e:?}");
    // Fitted to a curve put over 8-bit values (the mistake puts it over the
    // colour before they are taken): about 1 / 2.2.
    let power: f64 = top.what.split("power ").nth(1).and_then(|w| w[..4].parse().ok()).expect("a power");
    assert!((power - 1.0 / 2.2).abs() <= 0.02, "{}", top.what);
}
