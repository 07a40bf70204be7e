//! Camera control, for the preview's steering and `render --orbit`: orbit,
//! pan, dolly, fly, reset, frame the scene, and the `<cameradata>` block that
//! writes the camera back into a scene file. Pure geometry in f64 on the scene model's `Camera`, so that
//! after a reset the camera is the scene's, bit for bit.
//!
//! ```text
//!        up (the scene's, fixed)
//!        |      focus = pos + unit(look) * focus_distance
//!        |     /
//!   pos *-----*      orbit: pos turns about the focus (distance kept)
//!              \     pan:   pos and focus move in the image plane
//!                    dolly: pos moves along look, the focus stays
//! ```

use glam::{DQuat, DVec3};

use super::{Bounds, Camera};

/// Smallest angle between the view direction and the up axis while orbiting.
const POLE_MARGIN_DEG: f64 = 1.0;
/// How much one wheel step moves the camera toward the focus.
const DOLLY_STEP: f64 = 0.85;
const MIN_DISTANCE: f64 = 1e-4;

/// A camera and what it turns about.
#[derive(Clone, Debug)]
pub struct CameraControl {
    /// What is drawn. After `new` or `reset` exactly the scene's camera.
    pub camera: Camera,
    /// Distance from `camera.pos` along `camera.look` to the focus.
    focus_distance: f64,
    home: Camera,
    home_distance: f64,
}

impl CameraControl {
    /// Starts at the scene's camera. The focus is where the view axis passes
    /// closest to the centre of `bounds` (in front of the camera), or 5 units
    /// ahead without bounds.
    pub fn new(camera: &Camera, bounds: Option<Bounds>) -> CameraControl {
        let dir = unit_or(camera.look, DVec3::NEG_Z);
        let distance = match bounds {
            Some(b) => {
                let along = (b.center() - camera.pos).dot(dir);
                if along > MIN_DISTANCE {
                    along
                } else {
                    (b.center() - camera.pos).length().max(b.radius()).max(1.0)
                }
            }
            None => 5.0,
        };
        CameraControl {
            camera: camera.clone(),
            focus_distance: distance,
            home: camera.clone(),
            home_distance: distance,
        }
    }

    pub fn focus(&self) -> DVec3 {
        self.camera.pos + self.forward() * self.focus_distance
    }

    pub fn focus_distance(&self) -> f64 {
        self.focus_distance
    }

    /// Unit view direction.
    pub fn forward(&self) -> DVec3 {
        unit_or(self.camera.look, DVec3::NEG_Z)
    }

    /// Unit world up (the scene camera's up).
    fn world_up(&self) -> DVec3 {
        unit_or(self.camera.up, DVec3::Y)
    }

    /// Unit image-plane right and up.
    fn right_and_up(&self) -> (DVec3, DVec3) {
        let f = self.forward();
        let right = unit_or(f.cross(self.world_up()), DVec3::X);
        (right, right.cross(f))
    }

    /// Places the camera at `pos` looking at the focus `focus`.
    fn look_from(&mut self, pos: DVec3, focus: DVec3) {
        let d = focus - pos;
        self.focus_distance = d.length().max(MIN_DISTANCE);
        self.camera.pos = pos;
        self.camera.look = d;
    }

    /// Turns the camera about the focus: `yaw_deg` about the world up,
    /// `pitch_deg` about the image's right axis (positive: the camera rises),
    /// stopping short of the poles. The distance to the focus is kept.
    pub fn orbit(&mut self, yaw_deg: f64, pitch_deg: f64) {
        let focus = self.focus();
        let up = self.world_up();
        let (right, _) = self.right_and_up();
        let mut offset = self.camera.pos - focus;
        // The angle between offset and up, kept inside the margins.
        let polar = offset.angle_between(up).to_degrees();
        let pitch = pitch_deg.clamp(polar - (180.0 - POLE_MARGIN_DEG), polar - POLE_MARGIN_DEG);
        offset = DQuat::from_axis_angle(right, -pitch.to_radians()) * offset;
        offset = DQuat::from_axis_angle(up, yaw_deg.to_radians()) * offset;
        // Exactly the old distance along the new direction.
        let pos = focus + offset.normalize() * self.focus_distance;
        let distance = self.focus_distance;
        self.look_from(pos, focus);
        self.focus_distance = distance;
    }

    /// Moves camera and focus in the image plane so that the point under the
    /// cursor follows a drag of (dx, dy) pixels (y down) on a
    /// `viewport_height`-pixel image.
    pub fn pan(&mut self, dx: f64, dy: f64, viewport_height: f64) {
        let (right, up) = self.right_and_up();
        let per_pixel = 2.0 * self.focus_distance * (self.camera.height_angle_deg.to_radians() * 0.5).tan()
            / viewport_height.max(1.0);
        self.camera.pos += (-dx * right + dy * up) * per_pixel;
    }

    /// Moves toward the focus (steps > 0, wheel forward) or away, by a factor per step.
    pub fn dolly(&mut self, steps: f64) {
        let focus = self.focus();
        let distance = (self.focus_distance * DOLLY_STEP.powf(steps)).max(MIN_DISTANCE);
        let pos = focus - self.forward() * distance;
        self.look_from(pos, focus);
    }

    /// Moves camera and focus `forward` along the view, `right` along the
    /// image's right, `up` along the world up (world units).
    pub fn fly(&mut self, forward: f64, right: f64, up: f64) {
        let (r, _) = self.right_and_up();
        self.camera.pos += self.forward() * forward + r * right + self.world_up() * up;
    }

    /// Back to the scene's camera.
    pub fn reset(&mut self) {
        self.camera = self.home.clone();
        self.focus_distance = self.home_distance;
    }

    /// Keeps the view direction and moves back (or forward) until the sphere
    /// around `bounds` fills the narrower of the two fields of view of an
    /// image `aspect` = width / height; the focus goes to its centre.
    pub fn frame(&mut self, bounds: &Bounds, aspect: f64) {
        let half_v = (self.camera.height_angle_deg.to_radians() * 0.5).max(1e-6);
        let half_h = (half_v.tan() * aspect.max(1e-6)).atan();
        let radius = if bounds.radius() > 0.0 { bounds.radius() } else { 1.0 };
        let distance = radius / half_v.min(half_h).sin();
        let c = bounds.center();
        self.look_from(c - self.forward() * distance, c);
    }

    /// The camera as a `<cameradata>` block for a scene file. Numbers are
    /// written in Rust's shortest round-trip form, so parsing the block gives
    /// back this camera exactly.
    pub fn cameradata_block(&self) -> String {
        let c = &self.camera;
        let v = |name: &str, p: DVec3| format!("  <{name} x=\"{}\" y=\"{}\" z=\"{}\"/>\n", p.x, p.y, p.z);
        format!(
            "<cameradata>\n{}{}{}  <heightangle v=\"{}\"/>\n</cameradata>",
            v("pos", c.pos),
            v("look", c.look),
            v("up", c.up),
            c.height_angle_deg
        )
    }
}

fn unit_or(v: DVec3, fallback: DVec3) -> DVec3 {
    v.try_normalize().unwrap_or(fallback)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{parse_str, ParseOptions};
    use std::path::Path;

    fn camera(pos: [f64; 3], look: [f64; 3], up: [f64; 3], angle: f64) -> Camera {
        Camera {
            pos: DVec3::from(pos),
            look: DVec3::from(look),
            up: DVec3::from(up),
            height_angle_deg: angle,
            ..Camera::default()
        }
    }

    fn bounds() -> Bounds {
        Bounds { min: DVec3::new(-1.0, -0.5, -2.0), max: DVec3::new(3.0, 1.5, 0.5) }
    }

    /// Rule: |pos - focus| stays within 1e-9 relative of its start over many
    /// orbits of every size, the focus does not move, and the view never
    /// reaches the poles.
    #[test]
    fn orbit_keeps_the_distance_to_the_focus() {
        let mut c =
            CameraControl::new(&camera([4.5, 3.2, 6.5], [-4.5, -2.9, -6.5], [0.0, 1.0, 0.0], 40.0), Some(bounds()));
        let focus = c.focus();
        let d0 = (c.camera.pos - focus).length();
        for k in 0..500 {
            let (yaw, pitch) = ((k as f64 * 7.3) % 41.0 - 20.0, (k as f64 * 3.7) % 130.0 - 65.0);
            c.orbit(yaw, pitch);
            let d = (c.camera.pos - focus).length();
            assert!((d - d0).abs() <= 1e-9 * d0, "step {k} (yaw {yaw}, pitch {pitch}): distance {d}, started at {d0}");
            assert!((c.focus() - focus).length() <= 1e-9 * d0, "step {k}: focus moved to {}", c.focus());
            let polar = (c.camera.pos - focus).angle_between(DVec3::Y).to_degrees();
            assert!(
                (POLE_MARGIN_DEG - 1e-6..=180.0 - POLE_MARGIN_DEG + 1e-6).contains(&polar),
                "step {k}: polar {polar}"
            );
        }
    }

    #[test]
    fn orbit_turns_about_the_up_axis() {
        let mut c = CameraControl::new(&camera([0.0, 0.0, 5.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 45.0), None);
        c.orbit(90.0, 0.0);
        // A quarter turn about +y takes +z to +x.
        assert!((c.camera.pos - DVec3::new(5.0, 0.0, 0.0)).length() < 1e-9, "{}", c.camera.pos);
        assert!((c.forward() - DVec3::NEG_X).length() < 1e-9, "{}", c.forward());
    }

    #[test]
    fn pan_dolly_and_reset() {
        let start = camera([0.0, 0.0, 5.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0], 90.0);
        let mut c = CameraControl::new(&start, None);
        // 90 degrees, distance 5: the image is 10 units high; 100 px of 100 is 10 units.
        c.pan(100.0, 0.0, 100.0);
        assert!((c.camera.pos - DVec3::new(-10.0, 0.0, 5.0)).length() < 1e-9, "{}", c.camera.pos);
        c.dolly(1.0);
        assert!((c.focus_distance() - 5.0 * DOLLY_STEP).abs() < 1e-9);
        c.fly(1.0, 0.0, 2.0);
        c.reset();
        assert_eq!(c.camera, start, "reset gives back the scene's camera bit for bit");
    }

    /// Rule: after F the box's centre is on the view axis, the view direction
    /// is unchanged, every corner of the box is inside the field of view, and
    /// the enclosing sphere touches the narrower field of view.
    #[test]
    fn frame_fits_the_bounds() {
        for aspect in [0.5, 1.0, 4.0 / 3.0, 3.0] {
            let mut c =
                CameraControl::new(&camera([10.0, 20.0, 30.0], [-1.0, -1.0, -1.0], [0.0, 1.0, 0.0], 45.0), None);
            let dir = c.forward();
            let b = bounds();
            c.frame(&b, aspect);
            assert!((c.forward() - dir).length() < 1e-12, "the view direction changed");
            assert!((c.focus() - b.center()).length() < 1e-9, "focus {} is not the centre {}", c.focus(), b.center());
            let (right, up) = c.right_and_up();
            let tan_v = (22.5f64).to_radians().tan();
            let tan_h = tan_v * aspect;
            for corner in b.corners() {
                let p = corner - c.camera.pos;
                let z = p.dot(dir);
                assert!(z > 0.0, "corner {corner} is behind the camera");
                assert!(
                    (p.dot(right) / z).abs() <= tan_h + 1e-9,
                    "corner {corner} is outside horizontally (aspect {aspect})"
                );
                assert!(
                    (p.dot(up) / z).abs() <= tan_v + 1e-9,
                    "corner {corner} is outside vertically (aspect {aspect})"
                );
            }
            let half = (22.5f64).to_radians().min(tan_h.atan());
            assert!((c.focus_distance() * half.sin() - b.radius()).abs() < 1e-9);
        }
    }

    /// Rule: bit-exact. The printed block, parsed by the scene parser, is the camera.
    #[test]
    fn cameradata_block_round_trips_through_the_parser() {
        let mut c =
            CameraControl::new(&camera([4.5, 3.2, 6.5], [-4.5, -2.9, -6.5], [0.0, 1.0, 0.0], 40.0), Some(bounds()));
        c.orbit(33.3, 12.7);
        c.pan(13.0, -7.0, 384.0);
        c.dolly(-1.5);
        let block = c.cameradata_block();
        let xml = format!("<scenefile>\n{block}\n<object type=\"tree\" name=\"root\"></object>\n</scenefile>");
        let parsed =
            parse_str(&xml, Path::new("camera.xml"), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}\n{xml}"));
        assert_eq!(parsed.camera.pos, c.camera.pos, "{block}");
        assert_eq!(parsed.camera.look, c.camera.look, "{block}");
        assert_eq!(parsed.camera.up, c.camera.up, "{block}");
        assert_eq!(parsed.camera.height_angle_deg, c.camera.height_angle_deg, "{block}");
    }
}
