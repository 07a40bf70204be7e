//! The CPU build against itself and against what its pictures must hold.

use super::ffi::{buffer_pointers, has_avx2, BuildCopy};
use super::*;
use crate::render::Specialization;

#[test]
fn cpp_layouts_match_the_host() {
    check_layouts().unwrap();
}

/// Every copy of the C++ build draws the same bits: the whole one (in
/// the device's walk order), the lean one (in its own order, the record
/// columns read four at a time) and, where the CPU has AVX2, the lean
/// one's AVX2 build (eight at a time). Over instances bounded by spheres
/// (recursive spheres) and by boxes (recursive cubes, cones), the ties
/// scene, where the order the walk meets hits in matters most, and
/// leaves of box and sphere records together (divergent lanes), with
/// shadows and mirrors. Rule: every pixel's PixelOut, bit for bit.
#[test]
fn every_copy_draws_the_same_bits() {
    use crate::gen::{generate, Family, GenOptions};
    let stress = |name: &str| {
        let path = format!("{}/../tests/scenes/stress/{name}", env!("CARGO_MANIFEST_DIR"));
        let limits = crate::scene::FlattenLimits::default();
        crate::scene::load(path.as_ref(), &crate::scene::ParseOptions::default(), &limits).unwrap()
    };
    let untextured = GenOptions { texture: None };
    let generated = |family, depth| crate::scene::from_xml(generate(family, depth, &untextured).unwrap(), "gen.xml");
    let scenes = [
        ("recursive spheres 5", generated(Family::RecursiveSpheres, 5)),
        ("recursive cubes 4", generated(Family::RecursiveCubes, 4)),
        ("recursive cones 4", generated(Family::RecursiveCones, 4)),
        ("ties", stress("ties.xml")),
        // Box and sphere records in one leaf: records_meet's lanes and its scalar tests.
        ("divergent lanes", stress("divergent_lanes.xml")),
    ];
    let mut copies = vec![BuildCopy::Lean];
    if has_avx2() {
        copies.push(BuildCopy::LeanAvx2);
    } else {
        eprintln!("every_copy_draws_the_same_bits: no AVX2 on this CPU, its build not compared");
    }
    for (name, scene) in scenes {
        let settings = crate::frame::RenderSettings { width: 96, height: 72, ..Default::default() };
        let data = crate::frame::build(&scene, &settings).unwrap();
        assert!(Specialization::of(&data, &data.frame).cpu_lean(), "{name}: the lean copies draw it");
        let buffers = buffer_pointers(&data);
        let draw = |copy: BuildCopy| {
            let mut pixels = vec![PixelOut::default(); (data.frame.width * data.frame.height) as usize];
            // SAFETY: as in `CpuRenderer::run`; `pixels` holds every row.
            unsafe { (copy.row_loops().0)(buffers.as_ptr(), 0, data.frame.height, pixels.as_mut_ptr().cast()) };
            pixels
        };
        let whole = draw(BuildCopy::Whole);
        for &copy in &copies {
            let pixels = draw(copy);
            let differ: Vec<usize> =
                (0..whole.len()).filter(|&k| bytemuck::bytes_of(&pixels[k]) != bytemuck::bytes_of(&whole[k])).collect();
            assert!(
                differ.is_empty(),
                "{name}: {copy:?} differs from the whole copy at {} of {} pixels; the first, pixel {}: {:?} against {:?}",
                differ.len(),
                whole.len(),
                differ[0],
                pixels[differ[0]],
                whole[differ[0]]
            );
        }
    }
}

/// The camera between two facing mirrors (wide mirror cubes at z = -5
/// and z = +5) with `second` as its second light: every camera ray
/// bounces to the depth limit.
fn mirrors(second: &str) -> crate::scene::Scene {
    let xml = format!(
        r#"<scenefile>
  <globaldata><ambientcoeff v="0.5"/><diffusecoeff v="0.5"/><specularcoeff v="0.5"/></globaldata>
  <cameradata><pos x="0" y="0" z="0"/><look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="30"/></cameradata>
  <lightdata><id v="0"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="2" z="0"/></lightdata>
  {second}
  <object type="tree" name="root">
<transblock><translate x="0" y="0" z="-5"/><scale x="40" y="40" z="1"/>
  <object type="primitive" name="cube"><diffuse r="1" g="1" b="1"/><reflective r="1" g="1" b="1"/></object></transblock>
<transblock><translate x="0" y="0" z="5"/><scale x="40" y="40" z="1"/>
  <object type="primitive" name="cube"><diffuse r="1" g="1" b="1"/><reflective r="1" g="1" b="1"/></object></transblock>
  </object>
</scenefile>"#
    );
    crate::scene::from_xml(xml, "mirrors.xml")
}

/// Two point lights between the mirrors light both faces: every pixel
/// traces 1 camera ray + (depth + 1) shaded hits x 2 shadow rays +
/// depth mirror rays. A directional light along the mirrors (n . l = 0,
/// no specular) adds nothing anywhere, so it gets no shadow ray: one per
/// hit. Rule: exact count in every pixel.
#[test]
fn pixels_count_camera_shadow_and_mirror_rays() {
    let renderer = CpuRenderer::new().unwrap();
    let depth = 4;
    let point = r#"<lightdata><id v="1"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="-2" z="0"/></lightdata>"#;
    let grazing = r#"<lightdata><id v="1"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="-1" z="0"/></lightdata>"#;
    for (second, shadows, reflections, want) in [
        (point, true, true, 1 + (depth + 1) * 2 + depth),
        (point, false, true, 1 + depth),
        (point, true, false, 1 + 2),
        (grazing, true, true, 1 + (depth + 1) + depth),
    ] {
        let settings = crate::frame::RenderSettings {
            width: 16,
            height: 12,
            shadows,
            reflections,
            max_depth: depth,
            ..Default::default()
        };
        let picture = renderer.render(&crate::frame::build(&mirrors(second), &settings).unwrap()).unwrap();
        let wrong: Vec<(usize, u32)> =
            picture.pixels.iter().enumerate().filter(|(_, p)| p.rays != want).map(|(i, p)| (i, p.rays)).collect();
        assert!(
            wrong.is_empty(),
            "shadows {shadows}, reflections {reflections}: {} of {} pixels do not count {want} rays; first (pixel, rays) {:?}, all {:?}",
            wrong.len(),
            picture.pixels.len(),
            wrong.first(),
            wrong
        );
    }
}

/// `trace` follows the render: for every pixel of the mirrors (every
/// ray bouncing to the depth limit, two shadowed lights) and of the
/// embedded default scene (shadows cast, a spot light) and of glass (a
/// refracting sphere and cube, total internal reflection), at one sample a
/// pixel its last step holds the pixel's 8-bit colour, its ray steps are
/// the pixel's ray count and its camera ray's hit is the pixel's (id and
/// t bits); at two, the samples' rays add up to the pixel's. Each light
/// whose shadow ray decides is followed by that shadow ray. Rule: exact,
/// every pixel.
#[test]
fn the_trace_of_every_pixel_is_its_render() {
    use crate::layout::{TRACE_CAMERA, TRACE_LIGHT, TRACE_LIGHT_SHADOW, TRACE_PIXEL, TRACE_SHADOW};
    let renderer = CpuRenderer::new().unwrap();
    let point = r#"<lightdata><id v="1"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="-2" z="0"/></lightdata>"#;
    let default = crate::scene::from_xml(crate::source::DEFAULT_SCENE, "default.xml");
    let glass = crate::scene::from_xml(
        r#"<scenefile><globaldata><transparentcoeff v="0.9"/></globaldata>
          <cameradata><pos x="0" y="1" z="3"/><focus x="0" y="0" z="0"/></cameradata>
          <lightdata><type v="directional"/><direction x="-1" y="-2" z="-1"/></lightdata>
          <object type="tree" name="root">
            <transblock><translate x="0" y="-1" z="0"/><scale x="6" y="0.2" z="6"/><object type="primitive" name="cube"><diffuse r="0.8" g="0.5" b="0.2"/><reflective r="0.3" g="0.3" b="0.3"/></object></transblock>
            <transblock><translate x="-0.6" y="0" z="0"/><object type="primitive" name="sphere"><diffuse r="0.1" g="0.1" b="0.2"/><reflective r="0.2" g="0.2" b="0.2"/><transparent r="0.9" g="0.9" b="1"/><ior v="1.5"/></object></transblock>
            <transblock><translate x="0.6" y="0" z="0"/><rotate x="0" y="1" z="0" angle="30"/><object type="primitive" name="cube"><diffuse r="0" g="0.2" b="0"/><transparent r="0.8" g="1" b="0.8"/><ior v="2"/></object></transblock>
          </object></scenefile>"#,
        "glass.xml",
    );
    for (name, scene) in [("mirrors", mirrors(point)), ("default", default), ("glass", glass)] {
        for spp in [1, 2] {
            let settings = crate::frame::RenderSettings { width: 24, height: 18, spp, ..Default::default() };
            let data = crate::frame::build(&scene, &settings).unwrap();
            let picture = renderer.render(&data).unwrap();
            for (k, pixel) in picture.pixels.iter().enumerate() {
                let (x, y) = (k as u32 % 24, k as u32 / 24);
                let mut rays = 0;
                for sample in 0..spp {
                    let steps = renderer.trace(&data, &data.frame, x, y, sample).unwrap();
                    rays += steps.iter().filter(|s| s.is_ray()).count() as u32;
                    for pair in steps.windows(2) {
                        if pair[0].kind == TRACE_LIGHT && pair[0].id == TRACE_LIGHT_SHADOW {
                            assert!(
                                pair[1].kind == TRACE_SHADOW && pair[1].light == pair[0].light,
                                "{name} ({x}, {y}): {steps:?}"
                            );
                        }
                    }
                    let last = steps.last().expect("a step");
                    assert_eq!(last.kind, TRACE_PIXEL, "{name} ({x}, {y})");
                    if spp == 1 {
                        assert_eq!(last.id, pixel.rgba, "{name} ({x}, {y}): the 8-bit colour");
                        let camera = &steps[0];
                        assert_eq!(camera.kind, TRACE_CAMERA, "{name} ({x}, {y})");
                        assert_eq!(camera.id, pixel.id, "{name} ({x}, {y})");
                        if camera.id != layout::NO_HIT {
                            assert_eq!(camera.value[3].to_bits(), pixel.t.to_bits(), "{name} ({x}, {y}): t");
                        }
                    }
                }
                assert_eq!(rays, pixel.rays, "{name} ({x}, {y}), {spp} samples: the rays");
            }
        }
    }
    let data = crate::frame::build(&mirrors(point), &Default::default()).unwrap();
    assert!(renderer
        .trace(&data, &data.frame, 512, 0, 0)
        .unwrap_err()
        .to_string()
        .contains("outside the 512x384 picture"));
    assert!(renderer
        .trace(&data, &data.frame, 0, 0, 1)
        .unwrap_err()
        .to_string()
        .contains("sample 1 is not one of the pixel's 1"));
}

/// Two spheres in front of the camera: A (id 0, radius 1) at the
/// origin, 4 from the eye along the centre pixel's ray; B (id 1) higher
/// up, 5 behind it.
fn two_spheres() -> crate::scene::Scene {
    let xml = r#"<scenefile>
  <cameradata><pos x="0" y="0" z="5"/><look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="30"/></cameradata>
  <lightdata><id v="0"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="0" z="-1"/></lightdata>
  <object type="tree" name="root">
<transblock><scale x="2" y="2" z="2"/><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/></object></transblock>
<transblock><translate x="0" y="2" z="-5"/><scale x="2" y="2" z="2"/><object type="primitive" name="sphere"><diffuse r="0" g="1" b="0"/></object></transblock>
  </object>
</scenefile>"#;
    crate::scene::from_xml(xml, "two.xml")
}

/// raycast.glsl heat_color, quantised as pack_rgba8, as written here.
fn heat(x: f32) -> [u8; 3] {
    let s = 4.0 * x.clamp(0.0, 1.0);
    [3.0f32, 2.0, 1.0].map(|c| ((1.5 - (s - c).abs()).clamp(0.0, 1.0) * 255.0).floor() as u8)
}

fn rgb(p: &crate::layout::PixelOut) -> [u8; 3] {
    let b = p.rgba.to_le_bytes();
    [b[0], b[1], b[2]]
}

/// The AOVs show the first hit (the CPU build runs the kernels' code;
/// the check suite holds the device to it bit for bit). Rules, exact:
/// misses black; the normal AOV of the centre pixel (normal +z) is
/// floor(255 (n + 1) / 2); the depth AOV with --depth-range 3.75,4.75 of
/// the centre pixel (distance 4) is floor(255 * 3 / 4), and with the
/// default range A is lighter than B; the id AOV of every hit pixel is
/// its id's colour as written here (the hash of raycast.glsl id_color),
/// and both spheres appear.
#[test]
fn aovs_show_the_first_hit() {
    use crate::frame::{build, Aov, RenderSettings};
    let renderer = CpuRenderer::new().unwrap();
    let scene = two_spheres();
    let (w, h) = (33u32, 33u32);
    let at = |x: u32, y: u32| (y * w + x) as usize;
    let (centre, corner) = (at(16, 16), at(0, 32));
    let render = |aov: Aov, depth_range: Option<[f32; 2]>| {
        let settings = RenderSettings { width: w, height: h, aov, depth_range, ..RenderSettings::default() };
        settings.validate().unwrap();
        renderer.render(&build(&scene, &settings).unwrap()).unwrap()
    };
    // Where B shows: the pixels whose first hit is id 1.
    let ids = render(Aov::Id, None);
    let b_pixel = ids.pixels.iter().position(|p| p.id == 1).expect("sphere B is in the picture");
    assert_eq!(ids.pixels[centre].id, 0, "the centre pixel sees sphere A");

    let normal = render(Aov::Normal, None);
    assert_eq!(rgb(&normal.pixels[centre]), [127, 127, 255], "normal AOV, centre pixel");
    assert_eq!(rgb(&normal.pixels[corner]), [0, 0, 0], "normal AOV, a miss");

    let depth = render(Aov::Depth, Some([3.75, 4.75]));
    assert_eq!(rgb(&depth.pixels[centre]), [191, 191, 191], "depth AOV 3.75..4.75, distance 4: 1 - 1/4");
    assert_eq!(rgb(&depth.pixels[corner]), [0, 0, 0], "depth AOV, a miss");
    let auto = render(Aov::Depth, None);
    let (a, b) = (rgb(&auto.pixels[centre])[0], rgb(&auto.pixels[b_pixel])[0]);
    assert!(a > b && b > 0, "default depth range: A ({a}) lighter than B ({b}), B not black");

    let id_color = |id: u32| -> [u8; 3] {
        let mut hash = id.wrapping_add(1).wrapping_mul(2654435761);
        hash ^= hash >> 15;
        [0, 8, 16].map(|s| (((((hash >> s) & 255) as f32 / 255.0) * 0.75 + 0.25) * 255.0).floor() as u8)
    };
    let wrong: Vec<(usize, u32, [u8; 3])> = ids
        .pixels
        .iter()
        .enumerate()
        .filter(|(_, p)| rgb(p) != if p.id == crate::layout::NO_HIT { [0, 0, 0] } else { id_color(p.id) })
        .map(|(i, p)| (i, p.id, rgb(p)))
        .collect();
    assert!(
        wrong.is_empty(),
        "id AOV: {} of {} pixels not their id's colour; first (pixel, id, rgb) {:?}",
        wrong.len(),
        ids.pixels.len(),
        wrong.first()
    );
    assert_ne!(id_color(0), id_color(1), "the two spheres' colours");
}

/// The cost AOV: every pixel's colour is heat(passes / cost_max) for a
/// whole number of passes (the scale of raycast.glsl heat_color, as
/// written here), misses included, one for a ray that meets no box;
/// without the hierarchy's boxes no
/// pixel's walk is shorter and the picture's is longer; with
/// --cost-max 1 every walk of a pass or more is dark red; PixelOut.normal's
/// w holds the same counts. Rules, exact.
#[test]
fn cost_aov_counts_the_walk() {
    use crate::frame::{build, Aov, RenderSettings};
    let cubes: String = (0..20)
        .map(|i| {
            format!(
                r#"<transblock><translate x="{}" y="0" z="0"/><object type="primitive" name="cube"/></transblock>"#,
                i - 10
            )
        })
        .collect();
    let xml = format!(
        r#"<scenefile>
  <cameradata><pos x="0" y="2" z="12"/><look x="0" y="-0.2" z="-1"/><up x="0" y="1" z="0"/><heightangle v="60"/></cameradata>
  <object type="tree" name="root">{cubes}</object>
</scenefile>"#
    );
    let scene = crate::scene::from_xml(xml, "row.xml");
    let renderer = CpuRenderer::new().unwrap();
    let render = |bvh: bool, cost_max: Option<u32>| {
        let settings =
            RenderSettings { width: 48, height: 32, aov: Aov::Cost, bvh, cost_max, ..RenderSettings::default() };
        settings.validate().unwrap();
        renderer.render(&build(&scene, &settings).unwrap()).unwrap()
    };
    let max = 64u32;
    let passes = |picture: &crate::render::Picture| -> Vec<u32> {
        picture
            .pixels
            .iter()
            .enumerate()
            .map(|(i, p)| {
                (0..=max)
                    .find(|&n| heat(n as f32 / max as f32) == rgb(p))
                    .unwrap_or_else(|| panic!("pixel {i}: {:?} is no whole number of passes on the scale", rgb(p)))
            })
            .collect()
    };
    let picture = render(true, None);
    let with = passes(&picture);
    let without = passes(&render(false, None));
    // The passes also come back as numbers (PixelOut.normal's w), the same as the colours say.
    let counted: Vec<u32> = picture.pixels.iter().map(|p| p.normal[3] as u32).collect();
    assert_eq!(counted, with, "normal.w against the colours");
    assert!(
        picture.passes_text("x").contains(&format!("most {}", with.iter().max().unwrap())),
        "{}",
        picture.passes_text("x")
    );
    assert!(with.iter().all(|&n| n >= 1), "every camera ray walks a pass or more");
    // The top-left pixel looks above the row: its walk pops the root,
    // meets neither child's box, and ends.
    assert_eq!(with[0], 1, "a ray that meets no box: the root's pass alone");
    let shorter: Vec<usize> = (0..with.len()).filter(|&i| without[i] < with[i]).collect();
    assert!(shorter.is_empty(), "{} pixels walk less without the boxes; first {:?}", shorter.len(), shorter.first());
    let (a, b) = (with.iter().sum::<u32>(), without.iter().sum::<u32>());
    assert!(b > a, "without the boxes the walks are longer: {b} passes against {a}");
    let one = render(true, Some(1));
    assert!(one.pixels.iter().all(|p| rgb(p) == [127, 0, 0]), "--cost-max 1: every pixel dark red");
}

/// The cost of all a pixel's rays (AOV_COST_ALL): without shadows and
/// mirrors it is the camera ray's alone, pixel for pixel; with shadows
/// never less, and more where a shadow ray is traced; its colour is
/// heat(total / 256) of the total in PixelOut.normal's w. Rules, exact.
#[test]
fn cost_all_sums_every_rays_walk() {
    use crate::frame::{build, Aov, RenderSettings};
    let renderer = CpuRenderer::new().unwrap();
    let scene = two_spheres();
    let render = |aov: Aov, shadows: bool| {
        let settings = RenderSettings { width: 33, height: 33, aov, shadows, ..RenderSettings::default() };
        renderer.render(&build(&scene, &settings).unwrap()).unwrap()
    };
    let w = |p: &crate::render::Picture| p.pixels.iter().map(|p| p.normal[3] as u32).collect::<Vec<u32>>();
    let camera = w(&render(Aov::Cost, true));
    assert_eq!(w(&render(Aov::CostAll, false)), camera, "no shadow rays, no mirrors: the camera ray's walk alone");
    let all = render(Aov::CostAll, true);
    let totals = w(&all);
    assert!(totals.iter().zip(&camera).all(|(t, c)| t >= c), "a pixel's rays walk no less than its camera ray");
    let more = totals.iter().zip(&camera).filter(|(t, c)| t > c).count();
    assert!(more > 0, "shadow rays walk too");
    for (i, p) in all.pixels.iter().enumerate() {
        assert_eq!(rgb(p), heat(totals[i] as f32 / 256.0), "pixel {i}: total {}", totals[i]);
    }
}

/// The lanes AOV splits CostAll's passes by kind of ray: camera (Cost's
/// count), shadow and the rest, summing to CostAll's; its colour is
/// CostAll's; bytes fetched are whole structs and grow with the walk.
/// Rule: exact.
#[test]
fn lanes_split_every_rays_walk() {
    use crate::frame::{build, Aov, RenderSettings};
    let renderer = CpuRenderer::new().unwrap();
    let scene = two_spheres();
    let render = |aov: Aov| {
        let settings = RenderSettings { width: 33, height: 33, aov, max_depth: 3, ..RenderSettings::default() };
        renderer.render(&build(&scene, &settings).unwrap()).unwrap()
    };
    let (lanes, cost, all) = (render(Aov::Lanes), render(Aov::Cost), render(Aov::CostAll));
    let mut shadowed = 0;
    for (i, ((l, c), a)) in lanes.pixels.iter().zip(&cost.pixels).zip(&all.pixels).enumerate() {
        let [camera, shadow, rest, total] = l.normal;
        assert_eq!(camera, c.normal[3], "pixel {i}: the camera ray's passes are Cost's");
        assert_eq!(total, a.normal[3], "pixel {i}: every ray's passes are CostAll's");
        assert_eq!(camera + shadow + rest, total, "pixel {i}: the kinds sum to the total");
        assert_eq!(rgb(l), rgb(a), "pixel {i}: drawn as CostAll");
        assert!(l.t >= 0.0 && (l.t as u32).is_multiple_of(16), "pixel {i}: {} hierarchy bytes", l.t);
        assert!(l.id.is_multiple_of(80), "pixel {i}: {} primitive bytes", l.id);
        shadowed += usize::from(shadow > 0.0);
    }
    assert!(shadowed > 0, "shadow rays walk");
}
