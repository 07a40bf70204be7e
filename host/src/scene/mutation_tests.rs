//! Bad input, generated: scene files mutated many ways from a fixed seed
//! (numbers swapped for extreme or malformed ones, lines deleted,
//! duplicated or moved, bytes changed, names swapped, the file cut short)
//! go through everything a render does before the device: parse, flatten,
//! `frame::build`, and a tiny render on the CPU build.
//!
//! Rule: no panic, and every error names the scene file with a line and a
//! column (`FILE:LINE:COL: error: …`). A failure writes the mutated scene
//! to the temporary folder (raycast-mutated-scenes) and names it, with the
//! seed.

use super::mutate::{mutate, Rng, VALUES};
use super::{flatten, parse_str, FlattenLimits, ParseOptions};
use crate::cpu::CpuRenderer;
use crate::frame::{self, RenderSettings};
use std::path::{Path, PathBuf};

/// Mutated scenes per run: about two seconds on 2 cores.
const CASES: usize = 4000;

/// The seed of the cases (`Rng::seeded`).
const SEED: u64 = 0x9e37_79b9_7f4a_7c15;

/// The repository's scenes, and the corpus's when RAYCAST_CORPUS is set.
fn sources() -> (Vec<PathBuf>, Vec<PathBuf>) {
    let repo = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let xml_in = |dir: &Path| -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
            .map(|d| {
                d.filter_map(|e| e.ok().map(|e| e.path()))
                    .filter(|p| p.extension().is_some_and(|x| x == "xml"))
                    .collect()
            })
            .unwrap_or_default();
        files.sort();
        files
    };
    let mut files = xml_in(&repo.join("scenes"));
    files.extend(xml_in(&repo.join("tests/scenes/stress")));
    let mut assets = Vec::new();
    if let Some(corpus) = crate::test_support::corpus("scenes mutated from the corpus's") {
        for group in ["test_unit", "test_intersect", "test_light", "test_efficiency", "test_feature"] {
            files.extend(xml_in(&corpus.join(group)));
        }
        assets.push(corpus);
    }
    (files, assets)
}

#[test]
fn mutated_scenes_fail_with_located_errors_and_never_panic() {
    let (files, assets) = sources();
    assert!(files.len() >= 7, "the repository's scenes: {files:?}");
    let texts: Vec<String> = files.iter().map(|f| std::fs::read_to_string(f).unwrap()).collect();
    let cpu = CpuRenderer::new().expect("the CPU build");
    let options = ParseOptions { assets, ..ParseOptions::default() };
    let settings = RenderSettings { width: 8, height: 6, ..RenderSettings::default() };
    let mut rng = Rng::seeded(SEED);
    let (mut rendered, mut refused) = (0, 0);
    let mut failures: Vec<String> = Vec::new();
    for case in 0..CASES {
        let k = rng.below(files.len());
        let text = mutate(&texts[k], &mut rng, VALUES);
        let name = files[k].display().to_string();
        let outcome = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let file = parse_str(&text, &files[k], &options).map_err(crate::error::Error::scene)?;
            let scene = flatten(&file, &FlattenLimits::default()).map_err(crate::error::Error::scene)?;
            let data = frame::build(&scene, &settings)?;
            cpu.render(&data).map(|_| ())
        }));
        let problem = match outcome {
            Ok(Ok(())) => {
                rendered += 1;
                None
            }
            Ok(Err(e)) => {
                refused += 1;
                let e = e.to_string();
                // FILE:LINE:COL: error: …
                let located = e.strip_prefix(&name).and_then(|rest| {
                    let mut parts = rest.splitn(4, ':');
                    let (empty, line, col) = (parts.next()?, parts.next()?, parts.next()?);
                    let ok = empty.is_empty() && line.parse::<u32>().is_ok() && col.parse::<u32>().is_ok();
                    ok.then_some(())
                });
                located.is_none().then(|| format!("an error without FILE:LINE:COL: {e}"))
            }
            Err(panic) => Some(format!(
                "panicked: {}",
                panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default()
            )),
        };
        if let Some(problem) = problem {
            let dir = std::env::temp_dir().join("raycast-mutated-scenes");
            let _ = std::fs::create_dir_all(&dir);
            let kept = dir.join(format!("mutated-{case}.xml"));
            let _ = std::fs::write(&kept, &text);
            failures.push(format!("case {case} (from {name}, written to {}): {problem}", kept.display()));
        }
    }
    println!(
        "{CASES} mutated scenes (seed {SEED:#x}): {rendered} rendered, {refused} refused with located errors, {} failed",
        failures.len()
    );
    assert!(
        failures.is_empty(),
        "{} of {CASES} mutated scenes (seed {SEED:#x}) failed; first: {}",
        failures.len(),
        failures[0]
    );
    // The mutations reach every stage: some scenes still render, most are refused.
    assert!(rendered > CASES / 20 && refused > CASES / 2, "seed {SEED:#x}: {rendered} rendered, {refused} refused");
}
