//! The picture a renderer returns: every pixel's output (colour or view,
//! hit distance, id, normal, rays), and what the commands read off it.

use crate::error::Error;
use crate::image_io::Rgb8;
use crate::layout::PixelOut;

/// Every pixel's output: colour (or AOV), t, hit id and normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<PixelOut>,
}

/// An empty vector with room for `n` items, or an error naming `what` and
/// the bytes when the memory cannot be had (an absurd picture size), where
/// `Vec::with_capacity` would abort the process.
pub(crate) fn try_with_capacity<T>(n: usize, what: &str) -> Result<Vec<T>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        let bytes = (n as u128 * std::mem::size_of::<T>() as u128).min(u128::from(u64::MAX)) as u64;
        format!("cannot allocate {} for {what}; render a smaller image", crate::units::fmt_bytes(bytes))
    })?;
    Ok(v)
}

/// `n` copies of `value` (`try_with_capacity`'s error where the memory cannot be had).
pub(crate) fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, String> {
    let mut v = try_with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

impl Picture {
    /// The picture as 8-bit RGB, row 0 at the top (what a PNG holds); an
    /// error when its memory cannot be had.
    pub fn rgb8(&self) -> Result<Rgb8, Error> {
        let what = format!("the {}x{} picture's RGB bytes", self.width, self.height);
        let mut data = try_filled(self.pixels.len() * 3, 0u8, &what)?;
        for (rgb, p) in data.chunks_exact_mut(3).zip(&self.pixels) {
            rgb.copy_from_slice(&p.rgba.to_le_bytes()[..3]);
        }
        Ok(Rgb8 { width: self.width, height: self.height, data })
    }

    /// The walk passes of a render in an AOV other than colour
    /// (PixelOut.normal's w: the camera ray's, or with AOV_COST_ALL all the
    /// pixel's rays'), for people, after `what`: their mean, median, 90th
    /// and 99th percentiles and the most, with its pixel.
    pub fn passes_text(&self, what: &str) -> String {
        let Some((most_at, most)) = self.most_passes() else {
            return "cost: no pixels".to_string();
        };
        let mut passes: Vec<u32> = self.pixels.iter().map(|p| p.normal[3] as u32).collect();
        let mean = passes.iter().map(|&n| f64::from(n)).sum::<f64>() / passes.len() as f64;
        passes.sort_unstable();
        let at = |q: usize| passes[(passes.len() - 1) * q / 100];
        let (x, y) = (most_at % self.width as usize, most_at / self.width as usize);
        format!(
            "cost: {what} {mean:.2} passes on average: median {}, 90% at most {}, 99% at most {}, most {most} (pixel ({x}, {y}))",
            at(50),
            at(90),
            at(99)
        )
    }

    /// The most walk passes of any pixel (as `passes_text` reads them) and
    /// the first pixel with them, by index; None without pixels.
    pub fn most_passes(&self) -> Option<(usize, u32)> {
        let passes = self.pixels.iter().map(|p| p.normal[3] as u32).enumerate();
        passes.max_by_key(|&(i, n)| (n, std::cmp::Reverse(i)))
    }

    /// Every ray the frame traced (camera, shadow and mirror): the sum of the pixels' counts.
    pub fn rays(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.rays)).sum()
    }
}
