//! Area lights against closed forms (docs/scene-format.md#area-lights), on
//! the CPU build: the irradiance of a square light above a point of a
//! Lambertian floor, and the umbra and penumbra of a strip between a light
//! and the floor, from similar triangles.

use crate::cpu::CpuRenderer;
use crate::frame::{self, RenderSettings};
use crate::render::Picture;

/// A floor (top face y = 0, white, k_d = 1, no ambient) seen straight down
/// from (0, 1, 0) with film x along world x, lit by `light`, with `more`
/// in the root tree.
fn floor_scene(light: &str, more: &str, tan_w: f64, width: u32, height: u32) -> crate::scene::Scene {
    let tan_h = tan_w * f64::from(height) / f64::from(width);
    let angle = 2.0 * tan_h.atan().to_degrees();
    crate::scene::from_xml(
        format!(
            r#"<scenefile>
  <globaldata><ambientcoeff v="0"/><diffusecoeff v="1"/><specularcoeff v="0"/></globaldata>
  <cameradata><pos x="0" y="1" z="0"/><look x="0" y="-1" z="0"/><up x="0" y="0" z="-1"/><heightangle v="{angle}"/></cameradata>
  <lightdata><id v="0"/><type v="area"/><direction x="0" y="-1" z="0"/>{light}</lightdata>
  <object type="tree" name="root">
    <transblock><translate x="0" y="-0.5" z="0"/><scale x="40" y="1" z="40"/>
      <object type="primitive" name="cube"><diffuse r="1" g="1" b="1"/></object></transblock>
    {more}
  </object>
</scenefile>"#
        ),
        "floor.xml",
    )
}

fn render(scene: &crate::scene::Scene, settings: &RenderSettings) -> Picture {
    CpuRenderer::new().unwrap().render(&frame::build(scene, settings).unwrap()).unwrap()
}

/// The red channel of pixel (x, y), in [0, 1].
fn red(p: &Picture, x: u32, y: u32) -> f64 {
    f64::from(p.pixels[(y * p.width + x) as usize].rgba & 0xff) / 255.0
}

/// A 2 x 2 light of colour 4 at height 2 above the floor, attenuation
/// 1/d^2 (function 0 0 1; every point is 2 or more away, so the min with 1
/// never bites): under the model each of N points is a point light of
/// colour 4/N, so the floor below its centre shows (4/A) times the
/// integral of cos(theta)/d^2 over the light, the solid angle the square
/// subtends: 4 atan(ab / (h sqrt(a^2 + b^2 + h^2))) with half-sides a = b = 1
/// and h = 2. Rule: the rendered 8-bit value within 1/255 + 1/N of that
/// (quantisation plus the stratified points' error, which shrinks with N),
/// and the error at 256 points below that at 1. Measured: 0.805 expected;
/// off by 0.195 at 1 point, 0.014 at 4, 0.0024 at 16, 0.0015 at 64 and
/// 256 (the 8-bit rounding).
#[test]
fn an_unoccluded_square_light_gives_the_solid_angle_it_subtends() {
    let (a, b, h) = (1.0f64, 1.0f64, 2.0f64);
    let solid_angle = 4.0 * (a * b / (h * (a * a + b * b + h * h).sqrt())).atan();
    let expected = 4.0 * solid_angle / (4.0 * a * b);
    let light = r#"<color r="4" g="4" b="4"/><position x="0" y="2" z="0"/><function v1="0" v2="0" v3="1"/><width v="2"/><height v="2"/>"#;
    let scene = floor_scene(light, "", 0.1, 3, 3);
    let mut errors = Vec::new();
    for n in [1u32, 4, 16, 64, 256] {
        let settings = RenderSettings { width: 3, height: 3, light_samples: n, ..RenderSettings::default() };
        // The centre pixel's ray goes straight down to (0, 0, 0).
        let got = red(&render(&scene, &settings), 1, 1);
        let error = (got - expected).abs();
        let bound = 1.0 / 255.0 + 1.0 / f64::from(n);
        assert!(error <= bound, "{n} points: {got:.4} against {expected:.4}: off by {error:.4}, more than {bound:.4}");
        errors.push((n, error));
    }
    assert!(errors[4].1 < errors[0].1, "the error does not shrink with the points: {errors:?}");
    println!("closed form {expected:.4}; errors by points: {errors:?}");
}

/// A 1 x 1 light at height H = 4 (attenuation 1), a strip 1.5 wide (x in
/// [-0.75, 0.75], along z for 40) at height h = 2: by similar triangles the
/// umbra is x in +-(D H - W h) / (2 (H - h)) = +-1 and each penumbra
/// W h / (H - h) = 1 wide, the shadow ending at +-2. Measured along the
/// centre row (pixel x to floor x linear, 0.01 a pixel): the umbra is the
/// pixels drawn black, the lit ones those equal to the picture without
/// shadow rays. Rule: each edge within a pixel plus the half stratum of
/// the light's points, W/(2N) h/(H - h), of the closed form: 0.0178 at
/// N = 64. Measured: umbra edges at +-0.9983, shadow edges at +-1.9867.
#[test]
fn a_strip_casts_the_umbra_and_penumbra_of_similar_triangles() {
    let (big_w, big_h, d, h, n) = (1.0f64, 4.0f64, 1.5f64, 2.0f64, 64u32);
    let light = r#"<color r="1" g="1" b="1"/><position x="0" y="4" z="0"/><width v="1"/><height v="1"/>"#;
    let strip = r#"<transblock><translate x="0" y="2" z="0"/><scale x="1.5" y="0.002" z="40"/>
      <object type="primitive" name="cube"/></transblock>"#;
    let (width, height, tan_w) = (601u32, 3u32, 3.0f64);
    let scene = floor_scene(light, strip, tan_w, width, height);
    let settings = RenderSettings { width, height, light_samples: n, ..RenderSettings::default() };
    let shadowed = render(&scene, &settings);
    let lit = render(&scene, &RenderSettings { shadows: false, ..settings });
    let floor_x = |j: u32| ((f64::from(j) + 0.5) / f64::from(width) * 2.0 - 1.0) * tan_w;
    let row = 1;
    let dark: Vec<u32> =
        (0..width).filter(|&j| shadowed.pixels[(row * width + j) as usize].rgba & 0xffffff == 0).collect();
    let shaded: Vec<u32> = (0..width)
        .filter(|&j| shadowed.pixels[(row * width + j) as usize].rgba != lit.pixels[(row * width + j) as usize].rgba)
        .collect();
    let (umbra, shadow) =
        ((d * big_h - big_w * h) / (2.0 * (big_h - h)), (d * big_h + big_w * h) / (2.0 * (big_h - h)));
    let tolerance = 2.0 * tan_w / f64::from(width) + big_w / (2.0 * f64::from(n)) * h / (big_h - h);
    let edges = [
        ("umbra, left", floor_x(dark[0]), -umbra),
        ("umbra, right", floor_x(*dark.last().unwrap()), umbra),
        ("shadow, left", floor_x(shaded[0]), -shadow),
        ("shadow, right", floor_x(*shaded.last().unwrap()), shadow),
    ];
    for (what, got, want) in edges {
        assert!(
            (got - want).abs() <= tolerance,
            "{what} edge at x = {got:.4}, closed form {want:.4}, tolerance {tolerance:.4}"
        );
    }
    println!("edges (measured, closed form): {edges:?}; tolerance {tolerance:.4}");
}
