//! `raycast compare` as a grader meets it: the verdict line, exit 4 on any
//! mismatch (two sizes included), a diff picture where a wrong pixel shows,
//! and the folder mode. Pictures are made here, so no device is needed.

use std::path::{Path, PathBuf};

mod common;
use common::{raycast, text};
use raycast::image_io::{read_picture, write_png, Rgb8};
use serde_json::Value;

/// A folder of its own for one test, made and emptied.
fn dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("compare").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A picture with a different colour at every pixel, nowhere red.
fn gradient(width: u32, height: u32) -> Rgb8 {
    let mut data = Vec::with_capacity((3 * width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            data.extend([(x % 200) as u8 + 20, (y % 200) as u8 + 20, ((x + y) % 150) as u8 + 50]);
        }
    }
    Rgb8 { width, height, data }
}

/// `picture` with its first `n` pixels (row-major) off by 30 in blue.
fn with_differing(picture: &Rgb8, n: usize) -> Rgb8 {
    let mut p = picture.clone();
    for i in 0..n {
        p.data[3 * i + 2] = p.data[3 * i + 2].wrapping_add(30);
    }
    p
}

fn save(path: &Path, picture: &Rgb8) -> String {
    write_png(path, picture).unwrap();
    path.to_str().unwrap().to_string()
}

fn last_line(s: &str) -> &str {
    s.lines().last().unwrap_or("")
}

/// The last line is the verdict, with the counts (in thousands) and the
/// rule; the report lines stay above it; PASS exits 0, FAIL 4.
#[test]
fn the_verdict_line_says_pass_or_fail_with_the_rule() {
    let d = dir("verdict");
    let expected = gradient(512, 384);
    let e = save(&d.join("expected.png"), &expected);
    let a = save(&d.join("actual.png"), &with_differing(&expected, 12));
    let o = raycast(&["compare", &a, &e], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    assert!(out.starts_with("12 of 196608 pixels (0.0061%) differ by more than 2/255; first at (0, 0)"), "{out}");
    assert_eq!(
        last_line(&out),
        "PASS: 12 of 196,608 pixels (0.0061%) differ by more than 2/255 (rule: at most 0.1%)",
        "{out}"
    );
    let o = raycast(&["compare", &a, &e, "--max-percent", "0.001"], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{out}{err}");
    assert_eq!(
        last_line(&out),
        "FAIL: 12 of 196,608 pixels (0.0061%) differ by more than 2/255 (rule: at most 0.001%)",
        "{out}"
    );
    assert!(err.contains("raycast: compare failed: 0.0061% of pixels differ, more than --max-percent 0.001"), "{err}");
    // Within the tolerance: nothing differs.
    let o = raycast(&["compare", &a, &e, "--tolerance", "30"], &[]);
    assert_eq!(o.status.code(), Some(0));
    assert_eq!(
        last_line(&text(&o).0),
        "PASS: 0 of 196,608 pixels (0.0000%) differ by more than 30/255 (rule: at most 0.1%)"
    );
}

/// Two sizes are a mismatch of their own (exit 4, said as such); a file
/// that cannot be read stays an error (exit 1).
#[test]
fn a_size_mismatch_exits_4_and_an_unreadable_file_1() {
    let d = dir("sizes");
    let a = save(&d.join("small.png"), &gradient(8, 6));
    let e = save(&d.join("large.png"), &gradient(16, 12));
    let o = raycast(&["compare", &a, &e, "-o", d.join("diff.png").to_str().unwrap()], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{out}{err}");
    assert_eq!(out, "FAIL: sizes differ: 8x6 against 16x12\n");
    assert!(err.contains("raycast: compare failed: sizes differ: actual 8x6, expected 16x12"), "{err}");
    assert!(!d.join("diff.png").exists(), "a diff image of pictures that were not compared");
    let o = raycast(&["compare", &a, &e, "--json"], &[]);
    assert_eq!(o.status.code(), Some(4));
    let j: Value = serde_json::from_str(&text(&o).0).expect("one JSON object");
    assert_eq!(j["actual_size"], serde_json::json!([8, 6]));
    assert_eq!(j["expected_size"], serde_json::json!([16, 12]));
    assert_eq!(j["passes"], false);
    let empty = d.join("empty.png");
    std::fs::write(&empty, b"").unwrap();
    let o = raycast(&["compare", empty.to_str().unwrap(), &e], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(1), "{out}{err}");
    assert!(err.contains("the file is empty") && !out.contains("PASS") && !out.contains("FAIL"), "{out}{err}");
}

/// The diff picture: a differing pixel pure red, every other pixel the
/// expected picture in grey, faded towards white (lighter than it was).
#[test]
fn the_diff_image_shows_differing_pixels_red_over_a_faded_reference() {
    let d = dir("diff-image");
    let expected = gradient(32, 24);
    let e = save(&d.join("expected.png"), &expected);
    let a = save(&d.join("actual.png"), &with_differing(&expected, 3));
    let diff = d.join("diff.png");
    let o = raycast(&["compare", &a, &e, "-o", diff.to_str().unwrap()], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{out}{err}");
    assert!(out.contains(&format!("wrote {}", diff.display())), "{out}");
    assert!(last_line(&out).starts_with("FAIL: 3 of 768 pixels"), "{out}");
    let picture = read_picture(&diff).unwrap();
    assert_eq!((picture.width, picture.height), (32, 24));
    let mut red = 0;
    for y in 0..24 {
        for x in 0..32 {
            let (p, original) = (picture.pixel(x, y), expected.pixel(x, y));
            if y == 0 && x < 3 {
                assert_eq!(p, [255, 0, 0], "differing pixel ({x}, {y})");
                red += 1;
                continue;
            }
            assert!(p[0] == p[1] && p[1] == p[2], "({x}, {y}) is not grey: {p:?}");
            assert!(
                p[0] >= 229 && original.iter().all(|&c| p[0] > c),
                "({x}, {y}) {p:?} not lighter than {original:?}"
            );
        }
    }
    assert_eq!(red, 3);
}

/// Two folders: pairs by name, one line each (missing and size mismatch
/// among the failures), extra pictures noted, the sum last, exit 4; the
/// failing pairs' diff images in -o's folder (an earlier run's of a pair
/// that passes now removed); --json one object a line, then the sum.
#[test]
fn folder_mode_judges_pairs_by_name() {
    let d = dir("folders");
    let (actual, expected, out) = (d.join("actual"), d.join("expected"), d.join("diffs"));
    std::fs::create_dir_all(&actual).unwrap();
    std::fs::create_dir_all(&expected).unwrap();
    let picture = gradient(20, 10);
    for name in ["a.png", "b.png", "c.png", "d.png"] {
        save(&expected.join(name), &picture);
    }
    std::fs::write(expected.join("README.txt"), "not a picture").unwrap();
    save(&actual.join("a.png"), &picture);
    save(&actual.join("b.png"), &with_differing(&picture, 50));
    save(&actual.join("d.png"), &gradient(10, 10));
    save(&actual.join("extra.png"), &picture);
    std::fs::create_dir_all(&out).unwrap();
    std::fs::write(out.join("a-diff.png"), b"an earlier run's").unwrap();
    let (a, e, o_dir) = (actual.to_str().unwrap(), expected.to_str().unwrap(), out.to_str().unwrap());
    let o = raycast(&["compare", a, e, "-o", o_dir], &[]);
    let (stdout, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{stdout}{err}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert_eq!(
        lines[0], "PASS a.png: 0 of 200 pixels (0.0000%) differ by more than 2/255 (rule: at most 0.1%)",
        "{stdout}"
    );
    assert_eq!(
        lines[1], "FAIL b.png: 50 of 200 pixels (25.0000%) differ by more than 2/255 (rule: at most 0.1%)",
        "{stdout}"
    );
    assert_eq!(lines[2], format!("FAIL c.png: missing from {a}"));
    assert_eq!(lines[3], "FAIL d.png: sizes differ: 10x10 against 20x10");
    assert!(stdout.contains("note: 1 picture(s) in") && stdout.contains(": extra.png\n"), "{stdout}");
    assert_eq!(last_line(&stdout), "compare: 1 of 4 pairs pass, 3 fail");
    assert!(err.contains("raycast: compare failed: 3 of 4 pairs fail: b.png, c.png, d.png"), "{err}");
    let diff = read_picture(&out.join("b-diff.png")).unwrap();
    assert_eq!(diff.pixel(0, 0), [255, 0, 0]);
    assert_ne!(diff.pixel(19, 9), [255, 0, 0]);
    let mut written: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    written.sort();
    assert_eq!(written, ["b-diff.png"], "only the failing pair's diff image that could be drawn");

    let o = raycast(&["compare", a, e, "--out-dir", o_dir, "--json"], &[]);
    let (stdout, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{stdout}{err}");
    let objects: Vec<Value> =
        stdout.lines().map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}"))).collect();
    assert_eq!(objects.len(), 5, "{stdout}");
    let names: Vec<&str> = objects[..4].iter().map(|o| o["name"].as_str().unwrap()).collect();
    assert_eq!(names, ["a.png", "b.png", "c.png", "d.png"]);
    let passes: Vec<bool> = objects[..4].iter().map(|o| o["passes"].as_bool().unwrap()).collect();
    assert_eq!(passes, [true, false, false, false]);
    assert_eq!(objects[0]["differing"], 0);
    assert_eq!(objects[0]["percent"], 0);
    assert_eq!(objects[0]["max_percent"], 0.1);
    assert_eq!(objects[0]["diff_image"], Value::Null);
    assert_eq!(objects[1]["differing"], 50);
    assert_eq!(objects[1]["percent"], 25);
    assert_eq!(objects[1]["first"]["at"], serde_json::json!([0, 0]));
    assert_eq!(objects[1]["diff_image"], out.join("b-diff.png").to_str().unwrap());
    assert_eq!(objects[2]["error"], "missing");
    assert!(objects[3]["error"].as_str().unwrap().starts_with("sizes differ"));
    assert_eq!(
        objects[4],
        serde_json::json!({"pairs": 4, "passed": 1, "failed": 3, "unreadable": 0, "extra": ["extra.png"], "passes": false})
    );

    // Every pair passing: exit 0.
    std::fs::remove_file(expected.join("c.png")).unwrap();
    std::fs::remove_file(expected.join("d.png")).unwrap();
    save(&actual.join("b.png"), &picture);
    let o = raycast(&["compare", a, e], &[]);
    assert_eq!(o.status.code(), Some(0), "{:?}", text(&o));
    assert_eq!(last_line(&text(&o).0), "compare: 2 of 2 pairs pass, 0 fail");
    // A folder against a picture is a usage error.
    let o = raycast(&["compare", a, expected.join("a.png").to_str().unwrap()], &[]);
    assert_eq!(o.status.code(), Some(2), "{:?}", text(&o));
    assert!(text(&o).1.contains("compare takes two pictures or two folders"), "{:?}", text(&o));
}

/// The one-pair --json object parses and keeps the numbers of the text.
#[test]
fn json_of_one_pair_parses() {
    let d = dir("json");
    let expected = gradient(16, 8);
    let e = save(&d.join("expected.png"), &expected);
    let a = save(&d.join("actual.png"), &with_differing(&expected, 4));
    let o = raycast(&["compare", &a, &e, "--json", "--max-percent", "50"], &[]);
    assert_eq!(o.status.code(), Some(0), "{:?}", text(&o));
    let j: Value = serde_json::from_str(&text(&o).0).unwrap();
    assert_eq!(j["actual"], a.as_str());
    assert_eq!(j["pixels"], 128);
    assert_eq!(j["differing"], 4);
    assert_eq!(j["percent"], 3.125);
    assert_eq!(j["max_percent"], 50);
    assert_eq!(j["worst"]["by"], 30);
    assert_eq!(j["passes"], true);
    assert!(j.get("name").is_none(), "{j}");
}

/// `--min-psnr DB`: the rule for sampled pictures. 12 pixels of 512x384 off
/// by the amount with_differing gives are a PSNR the test computes here
/// from the pictures; a bound just below it passes, one just above fails
/// (exit 4, naming the PSNR), the verdict line and the JSON carry it, and
/// identical pictures pass any bound.
#[test]
fn min_psnr_is_a_rule_of_its_own() {
    let d = dir("psnr");
    let expected = gradient(512, 384);
    let actual = with_differing(&expected, 12);
    let squares: f64 =
        actual.data.iter().zip(&expected.data).map(|(&a, &e)| (f64::from(a) - f64::from(e)).powi(2)).sum();
    let db = 10.0 * (255.0f64.powi(2) / (squares / actual.data.len() as f64)).log10();
    let (a, e) = (save(&d.join("actual.png"), &actual), save(&d.join("expected.png"), &expected));
    let below = format!("{:.2}", db - 0.01);
    let o = raycast(&["compare", &a, &e, "--min-psnr", &below], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(0), "{out}{err}");
    let verdict = out.lines().last().unwrap_or("");
    assert!(verdict.starts_with("PASS: ") && verdict.contains(&format!("PSNR {db:.2} dB")), "{out}");
    assert!(verdict.ends_with(&format!("(rule: at most 0.1%, PSNR at least {below} dB)")), "{out}");
    let above = format!("{:.2}", db + 0.01);
    let o = raycast(&["compare", &a, &e, "--min-psnr", &above, "--json"], &[]);
    let (out, err) = text(&o);
    assert_eq!(o.status.code(), Some(4), "{out}{err}");
    assert!(err.contains(&format!("PSNR {db:.2} dB, below --min-psnr {above}")), "{err}");
    let v: Value = serde_json::from_str(out.trim()).unwrap();
    assert!((v["psnr_db"].as_f64().unwrap() - db).abs() < 0.006, "{v}");
    assert_eq!(v["passes"], false, "{v}");
    let o = raycast(&["compare", &e, &e, "--min-psnr", "200"], &[]);
    assert_eq!(o.status.code(), Some(0), "{:?}", text(&o));
    assert!(text(&o).0.contains(", identical (rule"), "{:?}", text(&o));
    assert_eq!(raycast(&["compare", &a, &e, "--min-psnr", "NaN"], &[]).status.code(), Some(2));
}
