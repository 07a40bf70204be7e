//! Bit-for-bit comparison of two renders of one frame (a device and the CPU
//! build): per buffer — t, hit id, normal, RGBA, ray count — how many pixels differ,
//! the first difference with both values in decimal and hex and its ULP
//! distance, and the worst ULP distance.

use crate::error::Error;
use crate::image_io::Rgb8;
use crate::layout::PixelOut;
use crate::render::Picture;
use std::fmt::{self, Write};

/// Distance in units in the last place between two floats: how many
/// representable floats lie between them. 0 only for identical bits
/// (+0 and -0 are 1 apart: the check is bitwise). u64::MAX when exactly one
/// is NaN, or both are NaN with different bits.
pub fn ulp_distance(a: f32, b: f32) -> u64 {
    if a.to_bits() == b.to_bits() {
        return 0;
    }
    if a.is_nan() || b.is_nan() {
        return u64::MAX;
    }
    // Map the sign-magnitude bits onto a line where adjacent floats are
    // adjacent integers, -0 just below +0.
    let key = |x: f32| -> i64 {
        let bits = x.to_bits();
        if bits & 0x8000_0000 != 0 {
            -i64::from(bits & 0x7fff_ffff) - 1
        } else {
            i64::from(bits)
        }
    };
    key(a).abs_diff(key(b))
}

/// One buffer's comparison.
#[derive(Clone, Debug, Default)]
pub struct BufferDiff {
    pub name: &'static str,
    pub differing: usize,
    /// (x, y, a, b) of the first differing pixel, values formatted.
    pub first: Option<(u32, u32, String, String, Option<u64>)>,
    /// Worst ULP distance (float buffers) or channel difference (RGBA).
    pub worst: Option<(u32, u32, u64)>,
    /// "ULP" for float buffers, "/255" for RGBA, "" for ids.
    pub unit: &'static str,
}

/// The comparison of two renders.
#[derive(Clone, Debug)]
pub struct CheckReport {
    pub width: u32,
    pub height: u32,
    pub a_name: String,
    pub b_name: String,
    pub buffers: Vec<BufferDiff>,
    /// Pixels that differ in any buffer.
    pub differing_pixels: usize,
    /// Black where identical, red where any buffer differs; a dim copy of
    /// render a elsewhere.
    pub diff_image: Rgb8,
}

impl CheckReport {
    pub fn identical(&self) -> bool {
        self.differing_pixels == 0
    }
}

fn float_text(x: f32) -> String {
    format!("{x:?} (0x{:08x})", x.to_bits())
}

fn hex_text(x: u32) -> String {
    format!("{x} (0x{x:08x})")
}

/// Compares every buffer of `a` and `b` bit for bit.
pub fn compare(a: &Picture, a_name: &str, b: &Picture, b_name: &str) -> Result<CheckReport, Error> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(Error::Failed(format!(
            "sizes differ: {a_name} {}x{}, {b_name} {}x{}",
            a.width, a.height, b.width, b.height
        )));
    }
    let mut t = BufferDiff { name: "t", unit: "ULP", ..Default::default() };
    let mut id = BufferDiff { name: "id", unit: "", ..Default::default() };
    let mut normal = BufferDiff { name: "normal", unit: "ULP", ..Default::default() };
    let mut rgba = BufferDiff { name: "rgba", unit: "/255", ..Default::default() };
    let mut rays = BufferDiff { name: "rays", unit: " rays", ..Default::default() };
    let mut diff_image = Rgb8 { width: a.width, height: a.height, data: vec![0; 3 * a.pixels.len()] };
    let mut differing_pixels = 0;

    fn note(d: &mut BufferDiff, x: u32, y: u32, va: String, vb: String, dist: Option<u64>) {
        d.differing += 1;
        if d.first.is_none() {
            d.first = Some((x, y, va, vb, dist));
        }
        if let Some(dist) = dist {
            if d.worst.is_none_or(|w| dist > w.2) {
                d.worst = Some((x, y, dist));
            }
        }
    }

    for (i, (pa, pb)) in a.pixels.iter().zip(&b.pixels).enumerate() {
        let (x, y) = ((i % a.width as usize) as u32, (i / a.width as usize) as u32);
        let mut any = false;
        if pa.t.to_bits() != pb.t.to_bits() {
            note(&mut t, x, y, float_text(pa.t), float_text(pb.t), Some(ulp_distance(pa.t, pb.t)));
            any = true;
        }
        if pa.id != pb.id {
            note(&mut id, x, y, hex_text(pa.id), hex_text(pb.id), None);
            any = true;
        }
        // xyz the normal, w the walk's passes (layout.h PixelOut).
        let n_differs = (0..4).any(|c| pa.normal[c].to_bits() != pb.normal[c].to_bits());
        if n_differs {
            let worst_c = (0..4).max_by_key(|&c| ulp_distance(pa.normal[c], pb.normal[c])).unwrap_or(0);
            let fmt = |p: &PixelOut| {
                let [x, y, z, w] = p.normal.map(float_text);
                if p.normal[3] == 0.0 {
                    format!("[{x}, {y}, {z}]")
                } else {
                    format!("[{x}, {y}, {z}], passes {w}")
                }
            };
            note(&mut normal, x, y, fmt(pa), fmt(pb), Some(ulp_distance(pa.normal[worst_c], pb.normal[worst_c])));
            any = true;
        }
        if pa.rgba != pb.rgba {
            let (ca, cb) = (pa.rgba.to_le_bytes(), pb.rgba.to_le_bytes());
            let dist = (0..4).map(|c| u64::from(ca[c].abs_diff(cb[c]))).max().unwrap_or(0);
            let fmt = |c: [u8; 4]| format!("{:?} (0x{:08x})", c, u32::from_le_bytes(c));
            note(&mut rgba, x, y, fmt(ca), fmt(cb), Some(dist));
            any = true;
        }
        if pa.rays != pb.rays {
            note(&mut rays, x, y, pa.rays.to_string(), pb.rays.to_string(), Some(u64::from(pa.rays.abs_diff(pb.rays))));
            any = true;
        }
        let px = &mut diff_image.data[3 * i..3 * i + 3];
        if any {
            differing_pixels += 1;
            px.copy_from_slice(&[255, 0, 0]);
        } else {
            let [r, g, b, _] = pa.rgba.to_le_bytes();
            px.copy_from_slice(&[r / 4, g / 4, b / 4]);
        }
    }
    Ok(CheckReport {
        width: a.width,
        height: a.height,
        a_name: a_name.to_string(),
        b_name: b_name.to_string(),
        buffers: vec![t, id, normal, rgba, rays],
        differing_pixels,
        diff_image,
    })
}

impl fmt::Display for CheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let total = self.width as usize * self.height as usize;
        for b in &self.buffers {
            let mut line = format!("{:<7} {} of {total} pixels differ", format!("{}:", b.name), b.differing);
            if let Some((x, y, va, vb, dist)) = &b.first {
                let _ = write!(line, "; first at ({x}, {y}): {} {va}, {} {vb}", self.a_name, self.b_name);
                if let Some(d) = dist {
                    let _ = write!(line, ", {}", distance_text(*d, b.unit));
                }
            }
            if let Some((x, y, d)) = b.worst {
                let _ = write!(line, "; worst {} at ({x}, {y})", distance_text(d, b.unit));
            }
            writeln!(f, "{line}")?;
        }
        if self.identical() {
            write!(f, "identical: every pixel of every buffer has the same bits")
        } else {
            write!(f, "{} of {total} pixels differ in at least one buffer", self.differing_pixels)
        }
    }
}

fn distance_text(d: u64, unit: &str) -> String {
    if d == u64::MAX {
        "NaN against a number".to_string()
    } else if unit == "ULP" {
        format!("{d} ULP")
    } else {
        format!("{d}{unit}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ulp_distance_counts_floats_between() {
        assert_eq!(ulp_distance(1.0, 1.0), 0);
        assert_eq!(ulp_distance(1.0, f32::from_bits(1.0f32.to_bits() + 1)), 1);
        assert_eq!(ulp_distance(1.0, f32::from_bits(1.0f32.to_bits() + 3)), 3);
        assert_eq!(ulp_distance(0.0, -0.0), 1);
        assert_eq!(ulp_distance(f32::from_bits(1), -f32::from_bits(1)), 3); // -min, -0, +0, +min
        assert_eq!(ulp_distance(f32::NAN, 1.0), u64::MAX);
        assert_eq!(ulp_distance(-1.0, 1.0), ulp_distance(1.0, -1.0));
    }

    fn picture(pixels: Vec<PixelOut>, width: u32) -> Picture {
        let height = pixels.len() as u32 / width;
        Picture { width, height, pixels }
    }

    #[test]
    fn reports_count_first_and_worst_per_buffer() {
        let base = PixelOut { normal: [0.0, 1.0, 0.0, 0.0], t: 2.0, id: 3, rgba: 0xff00_0000, rays: 4 };
        let a = picture(vec![base; 4], 2);
        let mut b = a.clone();
        b.pixels[1].t = f32::from_bits(2.0f32.to_bits() + 1);
        b.pixels[3].t = f32::from_bits(2.0f32.to_bits() + 5);
        b.pixels[2].rgba = 0xff00_0003;
        b.pixels[3].rays = 6;
        let r = compare(&a, "gpu", &b, "cpu").unwrap();
        assert_eq!(r.differing_pixels, 3);
        let t = &r.buffers[0];
        assert_eq!(t.differing, 2);
        assert_eq!(t.first.as_ref().unwrap().0, 1);
        assert_eq!(t.worst, Some((1, 1, 5)));
        assert_eq!(r.buffers[1].differing, 0);
        assert_eq!(r.buffers[3].differing, 1);
        assert_eq!(r.buffers[4].worst, Some((1, 1, 2)));
        let text = r.to_string();
        assert!(text.contains("t:      2 of 4 pixels differ; first at (1, 0): gpu 2.0 (0x40000000), cpu 2.0000002 (0x40000001), 1 ULP; worst 5 ULP at (1, 1)"), "{text}");
        assert!(
            text.contains(
                "rays:   1 of 4 pixels differ; first at (1, 1): gpu 4, cpu 6, 2 rays; worst 2 rays at (1, 1)"
            ),
            "{text}"
        );
        assert!(text.contains("3 of 4 pixels differ in at least one buffer"), "{text}");
        assert_eq!(r.diff_image.pixel(1, 0), [255, 0, 0]);
        assert!(compare(&a, "gpu", &a, "cpu").unwrap().identical());
    }
}
