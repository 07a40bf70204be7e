//! `<lightdata>`: point, directional, spot and area lights, each checked
//! for what its kind needs.

use super::names::{shown, suggest, LIGHT_ELEMENTS};
use super::{Ctx, R};
use crate::scene::model::*;
use crate::units::fmt_number;
use glam::DVec3;
use roxmltree::Node as XNode;
use std::collections::HashMap;

impl Ctx<'_> {
    pub(super) fn lightdata(&mut self, n: XNode) -> R<Light> {
        self.check_attrs(n, &[]);
        let mut light = Light {
            id: 0,
            kind: LightKind::Point,
            color: [1.0; 3],
            position: DVec3::new(3.0, 3.0, 3.0),
            direction: DVec3::ZERO,
            attenuation: [1.0, 0.0, 0.0],
            angle_deg: 0.0,
            penumbra_deg: 0.0,
            width: 0.0,
            height: 0.0,
            loc: self.nloc(n),
        };
        let mut seen = HashMap::new();
        let mut dir_node = None;
        let mut size_nodes = [None, None]; // <width>, <height>
        let mut has_angle = false;
        for c in self.elements(n) {
            match c.tag_name().name() {
                "id" => {
                    let v = self.v(c)?;
                    if v.fract() != 0.0 || v < i32::MIN as f64 || v > i32::MAX as f64 {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self
                            .err(self.aloc(&a), format!("light <id> is {} (expected a whole number)", fmt_number(v))));
                    }
                    light.id = v as i32;
                }
                "type" => {
                    self.check_attrs(c, &["v"]);
                    self.leaf(c);
                    let a = self.req_attr(c, "v", &["v"], "point, directional, spot or area")?;
                    const KINDS: &[&str] = &["point", "directional", "spot", "area"];
                    light.kind = match a.value().trim() {
                        "point" => LightKind::Point,
                        "directional" => LightKind::Directional,
                        "spot" => LightKind::Spot,
                        "area" => LightKind::Area,
                        other => {
                            let hint = match suggest(other, KINDS) {
                                Some(s) => format!("; did you mean \"{s}\"?"),
                                None => String::new(),
                            };
                            return Err(self.err(
                                self.aloc(&a),
                                format!(
                                    "unknown light type {} (expected point, directional, spot or area{hint})",
                                    shown(other)
                                ),
                            ));
                        }
                    };
                }
                "color" => light.color = self.rgb(c)?,
                "position" => light.position = self.xyz(c)?,
                "direction" => {
                    light.direction = self.xyz(c)?;
                    dir_node = Some(c);
                }
                "function" => {
                    let v = self.families(c, &[&["v1", "v2", "v3"], &["x", "y", "z"], &["a", "b", "c"]])?;
                    for i in 0..3 {
                        light.attenuation[i] = v.get(i).copied().unwrap_or(0.0) as f32;
                        if !light.attenuation[i].is_finite() {
                            return Err(self.err(
                                self.nloc(c),
                                "<function> has a value too large (expected magnitudes below 3.4e38)".to_string(),
                            ));
                        }
                    }
                }
                "angle" => {
                    light.angle_deg = self.v32(c)?;
                    has_angle = true;
                }
                "penumbra" => light.penumbra_deg = self.v32(c)?,
                "width" => {
                    light.width = self.v32(c)?;
                    size_nodes[0] = Some(c);
                }
                "height" => {
                    light.height = self.v32(c)?;
                    size_nodes[1] = Some(c);
                }
                _ => {
                    self.unknown_element(c, "lightdata", LIGHT_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "lightdata");
        }
        if matches!(light.kind, LightKind::Directional | LightKind::Spot | LightKind::Area)
            && unit(light.direction).is_none()
        {
            let kind = match light.kind {
                LightKind::Spot => "a spot",
                LightKind::Area => "an area",
                _ => "a directional",
            };
            return Err(match dir_node {
                Some(d) => self.err(
                    self.nloc(d),
                    format!("{kind} light's <direction> is the zero vector (expected the direction the light travels)"),
                ),
                None => self.err(
                    self.nloc(n),
                    format!("{kind} light has no <direction> (expected <direction x y z/>: the direction the light travels)"),
                ),
            });
        }
        if light.kind == LightKind::Area {
            self.area_light_size(n, &light, size_nodes)?;
        }
        if light.kind == LightKind::Spot && !has_angle {
            let msg = "spot light has no <angle>; using 0 degrees, so it lights nothing".to_string();
            self.warn(self.nloc(n), msg);
        }
        Ok(light)
    }

    /// An area light's `<width>` and `<height>`: both given, each a
    /// positive finite size (docs/scene-format.md#area-lights); `nodes`
    /// are the elements that gave them.
    fn area_light_size(&self, n: XNode, light: &Light, nodes: [Option<XNode>; 2]) -> R<()> {
        for ((name, v), node) in [("width", light.width), ("height", light.height)].into_iter().zip(nodes) {
            let Some(c) = node else {
                return Err(self.err(
                    self.nloc(n),
                    format!("an area light has no <{name}> (expected <{name} v=\"S\"/>: the rectangle's size in world units)"),
                ));
            };
            if !(v.is_finite() && v > 0.0) {
                let a = self.req_attr(c, "v", &["v"], "v")?;
                return Err(self.err(
                    self.aloc(&a),
                    format!("an area light's <{name}> is {} (expected a positive size in world units)", fmt_number(v)),
                ));
            }
        }
        Ok(())
    }
}
