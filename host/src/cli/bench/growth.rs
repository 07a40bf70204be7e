//! `bench --growth`: how each scene's times grow against the first's,
//! beside ln N, and the times fitted against ln N.

use super::rows::{median_time, short_name, Row};
use crate::units::{thousands, to_json};
use serde::Serialize;

/// One line of the growth table: a scene, its expanded primitive count,
/// ln N / ln N0, and its frame median over the first scene's for the
/// device and the CPU build (None where that backend did not run).
pub(super) struct Growth<'a> {
    pub(super) scene: &'a str,
    pub(super) primitives: u64,
    pub(super) log_ratio: Option<f64>,
    /// Every ray of the frame (camera, shadow, mirror) over the first
    /// scene's: a property of the scene, the same on every backend.
    pub(super) rays: Option<f64>,
    pub(super) gpu: Option<f64>,
    /// The device's dispatch median over the first scene's: the frame
    /// without the upload and readback, which a GPU's frame is mostly.
    pub(super) gpu_dispatch: Option<f64>,
    pub(super) cpu: Option<f64>,
}

impl Growth<'_> {
    /// A backend's frame ratio over the rays' ratio: how the time of one
    /// ray grows.
    pub(super) fn per_ray(&self, frame: Option<f64>) -> Option<f64> {
        Some(frame? / self.rays?)
    }

    /// One line of `--growth --json`: told from a result's line by its
    /// `growth_against` (the first scene's name); a ratio that is not there
    /// is null.
    pub(super) fn json(&self, against: &str) -> String {
        to_json(&GrowthJson {
            growth_against: against,
            scene: self.scene,
            primitives_expanded: self.primitives,
            log_ratio: self.log_ratio,
            rays_ratio: self.rays,
            gpu_frame_ratio: self.gpu,
            gpu_ray_ratio: self.per_ray(self.gpu),
            gpu_dispatch_ratio: self.gpu_dispatch,
            cpu_frame_ratio: self.cpu,
            cpu_ray_ratio: self.per_ray(self.cpu),
        })
    }
}

/// One line of `bench --growth --json` (`Growth::json`).
#[derive(Serialize)]
pub(super) struct GrowthJson<'a> {
    pub(super) growth_against: &'a str,
    pub(super) scene: &'a str,
    pub(super) primitives_expanded: u64,
    pub(super) log_ratio: Option<f64>,
    pub(super) rays_ratio: Option<f64>,
    pub(super) gpu_frame_ratio: Option<f64>,
    pub(super) gpu_ray_ratio: Option<f64>,
    pub(super) gpu_dispatch_ratio: Option<f64>,
    pub(super) cpu_frame_ratio: Option<f64>,
    pub(super) cpu_ray_ratio: Option<f64>,
}

/// One line of `bench --growth --json` for a fitted line: `a + b ln N`
/// for a backend's frame or ray (`growth_fit`), and its R².
#[derive(Serialize)]
pub(super) struct GrowthFitJson<'a> {
    pub(super) growth_fit: &'a str,
    pub(super) against: &'a str,
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) r2: f64,
}

/// The growth table of `rows`, against the first scene; a backend is
/// matched by its first word ("gpu" covers "gpu uniform" and "gpu storage").
pub(super) fn growth(rows: &[Row]) -> Vec<Growth<'_>> {
    let Some(first) = rows.first() else { return Vec::new() };
    let find = |scene: &str, backend: &str| rows.iter().find(|r| r.scene == scene && r.is(backend));
    let median = |scene: &str, backend: &str| find(scene, backend).map(Row::median);
    let dispatch = |scene: &str| {
        find(scene, "gpu").filter(|r| !r.dispatch.is_empty()).map(|r| median_time(&r.dispatch).as_secs_f64())
    };
    let n0 = first.counts.expanded as f64;
    let mut out: Vec<Growth> = Vec::new();
    for r in rows {
        if out.iter().any(|g| g.scene == r.scene) {
            continue;
        }
        let ratio = |backend: &str| match (median(&r.scene, backend), median(&first.scene, backend)) {
            (Some(m), Some(b)) => Some(m.as_secs_f64() / b.as_secs_f64().max(1e-12)),
            _ => None,
        };
        out.push(Growth {
            scene: &r.scene,
            primitives: r.counts.expanded,
            log_ratio: (n0 > 1.0).then(|| (r.counts.expanded as f64).ln() / n0.ln()),
            rays: (r.all_rays > 0 && first.all_rays > 0).then(|| r.all_rays as f64 / first.all_rays as f64),
            gpu: ratio("gpu"),
            gpu_dispatch: dispatch(&r.scene).zip(dispatch(&first.scene)).map(|(m, b)| m / b.max(1e-12)),
            cpu: ratio("cpu"),
        });
    }
    out
}

/// Each scene's frame median over the first scene's, per backend, beside
/// the ratio of the logarithms of their expanded primitive counts.
pub(super) fn print_growth(rows: &[Row], markdown: bool) {
    let Some(first) = rows.first() else { return };
    outln!();
    outln!(
        "Growth against {} ({} primitives): frame median over its frame median, and ln N / ln N0, the ratio logarithmic growth allows; \
         rays: every ray of the frame over its, and a ray: the frame ratio over the rays' (deeper scenes cover more of the picture, \
         so they trace more shadow and mirror rays); gpu dispatch: the device's dispatch median over its (the frame without upload and readback).",
        first.scene,
        thousands(first.counts.expanded)
    );
    if markdown {
        outln!();
        outln!("| scene | primitives N | ln N / ln N0 | rays / first | gpu frame / first | gpu a ray / first | gpu dispatch / first | cpu frame / first | cpu a ray / first |");
        outln!("|---|---|---|---|---|---|---|---|---|");
    }
    let text = |x: Option<f64>| x.map_or("–".to_string(), |x| format!("{x:.2}"));
    for g in growth(rows) {
        let (l, rays, gpu, cpu) = (text(g.log_ratio), text(g.rays), text(g.gpu), text(g.cpu));
        let (gpu_ray, cpu_ray, dispatch) = (text(g.per_ray(g.gpu)), text(g.per_ray(g.cpu)), text(g.gpu_dispatch));
        if markdown {
            outln!(
                "| {} | {} | {l} | {rays} | {gpu} | {gpu_ray} | {dispatch} | {cpu} | {cpu_ray} |",
                short_name(g.scene),
                thousands(g.primitives)
            );
        } else {
            outln!(
                "  {}: N = {}, ln N / ln N0 {l}, rays {rays}, gpu {gpu} ({gpu_ray} a ray, dispatch {dispatch}), cpu {cpu} ({cpu_ray} a ray)",
                g.scene,
                thousands(g.primitives)
            );
        }
    }
}

/// A least-squares line y = a + b·x over points (x, y), and its R².
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Fit {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) r2: f64,
}

/// The least-squares line through `points`; None for fewer than three or
/// where every x is the same.
pub(super) fn fit(points: &[(f64, f64)]) -> Option<Fit> {
    if points.len() < 3 {
        return None;
    }
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let syy: f64 = points.iter().map(|p| (p.1 - my).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let b = sxy / sxx;
    let a = my - b * mx;
    let residual: f64 = points.iter().map(|p| (p.1 - a - b * p.0).powi(2)).sum();
    Some(Fit { a, b, r2: if syy > 0.0 { 1.0 - residual / syy } else { 1.0 } })
}

/// The growth table's times fitted against ln N, per backend: the frame
/// median (ms), and one ray's time (the frame over the rays' ratio to the
/// first scene's: ms at the first scene's rays). A cost a + b·ln N grows
/// logarithmically; it keeps within the table's ln N / ln N0 column only
/// where a ≥ 0. Each: its key in `--json`, its words, the fit.
pub(super) fn growth_fits(rows: &[Row]) -> Vec<(&'static str, &'static str, Fit)> {
    let Some(first) = rows.first() else { return Vec::new() };
    let mut out = Vec::new();
    for (backend, keys) in [
        ("gpu", [("gpu_frame_ms", "gpu frame, ms"), ("gpu_ray_ms", "gpu a ray, ms at the first scene's rays")]),
        ("cpu", [("cpu_frame_ms", "cpu frame, ms"), ("cpu_ray_ms", "cpu a ray, ms at the first scene's rays")]),
    ] {
        let (mut frame, mut ray, mut seen) = (Vec::new(), Vec::new(), Vec::new());
        for r in rows.iter().filter(|r| r.is(backend) && r.counts.expanded > 0) {
            if seen.contains(&&r.scene) {
                continue;
            }
            seen.push(&r.scene);
            let (x, ms) = ((r.counts.expanded as f64).ln(), r.median().as_secs_f64() * 1e3);
            frame.push((x, ms));
            if r.all_rays > 0 && first.all_rays > 0 {
                ray.push((x, ms * first.all_rays as f64 / r.all_rays as f64));
            }
        }
        for ((key, words), points) in keys.into_iter().zip([frame, ray]) {
            if let Some(f) = fit(&points) {
                out.push((key, words, f));
            }
        }
    }
    out
}

/// A fit's line as words: `-185 + 47.2 ln N`.
pub(super) fn fit_text(f: &Fit) -> String {
    let sig = |x: f64| {
        let digits = if x.abs() >= 100.0 {
            0
        } else if x.abs() >= 10.0 {
            1
        } else {
            2
        };
        format!("{x:.digits$}")
    };
    format!("{} {} {} ln N", sig(f.a), if f.b < 0.0 { "−" } else { "+" }, sig(f.b.abs())).replace('-', "−")
}

pub(super) fn print_growth_fits(rows: &[Row], markdown: bool) {
    let fits = growth_fits(rows);
    if fits.is_empty() {
        return;
    }
    outln!();
    outln!(
        "Fitted by least squares against ln N over these scenes: a cost a + b·ln N grows logarithmically, and keeps within \
         ln N / ln N0 only where a ≥ 0."
    );
    if markdown {
        outln!();
        outln!("| what | fit | R² |");
        outln!("|---|---|---|");
    }
    for (_, words, f) in &fits {
        if markdown {
            outln!("| {words} | {} | {:.3} |", fit_text(f), f.r2);
        } else {
            outln!("  {words}: {}, R² {:.3}", fit_text(f), f.r2);
        }
    }
}
