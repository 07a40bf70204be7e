//! `raycast trace`: one sample of one pixel, step by step, as the CPU build
//! of the shared GLSL takes it (layout.h TraceStep, raycast.glsl TRACE):
//! each ray and what it meets, each hit's surface, each light's term and
//! its shadow ray, each level's colour and mirror weight, and the sample's
//! colour.

use crate::layout::{self, TraceStep, NO_HIT};
use crate::scene::{LightKind, Scene};
use serde::Serialize;

fn v3(v: [f32; 4]) -> String {
    format!("({}, {}, {})", v[0], v[1], v[2])
}

fn passes(n: u32) -> String {
    if n == 1 {
        "1 pass".to_string()
    } else {
        format!("{n} passes")
    }
}

/// `primitive 12 (sphere, scene.xml:34:7)`.
fn primitive(scene: &Scene, id: u32) -> String {
    match scene.primitive(u64::from(id)) {
        Some(p) => format!("primitive {id} ({}, {})", p.shape.name(), p.loc),
        None => format!("primitive {id}"),
    }
}

/// `light 0 (point, scene.xml:5:3)`.
fn light(scene: &Scene, index: u32) -> String {
    match scene.lights.get(index as usize) {
        Some(l) => format!("light {index} ({}, {})", l.kind.name(), l.loc),
        None => format!("light {index}"),
    }
}

/// The steps as lines of text, indented under the ray they belong to.
pub fn describe(scene: &Scene, steps: &[TraceStep]) -> Vec<String> {
    let mut lines = Vec::new();
    for s in steps {
        match s.kind {
            layout::TRACE_CAMERA | layout::TRACE_MIRROR | layout::TRACE_REFRACT => {
                let what = match s.kind {
                    layout::TRACE_CAMERA => "camera ray".to_string(),
                    layout::TRACE_MIRROR => format!("mirror ray {}", s.level),
                    _ => format!("refracted ray {}", s.level),
                };
                lines.push(format!("{what} from {} along {}", v3(s.origin), v3(s.direction)));
                if s.id == NO_HIT {
                    lines.push(format!("  misses everything (its walk: {})", passes(s.passes)));
                } else {
                    lines.push(format!(
                        "  hits {} at t {}, normal {} (its walk: {})",
                        primitive(scene, s.id),
                        s.value[3],
                        v3(s.value),
                        passes(s.passes)
                    ));
                }
            }
            layout::TRACE_SURFACE => {
                let material = scene.primitive(u64::from(s.id)).and_then(|p| scene.materials.get(p.material as usize));
                lines.push(format!("  point {}", v3(s.origin)));
                if let Some(m) = material {
                    lines.push(format!("  material: {}", m.describe()));
                }
                lines.push(format!(
                    "  ambient + emissive {}; diffuse {} (with its texture, where it has one)",
                    v3(s.value),
                    v3(s.extra)
                ));
            }
            layout::TRACE_LIGHT => {
                let term = v3(s.value);
                let what = match s.id {
                    layout::TRACE_LIGHT_NOTHING => {
                        format!("adds nothing ({term}: facing away, outside its cone, or dark)")
                    }
                    layout::TRACE_LIGHT_ADDED => format!("adds {term} (no shadow rays)"),
                    _ => format!("would add {term}; its shadow ray decides"),
                };
                // An area light's point: trace.glsl puts it in origin, its index in w.
                let area = scene.lights.get(s.light as usize).is_some_and(|l| l.kind == LightKind::Area);
                let point =
                    if area { format!(" (its point {} at {})", s.origin[3], v3(s.origin)) } else { String::new() };
                lines.push(format!("  {}{point}, toward {}: {what}", light(scene, s.light), v3(s.direction)));
            }
            layout::TRACE_SHADOW => {
                // T_FAR (raycast.glsl), the largest float: a directional light's.
                let t_max = if s.direction[3] == f32::MAX {
                    "any distance".to_string()
                } else {
                    format!("t {}", s.direction[3])
                };
                if s.id == NO_HIT {
                    lines.push(format!(
                        "    shadow ray from {} to {t_max}: clear, so the term is added (its walk: {})",
                        v3(s.origin),
                        passes(s.passes)
                    ));
                } else {
                    lines.push(format!(
                        "    shadow ray from {} to {t_max}: blocked by {} at t {} (its walk: {})",
                        v3(s.origin),
                        primitive(scene, s.id),
                        s.value[3],
                        passes(s.passes)
                    ));
                }
            }
            layout::TRACE_LEVEL => {
                let refracted = if s.origin[..3] == [0.0; 3] {
                    String::new()
                } else {
                    format!("; its refracted weight {}", v3(s.origin))
                };
                lines.push(format!(
                    "  this hit's colour {}; its mirror weight {}{refracted}",
                    v3(s.value),
                    v3(s.extra)
                ));
            }
            layout::TRACE_PIXEL => {
                let rgba = s.id.to_le_bytes();
                lines.push(format!(
                    "sample colour {} (from the last hit back: each hit's colour plus its mirror weight times the mirror ray's colour \
                     and its refracted weight times the refracted ray's, clamped to [0, 1]): \
                     8-bit ({}, {}, {}); every walk {}",
                    v3(s.value),
                    rgba[0],
                    rgba[1],
                    rgba[2],
                    passes(s.passes)
                ));
            }
            other => lines.push(format!("(a step of unknown kind {other})")),
        }
    }
    lines
}

/// A step's vector as JSON's array of its x, y and z. Floats are written
/// in the shortest digits that read back as the same f32, and as null where
/// they are not finite (JSON has no NaN or infinity): serde_json's way.
fn xyz(v: [f32; 4]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

/// What a ray met: the primitive (its id, shape and file:line:col), t and,
/// for a camera or mirror ray, the surface's normal.
#[derive(Serialize)]
pub struct Hit {
    primitive: u32,
    shape: Option<&'static str>,
    at: Option<String>,
    t: f32,
    #[serde(skip_serializing_if = "Option::is_none")]
    normal: Option<[f32; 3]>,
}

/// A camera, mirror or refracted ray.
#[derive(Serialize)]
pub struct Ray {
    level: u32,
    origin: [f32; 3],
    direction: [f32; 3],
    hit: Option<Hit>,
    passes: u32,
}

/// One step as JSON: an object whose `kind` is camera, mirror, refracted,
/// shadow, surface, light, level or pixel (unknown, with its code, for a kind this
/// build does not know).
#[derive(Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Step {
    Camera(Ray),
    Mirror(Ray),
    Refracted(Ray),
    Shadow {
        level: u32,
        light: u32,
        origin: [f32; 3],
        direction: [f32; 3],
        /// None: any distance (a directional light's).
        t_max: Option<f32>,
        blocked_by: Option<Hit>,
        passes: u32,
    },
    Surface {
        level: u32,
        primitive: u32,
        point: [f32; 3],
        ambient_emissive: [f32; 3],
        diffuse: [f32; 3],
    },
    Light {
        level: u32,
        light: u32,
        light_kind: Option<&'static str>,
        toward: [f32; 3],
        /// None: a directional light's, which has no distance.
        distance: Option<f32>,
        term: [f32; 3],
        outcome: &'static str,
    },
    Level {
        level: u32,
        colour: [f32; 3],
        mirror_weight: [f32; 3],
        /// k_t O_t where the level sends a refracted ray (1 leaving a transparent object), else 0.
        refracted_weight: [f32; 3],
    },
    Pixel {
        colour: [f32; 3],
        rgb8: [u8; 3],
        passes: u32,
    },
    Unknown {
        code: u32,
    },
}

/// What a ray met: None, or the primitive with its t and `normal`.
fn hit(scene: &Scene, s: &TraceStep, normal: Option<[f32; 3]>) -> Option<Hit> {
    if s.id == NO_HIT {
        return None;
    }
    let p = scene.primitive(u64::from(s.id));
    Some(Hit {
        primitive: s.id,
        shape: p.as_ref().map(|p| p.shape.name()),
        at: p.as_ref().map(|p| p.loc.to_string()),
        t: s.value[3],
        normal,
    })
}

/// The steps as JSON objects (serialize each, or the lot), one a step, in
/// the order `describe` gives them; every number as the CPU build computed it.
pub fn json(scene: &Scene, steps: &[TraceStep]) -> Vec<Step> {
    steps
        .iter()
        .map(|s| match s.kind {
            layout::TRACE_CAMERA | layout::TRACE_MIRROR | layout::TRACE_REFRACT => {
                let ray = Ray {
                    level: s.level,
                    origin: xyz(s.origin),
                    direction: xyz(s.direction),
                    hit: hit(scene, s, Some(xyz(s.value))),
                    passes: s.passes,
                };
                match s.kind {
                    layout::TRACE_CAMERA => Step::Camera(ray),
                    layout::TRACE_MIRROR => Step::Mirror(ray),
                    _ => Step::Refracted(ray),
                }
            }
            layout::TRACE_SHADOW => Step::Shadow {
                level: s.level,
                light: s.light,
                origin: xyz(s.origin),
                direction: xyz(s.direction),
                // T_FAR, the largest float: a directional light's, any distance (null).
                t_max: (s.direction[3] != f32::MAX).then_some(s.direction[3]),
                blocked_by: hit(scene, s, None),
                passes: s.passes,
            },
            layout::TRACE_SURFACE => Step::Surface {
                level: s.level,
                primitive: s.id,
                point: xyz(s.origin),
                ambient_emissive: xyz(s.value),
                diffuse: xyz(s.extra),
            },
            layout::TRACE_LIGHT => {
                let light = scene.lights.get(s.light as usize);
                Step::Light {
                    level: s.level,
                    light: s.light,
                    light_kind: light.map(|l| l.kind.name()),
                    toward: xyz(s.direction),
                    // A directional light has no distance (the kernel passes 0).
                    distance: (!light.is_some_and(|l| l.kind == LightKind::Directional)).then_some(s.direction[3]),
                    term: xyz(s.value),
                    outcome: match s.id {
                        layout::TRACE_LIGHT_NOTHING => "nothing",
                        layout::TRACE_LIGHT_ADDED => "added",
                        _ => "shadow_ray",
                    },
                }
            }
            layout::TRACE_LEVEL => Step::Level {
                level: s.level,
                colour: xyz(s.value),
                mirror_weight: xyz(s.extra),
                refracted_weight: xyz(s.origin),
            },
            layout::TRACE_PIXEL => {
                let [r, g, b, _] = s.id.to_le_bytes();
                Step::Pixel { colour: xyz(s.value), rgb8: [r, g, b], passes: s.passes }
            }
            other => Step::Unknown { code: other },
        })
        .collect()
}
