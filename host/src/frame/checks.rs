//! Scenes the renderer's 32-bit floats cannot draw, refused with an error
//! at their element before anything is packed: lights too far away, shapes
//! scaled beyond the intersection tests, cameras whose rows the floats
//! cannot tell apart.

use crate::error::Error;
use crate::scene::{LightKind, Scene};
use glam::{DMat4, DVec3};

/// The farthest a positioned light may be from the origin: the shader
/// squares a light's distance in f32 (raycast.glsl, `dot3(d, d)`), which
/// overflows beyond about 1.8e19, and such a light lights nothing.
pub(super) const LIGHT_REACH: f64 = 1.0e19;

/// The scene's positioned lights within what the renderer's 32-bit floats
/// can light with (`LIGHT_REACH`; the parser holds every number the
/// renderer takes as written, the camera's position among them, to f32).
pub(super) fn check_light_reach(scene: &Scene) -> Result<(), Error> {
    for l in scene.lights.iter().filter(|l| l.kind != LightKind::Directional) {
        let distance = l.position.length();
        if distance > LIGHT_REACH {
            return Err(Error::Scene(format!(
                "{}: error: this light is {distance:.3e} units from the origin: the renderer squares a light's distance in \
                 32-bit floats, which overflows beyond about 1.8e19, so it would light nothing; for light from far \
                 away, use type=\"directional\"",
                l.loc
            )));
        }
    }
    Ok(())
}

/// How far the walk may scale a ray's direction (a unit vector in the
/// world) into a primitive's or a master's space, either way: a shape drawn
/// more than 1e15 times its canonical size, or less than 1e-15 times, meets
/// rays whose squared length (the quadratic's leading term: a sphere's,
/// a cylinder's, an instance's bounding sphere) is beyond 1e30 or below
/// 1e-30, where the 32-bit tests lose it: a sphere scaled by 1e20 drew
/// as a one-pixel ring, one placed through masters scaled by 3e22 and 1e-23
/// not at all (and `--no-bvh` drew it).
pub(super) const MAX_SCALING: f64 = 1e15;

/// The narrowest angle between two rows' camera rays the renderer's
/// 32-bit floats resolve, in radians: where a row spans less, a hit
/// point's rounding (a few f32 steps of its distance from the origin, the
/// eye's included) is larger than the row's footprint, whatever the scene's
/// layout, and the picture is noise (a sphere filling 72 rows drew 3.9% of
/// its normals wrong at 1.7e-8 radians a row, none at 1.7e-7).
pub(super) const MIN_ROW_ANGLE: f64 = 1e-7;

/// The camera's height angle over the picture's rows, refused below
/// `MIN_ROW_ANGLE` (a telescope of heightangle 1e-5 degrees drew a sphere
/// with wrong normals and gaps, without a word).
pub(super) fn check_row_angle(scene: &Scene, height: u32) -> Result<(), Error> {
    let degrees = scene.camera.height_angle_deg;
    let per_row = degrees.to_radians() / f64::from(height.max(1));
    if per_row >= MIN_ROW_ANGLE {
        return Ok(());
    }
    let place = match &scene.camera.height_angle_loc {
        Some(loc) => loc.to_string(),
        None => format!("{} (its default heightangle)", scene.path.display()),
    };
    Err(Error::Scene(format!(
        "{place}: error: the camera's heightangle of {}° over {height} rows is {per_row:.1e} radians a row, less than the \
         {MIN_ROW_ANGLE:.0e} the renderer's 32-bit floats resolve (the picture would be noise): widen it (at least \
         {:.1e}°), or render fewer rows",
        crate::units::fmt_number(degrees),
        (MIN_ROW_ANGLE * f64::from(height.max(1))).to_degrees()
    )))
}

/// The largest singular value of `m`'s linear part: the most it stretches
/// a vector (the square root of the largest eigenvalue of LᵀL, by the
/// closed form for symmetric 3x3 matrices, which is accurate for the
/// largest one).
pub(super) fn stretch(m: &DMat4) -> f64 {
    let l = glam::DMat3::from_mat4(*m);
    let a = l.transpose() * l;
    let (a00, a11, a22) = (a.x_axis.x, a.y_axis.y, a.z_axis.z);
    let off = a.y_axis.x * a.y_axis.x + a.z_axis.x * a.z_axis.x + a.z_axis.y * a.z_axis.y;
    let largest = if off == 0.0 {
        a00.max(a11).max(a22)
    } else {
        let q = (a00 + a11 + a22) / 3.0;
        let p = (((a00 - q).powi(2) + (a11 - q).powi(2) + (a22 - q).powi(2) + 2.0 * off) / 6.0).sqrt();
        let b = (a - glam::DMat3::from_diagonal(DVec3::splat(q))) * (1.0 / p);
        let phi = (b.determinant() / 2.0).clamp(-1.0, 1.0).acos() / 3.0;
        q + 2.0 * p * phi.cos()
    };
    largest.max(0.0).sqrt()
}

/// A shape (or a master) drawn at a scale the 32-bit intersection tests
/// cannot hold (`MAX_SCALING`), through its transforms and those of every
/// chain of masters placing it: an error at the element, where it would
/// otherwise drop out of the picture. Each group's range of scalings from
/// the world is bounded from its placements' singular values (the most a
/// matrix stretches, and the most its inverse does), so nothing is
/// expanded.
pub(super) fn check_scaling(scene: &Scene) -> Result<(), Error> {
    // A ray's direction, of length 1 in the world, is of length within [lo, hi] in group g's space.
    let mut range = vec![(f64::INFINITY, 0.0f64); scene.groups.len()];
    if let Some(root) = range.first_mut() {
        *root = (1.0, 1.0);
    }
    let beyond = |(lo, hi): (f64, f64), what: &str, loc: &crate::scene::SourceLoc| {
        let (shrunk, grown) = (lo < 1.0 / MAX_SCALING, hi > MAX_SCALING);
        (shrunk || grown).then(|| {
            let scale = if shrunk { format!("up to {:.1e}", 1.0 / lo) } else { format!("down to {:.1e}", 1.0 / hi) };
            Error::Scene(format!(
                "{loc}: error: this {what} is scaled by {scale} in all (its transforms and those of the masters \
                 placing it): beyond {MAX_SCALING:.0e}, or below {:.0e}, the renderer's 32-bit intersection tests lose \
                 it, so it would drop out of the picture; scale the scene to other units",
                1.0 / MAX_SCALING
            ))
        })
    };
    for g in scene.groups_children_first().into_iter().rev() {
        let (lo, hi) = range[g];
        for p in &scene.groups[g].primitives {
            let r = (lo / stretch(&p.world_from_object), hi * stretch(&p.object_from_world));
            if let Some(e) = beyond(r, "primitive", &p.loc) {
                return Err(e);
            }
        }
        for i in &scene.groups[g].instances {
            let r = (lo / stretch(&i.parent_from_group), hi * stretch(&i.group_from_parent));
            if let Some(e) = beyond(r, "master", &i.loc) {
                return Err(e);
            }
            let child = &mut range[i.group as usize];
            *child = (child.0.min(r.0), child.1.max(r.1));
        }
    }
    Ok(())
}
