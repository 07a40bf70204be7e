//! `raycast compare`: two pictures, or two folders of them, judged under a
//! stated rule, with a verdict line, a diff picture a person can read, and
//! exit 4 on any mismatch.

use crate::error::Error;
use crate::image_io::{self, DiffJson, Rgb8};
use crate::output::*;
use crate::units::thousands;
use clap::Args;
use serde::Serialize;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The picture to judge, or a folder of them
    ///
    /// The picture to judge (PNG, JPEG, BMP or PNM, told by its content), or a folder of them: then EXPECTED is a
    /// folder too, and each of its pictures is compared with the one of the same name here.
    actual: PathBuf,
    /// The picture it should match, or a folder of them
    ///
    /// The picture it should match (PNG, JPEG, BMP or PNM), or the folder of them (every picture file in it is a
    /// pair; one missing from ACTUAL fails).
    expected: PathBuf,
    /// Channel difference allowed (0-255)
    ///
    /// A pixel differs when a colour channel (red, green or blue, at 8 bits;
    /// alpha is not compared) is off by more than this (0 to 255).
    #[arg(long, default_value_t = 2, value_name = "N", help_heading = "Rule")]
    tolerance: u8,
    /// Percent of pixels that may differ
    ///
    /// Fail (exit 4) when more than this percentage of pixels differ.
    #[arg(long, default_value_t = 0.1, value_name = "PERCENT", help_heading = "Rule")]
    max_percent: f64,
    /// Also require this PSNR in dB
    ///
    /// Also fail (exit 4) when the peak signal-to-noise ratio over every channel, 10 log10(255^2 / mean squared
    /// difference), is below this many dB: the rule for sampled pictures, which match a reference on average rather
    /// than pixel for pixel. Identical pictures have no noise and pass any.
    #[arg(long, value_name = "DB", help_heading = "Rule")]
    min_psnr: Option<f64>,
    /// Diff image, or folder of them
    ///
    /// Where to write the diff image: pure red where pixels differ, over the expected picture faded towards white.
    /// With two folders, a folder (made if need be) where each failing pair's is written as NAME-diff.png.
    #[arg(short, long, visible_alias = "out-dir", value_name = "DIFF.png|DIR", help_heading = "Output")]
    output: Option<PathBuf>,
    /// JSON instead of text (for graders)
    ///
    /// JSON instead of text (for graders): one object with the two files, the counts, the first and worst pixel,
    /// the rule (--tolerance, --max-percent) and whether the pictures pass it; with two folders one object per
    /// pair (with its "name") and a last one that sums them up. The exit status is the same.
    #[arg(long, help_heading = "Output")]
    json: bool,
}

/// What became of one pair of pictures.
enum Outcome {
    /// Compared: the counts, and whether they pass the rule.
    Compared { diff: image_io::ImageDiff, passes: bool },
    /// Pictures of two sizes: (width, height) of the actual and the expected one.
    SizesDiffer { actual: (u32, u32), expected: (u32, u32) },
    /// Folder mode: no picture of that name in ACTUAL_DIR.
    Missing,
    /// A file that could not be read (the reason, naming it).
    Unreadable(String),
}

impl Outcome {
    fn passes(&self) -> bool {
        matches!(self, Outcome::Compared { passes: true, .. })
    }

    /// The verdict after `PASS`/`FAIL`: the counts and the rule, or why
    /// the pictures could not be compared.
    fn verdict(&self, args: &CompareArgs) -> String {
        match self {
            Outcome::Compared { diff, .. } => {
                // The PSNR where the rule has it (--min-psnr).
                let (psnr, min_psnr) = match args.min_psnr {
                    Some(min) => (
                        diff.psnr().map_or(", identical".to_string(), |db| format!(", PSNR {db:.2} dB")),
                        format!(", PSNR at least {min} dB"),
                    ),
                    None => (String::new(), String::new()),
                };
                format!(
                    "{} of {} pixels ({:.4}%) differ by more than {}/255{psnr} (rule: at most {}%{min_psnr})",
                    thousands(diff.differing as u64),
                    thousands(diff.total as u64),
                    100.0 * diff.fraction(),
                    diff.tolerance,
                    args.max_percent
                )
            }
            Outcome::SizesDiffer { actual: (aw, ah), expected: (ew, eh) } => {
                format!("sizes differ: {aw}x{ah} against {ew}x{eh}")
            }
            Outcome::Missing => format!("missing from {}", args.actual.display()),
            Outcome::Unreadable(e) => e.clone(),
        }
    }

    /// What `--json` says of it, beside the files' names.
    fn json(&self, args: &CompareArgs, diff_image: Option<&Path>) -> OutcomeJson {
        match self {
            Outcome::Compared { diff, passes } => OutcomeJson::Compared {
                diff: diff.json(),
                max_percent: args.max_percent,
                min_psnr: args.min_psnr,
                passes: *passes,
                diff_image: diff_image.map(|p| p.display().to_string()),
            },
            Outcome::SizesDiffer { actual, expected } => OutcomeJson::SizesDiffer {
                actual_size: [actual.0, actual.1],
                expected_size: [expected.0, expected.1],
                error: size_error(*actual, *expected),
                passes: false,
            },
            Outcome::Missing => OutcomeJson::Error { error: "missing".into(), passes: false },
            Outcome::Unreadable(e) => OutcomeJson::Error { error: e.clone(), passes: false },
        }
    }
}

/// The reason a size mismatch fails (stderr, and "error" in JSON).
fn size_error(actual: (u32, u32), expected: (u32, u32)) -> String {
    format!("sizes differ: actual {}x{}, expected {}x{}", actual.0, actual.1, expected.0, expected.1)
}

/// One pair as `--json` writes it.
#[derive(Serialize)]
struct PairJson<'a> {
    /// The pair's file name (folder mode only).
    #[serde(skip_serializing_if = "Option::is_none")]
    name: Option<&'a str>,
    actual: String,
    expected: String,
    #[serde(flatten)]
    outcome: OutcomeJson,
}

#[derive(Serialize)]
#[serde(untagged)]
enum OutcomeJson {
    Compared {
        #[serde(flatten)]
        diff: DiffJson,
        #[serde(serialize_with = "image_io::json_number")]
        max_percent: f64,
        #[serde(skip_serializing_if = "Option::is_none")]
        min_psnr: Option<f64>,
        passes: bool,
        diff_image: Option<String>,
    },
    SizesDiffer {
        actual_size: [u32; 2],
        expected_size: [u32; 2],
        error: String,
        passes: bool,
    },
    Error {
        error: String,
        passes: bool,
    },
}

/// Folder mode's last JSON object.
#[derive(Serialize)]
struct SummaryJson {
    pairs: usize,
    passed: usize,
    failed: usize,
    /// Pairs with a file that could not be read (among the failed).
    unreadable: usize,
    /// Pictures in ACTUAL_DIR with no namesake in EXPECTED_DIR.
    extra: Vec<String>,
    passes: bool,
}

fn emit_json(value: &impl Serialize) -> Result<(), Error> {
    let line = serde_json::to_string(value).map_err(|e| Error::Failed(format!("cannot write JSON: {e}")))?;
    emit_line(&line)
}

pub fn run(args: &CompareArgs) -> Result<(), Error> {
    if !(0.0..=100.0).contains(&args.max_percent) {
        return Err(Error::Usage(format!("--max-percent {} is out of range: 0 to 100", args.max_percent)));
    }
    if let Some(db) = args.min_psnr.filter(|db| !db.is_finite()) {
        return Err(Error::Usage(format!("--min-psnr {db} is not a number of dB")));
    }
    match (args.actual.is_dir(), args.expected.is_dir()) {
        (true, true) => run_folders(args),
        (false, false) => run_pair(args),
        (actual_is_dir, _) => {
            let (folder, other) =
                if actual_is_dir { (&args.actual, &args.expected) } else { (&args.expected, &args.actual) };
            Err(Error::Usage(format!(
                "compare takes two pictures or two folders: {} is a folder and {} is not",
                folder.display(),
                other.display()
            )))
        }
    }
}

/// A picture read as RGB, a warning on stderr where some of it is not opaque.
fn read(path: &Path) -> Result<Rgb8, Error> {
    let (rgb, translucent) = image_io::read_picture_counting_alpha(path)?;
    if translucent > 0 {
        eprintln!(
            "raycast: warning: {}: {} of {} pixels are not opaque; compare reads the colour channels only (alpha is \
             not compared)",
            path.display(),
            thousands(translucent as u64),
            thousands(u64::from(rgb.width) * u64::from(rgb.height))
        );
    }
    Ok(rgb)
}

/// Reads and compares one pair; with `diff_picture`, the highlighted diff
/// picture of pictures that were compared (`image_io::highlight_diff`).
fn judge(actual: &Path, expected: &Path, args: &CompareArgs, diff_picture: bool) -> (Outcome, Option<Rgb8>) {
    let pictures = read(actual).and_then(|a| Ok((a, read(expected)?)));
    let (a, e) = match pictures {
        Ok(pictures) => pictures,
        Err(e) => return (Outcome::Unreadable(e.to_string()), None),
    };
    if (a.width, a.height) != (e.width, e.height) {
        return (Outcome::SizesDiffer { actual: (a.width, a.height), expected: (e.width, e.height) }, None);
    }
    let diff = match image_io::compare(&a, &e, args.tolerance) {
        Ok(diff) => diff,
        Err(e) => return (Outcome::Unreadable(e.to_string()), None),
    };
    let psnr_ok = match (args.min_psnr, diff.psnr()) {
        (Some(min), Some(db)) => db >= min,
        _ => true,
    };
    let passes = diff.fraction() * 100.0 <= args.max_percent && psnr_ok;
    let picture = diff_picture.then(|| image_io::highlight_diff(&a, &e, args.tolerance));
    (Outcome::Compared { diff, passes }, picture)
}

/// Two pictures: the report, the diff image (-o), the verdict line.
fn run_pair(args: &CompareArgs) -> Result<(), Error> {
    status_beside(&args.output);
    if let Some(path) = &args.output {
        image_io::check_output(path)?;
        refuse_overwriting(path, [args.actual.as_path(), args.expected.as_path()])?;
    }
    let (outcome, picture) = judge(&args.actual, &args.expected, args, args.output.is_some());
    let written = match (&args.output, &picture) {
        (Some(path), Some(picture)) => {
            image_io::write_png(path, picture)?;
            Some(path.as_path())
        }
        _ => None,
    };
    if args.json {
        let pair = PairJson {
            name: None,
            actual: args.actual.display().to_string(),
            expected: args.expected.display().to_string(),
            outcome: outcome.json(args, written),
        };
        emit_json(&pair)?;
    } else {
        if let Outcome::Compared { diff, .. } = &outcome {
            outln!("{diff}");
        }
        if let Some(path) = written {
            outln!("wrote {} (red: pixels that differ, over the expected picture faded)", path.display());
        }
        // A file that cannot be read is an error (exit 1), not a verdict.
        if !matches!(outcome, Outcome::Unreadable(_)) {
            outln!("{}: {}", if outcome.passes() { "PASS" } else { "FAIL" }, outcome.verdict(args));
        }
    }
    match outcome {
        Outcome::Compared { passes: true, .. } => Ok(()),
        Outcome::Compared { diff, .. } if diff.fraction() * 100.0 > args.max_percent => Err(Error::Mismatch {
            command: "compare",
            message: format!(
                "{:.4}% of pixels differ, more than --max-percent {}",
                diff.fraction() * 100.0,
                args.max_percent
            ),
        }),
        Outcome::Compared { diff, .. } => Err(Error::Mismatch {
            command: "compare",
            message: format!(
                "PSNR {:.2} dB, below --min-psnr {}",
                diff.psnr().unwrap_or(f64::INFINITY),
                args.min_psnr.unwrap_or_default()
            ),
        }),
        Outcome::SizesDiffer { actual, expected } => {
            Err(Error::Mismatch { command: "compare", message: size_error(actual, expected) })
        }
        Outcome::Unreadable(e) => Err(Error::Failed(e)),
        Outcome::Missing => unreachable!("a pair of files is never missing"),
    }
}

/// The extensions of the picture files folder mode pairs (`image_io::PICTURE_FORMATS`).
const PICTURE_EXTENSIONS: [&str; 8] = ["png", "jpg", "jpeg", "bmp", "ppm", "pgm", "pbm", "pnm"];

/// The names of the picture files in `dir` (by extension; hidden files and
/// sub-folders left out), sorted.
fn pictures_in(dir: &Path) -> Result<Vec<String>, Error> {
    let cannot = |e: std::io::Error| Error::Failed(format!("cannot read the folder {}: {e}", dir.display()));
    let mut names = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(cannot)? {
        let path = entry.map_err(cannot)?.path();
        let Some(name) = path.file_name().and_then(|n| n.to_str()) else { continue };
        let picture = path
            .extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| PICTURE_EXTENSIONS.iter().any(|p| e.eq_ignore_ascii_case(p)));
        if picture && !name.starts_with('.') && path.is_file() {
            names.push(name.to_string());
        }
    }
    names.sort();
    Ok(names)
}

/// Two folders: every picture of EXPECTED_DIR against its namesake in
/// ACTUAL_DIR, a line (or JSON object) each, then the sum.
fn run_folders(args: &CompareArgs) -> Result<(), Error> {
    let out_dir = args.output.as_deref();
    if let Some(dir) = out_dir {
        if dir.exists() && !dir.is_dir() {
            return Err(Error::Usage(format!(
                "-o {}: with two folders, -o names a folder for the diff images, and this is a file",
                dir.display()
            )));
        }
        let same = |a: &Path, b: &Path| {
            use std::os::unix::fs::MetadataExt;
            match (std::fs::metadata(a), std::fs::metadata(b)) {
                (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
                _ => false,
            }
        };
        if let Some(input) = [&args.actual, &args.expected].into_iter().find(|input| same(dir, input)) {
            return Err(Error::Usage(format!(
                "-o {}: the diff images would be written among the pictures compared ({}): name another folder",
                dir.display(),
                input.display()
            )));
        }
        std::fs::create_dir_all(dir).map_err(|e| Error::Failed(format!("cannot create {}: {e}", dir.display())))?;
    }
    let expected_names = pictures_in(&args.expected)?;
    if expected_names.is_empty() {
        return Err(Error::Failed(format!(
            "{} holds no picture to compare with (.png, .jpg, .jpeg, .bmp, .ppm, .pgm, .pbm, .pnm)",
            args.expected.display()
        )));
    }
    let extra: Vec<String> =
        pictures_in(&args.actual)?.into_iter().filter(|n| expected_names.binary_search(n).is_err()).collect();
    let (mut failed, mut unreadable, mut diffs) = (Vec::new(), Vec::new(), 0usize);
    for name in &expected_names {
        let (actual, expected) = (args.actual.join(name), args.expected.join(name));
        let (outcome, picture) =
            if actual.exists() { judge(&actual, &expected, args, out_dir.is_some()) } else { (Outcome::Missing, None) };
        let mut written = None;
        if let Some(dir) = out_dir {
            let stem = Path::new(name).file_stem().map_or(name.clone(), |s| s.to_string_lossy().into_owned());
            let path = dir.join(format!("{stem}-diff.png"));
            match picture.filter(|_| !outcome.passes()) {
                Some(picture) => {
                    image_io::write_png(&path, &picture)?;
                    diffs += 1;
                    written = Some(path);
                }
                // An earlier run's diff image would say this pair still fails.
                None => {
                    image_io::remove_stale(&[path])?;
                }
            }
        }
        if !outcome.passes() {
            failed.push(name.as_str());
        }
        if matches!(outcome, Outcome::Unreadable(_)) {
            unreadable.push(name.as_str());
        }
        if args.json {
            emit_json(&PairJson {
                name: Some(name),
                actual: actual.display().to_string(),
                expected: expected.display().to_string(),
                outcome: outcome.json(args, written.as_deref()),
            })?;
        } else {
            outln!("{} {name}: {}", if outcome.passes() { "PASS" } else { "FAIL" }, outcome.verdict(args));
        }
    }
    let pairs = expected_names.len();
    if args.json {
        emit_json(&SummaryJson {
            pairs,
            passed: pairs - failed.len(),
            failed: failed.len(),
            unreadable: unreadable.len(),
            extra,
            passes: failed.is_empty(),
        })?;
    } else {
        if !extra.is_empty() {
            outln!(
                "note: {} picture(s) in {} with no namesake in {}, not compared: {}",
                extra.len(),
                args.actual.display(),
                args.expected.display(),
                extra.join(", ")
            );
        }
        if let (Some(dir), true) = (out_dir, diffs > 0) {
            outln!("wrote {diffs} diff image(s) to {} (NAME-diff.png; red: pixels that differ)", dir.display());
        }
        outln!("compare: {} of {pairs} pairs pass, {} fail", pairs - failed.len(), failed.len());
    }
    if !unreadable.is_empty() {
        return Err(Error::Failed(format!(
            "{} of {pairs} pairs could not be read: {}",
            unreadable.len(),
            unreadable.join(", ")
        )));
    }
    if !failed.is_empty() {
        return Err(Error::Mismatch {
            command: "compare",
            message: format!("{} of {pairs} pairs fail: {}", failed.len(), failed.join(", ")),
        });
    }
    Ok(())
}
