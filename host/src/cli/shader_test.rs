//! `raycast shader-test [FILE…] [--only TEXT]… [--shaders DIR] [--device …] [--validate]`:
//! runs the cases of shader-test files (default: every tests/shaders/*.toml
//! of the source tree) and ends with the line `N passed, M failed`.
//!
//! Exit status: 0 every case passed, 1 an error (a file, the device), 2
//! `--only` matching no case, 3 a validation-layer message, 4 a case failed.

use std::path::{Path, PathBuf};

use clap::Args;

use crate::error::{check_validation, Error};
use crate::gpu::DeviceSelector;
use crate::harness::{file, source_root, summary, Harness, HarnessOptions};

#[derive(Args, Debug)]
pub struct ShaderTestArgs {
    /// Test files (TOML) [default: tests/shaders/*.toml]
    ///
    /// Test files (TOML) [default: every tests/shaders/*.toml of the source tree]
    files: Vec<PathBuf>,
    /// Test DIR's shaders instead of the source tree's
    ///
    /// Test the layout.h, scene_buffers.glsl and raycast.glsl of DIR instead of
    /// the source tree's shaders/ (on the device and in the C++ build).
    #[arg(long, value_name = "DIR", help_heading = "Device")]
    shaders: Option<PathBuf>,
    /// From `raycast devices`: an index or part of a name
    ///
    /// Vulkan device: an index from `raycast devices` or part of its name.
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Device")]
    device: Option<DeviceSelector>,
    /// Enable the Khronos validation layer (exit 3 on any message)
    ///
    /// Enable the Khronos validation layer; any message fails the command (exit 3).
    /// Also on when RAYCAST_VALIDATION=1.
    #[arg(long, help_heading = "Diagnostics")]
    validate: bool,
    /// Only cases whose function or name holds TEXT (repeatable)
    ///
    /// Only the cases whose function or name holds TEXT (`--only cone`,
    /// `--only div_rn`); repeatable, a case runs if any matches.
    #[arg(long, value_name = "TEXT")]
    only: Vec<String>,
    /// Longest a function's cases may run
    ///
    /// The longest a function's run of cases may take, on the device or in
    /// the C++ build (each in a process of its own), before its cases fail
    /// with the timeout's error (a tested function's endless loop).
    #[arg(long, value_name = "SECONDS", default_value = "60", value_parser = crate::cli::values::parse_timeout,
          help_heading = "Device")]
    timeout: std::time::Duration,
}

/// Runs the command; Err is (message for stderr, exit status).
pub fn run(args: &ShaderTestArgs) -> Result<(), Error> {
    let root = source_root();
    let files = if args.files.is_empty() { default_files(&root)? } else { args.files.clone() };

    let validation = args.validate || std::env::var("RAYCAST_VALIDATION").is_ok_and(|v| v == "1");
    let device = args.device.clone();
    let mut harness =
        Harness::new(&HarnessOptions { shaders: args.shaders.clone(), device, validation, timeout: args.timeout })?;

    let mut per_file = Vec::new();
    for path in &files {
        let shown = shown_path(path, &root);
        // File errors already read `file:line: error: …`.
        let cases = file::load(path, &shown, harness.shaders())?;
        let wanted = |c: &crate::harness::Case| {
            args.only.iter().any(|t| c.function.contains(t.as_str()) || c.display_name().contains(t.as_str()))
        };
        let cases: Vec<_> = cases.into_iter().filter(|c| args.only.is_empty() || wanted(c)).collect();
        if !cases.is_empty() {
            per_file.push((shown, cases));
        }
    }
    let total: usize = per_file.iter().map(|(_, c)| c.len()).sum();
    if total == 0 {
        return Err(Error::Usage(format!(
            "no case of {} file(s) matches --only {}",
            files.len(),
            args.only.join(", --only ")
        )));
    }
    let d = harness.device();
    // On a GPU the kernels correct division (raycast.glsl div_rn): say how.
    let kernels = harness.division().kernels_clause();
    outln!(
        "shader-test: {total} cases from {} file{}; device {} ({}){}; shaders {}",
        per_file.len(),
        if per_file.len() == 1 { "" } else { "s" },
        d.name,
        d.kind,
        kernels,
        harness.shaders().dir.display()
    );

    let all: Vec<_> = per_file.iter().flat_map(|(_, c)| c.iter().cloned()).collect();
    let results = harness.run(&all);
    let mut at = 0;
    for (shown, cases) in &per_file {
        let mine = &results[at..at + cases.len()];
        at += cases.len();
        let failed = mine.iter().filter(|r| !r.passed).count();
        if failed == 0 {
            outln!("ok   {shown}: {} cases", cases.len());
        } else {
            outln!("FAIL {shown}: {failed} of {} cases failed", cases.len());
        }
    }
    for r in results.iter().filter(|r| !r.passed) {
        out!("\n{}", r.report);
    }
    let failed = results.iter().filter(|r| !r.passed).count();
    if failed > 0 {
        outln!();
    }
    outln!("{}", summary(&results));

    let messages = harness.take_validation_messages();
    drop(harness);
    check_validation(messages)?;
    if failed > 0 {
        return Err(Error::Mismatch {
            command: "shader-test",
            message: format!("{failed} of {} cases", results.len()),
        });
    }
    Ok(())
}

/// Every tests/shaders/*.toml of the source tree, sorted.
fn default_files(root: &Path) -> Result<Vec<PathBuf>, Error> {
    let dir = root.join("tests/shaders");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&dir)
        .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().and_then(|e| e.to_str()) == Some("toml"))
        .collect();
    files.sort();
    if files.is_empty() {
        return Err(Error::Failed(format!("no test files in {}", dir.display())));
    }
    Ok(files)
}

/// A path relative to the source tree when it is inside it, else as given.
fn shown_path(path: &Path, root: &Path) -> String {
    path.canonicalize()
        .ok()
        .and_then(|p| p.strip_prefix(root).ok().map(|r| r.display().to_string()))
        .unwrap_or_else(|| path.display().to_string())
}
