//! The camera as the kernels take it: the film-to-world matrix, the thin
//! lens, and an area light's axes, each computed in f64 and rounded to f32
//! once, for both backends.

use super::vec4;
use crate::layout::{self, Mat4};
use crate::scene::Camera;
use glam::{DMat4, DVec3, DVec4};

pub(super) fn mat4(m: &DMat4) -> Mat4 {
    let c = m.to_cols_array_2d();
    c.map(|col| col.map(|x| x as f32))
}

/// world_from_film = translate(eye) · rotation(u, v, w) · scale⁻¹ (the seed
/// handout), where w = -look/|look|, u = (up × w)/|up × w|, v = w × u, and
/// scale⁻¹ = diag(tan(θw/2), tan(θh/2), 1) with θh the scene's height angle
/// and tan(θw/2) = tan(θh/2)·width/height.
pub fn world_from_film(cam: &Camera, width: u32, height: u32) -> DMat4 {
    let w = -cam.look.normalize();
    let u = cam.up.cross(w).normalize();
    let v = w.cross(u);
    let tan_h = (cam.height_angle_deg.to_radians() * 0.5).tan();
    let tan_w = tan_h * f64::from(width) / f64::from(height);
    let translate = DMat4::from_translation(cam.pos);
    let rotate = DMat4::from_cols(u.extend(0.0), v.extend(0.0), w.extend(0.0), DVec4::W);
    let scale_inv = DMat4::from_scale(DVec3::new(tan_w, tan_h, 1.0));
    translate * rotate * scale_inv
}

/// The thin lens of `camera`, (radius, focal distance) in world units, or
/// None for a pinhole: no aperture, or one of 0
/// (docs/scene-format.md#depth-of-field). The parser has checked both
/// numbers: an aperture comes with a positive focal length.
pub fn lens(camera: &Camera) -> Option<(f32, f32)> {
    let aperture = camera.aperture.filter(|&a| a > 0.0)?;
    let focal = camera.focal_length?;
    Some(((aperture * LENS_RADIUS_PER_APERTURE) as f32, focal as f32))
}

/// The lens radius of an `<aperture>` of 1, in world units: fitted to the
/// course's render of test_dof/dof.xml (docs/scene-format.md#depth-of-field).
pub const LENS_RADIUS_PER_APERTURE: f64 = 1.5;

/// An area light's in-plane unit axes (e_u, e_v) for its unit normal `n`
/// (the direction it faces): e_u is the world x axis made perpendicular to
/// n when n is within about 26 degrees of straight up or down (|n_y| >=
/// 0.9), e_v = n x e_u; otherwise e_v is the world y axis made
/// perpendicular to n, e_u = e_v x n (docs/scene-format.md#area-lights).
pub fn area_edges(n: DVec3) -> (DVec3, DVec3) {
    if n.y.abs() >= 0.9 {
        let e_u = (DVec3::X - DVec3::X.dot(n) * n).normalize();
        (e_u, n.cross(e_u))
    } else {
        let e_v = (DVec3::Y - DVec3::Y.dot(n) * n).normalize();
        (e_v.cross(n), e_v)
    }
}

/// `frame` seen through `camera`: its world_from_film (for the frame's
/// width and height) and eye, each element computed in f64 and rounded to
/// f32, as `build` makes them for a scene with that camera.
pub fn set_camera(frame: &mut layout::Frame, camera: &Camera) {
    frame.world_from_film = mat4(&world_from_film(camera, frame.width, frame.height));
    frame.eye = vec4(camera.pos, 1.0);
}
