//! `raycast conformance`: the course corpus rendered and judged under its rule.

use crate::cli::options::*;
use crate::error::Error;
use crate::render::Backend;
use crate::render::Progress;
use clap::Args;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ConformanceArgs {
    /// The cs1230 corpus [default: $RAYCAST_CORPUS]
    ///
    /// The cs1230 corpus: its scene folders (test_unit, test_intersect, …)
    /// and bench/ of official renders [default: $RAYCAST_CORPUS]
    #[arg(value_name = "CORPUS")]
    corpus: Option<PathBuf>,
    /// Folder for failures and table.md [default: conformance]
    ///
    /// Folder for each failing case's actual / expected / diff pictures and
    /// for table.md, the measured fractions (made if missing).
    #[arg(long, value_name = "DIR", default_value = "conformance", help_heading = "Output", hide_default_value = true)]
    out_dir: PathBuf,
    /// gpu (default), cpu (the C++ build) or auto
    #[arg(long, value_enum, default_value_t = Backend::Gpu, help_heading = "Device", hide_possible_values = true,
          hide_default_value = true, long_help = crate::cli::values::with_values::<Backend>(
              "Where to run the shared code: a Vulkan device, or its C++ build on every core [default: gpu]"))]
    backend: Backend,
    /// The device and its kernel (`--shaders DIR`: does a shader change still match the course's renders?).
    #[command(flatten)]
    kernel: KernelOptions,
    /// Only the cases whose name holds TEXT (repeatable)
    ///
    /// Only the cases whose name holds TEXT (`test_light/`, `Normal`,
    /// `recursiveSpheres4 Color`); repeatable, a case runs if any matches.
    #[arg(long, value_name = "TEXT")]
    only: Vec<String>,
}

pub fn run(args: &ConformanceArgs) -> Result<(), Error> {
    cpu_takes_no_device_options(args.backend == Backend::Cpu, &args.kernel)?;
    let from_env = std::env::var_os("RAYCAST_CORPUS").filter(|v| !v.is_empty()).map(PathBuf::from);
    let Some(corpus) = args.corpus.clone().or(from_env) else {
        return Err(Error::Usage(
            "conformance needs the cs1230 corpus: give its folder (say ../shared/corpus/cs1230), or set RAYCAST_CORPUS"
                .into(),
        ));
    };
    // Not a corpus, or one that cannot be read, fails before the device starts.
    let all = crate::conformance::cases(&corpus)?;
    let total = all.len();
    let cases: Vec<_> = all
        .into_iter()
        .filter(|c| args.only.is_empty() || args.only.iter().any(|t| c.label().contains(t.as_str())))
        .collect();
    if cases.is_empty() {
        return Err(Error::Usage(format!(
            "no case of the {total} in {} matches --only {}",
            corpus.display(),
            args.only.join(", --only ")
        )));
    }
    let count = cases.len();
    std::fs::create_dir_all(&args.out_dir)
        .map_err(|e| format!("cannot make the folder {} (--out-dir): {e}", args.out_dir.display()))?;
    let renderer = open_backend(args.backend, &args.kernel)?;
    let info = renderer.info();
    // The CPU build is the code raycast was built with; a device runs the built-in kernel or --shaders'.
    let who = if info.cpu_build {
        format!("the {}", info.summary)
    } else {
        format!("{} on {}", args.kernel.kernel_text(), info.name)
    };
    outln!("conformance: {who} against {}, {count} cases", corpus.display());
    let done = std::cell::Cell::new(0);
    let summary = crate::progress::told("conformance", |told| {
        crate::conformance::run(
            &corpus,
            &cases,
            &args.out_dir,
            |data| {
                told(Progress {
                    fraction: f64::from(done.get()) / count as f64,
                    detail: format!("case {} of {count}", done.get() + 1),
                });
                done.set(done.get() + 1);
                renderer.render_frame(data, &|_| {}).map(|(picture, _)| picture)
            },
            || renderer.take_messages(),
        )
    })?;
    outln!("{} passed, {} failed; the measured fractions: {}", summary.passed, summary.failed, summary.table.display());
    if summary.failed > 0 {
        return Err(Error::Mismatch {
            command: "conformance",
            message: format!(
                "{} of {count} cases (each FAILED line above says why; the actual, expected \
                 and diff pictures of those beyond the rule are in {})",
                summary.failed,
                args.out_dir.display()
            ),
        });
    }
    Ok(())
}
