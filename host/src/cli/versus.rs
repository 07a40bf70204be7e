//! `raycast bench --versus DIR`: two device kernels timed side by side in
//! one process, for whoever is changing the shaders. Kernel A is the
//! built-in one (or `--shaders`), kernel B is compiled from DIR; each has
//! its own Vulkan device, over the same FrameData. After K warm-up frames
//! of each, N pairs of frames alternate A B, B A, A B, … (so a drift of
//! the machine's speed favours neither), and per scene the report gives:
//!
//! - each kernel's dispatch median (the kernel's work; upload and readback
//!   are the same buffers for both);
//! - the median of the N paired ratios B/A and their range: a machine
//!   whose speed wanders by tens of percent between runs still gives
//!   pairs taken seconds apart a like footing;
//! - how many pairs each won, and the two-sided sign test's p-value (the
//!   chance of a split at least that uneven if the kernels were alike);
//! - whether the two pictures have the same bits (`check::compare`).

use super::batch::each_named;
use super::bench::{load_or_skip, skipped, BenchArgs, BenchBackend};
use super::options::open_renderer;
use crate::check;
use crate::error::{check_validation, Error};
use crate::render::{CutShort, Picture, Renderer};
use crate::scene::FlattenLimits;
use crate::units::median;
use crate::units::{rounded, to_json};
use serde::Serialize;
use std::path::Path;
use std::time::Duration;

/// The paired comparison of one scene: dispatch times of A and B, pair by pair.
pub struct Pairs {
    pub a: Vec<Duration>,
    pub b: Vec<Duration>,
}

/// What the pairs say.
#[derive(Debug, PartialEq)]
pub struct Verdict {
    pub a_median_ms: f64,
    pub b_median_ms: f64,
    /// Median, min and max of B/A over the pairs.
    pub ratio: (f64, f64, f64),
    pub b_faster: usize,
    pub a_faster: usize,
    /// Two-sided sign test over the pairs that were not tied.
    pub p_value: f64,
}

/// P(a split at least as uneven as k of n | each side wins with chance 1/2), both tails.
pub fn sign_test(k: usize, n: usize) -> f64 {
    if n == 0 {
        return 1.0;
    }
    let low = k.min(n - k);
    // Sum C(n, i) / 2^n for i <= low, in f64 (n is a frame count: small).
    let mut term = 0.5f64.powi(n as i32); // C(n, 0) / 2^n
    let mut tail = term;
    for i in 1..=low {
        term = term * (n - i + 1) as f64 / i as f64;
        tail += term;
    }
    (2.0 * tail).min(1.0)
}

impl Pairs {
    pub fn verdict(&self) -> Verdict {
        let ms = |d: &Duration| d.as_secs_f64() * 1e3;
        let ratios: Vec<f64> = self.a.iter().zip(&self.b).map(|(a, b)| ms(b) / ms(a).max(1e-9)).collect();
        let b_faster = self.a.iter().zip(&self.b).filter(|(a, b)| b < a).count();
        let a_faster = self.a.iter().zip(&self.b).filter(|(a, b)| a < b).count();
        let min = ratios.iter().copied().fold(f64::INFINITY, f64::min);
        let max = ratios.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        Verdict {
            a_median_ms: median(self.a.iter().map(ms)),
            b_median_ms: median(self.b.iter().map(ms)),
            ratio: (median(ratios), min, max),
            b_faster,
            a_faster,
            p_value: sign_test(b_faster, a_faster + b_faster),
        }
    }
}

/// One line of `bench --versus DIR --json`: a scene's dispatch times on
/// kernels A and B (ms, medians), B/A's ratios, the sign test and whether
/// the pictures are identical.
#[derive(Serialize)]
struct VersusJson<'a> {
    scene: &'a str,
    a: &'a str,
    b: &'a str,
    a_kernel: &'a str,
    b_kernel: &'a str,
    pairs: u32,
    a_dispatch_ms: f64,
    b_dispatch_ms: f64,
    ratio_median: f64,
    ratio_min: f64,
    ratio_max: f64,
    b_faster: usize,
    a_faster: usize,
    sign_test_p: f64,
    identical: bool,
}

/// `bench --versus DIR`.
pub(crate) fn run(args: &BenchArgs, versus: &Path) -> Result<(), Error> {
    if args.backend != BenchBackend::Gpu {
        return Err(Error::Usage("--versus compares two device kernels: use it without --backend cpu or both".into()));
    }
    let settings = args.render.settings();
    settings.validate().map_err(Error::usage)?;
    let a_name = args
        .render
        .kernel
        .shaders
        .as_ref()
        .map_or("the built-in kernel".to_string(), |d| format!("the kernel from {}", d.display()));
    let b_name = format!("the kernel from {}", versus.display());
    let r = &args.render;
    let k = &r.kernel;
    let a: Box<dyn Renderer> = Box::new(k.renderer()?);
    let b: Box<dyn Renderer> = Box::new(open_renderer(k, Some(versus))?);
    if !args.json {
        outln!("device: {}, two devices in one process", a.info().label);
        outln!("A: {a_name}\nB: {b_name}");
        outln!(
            "{} pairs of frames after {} warm-up frames each, in turn A B, B A, …; dispatch times",
            args.frames,
            args.warmup
        );
    }
    let opts = args.render.parse_options();
    let limits = FlattenLimits { max_primitives: args.render.max_primitives };
    let names = super::batch::scene_names(&args.scenes);
    // One scene compared (or listed as skipped).
    let compare_one = |name: Option<&str>| -> Result<(), Error> {
        // Over --max-primitives: listed as skipped, as `bench` does.
        let Some(loaded) = load_or_skip(name, &opts, &limits, &settings, args)? else {
            return Ok(());
        };
        // Which kernel each runs: a folder without render_uniform.comp has only the storage one.
        let kernel = |r: &dyn Renderer| Ok::<_, Error>(r.kernel(&loaded.data)?.map(|k| k.name).unwrap_or_default());
        let kernels = (kernel(a.as_ref())?, kernel(b.as_ref())?);
        let timed = (|| {
            for _ in 0..args.warmup {
                a.render_frame(&loaded.data, &|_| {})?;
                b.render_frame(&loaded.data, &|_| {})?;
            }
            let mut pairs = Pairs { a: Vec::new(), b: Vec::new() };
            let mut last: (Option<Picture>, Option<Picture>) = (None, None);
            for i in 0..args.frames {
                for first_a in if i % 2 == 0 { [true, false] } else { [false, true] } {
                    let (picture, t) = if first_a {
                        a.render_frame(&loaded.data, &|_| {})?
                    } else {
                        b.render_frame(&loaded.data, &|_| {})?
                    };
                    if first_a {
                        pairs.a.push(t.dispatch);
                        last.0 = Some(picture);
                    } else {
                        pairs.b.push(t.dispatch);
                        last.1 = Some(picture);
                    }
                }
            }
            Ok::<_, Error>((pairs, last))
        })();
        let (pairs, (pa, pb)) = match timed {
            Ok(x) => x,
            Err(Error::CutShort(CutShort { count, total, .. })) => {
                let why = format!(
                    "not timed: a kernel cut {count} of {total} pixels short (Mesa's loop budget per invocation)"
                );
                skipped(&loaded.name, None, loaded.counts, &why, args);
                return Ok(());
            }
            Err(e) => return Err(e),
        };
        let (Some(pa), Some(pb)) = (pa, pb) else { return Ok(()) };
        let report = check::compare(&pa, "A", &pb, "B")?;
        let v = pairs.verdict();
        let pictures = if report.identical() {
            "identical (every buffer, bit for bit)".to_string()
        } else {
            format!("differ ({} of {} pixels)", report.differing_pixels, u64::from(pa.width) * u64::from(pa.height))
        };
        if args.json {
            outln!(
                "{}",
                to_json(&VersusJson {
                    scene: &loaded.name,
                    a: &a_name,
                    b: &b_name,
                    a_kernel: &kernels.0,
                    b_kernel: &kernels.1,
                    pairs: args.frames,
                    a_dispatch_ms: rounded(v.a_median_ms, 3),
                    b_dispatch_ms: rounded(v.b_median_ms, 3),
                    ratio_median: rounded(v.ratio.0, 4),
                    ratio_min: rounded(v.ratio.1, 4),
                    ratio_max: rounded(v.ratio.2, 4),
                    b_faster: v.b_faster,
                    a_faster: v.a_faster,
                    sign_test_p: rounded(v.p_value, 4),
                    identical: report.identical(),
                })
            );
        } else {
            outln!("scene: {}", loaded.name);
            if kernels.0 != kernels.1 {
                outln!("  kernels differ: A {}, B {} (the scene's arrays read another way)", kernels.0, kernels.1);
            }
            outln!("  dispatch median: A {:.1} ms, B {:.1} ms", v.a_median_ms, v.b_median_ms);
            outln!(
                "  B/A: {:.3} median of {} pairs ({:.3} – {:.3}); B faster in {}, A in {} (sign test p = {:.3})",
                v.ratio.0,
                args.frames,
                v.ratio.1,
                v.ratio.2,
                v.b_faster,
                v.a_faster,
                v.p_value
            );
            outln!("  pictures: {pictures}");
        }
        Ok(())
    };
    let batch = each_named(&names, crate::source::scene_label, |name| Ok(compare_one(name)))?;
    let result = batch.failure("").map_or(Ok(()), Err);
    let messages = [a.take_messages(), b.take_messages()].concat();
    drop(a);
    drop(b);
    result.and(check_validation(messages))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_test_matches_the_binomial_tails() {
        // 8 of 8: 2 / 256.
        assert!((sign_test(8, 8) - 2.0 / 256.0).abs() < 1e-12);
        assert!((sign_test(0, 8) - 2.0 / 256.0).abs() < 1e-12);
        // 6 of 8: 2 (1 + 8 + 28) / 256.
        assert!((sign_test(6, 8) - 74.0 / 256.0).abs() < 1e-12);
        // An even split, and nothing to test.
        assert_eq!(sign_test(4, 8), 1.0);
        assert_eq!(sign_test(0, 0), 1.0);
    }

    #[test]
    fn verdict_of_pairs() {
        let d = |ms: u64| Duration::from_millis(ms);
        let pairs = Pairs { a: vec![d(100), d(200), d(100), d(300)], b: vec![d(50), d(100), d(100), d(330)] };
        let v = pairs.verdict();
        assert_eq!(v.a_median_ms, 150.0);
        assert_eq!(v.b_median_ms, 100.0);
        // Ratios 0.5, 0.5, 1.0, 1.1: median 0.75.
        assert!((v.ratio.0 - 0.75).abs() < 1e-12, "{v:?}");
        assert!((v.ratio.1 - 0.5).abs() < 1e-12 && (v.ratio.2 - 1.1).abs() < 1e-12, "{v:?}");
        assert_eq!((v.b_faster, v.a_faster), (2, 1));
        // The tie is left out: 2 of 3.
        assert!((v.p_value - 1.0).abs() < 1e-12, "{v:?}");
    }
}
