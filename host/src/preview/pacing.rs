//! How fast the preview draws: the frame budget, the resolution while the
//! camera moves, bands of rows for a slow sample, the sample pattern, and
//! the rates it reports.

use std::time::Duration;

use crate::layout;

/// After the camera's last move, frames stay at the motion resolution this long.
pub(super) const MOTION_HOLD: Duration = Duration::from_millis(300);
/// While the camera moves, a frame should take at most this long: 125 ms (8
/// a second) where the CPU draws (lavapipe, the CPU build), where every
/// pixel is dear, and 33 ms (30 a second) on a GPU, where a window's full
/// size is usually within reach (on an H200, depth 10 with shadows at
/// 1920x1080 took 95 ms a frame at full size: with 125 ms it steered at 10
/// a second). At rest a slow sample is drawn in bands of the same budget.
pub(super) const MOTION_FRAME_MS: [f64; 2] = [125.0, 1000.0 / 30.0];

/// The frame budget (MOTION_FRAME_MS) of a drawer that runs on the CPU or not.
pub(super) fn frame_budget_ms(on_cpu: bool) -> f64 {
    MOTION_FRAME_MS[usize::from(!on_cpu)]
}
/// The most the motion resolution divides the width and height by: 2^(MAX_MOTION_STEPS / 4) = 8.
pub(super) const MAX_MOTION_STEPS: u32 = 12;
/// Frames smaller than this do not update the cost per pixel.
pub(super) const COST_MIN_PIXELS: u64 = 16384;
/// `--moving`: how far the camera orbits before each frame.
pub(super) const MOVING_DEG_PER_FRAME: f64 = 2.0;

/// Milliseconds per pixel of the last COST_FRAMES frames measured.
#[derive(Default)]
pub(super) struct PixelCost {
    last: std::collections::VecDeque<f64>,
}

/// Frames `PixelCost` keeps.
pub(super) const COST_FRAMES: usize = 5;

impl PixelCost {
    pub(super) fn push(&mut self, ms_per_pixel: f64) {
        if !ms_per_pixel.is_finite() || ms_per_pixel <= 0.0 {
            return;
        }
        if self.last.len() == COST_FRAMES {
            self.last.pop_front();
        }
        self.last.push_back(ms_per_pixel);
    }

    /// Their median (None before the first): one slow frame (a pipeline
    /// built, another process on the cores) does not shrink the steering
    /// size, as it did in an average; a lasting change moves it within
    /// three frames.
    pub(super) fn estimate(&self) -> Option<f64> {
        Some(crate::units::median(self.last.iter().copied())).filter(|m| !m.is_nan())
    }
}

/// The divisor of width and height that brings a frame of `pixels` pixels,
/// at `ms_per_pixel`, within `budget_ms`: the smallest of 1, 2^(1/4),
/// 2^(2/4), … (each step 29% fewer pixels; whole divisors went from 512x384
/// straight to 256x192, a quarter, where 363x272 fits), 1 when the cost is
/// not known yet, at most 2^(MAX_MOTION_STEPS / 4).
pub(super) fn motion_scale(ms_per_pixel: Option<f64>, pixels: u64, budget_ms: f64) -> f64 {
    let Some(cost) = ms_per_pixel.filter(|c| c.is_finite() && *c > 0.0) else { return 1.0 };
    let full_ms = cost * pixels as f64;
    // Dividing both sides by s = 2^(k/4) divides the pixels by s² = 2^(k/2).
    let steps = (2.0 * (full_ms / budget_ms).log2()).ceil();
    2f64.powf(steps.clamp(0.0, f64::from(MAX_MOTION_STEPS)) / 4.0)
}

/// Rows of a `width`-pixel frame that one frame draws at `ms_per_pixel`
/// within `budget_ms`: a multiple of the work group's height (at least
/// one), all `height` rows when they fit or the cost is not known yet.
pub(super) fn band_rows(ms_per_pixel: Option<f64>, width: u32, height: u32, budget_ms: f64) -> u32 {
    let Some(cost) = ms_per_pixel.filter(|c| c.is_finite() && *c > 0.0) else { return height };
    let rows = (budget_ms / (cost * f64::from(width.max(1)))).floor();
    if rows >= f64::from(height) {
        return height;
    }
    let group = layout::WORKGROUP_SIZE;
    ((rows as u32) / group * group).max(group)
}

/// RAYCAST_PREVIEW_BAND_ROWS=N: every sample at rest drawn N rows a frame,
/// whatever the device's speed (how the suite resizes a window under a
/// sample in progress on a fast machine).
pub(super) fn forced_band_rows() -> Option<u32> {
    static ROWS: std::sync::OnceLock<Option<u32>> = std::sync::OnceLock::new();
    *ROWS.get_or_init(|| std::env::var("RAYCAST_PREVIEW_BAND_ROWS").ok()?.parse().ok().filter(|&n: &u32| n > 0))
}

/// "10 frames at 171x128 then 128x96": how many frames, at which sizes in turn.
pub(super) fn frames_at(times: &[(Duration, [u32; 2])]) -> String {
    let mut sizes: Vec<[u32; 2]> = times.iter().map(|t| t.1).collect();
    sizes.dedup();
    let sizes: Vec<String> = sizes.iter().map(|[w, h]| format!("{w}x{h}")).collect();
    let n = times.len();
    format!("{n} frame{} at {}", if n == 1 { "" } else { "s" }, sizes.join(" then "))
}

/// "median 150.4 ms a frame, 6.6 frames a second" of frame times (at least one).
pub(super) fn rate(times: &[(Duration, [u32; 2])]) -> String {
    let median = crate::units::median(times.iter().map(|t| t.0.as_secs_f64()));
    format!("median {:.1} ms a frame, {:.1} frames a second", median * 1e3, 1.0 / median.max(1e-9))
}

/// The i-th point of the Halton (2, 3) sequence, centred on 0: sub-pixel
/// offsets in [-0.5, 0.5)², deterministic and evenly spread.
pub(super) fn jitter(i: u32) -> [f32; 2] {
    fn radical_inverse(mut i: u32, base: u32) -> f64 {
        let (mut f, mut r) = (1.0, 0.0);
        while i > 0 {
            f /= f64::from(base);
            r += f * f64::from(i % base);
            i /= base;
        }
        r
    }
    [(radical_inverse(i, 2) - 0.5) as f32, (radical_inverse(i, 3) - 0.5) as f32]
}

#[cfg(test)]
mod tests {
    use super::{band_rows, frame_budget_ms, jitter, motion_scale, PixelCost};

    /// The median of the last five: a spike leaves it, a lasting change moves it on the third frame.
    #[test]
    fn one_slow_frame_does_not_move_the_pixel_cost() {
        let mut c = PixelCost::default();
        assert_eq!(c.estimate(), None);
        c.push(f64::NAN);
        c.push(0.0);
        assert_eq!(c.estimate(), None);
        for v in [10.0, 1.0, 1.1, 0.9, 1.0] {
            c.push(v);
        }
        assert_eq!(c.estimate(), Some(1.0), "one slow frame among five");
        c.push(3.0);
        c.push(3.0);
        assert_eq!(c.estimate(), Some(1.1), "two of five at 3");
        c.push(3.0);
        assert_eq!(c.estimate(), Some(3.0), "three of five at 3");
    }

    #[test]
    fn bands_keep_a_frame_within_its_budget() {
        // Unknown cost, or the whole frame fits: all rows.
        let cpu = frame_budget_ms(true);
        assert_eq!(band_rows(None, 512, 384, cpu), 384);
        assert_eq!(band_rows(Some(1e-6), 512, 384, cpu), 384);
        // 2.69 s for 512x384: 125 ms is 17.8 rows, so 16 (two work groups).
        assert_eq!(band_rows(Some(2690.0 / (512.0 * 384.0)), 512, 384, cpu), 16);
        // Slower than a work group's rows in the budget: one work group anyway.
        assert_eq!(band_rows(Some(1.0), 512, 384, cpu), 8);
        // A GPU's 33 ms: 95 ms for 1920x1080 is 378.9 rows, so 376 (47 work groups).
        assert_eq!(band_rows(Some(95.0 / (1920.0 * 1080.0)), 1920, 1080, frame_budget_ms(false)), 376);
    }

    #[test]
    fn motion_scale_keeps_a_moving_frame_within_its_budget() {
        let pixels = 512 * 384;
        let (cpu, gpu) = (frame_budget_ms(true), frame_budget_ms(false));
        assert_eq!((cpu, gpu), (125.0, 1000.0 / 30.0), "8 frames a second on a CPU, 30 on a GPU");
        // Unknown cost, or a fast device: full resolution.
        assert_eq!(motion_scale(None, pixels, cpu), 1.0);
        assert_eq!(motion_scale(Some(f64::NAN), pixels, cpu), 1.0);
        assert_eq!(motion_scale(Some(10.0 / pixels as f64), pixels, cpu), 1.0);
        // 2.69 s a frame: 2690 / 125 = 21.5 times the budget, s >= 4.64: 2^(9/4) = 4.76,
        // 108x81 pixels, about 120 ms.
        assert_eq!(motion_scale(Some(2690.0 / pixels as f64), pixels, cpu), 2f64.powf(9.0 / 4.0));
        // 0.24 s (depth 6 without shadows on lavapipe): 2^(2/4), 363x272, about 120 ms.
        assert_eq!(motion_scale(Some(240.0 / pixels as f64), pixels, cpu), 2f64.sqrt());
        // Exactly at the budget stays; just over takes the next step.
        assert_eq!(motion_scale(Some(125.0 * 4.0 / pixels as f64), pixels, cpu), 2.0);
        assert_eq!(motion_scale(Some(125.0 * 4.01 / pixels as f64), pixels, cpu), 2f64.powf(5.0 / 4.0));
        // Never beyond the cap.
        assert_eq!(motion_scale(Some(1.0), pixels, cpu), 8.0);
        // A GPU at 1920x1080, 95 ms a frame (depth 10 with shadows on an H200): 2.85 times
        // its budget, s >= 1.69: 2^(4/4) = 2, 960x540, about 24 ms; at 512x384, 7.2 ms: whole.
        assert_eq!(motion_scale(Some(95.0 / (1920.0 * 1080.0)), 1920 * 1080, gpu), 2.0);
        assert_eq!(motion_scale(Some(7.2 / pixels as f64), pixels, gpu), 1.0);
    }

    #[test]
    fn jitter_is_centred_and_spread() {
        assert_eq!(jitter(0), [-0.5, -0.5], "index 0 of Halton is 0; sample 0 does not use it");
        assert_eq!(jitter(1), [0.0, (1.0f64 / 3.0 - 0.5) as f32]);
        for i in 1..256 {
            let [x, y] = jitter(i);
            assert!((-0.5..0.5).contains(&x) && (-0.5..0.5).contains(&y), "sample {i}: {x}, {y}");
        }
    }
}
