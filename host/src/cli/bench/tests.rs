//! `bench`: memory, rows, growth and its fits.

use super::growth::{fit, fit_text, Fit};
use super::*;
use crate::layout::{Frame, SampleSum};
use crate::units::median;

#[test]
fn peak_host_memory_is_read_and_reset() {
    let before = peak_host_bytes().expect("VmHWM in /proc/self/status");
    assert!(before > 0);
    // Touch 64 MiB: the peak must see it.
    let block = vec![1u8; 64 << 20];
    let touched: u64 = block.iter().step_by(4096).map(|&b| u64::from(b)).sum();
    assert_eq!(touched, (64 << 20) / 4096);
    let high = peak_host_bytes().unwrap();
    assert!(high >= 64 << 20, "VmHWM {high} after touching 64 MiB");
    drop(block);
    if reset_peak_host() {
        let after = peak_host_bytes().unwrap();
        assert!(after < high, "VmHWM {after} not reset below {high}");
    }
}

#[test]
fn device_bytes_counts_every_buffer() {
    let settings = RenderSettings { width: 10, height: 4, textures: false, ..RenderSettings::default() };
    let loaded =
        load_scene(Some("gen:recursive-spheres:2"), &ParseOptions::default(), &FlattenLimits::default(), &settings)
            .unwrap();
    assert_eq!(loaded.counts, PrimitiveCounts { expanded: 7, unique: 2 });
    let scene: u64 = loaded.data.scene_buffers().iter().map(|b| b.2.len() as u64).sum();
    assert!(scene > 0);
    let per_pixel = std::mem::size_of::<PixelOut>() + std::mem::size_of::<SampleSum>();
    let expect = std::mem::size_of::<Frame>() as u64 + scene + 40 * per_pixel as u64;
    assert_eq!(crate::measure::device_bytes(&loaded.data, false, u32::MAX), expect);
    // In bands of 2 rows, half the pixels at a time.
    assert_eq!(crate::measure::device_bytes(&loaded.data, false, 2), expect - 20 * per_pixel as u64);
    // The uniform kernels' images are uploaded as `padded_for_uniform` pads them:
    // at least one texel (these arrays are all shorter than a row), a
    // primitive or an instance in 64 bytes where its struct takes 80.
    let images: u64 = loaded
        .data
        .scene_buffers()
        .iter()
        .map(|&(binding, _, bytes)| {
            let packed = [crate::layout::BINDING_PRIMITIVES, crate::layout::BINDING_INSTANCES].contains(&binding);
            let image = crate::layout::UNIFORM_KERNEL_IMAGES.contains(&binding);
            let len = if packed { bytes.len() / 80 * 64 } else { bytes.len() };
            (if image { len.max(16) } else { len }) as u64
        })
        .sum();
    assert_eq!(crate::measure::device_bytes(&loaded.data, true, 4), expect - scene + images);
}

#[test]
fn least_squares_lines() {
    // On a line: that line, R² 1.
    let f = fit(&[(1.0, 5.0), (2.0, 7.0), (4.0, 11.0)]).unwrap();
    assert!((f.a - 3.0).abs() < 1e-12 && (f.b - 2.0).abs() < 1e-12 && (f.r2 - 1.0).abs() < 1e-12, "{f:?}");
    // Off it: y = 1, 3, 2 at x = 0, 1, 2 fits 1.5 + 0.5x, residuals −0.5, 1, −0.5: R² 1 − 1.5 / 2.
    let f = fit(&[(0.0, 1.0), (1.0, 3.0), (2.0, 2.0)]).unwrap();
    assert!((f.a - 1.5).abs() < 1e-12 && (f.b - 0.5).abs() < 1e-12 && (f.r2 - 0.25).abs() < 1e-12, "{f:?}");
    assert_eq!(fit(&[(0.0, 1.0), (1.0, 2.0)]), None);
    assert_eq!(fit(&[(1.0, 1.0), (1.0, 2.0), (1.0, 3.0)]), None);
    assert_eq!(fit_text(&Fit { a: -185.04, b: 47.21, r2: 0.989 }), "−185 + 47.2 ln N");
    assert_eq!(fit_text(&Fit { a: 2.5, b: -0.126, r2: 1.0 }), "2.50 − 0.13 ln N");
}

/// One median for bench's frames and versus's ratios: unsorted input,
/// odd and even counts, none.
#[test]
fn medians() {
    assert_eq!(median([3.0, 1.0, 2.0]), 2.0);
    assert_eq!(median([4.0, 1.0, 3.0, 2.0]), 2.5);
    assert!(median(std::iter::empty()).is_nan());
    let ms = Duration::from_millis;
    assert_eq!(median_time(&[ms(30), ms(10), ms(20), ms(40)]), ms(25));
    assert_eq!(median_time(&[]), Duration::ZERO);
}

#[test]
fn growth_matches_backends_by_their_first_word() {
    let row = |scene: &str, backend: &'static str, n: u64, ms: u64| Row {
        scene: scene.into(),
        backend: backend.into(),
        device: String::new(),
        counts: PrimitiveCounts { expanded: n, unique: 1 },
        lights: 1,
        load: Duration::ZERO,
        build: Duration::ZERO,
        frames: vec![Duration::from_millis(ms)],
        // The device's dispatch: a fifth of its frame (none on the CPU).
        dispatch: if backend == "cpu" { Vec::new() } else { vec![Duration::from_millis(ms) / 5] },
        phases: Vec::new(),
        primary_rays: 1,
        // Twice the rays in the deeper scene.
        all_rays: if n > 100 { 40 } else { 20 },
        host_peak: None,
        device_bytes: None,
        cpu_over_gpu: None,
        identical: None,
        kernel_build: None,
        kernel_stats: None,
    };
    let rows = [
        row("a", "gpu uniform", 100, 10),
        row("a", "cpu", 100, 4),
        row("b", "gpu storage", 10_000, 25),
        row("b", "cpu", 10_000, 6),
    ];
    let g = growth(&rows);
    assert_eq!(g.len(), 2);
    assert_eq!((g[0].gpu, g[0].cpu, g[0].log_ratio), (Some(1.0), Some(1.0), Some(1.0)));
    assert_eq!((g[1].gpu, g[1].cpu), (Some(2.5), Some(1.5)));
    assert_eq!(g[1].rays, Some(2.0));
    assert_eq!((g[1].per_ray(g[1].gpu), g[1].per_ray(g[1].cpu)), (Some(1.25), Some(0.75)));
    assert_eq!((g[0].gpu_dispatch, g[1].gpu_dispatch), (Some(1.0), Some(2.5)));
    assert!((g[1].log_ratio.unwrap() - 2.0).abs() < 1e-12);
    // Two scenes are too few to fit a line; a third makes one for each backend, its frame and a ray.
    assert!(growth_fits(&rows).is_empty());
    let three = [
        row("a", "gpu uniform", 100, 10),
        row("a", "cpu", 100, 4),
        row("b", "gpu storage", 10_000, 25),
        row("b", "cpu", 10_000, 6),
        row("c", "gpu storage", 1_000_000, 40),
        row("c", "cpu", 1_000_000, 8),
    ];
    let fits = growth_fits(&three);
    let keys: Vec<&str> = fits.iter().map(|f| f.0).collect();
    assert_eq!(keys, ["gpu_frame_ms", "gpu_ray_ms", "cpu_frame_ms", "cpu_ray_ms"]);
    // gpu frames 10, 25, 40 ms at ln N = 2, 4, 6 ln 10: 10 + 7.5 (ln N / ln 10 - 2) ms, exactly.
    let f = fits[0].2;
    assert!((f.b * 10f64.ln() - 7.5).abs() < 1e-9 && (f.r2 - 1.0).abs() < 1e-12, "{f:?}");
    // --growth --json: a line a scene, after the results' lines.
    let j = g[1].json(&rows[0].scene);
    assert!(j.starts_with("{\"growth_against\":\""), "{j}");
    for needle in [
        "\"gpu_frame_ratio\":2.5,\"gpu_ray_ratio\":1.25,\"gpu_dispatch_ratio\":2.5,",
        "\"cpu_frame_ratio\":1.5,\"cpu_ray_ratio\":0.75}",
    ] {
        assert!(j.contains(needle), "{needle} in {j}");
    }
}

#[test]
fn json_and_markdown_rows() {
    let row = Row {
        scene: "a \"b\"".into(),
        backend: "gpu".into(),
        device: "llvmpipe".into(),
        counts: PrimitiveCounts { expanded: 2_929_687, unique: 10 },
        lights: 3,
        load: Duration::from_micros(1500),
        build: Duration::from_micros(250),
        frames: vec![Duration::from_millis(10), Duration::from_millis(20), Duration::from_millis(40)],
        dispatch: vec![Duration::from_millis(9)],
        phases: Vec::new(),
        primary_rays: 1_000_000,
        all_rays: 4_000_000,
        host_peak: Some(3 << 20),
        device_bytes: Some(2048),
        cpu_over_gpu: None,
        identical: None,
        kernel_build: Some((Duration::from_micros(43_500), Some("SPIR-V specialised ahead".into()))),
        kernel_stats: None,
    };
    let j = row.json(&RenderSettings::default(), 1);
    assert!(j.starts_with("{\"scene\":\"a \\\"b\\\"\",\"backend\":\"gpu\""), "{j}");
    // serde_json writes a whole f64 as 20.0 where format! wrote 20: the values compared.
    let v: serde_json::Value = serde_json::from_str(&j).unwrap();
    for (key, want) in [
        ("primitives_expanded", serde_json::json!(2929687)),
        ("frame_ms_median", serde_json::json!(20.0)),
        ("frame_ms_min", serde_json::json!(10.0)),
        ("primary_mrays_per_s", serde_json::json!(50.0)),
        ("all_rays_per_frame", serde_json::json!(4000000)),
        ("all_mrays_per_s", serde_json::json!(200.0)),
        ("device_bytes", serde_json::json!(2048)),
        ("cpu_over_gpu", serde_json::Value::Null),
        ("kernel_build_ms", serde_json::json!(43.5)),
    ] {
        assert_eq!(v[key], want, "{key} in {j}");
    }
    assert!(j.contains("\"all_rays_per_frame\":4000000,\"all_mrays_per_s\":200.0,"), "{j}");
    assert!(j.contains("\"kernel_build_ms\":43.5,\"host_cpu\":\""), "{j}");
    assert!(!j.contains('\n'));
    let m = row.markdown();
    assert!(
        m.contains("| 2,929,687 / 10 |")
            && m.contains("| 20.0 ms | 10.0 ms – 40.0 ms | 9.00 ms |")
            && m.contains("| 3.0 MiB | 2.0 KiB |"),
        "{m}"
    );
    assert_eq!(m.matches('|').count(), MARKDOWN_HEADER.lines().next().unwrap().matches('|').count());
}
