//! Conformance with the CS1230 course's official renders (the rule and the
//! measured allowances: host/src/conformance.rs, which `raycast
//! conformance` runs too).
//!
//! Reads the corpus from RAYCAST_CORPUS (../shared/corpus/cs1230 in CI) and
//! skips, saying so (`common::skip`: ctest counts it as Skipped), without
//! it. Every case renders on the Vulkan device with the validation layer on
//! (any message fails the case). A failure writes actual / expected / diff
//! PNGs and prints their paths. Ends with `N passed, M failed`.

use raycast::conformance;
use raycast::gpu::GpuOptions;
use raycast::gpu::GpuRenderer;
use std::path::Path;
use std::process::ExitCode;

mod common;

fn main() -> ExitCode {
    let Some(corpus) = common::corpus("the conformance cases") else {
        println!("0 passed, 0 failed, 1 skipped");
        return ExitCode::SUCCESS;
    };
    let out_dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("conformance");
    let renderer = match GpuRenderer::new(&GpuOptions { validation: true, ..GpuOptions::default() }) {
        Ok(r) => r,
        Err(e) => {
            println!("FAILED: cannot start the Vulkan device: {e}");
            println!("0 passed, 1 failed");
            return ExitCode::FAILURE;
        }
    };
    println!("conformance on {} against {}", renderer.context().info().name, corpus.display());
    let summary = conformance::cases(&corpus).and_then(|cases| {
        conformance::run(
            &corpus,
            &cases,
            &out_dir,
            |data| renderer.render(data).map(|(picture, _)| picture),
            || renderer.context().take_validation_messages(),
        )
    });
    match summary {
        Ok(s) => {
            println!("table of measured fractions: {}", s.table.display());
            println!("{} passed, {} failed", s.passed, s.failed);
            if s.failed == 0 {
                ExitCode::SUCCESS
            } else {
                ExitCode::FAILURE
            }
        }
        Err(e) => {
            println!("FAILED: {e}");
            println!("0 passed, 1 failed");
            ExitCode::FAILURE
        }
    }
}
