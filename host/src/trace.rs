//! `raycast trace`: one sample of one pixel, step by step, as the CPU build
//! of the shared GLSL takes it (layout.h TraceStep, raycast.glsl TRACE):
//! each ray and what it meets, each hit's surface, each light's term and
//! its shadow ray, each level's colour and mirror weight, and the sample's
//! colour.

use crate::layout::{self, TraceStep, NO_HIT};
use crate::scene::{LightKind, Scene};
use crate::units::json_str;

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
            layout::TRACE_CAMERA | layout::TRACE_MIRROR => {
                let what = if s.kind == layout::TRACE_CAMERA {
                    "camera ray".to_string()
                } else {
                    format!("mirror ray {}", s.level)
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
                lines.push(format!("  {}, toward {}: {what}", light(scene, s.light), v3(s.direction)));
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
                lines.push(format!("  this hit's colour {}; its mirror weight {}", v3(s.value), v3(s.extra)));
            }
            layout::TRACE_PIXEL => {
                let rgba = s.id.to_le_bytes();
                lines.push(format!(
                    "sample colour {} (from the last hit back: each hit's colour plus its mirror weight times the next, clamped to [0, 1]): \
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

/// A float in JSON: Rust's shortest digits that read back as the same f32,
/// or null where it is not finite (JSON has no NaN or infinity).
fn num(x: f32) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        "null".to_string()
    }
}

fn vec3_json(v: [f32; 4]) -> String {
    format!("[{},{},{}]", num(v[0]), num(v[1]), num(v[2]))
}

/// What a ray met, as JSON: null, or the primitive (its id, shape and
/// file:line:col), t and `more` fields.
fn hit_json(scene: &Scene, s: &TraceStep, more: &str) -> String {
    if s.id == NO_HIT {
        return "null".to_string();
    }
    let (shape, loc) = match scene.primitive(u64::from(s.id)) {
        Some(p) => (json_str(p.shape.name()), json_str(&p.loc.to_string())),
        None => ("null".to_string(), "null".to_string()),
    };
    format!("{{\"primitive\":{},\"shape\":{shape},\"at\":{loc},\"t\":{}{more}}}", s.id, num(s.value[3]))
}

/// The steps as JSON objects, one a step, in the order `describe` gives
/// them; every number as the CPU build computed it. `kind` is one of
/// camera, mirror, shadow, surface, light, level, pixel.
pub fn json(scene: &Scene, steps: &[TraceStep]) -> Vec<String> {
    steps
        .iter()
        .map(|s| match s.kind {
            layout::TRACE_CAMERA | layout::TRACE_MIRROR => {
                let kind = if s.kind == layout::TRACE_CAMERA { "camera" } else { "mirror" };
                let hit = hit_json(scene, s, &format!(",\"normal\":{}", vec3_json(s.value)));
                format!(
                    "{{\"kind\":\"{kind}\",\"level\":{},\"origin\":{},\"direction\":{},\"hit\":{hit},\"passes\":{}}}",
                    s.level,
                    vec3_json(s.origin),
                    vec3_json(s.direction),
                    s.passes
                )
            }
            layout::TRACE_SHADOW => {
                let hit = hit_json(scene, s, "");
                // T_FAR, the largest float: a directional light's, any distance (null).
                let t_max = if s.direction[3] == f32::MAX { "null".to_string() } else { num(s.direction[3]) };
                format!(
                    "{{\"kind\":\"shadow\",\"level\":{},\"light\":{},\"origin\":{},\"direction\":{},\"t_max\":{t_max},\"blocked_by\":{hit},\"passes\":{}}}",
                    s.level,
                    s.light,
                    vec3_json(s.origin),
                    vec3_json(s.direction),
                    s.passes
                )
            }
            layout::TRACE_SURFACE => format!(
                "{{\"kind\":\"surface\",\"level\":{},\"primitive\":{},\"point\":{},\"ambient_emissive\":{},\"diffuse\":{}}}",
                s.level,
                s.id,
                vec3_json(s.origin),
                vec3_json(s.value),
                vec3_json(s.extra)
            ),
            layout::TRACE_LIGHT => {
                let outcome = match s.id {
                    layout::TRACE_LIGHT_NOTHING => "nothing",
                    layout::TRACE_LIGHT_ADDED => "added",
                    _ => "shadow_ray",
                };
                let light = scene.lights.get(s.light as usize);
                let kind = light.map_or("null".to_string(), |l| json_str(l.kind.name()));
                // A directional light has no distance (the kernel passes 0).
                let distance = if light.is_some_and(|l| l.kind == LightKind::Directional) { "null".to_string() } else { num(s.direction[3]) };
                format!(
                    "{{\"kind\":\"light\",\"level\":{},\"light\":{},\"light_kind\":{kind},\"toward\":{},\"distance\":{},\"term\":{},\"outcome\":\"{outcome}\"}}",
                    s.level,
                    s.light,
                    vec3_json(s.direction),
                    distance,
                    vec3_json(s.value)
                )
            }
            layout::TRACE_LEVEL => format!(
                "{{\"kind\":\"level\",\"level\":{},\"colour\":{},\"mirror_weight\":{}}}",
                s.level,
                vec3_json(s.value),
                vec3_json(s.extra)
            ),
            layout::TRACE_PIXEL => {
                let rgba = s.id.to_le_bytes();
                format!(
                    "{{\"kind\":\"pixel\",\"colour\":{},\"rgb8\":[{},{},{}],\"passes\":{}}}",
                    vec3_json(s.value),
                    rgba[0],
                    rgba[1],
                    rgba[2],
                    s.passes
                )
            }
            other => format!("{{\"kind\":\"unknown\",\"code\":{other}}}"),
        })
        .collect()
}
