//! `raycast preview` in a real window: under Xvfb (`xvfb-run -a`) on
//! lavapipe, with the validation layer on (RAYCAST_VALIDATION=1: any message
//! fails with exit status 3).
//!
//! - The first frame's screenshot equals `raycast render` of the same scene
//!   and size. Rule: bit-exact (both quantise the same centre ray with the
//!   same code; sample 0 is not jittered). On failure: the count of
//!   differing pixels, the first and the worst, and actual / expected / diff
//!   PNGs in the test's output folder.
//! - More frames accumulate jittered samples: frame 8 differs from frame 1
//!   on silhouettes, and nowhere far from an edge.
//! - `--backend cpu` (the CPU build draws the samples) shows the device's
//!   pictures, and `--keys` (scripted key presses: views, flags, B to
//!   switch who draws) the pictures of the same settings given at start.
//!   Rule: bit-exact, as above.
//! - No display: a clear error, no panic.
//!
//! Corpus scenes come from RAYCAST_CORPUS (skipped, saying so, without it);
//! the default scene always runs.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Mutex;

use raycast::image_io::{self, Rgb8};

/// One preview at a time: each starts its own Xvfb, and they are CPU-bound.
static SERIAL: Mutex<()> = Mutex::new(());

mod common;
use common::repo;

fn out_dir() -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("preview");
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn text(o: &Output) -> String {
    let (out, err) = common::text(o);
    format!("stdout:\n{out}\nstderr:\n{err}")
}

/// `raycast ARGS`, validation on.
fn raycast(args: &[&str]) -> Output {
    common::raycast(args, &[])
}

/// `raycast preview ARGS` in a window: under `xvfb-run -a` (a private X
/// server), which is how CI runs it.
/// The device draws (`--backend gpu`) unless `args` say who does: these
/// tests are of the device's preview kernel, which `--backend auto`, the
/// default, leaves to the CPU build on lavapipe.
fn preview(args: &[&str]) -> Output {
    if args.contains(&"--backend") {
        return preview_as_given(args);
    }
    preview_as_given(&[args, &["--backend", "gpu"]].concat())
}

/// `raycast preview ARGS` as they are (`preview`).
fn preview_as_given(args: &[&str]) -> Output {
    preview_on("-screen 0 1280x1024x24", &[], args)
}

/// `raycast preview ARGS` with `env` under an X server started with `server` (Xvfb's options).
/// xvfb-run now and then fails to remove its temporary folder after a
/// preview that ended at once, and exits 5 ("problem while cleaning up
/// temporary directory") in place of the preview's own status: seen once in
/// CI, and here in 2 of 235 runs with the server resetting as its last
/// client leaves, 0 of 235 with `-noreset`. So the server runs with
/// `-noreset`, and a run that xvfb-run's clean-up failed is repeated (twice
/// at most).
fn preview_on(server: &str, env: &[(&str, &str)], args: &[&str]) -> Output {
    raycast_on(server, env, &[&["preview"][..], args].concat())
}

/// `raycast ARGS` with `env` under an X server started with `server`, as `preview_on`.
fn raycast_on(server: &str, env: &[(&str, &str)], args: &[&str]) -> Output {
    program_on(server, env, env!("CARGO_BIN_EXE_raycast"), args)
}

/// `PROGRAM ARGS` with `env` under an X server started with `server`, as `preview_on`.
fn program_on(server: &str, env: &[(&str, &str)], program: &str, args: &[&str]) -> Output {
    let _serial = SERIAL.lock().unwrap_or_else(|p| p.into_inner());
    let server = format!("{server} -noreset");
    let run = || {
        Command::new("xvfb-run")
            .args(["-a", "-s", &server, program])
            .args(args)
            .env("RAYCAST_VALIDATION", "1")
            .env("RAYCAST_CACHE_DIR", common::shader_cache())
            .envs(env.iter().copied())
            .output()
            .unwrap_or_else(|e| panic!("cannot run xvfb-run (Debian packages xvfb and xauth): {e}"))
    };
    let cleanup_failed = |o: &Output| {
        o.status.code() == Some(5) && String::from_utf8_lossy(&o.stderr).contains("problem while cleaning up")
    };
    let mut o = run();
    for _ in 0..2 {
        if !cleanup_failed(&o) {
            break;
        }
        o = run();
    }
    o
}

/// Asserts exit 0, no panic and no validation message.
fn assert_clean(o: &Output, what: &str) {
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{what}: panic\n{}", text(o));
    assert!(!err.contains("validation"), "{what}: validation messages\n{}", text(o));
    assert_eq!(o.status.code(), Some(0), "{what}: exit status\n{}", text(o));
}

/// Asserts that stderr says each of `said`.
fn assert_says(o: &Output, said: &[&str]) {
    let err = String::from_utf8_lossy(&o.stderr);
    for s in said {
        assert!(err.contains(s), "{s:?} missing: {}", text(o));
    }
}

/// The preview's screenshot after `frames` frames of `scene` (None: the default scene).
/// `extra`: more flags for the preview.
fn screenshot(scene: Option<&Path>, size: [u32; 2], frames: u32, name: &str, extra: &[&str]) -> Rgb8 {
    let png = out_dir().join(format!("{name}-preview-{frames}.png"));
    let _ = std::fs::remove_file(&png);
    let (w, h, n) = (size[0].to_string(), size[1].to_string(), frames.to_string());
    let mut args = vec!["--width", &w, "--height", &h, "--frames", &n, "--screenshot", png.to_str().unwrap()];
    args.extend_from_slice(extra);
    let scene_arg;
    if let Some(s) = scene {
        scene_arg = s.to_str().unwrap().to_string();
        args.insert(0, &scene_arg);
    }
    let o = preview(&args);
    assert_clean(&o, &format!("preview of {name}"));
    assert!(String::from_utf8_lossy(&o.stdout).contains("wrote "), "{}", text(&o));
    image_io::read_picture(&png).unwrap()
}

/// `raycast render` of the same scene and size. `extra`: more flags for it.
fn render(scene: Option<&Path>, size: [u32; 2], name: &str, extra: &[&str]) -> Rgb8 {
    let png = out_dir().join(format!("{name}-render.png"));
    let (w, h) = (size[0].to_string(), size[1].to_string());
    let mut args = vec!["render", "--width", &w, "--height", &h, "-o", png.to_str().unwrap()];
    args.extend_from_slice(extra);
    let scene_arg;
    if let Some(s) = scene {
        scene_arg = s.to_str().unwrap().to_string();
        args.insert(1, &scene_arg);
    }
    let o = raycast(&args);
    assert_clean(&o, &format!("render of {name}"));
    image_io::read_picture(&png).unwrap()
}

/// Rule: bit-exact. `extra`: more flags for the preview; `both`: flags for
/// the preview and the render.
fn assert_first_frame_is_the_render(scene: Option<&Path>, size: [u32; 2], name: &str, extra: &[&str], both: &[&str]) {
    let actual = screenshot(scene, size, 1, name, &[extra, both].concat());
    let expected = render(scene, size, name, both);
    assert_bit_exact(
        &actual,
        &expected,
        &format!("{name}-first-frame"),
        "the preview's first frame is not `raycast render`",
    );
}

/// Rule: bit-exact; on failure the counts, the first and worst pixel, and
/// actual / expected / diff PNGs named after `name`.
fn assert_bit_exact(actual: &Rgb8, expected: &Rgb8, name: &str, what: &str) {
    let diff = image_io::compare(actual, expected, 0).unwrap_or_else(|e| panic!("{name}: {e}"));
    if diff.differing > 0 {
        let paths =
            image_io::write_diff_images(&out_dir(), name, actual, expected, &diff).unwrap_or_else(|e| panic!("{e}"));
        panic!(
            "{name}: {what} (rule: bit-exact): {diff}\nactual {}\nexpected {}\ndiff {}",
            paths[0].display(),
            paths[1].display(),
            paths[2].display()
        );
    }
}

#[test]
fn first_frame_of_the_default_scene_is_the_render() {
    assert_first_frame_is_the_render(None, [512, 384], "default", &[], &[]);
}

/// A size that is not a multiple of the 8x8 work group, and a file path (watched for reloads).
#[test]
fn first_frame_at_an_odd_size_is_the_render() {
    let scene = repo().join("scenes/default.xml");
    assert_first_frame_is_the_render(Some(&scene), [203, 97], "default-203x97", &[], &[]);
}

#[test]
fn first_frame_of_corpus_scenes_is_the_render() {
    let Some(corpus) = common::corpus("first_frame_of_corpus_scenes_is_the_render") else {
        return;
    };
    for rel in ["test_unit/unit_cone.xml", "test_unit/unit_cylinder.xml"] {
        let scene = corpus.join(rel);
        assert!(scene.is_file(), "RAYCAST_CORPUS={} has no {rel}", corpus.display());
        let name = rel.replace('/', "-").trim_end_matches(".xml").to_string();
        assert_first_frame_is_the_render(Some(&scene), [512, 384], &name, &[], &[]);
    }
}

/// The normal, depth, id and both cost AOVs (`--aov`; keys 2 to 6 in the window):
/// the same pictures as `raycast render --aov`, the depth AOV's range from
/// the same camera.
#[test]
fn first_frame_in_each_aov_is_the_render() {
    for aov in ["normal", "depth", "id", "cost", "cost-all"] {
        assert_first_frame_is_the_render(None, [96, 64], &format!("default-{aov}"), &[], &["--aov", aov]);
    }
}

/// A --shaders folder without preview_uniform.comp: preview.comp draws
/// the scene from buffers alone (the scene's arrays are uploaded once, for
/// the kernel that draws them), and gives the same picture.
#[test]
fn first_frame_without_the_uniform_kernel_is_the_render() {
    let dir = common::copy_of_shaders(&out_dir().join("no-uniform-shaders"));
    std::fs::remove_file(dir.join("preview_uniform.comp")).unwrap();
    assert_first_frame_is_the_render(None, [96, 64], "default-no-uniform", &["--shaders", dir.to_str().unwrap()], &[]);
}

/// `--backend cpu`: the C++ build of the shared GLSL draws the samples and
/// the device only shows them. Rule: bit-exact against the device's own
/// preview (on lavapipe the two builds agree bit for bit) after 1 and 8
/// frames (jittered samples summed the same way), and after two frames
/// that steer (smaller frames, which `--moving` times) and two at rest.
/// `--backend auto` takes the CPU build where the device is of type CPU
/// (lavapipe) and the device elsewhere, and is the default; `--backend cpu`
/// with `--shaders` (which only the device's kernel follows) is a usage error.
#[test]
fn the_cpu_build_draws_the_devices_samples() {
    for (frames, extra) in [(1, &[][..]), (8, &[][..]), (4, &["--moving", "2"][..])] {
        let name = format!("backend-{frames}{}", extra.join(""));
        let gpu = screenshot(None, [128, 96], frames, &format!("{name}-gpu"), &[extra, &["--backend", "gpu"]].concat());
        let cpu = screenshot(None, [128, 96], frames, &format!("{name}-cpu"), &[extra, &["--backend", "cpu"]].concat());
        assert_bit_exact(&cpu, &gpu, &name, "--backend cpu's preview is not the device's");
    }
    let o = preview(&["--width", "32", "--height", "24", "--frames", "1", "--backend", "auto"]);
    assert_clean(&o, "preview --backend auto");
    let gpu = preview(&["--width", "32", "--height", "24", "--frames", "1", "--backend", "gpu"]);
    let line =
        |o: &Output| String::from_utf8_lossy(&o.stdout).lines().find(|l| l.starts_with("device: ")).map(str::to_string);
    let (auto, device) = (line(&o).unwrap_or_default(), line(&gpu).unwrap_or_default());
    // auto is the default.
    let default = preview_as_given(&["--width", "32", "--height", "24", "--frames", "1"]);
    assert_clean(&default, "preview without --backend");
    assert_eq!(line(&default).unwrap_or_default(), auto, "the default backend is not auto's choice");
    if device.contains(" (cpu, Vulkan") {
        let name = device["device: ".len()..].split(" (cpu, Vulkan").next().unwrap();
        assert!(
            auto.starts_with("device: CPU build of the shared GLSL (")
                && auto.contains(&format!("; --backend auto: {name} runs on the CPU); the window through {name}")),
            "{auto}"
        );
    } else {
        assert_eq!(auto, device, "auto on a device that is not a CPU");
    }
    // A device named to draw draws, lavapipe included (as render's auto).
    let named = preview(&["--width", "32", "--height", "24", "--frames", "1", "--backend", "auto", "--device", "0"]);
    assert_clean(&named, "preview --backend auto --device 0");
    assert!(!line(&named).unwrap_or_default().contains("CPU build"), "{}", text(&named));
    let o = raycast(&["preview", "--backend", "cpu", "--shaders", "shaders"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--backend cpu runs the CPU build"), "{}", text(&o));
}

/// `--keys` presses the window's keys before given frames. Rules (bit-exact
/// screenshots; each switch starts the samples over): 2, 1, 2 (normal,
/// colour, normal: the last finds its kernel kept) ends as `--aov normal`'s
/// first frame; H twice as the plain first frame; B before frame 2 of 3
/// (the CPU build draws samples 0 and 1 after the device drew one, or the
/// device after the CPU build) as two frames drawn by the device alone,
/// and stderr says who draws; K before frame 2 of 3 with the CPU build
/// drawing (the source tree's shaders recompiled, as an edit: the device
/// draws from then on, the samples start over) as two frames of the
/// device alone, and stderr says so. A frame 0, an unknown key, or no
/// --frames is a usage error.
#[test]
fn scripted_keys_switch_the_view_the_flags_and_who_draws() {
    let size = [64, 48];
    // (name, frames, flags, the expected picture's frames and flags)
    type Case<'a> = (&'a str, u32, &'a [&'a str], u32, &'a [&'a str]);
    let cases: [Case; 5] = [
        ("keys-aov", 3, &["--keys", "1:2,2:1,3:2"], 1, &["--aov", "normal"]),
        ("keys-shadows", 2, &["--keys", "1:H,2:h"], 1, &[]),
        ("keys-to-cpu", 3, &["--keys", "2:B"], 2, &[]),
        ("keys-to-device", 3, &["--backend", "cpu", "--keys", "2:B"], 2, &[]),
        ("keys-recompile", 3, &["--backend", "cpu", "--keys", "2:K"], 2, &[]),
    ];
    for (name, frames, keys, expected_frames, expected_flags) in cases {
        let actual = screenshot(None, size, frames, name, keys);
        let expected = screenshot(None, size, expected_frames, &format!("{name}-expected"), expected_flags);
        assert_bit_exact(&actual, &expected, name, "the keys' picture");
    }
    let o = preview(&["--width", "32", "--height", "24", "--frames", "2", "--keys", "2:B"]);
    assert_clean(&o, "B");
    assert!(String::from_utf8_lossy(&o.stderr).contains("raycast: preview: CPU build ("), "{}", text(&o));
    // The hand-over an edit makes, through K: recompiled, reloaded, the device
    // draws; so B after it goes back to the CPU build, which says it is not the edit.
    let o = preview(&["--width", "32", "--height", "24", "--frames", "3", "--backend", "cpu", "--keys", "2:K,3:B"]);
    assert_clean(&o, "K then B");
    assert_says(
        &o,
        &[
            "recompiling the shaders of ",
            "reloaded the kernel (preview.comp)",
            "draws from now on: the CPU build is the code",
            "CPU build (",
            "draws: the code raycast was built with, not the edited shader",
        ],
    );
    // --no-textures loads none, as `render --no-textures`: a scene whose
    // textures cannot be found opens (here a generated one without --assets),
    // and T says it has nothing to turn on.
    let scene = Path::new("gen:recursive-spheres:3");
    let args = ["--no-textures", "--keys", "2:T"];
    let actual = screenshot(Some(scene), size, 2, "no-textures", &args);
    let expected = screenshot(Some(scene), size, 2, "no-textures-expected", &["--no-textures"]);
    assert_bit_exact(&actual, &expected, "no-textures", "T with no textures loaded changed the picture");
    let o = preview(&["gen:recursive-spheres:3", "--no-textures", "--frames", "2", "--keys", "2:T"]);
    assert_says(&o, &["raycast: preview: no textures were loaded (--no-textures): start without it to turn them on"]);
    for bad in [
        &["--frames", "2", "--keys", "0:H"][..],
        &["--frames", "2", "--keys", "1:Q"],
        &["--frames", "2", "--keys", "1"],
        &["--keys", "1:H"],
    ] {
        let o = raycast(&[&["preview"][..], bad].concat());
        assert_eq!(o.status.code(), Some(2), "{bad:?}: {}", text(&o));
    }
}

/// Largest channel difference between two colours.
fn delta(a: [u8; 3], b: [u8; 3]) -> u8 {
    (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap()
}

/// Rules, frame 8 against frame 1 of the default scene:
/// - at least 500 pixels differ (jittered samples smooth the silhouettes);
/// - a black pixel of frame 1 whose 5x5 neighbourhood is all black (far
///   from any object: a sub-pixel jitter cannot reach one) stays black;
/// - a pixel that changed by more than 48/255 lies next to an edge of
///   frame 1: a neighbour differs from it by more than 48/255 there.
#[test]
fn more_frames_accumulate_jittered_samples() {
    let size = [256, 192];
    let one = screenshot(None, size, 1, "default-accumulate", &[]);
    let eight = screenshot(None, size, 8, "default-accumulate", &[]);
    let (w, h) = (size[0] as i64, size[1] as i64);
    let at = |img: &Rgb8, x: i64, y: i64| img.pixel(x.clamp(0, w - 1) as u32, y.clamp(0, h - 1) as u32);
    let mut changed = 0;
    let mut problems = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let (a, b) = (at(&one, x, y), at(&eight, x, y));
            let d = delta(a, b);
            if d > 0 {
                changed += 1;
            }
            let far = (-2..=2).all(|dy| (-2..=2).all(|dx| at(&one, x + dx, y + dy) == [0, 0, 0]));
            if far && b != [0, 0, 0] {
                problems.push(format!("({x}, {y}) is far from every object but became {b:?}"));
            }
            let edge = (-1..=1).any(|dy| (-1..=1).any(|dx| delta(at(&one, x + dx, y + dy), a) > 48));
            if d > 48 && !edge {
                problems.push(format!("({x}, {y}) changed by {d}/255 ({a:?} -> {b:?}) away from any edge"));
            }
        }
    }
    assert!(changed >= 500, "only {changed} pixels differ between frame 1 and frame 8");
    if !problems.is_empty() {
        let diff = image_io::compare(&eight, &one, 0).unwrap();
        let paths = image_io::write_diff_images(&out_dir(), "accumulate", &eight, &one, &diff).unwrap();
        panic!(
            "{} problem(s), first: {}\nframe 8 {}, frame 1 {}, diff {}",
            problems.len(),
            problems[0],
            paths[0].display(),
            paths[1].display(),
            paths[2].display()
        );
    }
}

#[test]
fn no_display_is_a_clear_error() {
    let o = Command::new(env!("CARGO_BIN_EXE_raycast"))
        .args(["preview", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("run raycast");
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(err.contains("cannot open a window") && err.contains("xvfb-run"), "{}", text(&o));
    assert!(!err.contains("panicked"), "{}", text(&o));
}

/// The window's veto of a device, asked before its driver is: NVIDIA's
/// crashes when asked to present to an X display with neither NV-GLX nor
/// DRI3 (seen on an H100 under Xvfb), so the preview asks the display first
/// and refuses with the reason. RAYCAST_PRESENT_CHECK=1 applies that rule to
/// lavapipe: Xvfb has neither, so it is refused there (exit 1, the reason
/// named, no crash); without it, lavapipe's own rule (it needs neither)
/// shows the picture on the same display. (The display's answers, both
/// ways, are x11.rs's test; the rule's, app.rs's.)
#[test]
fn a_display_the_driver_cannot_present_to_is_refused() {
    let check = [("RAYCAST_PRESENT_CHECK", "1")];
    let server = "-screen 0 1280x1024x24";
    let o = preview_on(server, &check, &["--backend", "gpu", "--frames", "1"]);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        err.contains("cannot present to this window")
            && err.contains("has neither NV-GLX (NVIDIA's X driver) nor DRI3"),
        "the refusal and its reason:\n{}",
        text(&o)
    );
    assert!(!err.contains("panicked"), "{}", text(&o));
    assert_clean(&preview_on(server, &[], &["--backend", "gpu", "--frames", "1"]), "lavapipe on the same display");
    // `raycast devices` says it of each device the rule refuses, and only of those.
    let said = "   preview: cannot present to this display (the X display :";
    for (env, refused) in [(&check[..], true), (&[][..], false)] {
        let o = raycast_on(server, env, &["devices"]);
        assert_clean(&o, "devices");
        let out = String::from_utf8_lossy(&o.stdout);
        assert_eq!(out.contains(said), refused, "{env:?}: {}", text(&o));
        if refused {
            assert!(out.contains("`raycast preview` draws here and a device that can present shows"), "{}", text(&o));
        }
    }
}

/// A device apart from the window draws (`--window-device`: here the same
/// lavapipe, opened twice; on a GPU machine under Xvfb, NVIDIA's driver
/// draws and lavapipe shows). Rules (bit-exact screenshots): the pictures
/// are those of the window's device drawing alone, at rest, steering
/// (`--moving`), after B twice (the CPU build, then the device apart again)
/// and after K (the shaders recompiled for the device apart); stdout names
/// both devices. Where no device can present, an explicit --device is still
/// refused with the reason.
#[test]
fn a_device_apart_from_the_window_draws() {
    let apart = ["--device", "0", "--window-device", "0", "--backend", "gpu"];
    let cases: [(&str, u32, &[&str]); 4] = [
        ("apart-rest", 3, &[]),
        ("apart-moving", 4, &["--moving", "2"]),
        ("apart-keys", 4, &["--keys", "2:B,3:B,4:2"]),
        ("apart-recompile", 3, &["--keys", "2:K"]),
    ];
    for (name, frames, extra) in cases {
        let actual = screenshot(None, [64, 48], frames, name, &[&apart[..], extra].concat());
        let alone =
            screenshot(None, [64, 48], frames, &format!("{name}-alone"), &[&["--backend", "gpu"][..], extra].concat());
        assert_bit_exact(&actual, &alone, name, "the device apart's picture is not the window's device's");
    }
    let o = preview(&[&apart[..], &["--width", "32", "--height", "24", "--frames", "1"]].concat());
    assert_clean(&o, "a device apart");
    let out = String::from_utf8_lossy(&o.stdout);
    let device = out.lines().find(|l| l.starts_with("device: ")).unwrap_or_default();
    let name = device.trim_start_matches("device: ").split(" (").next().unwrap_or_default();
    assert!(
        !name.is_empty() && device.contains("; the window through ") && device.matches(name).count() == 2,
        "the device that draws, then the window's:\n{}",
        text(&o)
    );
    let o =
        preview_on("-screen 0 1280x1024x24", &[("RAYCAST_PRESENT_CHECK", "1")], &["--device", "0", "--frames", "1"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("cannot present to this window") && !err.contains("panicked"), "{}", text(&o));
    // A device not found is named by its option.
    for args in [&["--window-device", "no such device"][..], &["--device", "no such device", "--window-device", "0"]] {
        let o = preview(&[&["--frames", "1"][..], args].concat());
        assert_eq!(o.status.code(), Some(1), "{args:?}: {}", text(&o));
        let said = format!("raycast: error: {}: no Vulkan device matches name \"no such device\"", args[0]);
        assert_says(&o, &[&said]);
    }
}

/// Runs `raycast preview ARGS` under an X server of its own with `env`, and
/// `body`, a bash script, beside it once its window is up (`$w`, for
/// xdotool: Debian package xdotool, which ci/install-deps.sh installs);
/// then Escape, and the preview's output and exit status (killed after 60
/// s: a hang fails).
fn with_window(body: &str, args: &[&str], env: &[(&str, &str)]) -> Output {
    let script = format!(
        r#"
        "$RAYCAST" preview "$@" & pid=$!
        # Off the output pipes, which the test waits on: a sleep left holding one kept it 60 s.
        ( sleep 60; kill $pid ) >/dev/null 2>&1 & watchdog=$!
        for i in $(seq 100); do
            w=$(xdotool search --name 'raycast preview' 2>/dev/null | head -1)
            [ -n "$w" ] && break
            sleep 0.1
        done
        [ -n "$w" ] || {{ kill $pid; echo "no preview window appeared"; exit 90; }}
        sleep 1
        {body}
        xdotool key --window $w Escape 2>/dev/null
        wait $pid; status=$?
        kill $watchdog 2>/dev/null
        [ $status = 143 ] && echo "the preview hung: killed after 60 s"
        exit $status
        "#
    );
    let env = [env, &[("RAYCAST", env!("CARGO_BIN_EXE_raycast"))]].concat();
    program_on("-screen 0 1280x1024x24", &env, "bash", &[&["-c", &script, "window"][..], args].concat())
}

/// A window made smaller while a sample is drawn in bands (here 8 rows a
/// frame, RAYCAST_PREVIEW_BAND_ROWS) starts that sample over: its next band
/// lay below the new picture's bottom, and the preview panicked ("the band
/// is inside the frame"), found resizing a preview drawn by a device apart.
/// xdotool resizes the window eight times, a quarter of a second apart, with
/// the window's device and with a device apart. Rule: exit 0, no panic, no
/// validation message. Before the fix it panicked at the first shrink that
/// found the band below 48 rows, in every run tried.
#[test]
fn a_smaller_window_mid_sample_starts_it_over() {
    let resize = r#"
        for size in "64 48" "512 384" "64 48" "400 300" "64 48" "512 384" "80 40" "512 384"; do
            xdotool windowsize $w $size; sleep 0.25
        done"#;
    for apart in [&[][..], &["--device", "0", "--window-device", "0"]] {
        let o =
            with_window(resize, &[&["--backend", "gpu"][..], apart].concat(), &[("RAYCAST_PREVIEW_BAND_ROWS", "8")]);
        assert_clean(&o, &format!("resizing the window {apart:?}"));
    }
}

/// The window under 50 inputs chosen at random (a fixed seed): keys (the
/// views, H M T, B, R F, flying), orbit drags, wheel clicks, resizes, and
/// the scene file replaced by another scene (generated: spheres, cones,
/// cubes) or by a truncated one (an error, the last good scene kept),
/// samples drawn in bands of 16 rows; with the CPU build drawing (auto) and
/// with a device apart. Rule: exit 0, no panic, no validation message; the
/// reloads and the refused files said on stderr.
#[test]
fn the_window_survives_random_input() {
    let dir = out_dir().join("random-input");
    std::fs::create_dir_all(&dir).unwrap();
    for (family, depth) in [("spheres", "2"), ("spheres", "3"), ("cones", "2"), ("cubes", "3")] {
        let out = dir.join(format!("gen-{family}-{depth}.xml"));
        let o = raycast(&["gen", &format!("recursive-{family}"), "--depth", depth, "-o", out.to_str().unwrap()]);
        assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    }
    let scene = dir.join("scene.xml");
    let events = r#"
        RANDOM=5
        keys=(1 2 3 4 5 6 h m t b r f w a s d)
        scenes=("$DIR"/gen-*.xml)
        for i in $(seq 50); do
            case $((RANDOM % 6)) in
                0) xdotool key --window $w ${keys[$((RANDOM % ${#keys[@]}))]} ;;
                1) xdotool mousemove --window $w $((RANDOM % 400 + 50)) $((RANDOM % 300 + 40)) mousedown 1 \
                       mousemove_relative -- $((RANDOM % 60 - 30)) $((RANDOM % 40 - 20)) mouseup 1 ;;
                2) xdotool mousemove --window $w 200 150 click $((4 + RANDOM % 2)) ;;
                3) xdotool windowsize $w $((RANDOM % 600 + 20)) $((RANDOM % 500 + 20)) ;;
                4) cp "${scenes[$((RANDOM % ${#scenes[@]}))]}" "$SCENE.tmp" && mv "$SCENE.tmp" "$SCENE" ;;
                5) head -c $((RANDOM % 400 + 10)) "${scenes[$((RANDOM % ${#scenes[@]}))]}" > "$SCENE.tmp" &&
                       mv "$SCENE.tmp" "$SCENE" ;;
            esac
            sleep 0.1
        done 2>/dev/null
        sleep 1"#;
    for apart in [&[][..], &["--device", "0", "--window-device", "0", "--backend", "gpu"]] {
        std::fs::copy(dir.join("gen-spheres-3.xml"), &scene).unwrap();
        let (s, d) = (scene.to_str().unwrap(), dir.to_str().unwrap());
        let args = [&[s, "--no-textures"][..], apart].concat();
        let o = with_window(events, &args, &[("RAYCAST_PREVIEW_BAND_ROWS", "16"), ("SCENE", s), ("DIR", d)]);
        assert_clean(&o, &format!("random input {apart:?}"));
        assert_says(&o, &["raycast: preview: reloaded ", "raycast: preview: keeping the last good picture"]);
    }
}

/// A texture the scene uses, changed on disk while the window is open,
/// reloads the scene (as an edit of the scene file does); the texture
/// replaced by a file that is not a picture is an error that keeps the last
/// good scene.
#[test]
fn a_changed_texture_reloads_the_scene() {
    let dir = out_dir().join("texture-reload");
    std::fs::create_dir_all(&dir).unwrap();
    for (name, colour) in [("red.png", [255, 0, 0]), ("blue.png", [0, 0, 255])] {
        let data = colour.iter().copied().cycle().take(4 * 4 * 3).collect();
        raycast::image_io::write_png(&dir.join(name), &raycast::image_io::Rgb8 { width: 4, height: 4, data }).unwrap();
    }
    std::fs::copy(dir.join("red.png"), dir.join("tex.png")).unwrap();
    let default = std::fs::read_to_string(common::repo().join("scenes/default.xml")).unwrap();
    let scene = dir.join("textured.xml");
    let textured = default.replace(
        r#"<object type="primitive" name="cube">"#,
        r#"<object type="primitive" name="cube"><texture file="tex.png" u="1" v="1"/><blend v="1"/>"#,
    );
    std::fs::write(&scene, textured).unwrap();
    let events = r#"
        sleep 1
        cp "$DIR/blue.png" "$DIR/tex.tmp" && mv "$DIR/tex.tmp" "$DIR/tex.png"
        sleep 1.5
        echo "not a picture" > "$DIR/tex.tmp" && mv "$DIR/tex.tmp" "$DIR/tex.png"
        sleep 1.5"#;
    let (s, d) = (scene.to_str().unwrap(), dir.to_str().unwrap());
    let o = with_window(events, &[s], &[("DIR", d)]);
    assert_clean(&o, "texture reload");
    let reloaded = format!("raycast: preview: reloaded {s}");
    assert_says(&o, &[&reloaded, "raycast: preview: keeping the last good picture"]);
}

/// Textures beyond one storage buffer of the device (lavapipe: 128 MiB of
/// texels). With the device drawing (`--backend gpu`) they are refused by
/// name, with the preview's advice. With the CPU build drawing (`--backend
/// auto`, the default, on lavapipe) the scene stays off the device and is
/// previewed: a note says why, B (the device to draw) and K (an edit the
/// device would draw) say it cannot and leave the CPU build drawing, and
/// the picture after them, one sample, is `render --backend cpu`'s.
#[test]
fn textures_beyond_one_storage_buffer() {
    let scene = common::big_texture_scene(&out_dir().join("big-texture"));
    let s = scene.to_str().unwrap();
    let o = preview(&[s, "--width", "64", "--height", "48", "--frames", "1"]);
    if !text(&o).contains("llvmpipe") {
        println!("skipped: the device is not lavapipe, whose buffer limit this test knows: {}", text(&o));
        return;
    }
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(
        err.contains("the storage buffer of the texels needs 128.3 MiB")
            && err.contains("use smaller textures, or preview with --backend cpu")
            && !err.contains("panicked"),
        "{}",
        text(&o)
    );

    let png = out_dir().join("big-texture-preview.png");
    let _ = std::fs::remove_file(&png);
    let args = [s, "--width", "64", "--height", "48", "--frames", "3", "--keys", "2:B,3:K"];
    let o = preview_as_given(&[&args[..], &["--screenshot", png.to_str().unwrap()]].concat());
    assert_clean(&o, "the CPU build drawing");
    assert_says(
        &o,
        &[
            "raycast: preview: note: the storage buffer of the texels needs 128.3 MiB",
            "the CPU build draws the samples; with smaller textures the device could draw them too (B)",
            "raycast: preview: error: cannot switch who draws: the storage buffer of the texels",
            "raycast: preview: the reloaded kernel cannot draw this scene on llvmpipe",
        ],
    );
    let expected = render(Some(&scene), [64, 48], "big-texture", &["--backend", "cpu"]);
    assert_bit_exact(&image_io::read_picture(&png).unwrap(), &expected, "big-texture", "the CPU build's preview");
}

/// A window larger than one storage buffer of the device holds (lavapipe:
/// 128 MiB of 32-byte pixel records) is refused with the sizes, and the
/// message says where larger pictures go.
#[test]
fn a_window_beyond_one_storage_buffer_is_a_clear_error() {
    let o = preview(&[
        "--width",
        "4096",
        "--height",
        "3072",
        "--frames",
        "1",
        "--screenshot",
        out_dir().join("huge.png").to_str().unwrap(),
    ]);
    let err = String::from_utf8_lossy(&o.stderr);
    if !text(&o).contains("llvmpipe") {
        println!("skipped: the device is not lavapipe, whose buffer limit this test knows: {}", text(&o));
        return;
    }
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(err.contains("the preview's pixel buffer") && err.contains("maxStorageBufferRange"), "{}", text(&o));
    assert!(
        err.contains("`raycast render` draws larger pictures in bands") && !err.contains("panicked"),
        "{}",
        text(&o)
    );
    assert!(!out_dir().join("huge.png").exists(), "a screenshot was written");
}

#[test]
fn bad_arguments_are_usage_errors() {
    let o = raycast(&["preview", "--frames", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = raycast(&["preview", "--present-mode", "sometimes"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    let o = raycast(&["preview", "--width", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--width 0 is out of range"), "{}", text(&o));
    let o = raycast(&["preview", "--shaders", "/nonexistent"]);
    assert_eq!(o.status.code(), Some(1), "{}", text(&o));
    assert!(String::from_utf8_lossy(&o.stderr).contains("no preview.comp"), "{}", text(&o));
    let o = raycast(&["preview", "--timeout", "0"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// `--timeout` reaches the preview's device: a frame that cannot finish
/// within a millisecond ends the preview with the error that names the
/// flag, not a hang or a panic. Drawn apart from the window (the way a GPU
/// server's preview draws, and where its wait is raycast's: lavapipe's
/// presentation to Xvfb waits for the frame itself, inside the driver).
#[test]
fn the_timeout_ends_a_frame_that_does_not_finish() {
    let apart = ["--device", "0", "--window-device", "0", "--backend", "gpu"];
    let rest = ["--frames", "2", "--timeout", "0.001", "gen:recursive-spheres:6", "--no-textures"];
    let o = preview(&[&apart[..], &rest[..]].concat());
    let err = text(&o);
    assert_eq!(o.status.code(), Some(1), "{err}");
    assert!(err.contains("did not finish within 0.001 s") && !err.contains("panicked"), "{err}");
}

/// A preview frame the device cut short (lavapipe's 65535 loop iterations
/// per invocation; here a planted loop of 70,000 in a copy of the preview kernel,
/// which --shaders compiles before the first frame) is named on stderr, and
/// its screenshot is refused, not written wrong. On a device without the
/// budget (`common::device_loop_budget`: Mesa 25's lavapipe, a GPU) the
/// loop runs through: no such message, and the screenshot is written.
#[test]
fn pixels_cut_short_are_reported_and_not_saved() {
    let dir = common::copy_of_shaders(&out_dir().join("planted-loop-shaders"));
    let anchor = "    bool cut_short = !loop_budget_ok();";
    let planted = "    uint spin = 0u;\n    for (uint k = 0u; k < 70000u + preview.pad1; k++) {\n        spin = spin * 1664525u + k;\n    }\n    if (spin == 1u) {\n        rays = rays + 1u;\n    }\n";
    common::plant(&dir, "preview_main.glsl", anchor, &format!("{planted}{anchor}"));

    // The window's device drawing, and a device apart (the same one, as
    // --window-device makes it) whose count comes back with its pixels.
    for apart in [&[][..], &["--device", "0", "--window-device", "0"]] {
        let png = out_dir().join("planted-loop.png");
        let _ = std::fs::remove_file(&png);
        let args = ["--shaders", dir.to_str().unwrap(), "--width", "24", "--height", "16", "--frames", "2"];
        let o = preview(&[&args[..], apart, &["--screenshot", png.to_str().unwrap()]].concat());
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("panicked"), "{}", text(&o));
        if common::device_loop_budget(&out_dir()).is_none() {
            assert_eq!(o.status.code(), Some(0), "{}", text(&o));
            assert!(!err.contains("short") && png.exists(), "{}", text(&o));
            continue;
        }
        assert_eq!(o.status.code(), Some(1), "{apart:?}: {}", text(&o));
        assert!(err.contains("the picture is WRONG: the device cut 384 pixels short"), "{}", text(&o));
        assert!(err.contains("cut 384 of 384 pixels short") && err.contains("nothing was written"), "{}", text(&o));
        assert!(err.contains("Turn mirror reflections off (M, or --no-reflections)"), "{}", text(&o));
        assert!(!png.exists(), "the screenshot was written");
    }
}

/// `--moving N` turns the camera before each of the first N frames, as a
/// drag does: those render at the motion resolution (smaller than the
/// picture when a full frame would take more than 125 ms) and their frame
/// rate is printed; the frames after them, at rest, are the full picture,
/// and their rate is printed too.
#[test]
fn moving_frames_report_their_rate_and_the_frame_at_rest_is_full_size() {
    let png = out_dir().join("moving.png");
    let _ = std::fs::remove_file(&png);
    let o = preview(&[
        "--width",
        "96",
        "--height",
        "64",
        "--frames",
        "7",
        "--moving",
        "4",
        "--screenshot",
        png.to_str().unwrap(),
    ]);
    assert_clean(&o, "preview --moving");
    let out = String::from_utf8_lossy(&o.stdout);
    let line = out
        .lines()
        .find(|l| l.starts_with("moving: 3 frames at "))
        .unwrap_or_else(|| panic!("no moving line:\n{}", text(&o)));
    assert!(line.contains("(the picture 96x64): median ") && line.ends_with(" frames a second"), "{line}");
    // Frames 5 and 6 at rest are timed (the 7th, the last, is not).
    let line =
        out.lines().find(|l| l.starts_with("at rest: ")).unwrap_or_else(|| panic!("no at-rest line:\n{}", text(&o)));
    assert!(line.starts_with("at rest: 2 frames at 96x64: median ") && line.ends_with(" frames a second"), "{line}");
    let shot = image_io::read_picture(&png).unwrap();
    assert_eq!((shot.width, shot.height), (96, 64), "the frame at rest is the full picture");
    // --moving needs --frames.
    let o = raycast(&["preview", "--moving", "3"]);
    assert_eq!(o.status.code(), Some(2), "{}", text(&o));
}

/// A click (scripted: `--click X,Y` after the last frame) prints the
/// pixel's first hit and, in the colour view, its sample 0's rays as
/// `raycast trace` follows them, from the preview's camera. Rules: at the
/// scene's camera the trace lines are `raycast trace --pixel`'s, line for
/// line; after the camera turned, the trace starts from another eye and its
/// 8-bit colour is the screenshot's pixel (one sample at rest), exactly;
/// after 4 samples at rest the trace says it follows sample 0 of the 4.
#[test]
fn a_click_prints_the_pixel_and_its_rays() {
    let o = preview(&["--frames", "1", "--click", "256,200"]);
    assert_clean(&o, "click");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(out.contains("pixel (256, 200): primitive 0 (cube) at <default scene>:48:7"), "{}", text(&o));
    let traced: Vec<&str> =
        out.lines().skip_while(|l| !l.contains("its rays (`raycast trace`)")).skip(1).map(str::trim).collect();
    let cli = raycast(&["trace", "--pixel", "256,200"]);
    assert!(cli.status.success(), "{}", text(&cli));
    let cli_out = String::from_utf8_lossy(&cli.stdout).into_owned();
    let want: Vec<&str> = cli_out
        .lines()
        .skip_while(|l| !l.starts_with("pixel (256, 200), sample 0 of 1:"))
        .skip(1)
        .take_while(|l| !l.starts_with("the render's pixel"))
        .map(str::trim)
        .collect();
    assert!(want.len() > 5, "{cli_out}");
    assert_eq!(traced, want, "the preview's trace against raycast trace's");

    let png = out_dir().join("click-moved.png");
    let _ = std::fs::remove_file(&png);
    let o = preview(&["--frames", "3", "--moving", "2", "--click", "256,200", "--screenshot", png.to_str().unwrap()]);
    assert_clean(&o, "click after moving");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    let camera =
        out.lines().find(|l| l.trim_start().starts_with("camera ray from")).unwrap_or_else(|| panic!("{}", text(&o)));
    assert!(!camera.contains("from (4.5, 3.2, 6.5)"), "the scene's eye, not the turned camera's: {camera}");
    let sample =
        out.lines().find(|l| l.trim_start().starts_with("sample colour")).unwrap_or_else(|| panic!("{}", text(&o)));
    let shot = image_io::read_picture(&png).unwrap();
    let k = (200 * shot.width as usize + 256) * 3;
    let rgb = &shot.data[k..k + 3];
    assert!(
        sample.contains(&format!("8-bit ({}, {}, {})", rgb[0], rgb[1], rgb[2])),
        "screenshot pixel {rgb:?}; {sample}"
    );

    // After several samples at rest the trace says which one it follows.
    let o = preview(&["--frames", "4", "--click", "256,200"]);
    assert_clean(&o, "click after 4 samples");
    let out = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        out.contains("its rays (`raycast trace`), sample 0 (the pixel centre) of the 4 averaged here:"),
        "{}",
        text(&o)
    );
}

/// The screenshot is never written over what the preview reads: its scene
/// file (whatever its name says) or a texture the scene uses. Rule: as
/// `render -o`, a usage error (exit 2) before any window opens (no status
/// line), and the file as it was.
#[test]
fn a_screenshot_over_the_scene_or_its_texture_is_refused() {
    let dir = out_dir().join("screenshot-over-input");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let scene = dir.join("scene.png");
    std::fs::copy(repo().join("scenes/default.xml"), &scene).unwrap();
    let texture = dir.join("texture.png");
    image_io::write_png(&texture, &Rgb8 { width: 2, height: 2, data: vec![200; 12] }).unwrap();
    let textured = dir.join("textured.xml");
    std::fs::write(
        &textured,
        r#"<scenefile><cameradata><pos x="0" y="0" z="5"/><look x="0" y="0" z="-1"/></cameradata>
<object type="tree" name="root"><transblock><object type="primitive" name="cube"><texture file="texture.png" u="1" v="1"/><blend v="1"/></object></transblock></object></scenefile>"#,
    )
    .unwrap();
    for (scene, output) in [(&scene, &scene), (&textured, &texture)] {
        let before = std::fs::read(output).unwrap();
        let o = preview(&[
            scene.to_str().unwrap(),
            "--width",
            "32",
            "--height",
            "24",
            "--frames",
            "1",
            "--screenshot",
            output.to_str().unwrap(),
        ]);
        assert_eq!(o.status.code(), Some(2), "{}", text(&o));
        assert_says(
            &o,
            &[&format!("would be written over {}, which this command reads: name another file", output.display())],
        );
        assert!(!String::from_utf8_lossy(&o.stdout).contains("device:"), "a window opened: {}", text(&o));
        assert_eq!(std::fs::read(output).unwrap(), before, "{} was written over", output.display());
    }
}

/// `--screenshot /dev/stdout`: the PNG is all that goes to stdout; the
/// status lines (device, scene, wrote) go to stderr, as `render -o
/// /dev/stdout`'s. Rule: stdout is a PNG of the picture's size, whole.
#[test]
fn a_screenshot_to_stdout_is_the_png_alone() {
    let o = preview(&["--width", "32", "--height", "24", "--frames", "1", "--screenshot", "/dev/stdout"]);
    assert_clean(&o, "--screenshot /dev/stdout");
    assert!(o.stdout.starts_with(b"\x89PNG\r\n\x1a\n"), "stdout is not a PNG: {}", text(&o));
    let png = out_dir().join("stdout-screenshot.png");
    std::fs::write(&png, &o.stdout).unwrap();
    let shot = image_io::read_picture(&png).unwrap_or_else(|e| panic!("{e}: {}", text(&o)));
    assert_eq!((shot.width, shot.height), (32, 24));
    assert_says(&o, &["device: ", "scene: ", "wrote /dev/stdout (32x24"]);
}

/// What a scripted run asks of frames it will not draw is known before the
/// first: a --click outside the picture, a --keys press or --moving turn
/// past --frames. Rule: a usage error (exit 2) naming the value, before any
/// window opens (no status line), as `trace --pixel` outside the picture.
#[test]
fn a_script_beyond_the_picture_or_the_frames_is_a_usage_error() {
    let size = ["--width", "32", "--height", "24", "--frames", "3"];
    for (extra, said) in [
        (&["--click", "32,12"][..], "--click 32,12 is outside the 32x24 picture"),
        (&["--click", "0,24"], "--click 0,24 is outside the 32x24 picture"),
        (&["--keys", "2:H,4:M"], "--keys 4:M presses M before frame 4, past --frames 3"),
        (&["--moving", "4"], "--moving 4 turns the camera before frame 4, past --frames 3"),
    ] {
        let o = preview(&[&size[..], extra].concat());
        assert_eq!(o.status.code(), Some(2), "{extra:?}: {}", text(&o));
        assert_says(&o, &[said]);
        assert!(!String::from_utf8_lossy(&o.stdout).contains("device:"), "a window opened: {}", text(&o));
    }
    // At the edge: the last pixel, a key before the last frame, every frame turning.
    let o = preview(&[&size[..], &["--click", "31,23", "--keys", "3:H", "--moving", "3"]].concat());
    assert_clean(&o, "the last pixel, frame and turn");
    assert!(String::from_utf8_lossy(&o.stdout).contains("pixel (31, 23)"), "{}", text(&o));
}

/// Without a Vulkan driver (VK_ICD_FILENAMES at a file that is not there)
/// the preview says so, as `render` does, naming the variable and what to
/// do, and that the window needs Vulkan even where the CPU build draws.
/// Rule: exit 1, no panic, no empty "()" where the reason should be.
#[test]
fn no_vulkan_driver_is_named_as_the_reason() {
    let env = [("VK_ICD_FILENAMES", "/nonexistent/icd.json"), ("RAYCAST_VALIDATION", "0")];
    for backend in ["cpu", "gpu"] {
        let o = preview_on("-screen 0 1280x1024x24", &env, &["--frames", "1", "--backend", backend]);
        assert_eq!(o.status.code(), Some(1), "{}", text(&o));
        assert_says(
            &o,
            &[
                "no Vulkan device found",
                "VK_ICD_FILENAMES=\"/nonexistent/icd.json\"; unset it or point it at an existing ICD file",
                "even with --backend cpu",
            ],
        );
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(!err.contains("()") && !err.contains("panicked"), "{}", text(&o));
    }
}

/// `preview --help` describes the views as the preview draws them: it takes
/// no --depth-range or --cost-max (render's and check's), so its text names
/// them only as theirs and says what the preview does instead (the depth
/// range follows the camera, the cost scales are 64 and 256 passes).
#[test]
fn the_help_names_only_the_previews_own_options() {
    let o = raycast(&["preview", "--help"]);
    assert_eq!(o.status.code(), Some(0), "{}", text(&o));
    // Words as they read, whatever the terminal's width wraps.
    let help = String::from_utf8_lossy(&o.stdout).split_whitespace().collect::<Vec<_>>().join(" ");
    let mentions = |flag: &str| help.matches(flag).count();
    let as_theirs = |flag: &str| help.matches(&format!("(render and check: {flag}")).count();
    for flag in ["--depth-range", "--cost-max"] {
        assert_eq!(mentions(flag), as_theirs(flag), "{flag} told as the preview's own:\n{help}");
    }
    assert!(help.contains("the preview: that sphere, following the camera"), "{help}");
    assert!(help.contains("from 64 passes on") && help.contains("from 256 passes on"), "{help}");
}
