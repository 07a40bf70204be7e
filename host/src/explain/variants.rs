//! The mistakes `explain` knows, each a variant of the frame raycast can
//! draw: a lighting term left out, doubled or without its global
//! coefficient, a convention changed (the camera's half pixel, the normal
//! rule, a texture's orientation, the 8-bit rounding), a part of a shape
//! left out. A variant changes the packed frame's data, or sets a
//! FLAG_EXPLAIN_* bit that the shaders' explain code reads (layout.h,
//! SPEC_EXPLAIN); the default kernels have none of it.

use crate::frame::FrameData;
use crate::layout;
use glam::DVec3;
use serde::Serialize;

/// What kind of mistake a variant is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Category {
    Geometry,
    Normals,
    Lighting,
    Textures,
    Clamping,
}

impl Category {
    pub fn name(self) -> &'static str {
        match self {
            Category::Geometry => "geometry",
            Category::Normals => "normals",
            Category::Lighting => "lighting",
            Category::Textures => "textures",
            Category::Clamping => "clamping",
        }
    }
}

/// One mistake as raycast draws it.
pub struct Variant {
    /// Its name in `--json` and the tests: `no-specular`.
    pub id: &'static str,
    /// For people, after "raycast with": "no specular term".
    pub what: &'static str,
    pub category: Category,
    /// Whether drawing it can change anything in this frame (a scene without
    /// a texture has no texture mistake to make).
    pub applies: fn(&FrameData) -> bool,
    /// The frame drawn with the mistake.
    pub apply: fn(&mut FrameData),
}

fn any_material(d: &FrameData, f: impl Fn(&layout::Material) -> bool) -> bool {
    d.materials.iter().any(f)
}

fn nonzero(c: [f32; 4]) -> bool {
    c[..3].iter().any(|&x| x != 0.0)
}

fn flag(d: &FrameData, f: u32) -> bool {
    d.frame.flags & f != 0
}

fn textured(d: &FrameData) -> bool {
    flag(d, layout::FLAG_TEXTURES) && any_material(d, |m| m.texture >= 0 && m.blend > 0.0)
}

fn ambient(d: &FrameData) -> bool {
    d.frame.k[0] != 0.0 && any_material(d, |m| nonzero(m.ambient))
}

fn diffuse(d: &FrameData) -> bool {
    d.frame.k[1] != 0.0 && any_material(d, |m| nonzero(m.diffuse)) && !d.lights.is_empty()
}

fn specular(d: &FrameData) -> bool {
    d.frame.k[2] != 0.0 && any_material(d, |m| nonzero(m.specular) && m.shininess > 0.0) && !d.lights.is_empty()
}

fn materials(d: &mut FrameData, f: impl Fn(&mut layout::Material)) {
    d.materials.iter_mut().for_each(f);
}

fn scale3(c: &mut [f32; 4], s: f32) {
    for x in &mut c[..3] {
        *x *= s;
    }
}

/// Every material's `colour` (one k_s weights) divided by k_s: the term
/// without its global coefficient.
fn without_ks(d: &mut FrameData, colour: fn(&mut layout::Material) -> &mut [f32; 4]) {
    let ks = d.frame.k[2];
    materials(d, |m| scale3(colour(m), 1.0 / ks));
}

/// A positioned light whose attenuation is not 1 at every distance.
fn attenuated(d: &FrameData) -> bool {
    d.lights.iter().any(|l| l.kind != layout::LIGHT_DIRECTIONAL && l.attenuation[..3] != [1.0, 0.0, 0.0])
}

/// The film moved by (`dx`, `dy`) pixels: a ray through a pixel's corner
/// rather than its centre; or the picture upside down (`flip`). The camera
/// ray's direction is world_from_film's linear part times the film point
/// (x, y, -1) (camera.glsl), so a shift s of (x, y) is -s of its z column.
fn film(d: &mut FrameData, dx: f64, dy: f64, flip: bool) {
    let f = &mut d.frame;
    let [c0, c1, c2, c3] = f.world_from_film.map(|c| DVec3::new(c[0].into(), c[1].into(), c[2].into()));
    // Film x spans [-1, 1] over the width, y over the height, y up.
    let (sx, sy) = (2.0 * dx / f64::from(f.width), -2.0 * dy / f64::from(f.height));
    let z = c2 - (sx * c0 + sy * c1);
    let y = if flip { -c1 } else { c1 };
    let w = f.world_from_film[3][3];
    let col = |v: DVec3, w: f32| [v.x as f32, v.y as f32, v.z as f32, w];
    f.world_from_film = [col(c0, 0.0), col(y, 0.0), col(z, 0.0), col(c3, w)];
}

/// The film's x and y scaled by `sx` and `sy`: a field of view drawn
/// otherwise (the ray through film point (x, y) is the one through
/// (sx x, sy y); camera.glsl).
fn film_scale(d: &mut FrameData, sx: f32, sy: f32) {
    let f = &mut d.frame;
    for (c, s) in [(0, sx), (1, sy)] {
        for x in &mut f.world_from_film[c][..3] {
            *x *= s;
        }
    }
}

/// tan(θ/2) of the camera's height angle θ: the length of the film's y
/// column (frame/camera.rs world_from_film).
fn tan_half_height(d: &FrameData) -> f64 {
    let c = d.frame.world_from_film[1];
    (f64::from(c[0]).powi(2) + f64::from(c[1]).powi(2) + f64::from(c[2]).powi(2)).sqrt()
}

/// The factor a height angle used whole (tan θ for tan θ/2) scales the
/// film by, where θ is below 89 degrees.
fn whole_angle(d: &FrameData) -> Option<f32> {
    let t = tan_half_height(d);
    let half = t.atan();
    (t > 0.0 && half.to_degrees() < 44.5).then(|| ((2.0 * half).tan() / t) as f32)
}

/// Every texture's texels mirrored left to right (`u`) or top to bottom.
fn mirror_texels(d: &mut FrameData, u: bool) {
    for t in &d.textures {
        let (w, h, o) = (t.width as usize, t.height as usize, t.offset as usize);
        for row in 0..h {
            for col in 0..w {
                let (r2, c2) = if u { (row, w - 1 - col) } else { (h - 1 - row, col) };
                let (a, b) = (o + row * w + col, o + r2 * w + c2);
                if a < b {
                    d.texels.swap(a, b);
                }
            }
        }
    }
}

fn has_caps(d: &FrameData) -> bool {
    d.primitives.iter().any(|p| p.shape == layout::SHAPE_CONE || p.shape == layout::SHAPE_CYLINDER)
}

fn always(_: &FrameData) -> bool {
    true
}

fn lit(d: &FrameData) -> bool {
    !d.lights.is_empty()
}

/// Every mistake `explain` tries, in the order it reports ties.
pub static VARIANTS: &[Variant] = &[
    Variant {
        id: "no-ambient",
        what: "no ambient term",
        category: Category::Lighting,
        applies: ambient,
        apply: |d| d.frame.k[0] = 0.0,
    },
    Variant {
        id: "no-diffuse",
        what: "no diffuse term (nor the texture blended into it)",
        category: Category::Lighting,
        applies: diffuse,
        apply: |d| {
            d.frame.k[1] = 0.0;
            materials(d, |m| m.blend = 0.0);
        },
    },
    Variant {
        id: "no-specular",
        what: "no specular term",
        category: Category::Lighting,
        applies: specular,
        apply: |d| materials(d, |m| m.specular = [0.0; 4]),
    },
    Variant {
        id: "double-ambient",
        what: "the ambient term counted twice",
        category: Category::Lighting,
        applies: ambient,
        apply: |d| d.frame.k[0] *= 2.0,
    },
    Variant {
        id: "double-diffuse",
        what: "the diffuse term counted twice",
        category: Category::Lighting,
        applies: diffuse,
        apply: |d| d.frame.k[1] *= 2.0,
    },
    Variant {
        id: "double-specular",
        what: "the specular term counted twice",
        category: Category::Lighting,
        applies: specular,
        apply: |d| materials(d, |m| scale3(&mut m.specular, 2.0)),
    },
    Variant {
        id: "unweighted-ambient",
        what: "the ambient term without the global coefficient k_a",
        category: Category::Lighting,
        applies: |d| ambient(d) && d.frame.k[0] != 1.0,
        apply: |d| d.frame.k[0] = 1.0,
    },
    Variant {
        id: "unweighted-diffuse",
        what: "the diffuse term without the global coefficient k_d",
        category: Category::Lighting,
        applies: |d| diffuse(d) && d.frame.k[1] != 1.0,
        apply: |d| d.frame.k[1] = 1.0,
    },
    Variant {
        id: "unweighted-specular",
        what: "the specular term without the global coefficient k_s",
        category: Category::Lighting,
        applies: |d| specular(d) && d.frame.k[2] != 1.0,
        apply: |d| without_ks(d, |m| &mut m.specular),
    },
    Variant {
        id: "no-attenuation",
        what: "no distance attenuation",
        category: Category::Lighting,
        applies: attenuated,
        apply: |d| {
            for l in d.lights.iter_mut().filter(|l| l.kind != layout::LIGHT_DIRECTIONAL) {
                l.attenuation = [1.0, 0.0, 0.0, 0.0];
            }
        },
    },
    Variant {
        id: "blinn-phong",
        what: "specular highlights from the half vector (Blinn-Phong), not the reflected light",
        category: Category::Lighting,
        applies: specular,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_BLINN,
    },
    Variant {
        id: "negative-light",
        what: "n.l not clamped at 0 (a light darkens the surfaces that face away from it)",
        category: Category::Lighting,
        applies: diffuse,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_NEGATIVE_LIGHT,
    },
    Variant {
        id: "uncapped-attenuation",
        what: "distance attenuation not capped at 1 (lights brighter than their colour near them)",
        category: Category::Lighting,
        applies: attenuated,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_UNCAPPED_ATTENUATION,
    },
    Variant {
        id: "spot-as-point",
        what: "spot lights lighting every way, as point lights",
        category: Category::Lighting,
        applies: |d| d.lights.iter().any(|l| l.kind == layout::LIGHT_SPOT),
        apply: |d| {
            for l in d.lights.iter_mut().filter(|l| l.kind == layout::LIGHT_SPOT) {
                l.kind = layout::LIGHT_POINT;
            }
        },
    },
    Variant {
        id: "hard-spot-edge",
        what: "spot lights with a hard edge (no penumbra)",
        category: Category::Lighting,
        applies: |d| d.lights.iter().any(|l| l.kind == layout::LIGHT_SPOT && l.penumbra_deg > 0.0),
        apply: |d| {
            for l in d.lights.iter_mut().filter(|l| l.kind == layout::LIGHT_SPOT) {
                l.penumbra_deg = 0.0;
            }
        },
    },
    Variant {
        id: "no-shadows",
        what: "no shadows",
        category: Category::Lighting,
        applies: |d| flag(d, layout::FLAG_SHADOWS) && lit(d),
        apply: |d| d.frame.flags &= !layout::FLAG_SHADOWS,
    },
    Variant {
        id: "no-reflections",
        what: "no mirror reflection",
        category: Category::Lighting,
        applies: |d| {
            flag(d, layout::FLAG_REFLECTIONS) && d.frame.k[2] != 0.0 && any_material(d, |m| nonzero(m.reflective))
        },
        apply: |d| d.frame.flags &= !layout::FLAG_REFLECTIONS,
    },
    Variant {
        id: "unweighted-reflection",
        what: "the mirror reflection without the global coefficient k_s",
        category: Category::Lighting,
        applies: |d| {
            flag(d, layout::FLAG_REFLECTIONS)
                && d.frame.k[2] != 0.0
                && d.frame.k[2] != 1.0
                && any_material(d, |m| nonzero(m.reflective))
        },
        apply: |d| without_ks(d, |m| &mut m.reflective),
    },
    Variant {
        id: "white-lights",
        what: "every light white (its colour ignored)",
        category: Category::Lighting,
        applies: |d| d.lights.iter().any(|l| l.color[..3] != [1.0, 1.0, 1.0]),
        apply: |d| d.lights.iter_mut().for_each(|l| l.color = [1.0, 1.0, 1.0, 0.0]),
    },
    Variant {
        id: "no-refraction",
        what: "no refraction (transparent materials opaque)",
        category: Category::Lighting,
        applies: |d| flag(d, layout::FLAG_REFRACTION),
        apply: |d| d.frame.flags &= !layout::FLAG_REFRACTION,
    },
    Variant {
        id: "no-textures",
        what: "no textures",
        category: Category::Textures,
        applies: textured,
        apply: |d| d.frame.flags &= !layout::FLAG_TEXTURES,
    },
    Variant {
        id: "blend-ignored",
        what: "the texture replacing the diffuse colour (blend taken as 1)",
        category: Category::Textures,
        applies: |d| textured(d) && any_material(d, |m| m.texture >= 0 && m.blend < 1.0),
        apply: |d| {
            materials(d, |m| {
                if m.texture >= 0 {
                    m.blend = 1.0;
                }
            })
        },
    },
    Variant {
        id: "flip-u",
        what: "textures mirrored left to right (u reversed)",
        category: Category::Textures,
        applies: textured,
        apply: |d| mirror_texels(d, true),
    },
    Variant {
        id: "flip-v",
        what: "textures upside down (v reversed: v = 0 at the bottom row)",
        category: Category::Textures,
        applies: textured,
        apply: |d| mirror_texels(d, false),
    },
    Variant {
        id: "no-repeat",
        what: "the texture's repeat ignored (u and v repeated once)",
        category: Category::Textures,
        applies: |d| textured(d) && any_material(d, |m| m.texture >= 0 && m.texture_repeat[..2] != [1.0, 1.0]),
        apply: |d| materials(d, |m| m.texture_repeat = [1.0, 1.0, 0.0, 0.0]),
    },
    Variant {
        id: "filter-nearest",
        what: "textures sampled at the nearest texel",
        category: Category::Textures,
        applies: |d| textured(d) && d.frame.texture_filter != layout::FILTER_NEAREST,
        apply: |d| d.frame.texture_filter = layout::FILTER_NEAREST,
    },
    Variant {
        id: "filter-bilinear",
        what: "textures filtered bilinearly",
        category: Category::Textures,
        applies: |d| textured(d) && d.frame.texture_filter != layout::FILTER_BILINEAR,
        apply: |d| d.frame.texture_filter = layout::FILTER_BILINEAR,
    },
    Variant {
        id: "flip-normals",
        what: "every normal reversed",
        category: Category::Normals,
        applies: lit,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_FLIP_NORMALS,
    },
    Variant {
        id: "untransposed-normals",
        what: "normals mapped to the world as vectors are, not by the inverse transpose",
        category: Category::Normals,
        applies: lit,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_UNTRANSPOSED_NORMALS,
    },
    Variant {
        id: "long-normals",
        what:
            "normals not made unit length after their mapping to the world (scaled shapes lit too much or too little)",
        category: Category::Normals,
        applies: lit,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_LONG_NORMALS,
    },
    Variant {
        id: "pixel-corner",
        what: "camera rays through the pixels' corners, not their centres (half a pixel off)",
        category: Category::Geometry,
        applies: always,
        apply: |d| film(d, -0.5, -0.5, false),
    },
    Variant {
        id: "upside-down",
        what: "the picture upside down (film y reversed)",
        category: Category::Geometry,
        applies: always,
        apply: |d| film(d, 0.0, 0.0, true),
    },
    Variant {
        id: "whole-height-angle",
        what: "the height angle used whole, not halved (tan θ for tan θ/2: the view too wide)",
        category: Category::Geometry,
        applies: |d| whole_angle(d).is_some(),
        apply: |d| {
            let f = whole_angle(d).unwrap_or(1.0);
            film_scale(d, f, f);
        },
    },
    Variant {
        id: "aspect-ignored",
        what: "the width's angle taken as the height's (the picture squeezed or stretched across)",
        category: Category::Geometry,
        applies: |d| d.frame.width != d.frame.height,
        apply: |d| {
            let aspect = d.frame.width as f32 / d.frame.height as f32;
            film_scale(d, 1.0 / aspect, 1.0);
        },
    },
    Variant {
        id: "no-caps",
        what: "the cones' and cylinders' flat caps left out",
        category: Category::Geometry,
        applies: has_caps,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_NO_CAPS,
    },
    Variant {
        id: "rounded",
        what: "8-bit values rounded to nearest, not truncated (floor(255 c))",
        category: Category::Clamping,
        applies: always,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_ROUND,
    },
    Variant {
        id: "no-clamp",
        what: "colours not clamped to [0, 1] (the 8-bit value wraps)",
        category: Category::Clamping,
        applies: always,
        apply: |d| d.frame.flags |= layout::FLAG_EXPLAIN_NO_CLAMP,
    },
];

/// The variant named `id`.
pub fn variant(id: &str) -> Option<&'static Variant> {
    VARIANTS.iter().find(|v| v.id == id)
}
