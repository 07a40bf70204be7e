//! Pixels a device cut short (Mesa's loop budget per invocation:
//! raycast.glsl loop_budget_ok), whatever the backend: refused with advice,
//! or finished by another renderer that runs the same code.

use super::{Picture, Renderer, Specialization, Told};
pub use crate::error::CutShort;
use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, PixelOut};

/// What to do about pixels cut short, for the commands that render
/// `data`: the settings of its frame that spend the loop budget (mirror
/// bounces where its kernel keeps mirrors), then another device.
pub fn render_advice(data: &FrameData) -> String {
    let f = &data.frame;
    let mirrors = Specialization::of(data, f).constants().get(layout::SPEC_REFLECTIONS as usize) == Some(&1);
    let mut ways: Vec<String> = Vec::new();
    if f.flags & layout::FLAG_NO_BVH != 0 {
        ways.push("drop --no-bvh".into());
    }
    if f.flags & layout::FLAG_SHADOWS != 0 && f.light_count > 1 {
        ways.push(format!(
            "render with --no-shadows (each hit sends a shadow ray to each of {} lights)",
            f.light_count
        ));
    }
    if mirrors && f.max_depth > 1 {
        ways.push(format!("use a smaller --depth than {}", f.max_depth));
    }
    ways.push("use another Vulkan device".into());
    let last = ways.pop().unwrap_or_default();
    let ways = if ways.is_empty() { last } else { format!("{}, or {last}", ways.join(", ")) };
    format!("`raycast render` finishes such pixels with the CPU build (the same code; on lavapipe the same bits); here, {ways}")
}

/// An error when the kernel marked pixels whose loops the device ended
/// early (raycast.glsl loop_budget_ok): such a picture is wrong.
pub fn refuse_cut_short(pixels: &[PixelOut], width: u32, device: &str, advice: String) -> Result<(), CutShort> {
    let Some(first) = pixels.iter().position(PixelOut::is_cut_short) else { return Ok(()) };
    let first = first as u32;
    Err(CutShort {
        device: device.to_string(),
        count: pixels.iter().filter(|p| p.is_cut_short()).count(),
        total: pixels.len(),
        first: (first % width, first / width),
        advice,
    })
}

/// Recomputes with `finisher` (the CPU build) the pixels of `picture` (a
/// render of `data`) that the device cut short; returns how many. The CPU
/// build runs the same shader code: on lavapipe, the only device known to
/// cut pixels short, its pixels are the device's bit for bit (what `raycast
/// check` and CI compare), so the finished picture is the one the device
/// would have made without its limit.
pub fn finish_cut_short(
    picture: &mut Picture,
    data: &FrameData,
    finisher: &dyn Renderer,
    told: Told,
) -> Result<usize, Error> {
    let width = picture.width as usize;
    let rows: Vec<u32> = picture
        .pixels
        .chunks(width)
        .enumerate()
        .filter(|(_, row)| row.iter().any(PixelOut::is_cut_short))
        .map(|(i, _)| i as u32)
        .collect();
    let mut count = 0;
    for (row, finished) in rows.iter().zip(finisher.render_rows(data, &rows, told)?) {
        let device_row = &mut picture.pixels[*row as usize * width..][..width];
        for (d, c) in device_row.iter_mut().zip(finished) {
            if d.is_cut_short() {
                *d = c;
                count += 1;
            }
        }
    }
    Ok(count)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::RenderSettings;

    fn data(xml: &str, settings: &RenderSettings) -> FrameData {
        let scene = crate::scene::from_xml(xml, "t.xml");
        crate::frame::build(&scene, settings).unwrap()
    }

    /// The advice for pixels cut short names what spends the loop budget in
    /// this frame: --no-bvh where given, shadows where several lights cast
    /// them, mirror bounces where the scene has a mirror, then another device.
    #[test]
    fn cut_short_advice_names_what_spends_the_budget() {
        let lights = r#"<lightdata><id v="0"/><position x="0" y="4" z="0"/></lightdata>
          <lightdata><id v="1"/><position x="4" y="4" z="0"/></lightdata>"#;
        let scene = |reflective: &str| {
            format!(
                r#"<scenefile>{lights}<object type="tree" name="root"><transblock><object type="primitive" name="cube">
                <reflective r="{reflective}" g="0" b="0"/></object></transblock></object></scenefile>"#
            )
        };
        let all = render_advice(&data(&scene("0.5"), &RenderSettings::default()));
        assert!(
            all.ends_with(
                "here, render with --no-shadows (each hit sends a shadow ray to each of 2 lights), use a smaller \
                 --depth than 4, or use another Vulkan device"
            ),
            "{all}"
        );
        assert!(!all.contains("--no-bvh"), "{all}");
        let no_bvh = RenderSettings { bvh: false, shadows: false, ..RenderSettings::default() };
        let a = render_advice(&data(&scene("0"), &no_bvh));
        assert!(a.ends_with("here, drop --no-bvh, or use another Vulkan device"), "{a}");
    }
}
