//! The status lines of the rendering commands (stderr).

use crate::cli::batch::*;
use crate::error::Error;
use crate::frame::FrameData;
use crate::image_io;
use crate::layout;
use crate::render::{Picture, Renderer};
use std::path::Path;
use std::time::Duration;

pub(crate) fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// The scene line: what was loaded and what it expanded to.
pub(crate) fn scene_line(p: &Prepared) -> String {
    format!(
        "scene: {} ({} primitives, {} unique in {} groups, {} lights; hierarchy built in {})",
        p.scene.path.display(),
        p.data.expanded,
        p.data.primitives.len(),
        p.data.groups,
        p.data.lights.len(),
        ms(p.data.build_time)
    )
}

/// [`scene_line`] with `-v`.
pub(crate) fn print_scene(p: &Prepared) {
    detail!("{}", scene_line(p));
}

/// Which kernel drew `data`, and what its specialization kept of the
/// shaders; nothing where the backend has no kernel (the CPU build).
pub(crate) fn print_kernel(renderer: &dyn Renderer, data: &FrameData) -> Result<(), Error> {
    let Some(k) = renderer.kernel(data)? else { return Ok(()) };
    let how = k.how_built.map(|h| format!(" ({h})")).unwrap_or_default();
    detail!("kernel: {}{}{how}, specialised for the scene: {}", k.name, k.division, k.specialization);
    Ok(())
}

/// The rate line, and with the cost AOV what the walks took.
pub(crate) fn print_rates(data: &FrameData, picture: &Picture, time: Duration) {
    detail!("{}", rate_line(data, picture, time));
    let what = match data.frame.aov {
        layout::AOV_COST => "a camera ray's walk takes",
        layout::AOV_COST_ALL | layout::AOV_LANES => "a pixel's rays walk",
        _ => return,
    };
    detail!("{}", picture.passes_text(what));
    // A scale far above the picture's passes leaves it all dark blue: say what would spread it.
    let scale = data.frame.aov_scale[2];
    let most = picture.most_passes().map_or(0, |(_, n)| n) as f32;
    if most > 0.0 && most * 2.0 <= scale {
        detail!("cost: drawn dark red at {scale} passes (--cost-max), twice the most here or more: --cost-max {most} spreads the colours over this picture");
    }
}

/// Camera rays (width x height x spp) and every ray the pixels counted, per second of `time`.
pub(crate) fn rate_line(data: &FrameData, picture: &Picture, time: Duration) -> String {
    let f = &data.frame;
    let primary = f.camera_rays();
    let all = picture.rays();
    let per_s = |n: u64| n as f64 / time.as_secs_f64().max(1e-9) / 1e6;
    format!(
        "rate: {:.2} M primary rays/s, {:.2} M rays/s in all ({primary} camera rays, {all} in all, in {})",
        per_s(primary),
        per_s(all),
        ms(time)
    )
}

/// Writes `picture` as a PNG to `path`, and says so with the time it took
/// to render (the one summary line).
pub(crate) fn write_picture(path: &Path, picture: &Picture, time: Duration) -> Result<(), Error> {
    let image = picture.rgb8()?;
    image_io::write_png(path, &image)?;
    summary!("wrote {} ({}x{}) in {:.2} s", path.display(), picture.width, picture.height, time.as_secs_f64());
    Ok(())
}
