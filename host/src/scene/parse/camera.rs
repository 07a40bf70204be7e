//! `<cameradata>`: the position, where it looks (`<focus>` or `<look>`),
//! the up vector and field of view, and a lens for depth of field.

use super::names::CAMERA_ELEMENTS;
use super::{Ctx, R};
use crate::scene::model::*;
use crate::units::{fmt_number, fmt_vector};
use glam::DVec3;
use roxmltree::Node as XNode;
use std::collections::HashMap;

impl Ctx<'_> {
    pub(super) fn cameradata(&mut self, n: XNode) -> R<Camera> {
        self.check_attrs(n, &[]);
        let mut cam = Camera::default();
        let mut seen = HashMap::new();
        let mut aim: Option<(XNode, DVec3)> = None; // <focus> or <look>, value as written
        let mut up_node = None;
        let mut aperture_node = None;
        for c in self.elements(n) {
            let name = c.tag_name().name();
            match name {
                "pos" => cam.pos = self.xyz_f32(c)?,
                "focus" | "look" => {
                    let v = self.xyz(c)?;
                    if let Some((prev, _)) = aim {
                        let pname = prev.tag_name().name();
                        if pname != name {
                            let at = self.nloc(prev);
                            return Err(self.err(
                                self.nloc(c),
                                format!(
                                    "<cameradata> has both <{pname}> (at {}:{}) and <{name}>; use one (<focus> is a point to look at, <look> a direction)",
                                    at.line,
                                    at.col
                                ),
                            ));
                        }
                    }
                    aim = Some((c, v));
                }
                "up" => {
                    cam.up = self.xyz(c)?;
                    up_node = Some(c);
                }
                "heightangle" => {
                    let v = self.v(c)?;
                    if !(v > 0.0 && v < 180.0) {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self.err(
                            self.aloc(&a),
                            format!(
                                "<heightangle> is {} degrees (expected more than 0 and less than 180: the full vertical field of view)",
                                fmt_number(v)
                            ),
                        ));
                    }
                    cam.height_angle_deg = v;
                    cam.height_angle_loc = Some(self.nloc(c));
                }
                "aspectratio" => {
                    let v = self.v(c)?;
                    if v <= 0.0 {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self.err(
                            self.aloc(&a),
                            format!("<aspectratio> is {} (expected a positive width/height ratio)", fmt_number(v)),
                        ));
                    }
                    cam.aspect_ratio = Some(v);
                    let msg = "raycast takes the aspect ratio from the picture's size (--width and --height); <aspectratio> is ignored";
                    self.warn(self.nloc(c), msg.to_string());
                }
                // Depth of field (docs/scene-format.md#depth-of-field): a thin
                // lens, drawn where a sample has lens points (--spp above 1).
                "aperture" | "focallength" => {
                    let v = self.v(c)?;
                    let aperture = name == "aperture";
                    // An aperture may be 0 (a pinhole); the distance in focus may not.
                    if !(v.is_finite() && (v > 0.0 || (aperture && v == 0.0)) && v < f64::from(f32::MAX)) {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        let expected = if aperture {
                            "expected a lens size of 0 or more, 0 for a pinhole"
                        } else {
                            "expected the positive distance in focus, in world units"
                        };
                        return Err(self.err(self.aloc(&a), format!("<{name}> is {} ({expected})", fmt_number(v))));
                    }
                    if aperture {
                        cam.aperture = Some(v);
                        aperture_node = Some(c);
                    } else {
                        cam.focal_length = Some(v);
                    }
                }
                _ => {
                    self.unknown_element(c, "cameradata", CAMERA_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "cameradata");
        }
        if let (Some(c), None) = (aperture_node.filter(|_| cam.aperture > Some(0.0)), cam.focal_length) {
            let msg = "<aperture> without a <focallength>: a lens needs the distance in focus (add <focallength v=\"D\"/>, or give an aperture of 0 for a pinhole)";
            return Err(self.err(self.nloc(c), msg.to_string()));
        }
        let mut look_node = None;
        if let Some((c, v)) = aim {
            look_node = Some(c);
            cam.look = if c.tag_name().name() == "focus" { v - cam.pos } else { v };
            if unit(cam.look).is_none() {
                let msg = if c.tag_name().name() == "focus" {
                    if cam.look.is_finite() {
                        "<focus> is the same point as <pos>, so the camera looks nowhere; move one of them".to_string()
                    } else {
                        "<focus> is too far from <pos> (the look direction overflows)".to_string()
                    }
                } else {
                    "<look> is the zero vector (expected a direction to look along)".to_string()
                };
                return Err(self.err(self.nloc(c), msg));
            }
        }
        let look = unit(cam.look);
        let up = unit(cam.up);
        if up.is_none() {
            let loc = up_node.map(|u| self.nloc(u)).unwrap_or_else(|| self.nloc(n));
            return Err(self.err(loc, "<up> is the zero vector (expected a direction, usually 0 1 0)".to_string()));
        }
        if let (Some(l), Some(u)) = (look, up) {
            if l.cross(u).length() < 1e-9 {
                let (loc, which) = match (up_node, look_node) {
                    (Some(u), _) => (self.nloc(u), "<up>"),
                    (None, Some(l)) => {
                        (self.nloc(l), if l.tag_name().name() == "focus" { "<focus>" } else { "<look>" })
                    }
                    (None, None) => (self.nloc(n), "<cameradata>"),
                };
                return Err(self.err(
                    loc,
                    format!(
                        "{which}: the up vector {} is parallel to the look direction {}, so the camera's roll is undefined; choose an up that is not along the look direction",
                        fmt_vector(cam.up),
                        fmt_vector(cam.look)
                    ),
                ));
            }
        }
        Ok(cam)
    }
}
