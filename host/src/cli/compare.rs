//! `raycast compare`: two pictures judged under a stated rule.

use crate::error::Error;
use crate::image_io::{self};
use crate::output::*;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct CompareArgs {
    /// The picture to judge (PNG, JPEG, BMP or PNM, told by its content).
    actual: PathBuf,
    /// The picture it should match (PNG, JPEG, BMP or PNM).
    expected: PathBuf,
    /// A pixel differs when a colour channel (red, green or blue, at 8 bits;
    /// alpha is not compared) is off by more than this (0 to 255).
    #[arg(long, default_value_t = 2, value_name = "N")]
    tolerance: u8,
    /// Fail (exit 4) when more than this percentage of pixels differ.
    #[arg(long, default_value_t = 0.1, value_name = "PERCENT")]
    max_percent: f64,
    /// Where to write the diff image (red where pixels differ).
    #[arg(short, long, value_name = "DIFF.png")]
    output: Option<PathBuf>,
    /// One JSON object instead of text (for graders): the two files, the counts, the first and worst pixel, the
    /// rule (--tolerance, --max-percent) and whether the pictures pass it; the exit status is the same.
    #[arg(long)]
    json: bool,
}

pub fn run(args: &CompareArgs) -> Result<(), Error> {
    status_beside(&args.output);
    if !(0.0..=100.0).contains(&args.max_percent) {
        return Err(Error::Usage(format!("--max-percent {} is out of range: 0 to 100", args.max_percent)));
    }
    if let Some(path) = &args.output {
        check_output(path)?;
        refuse_overwriting(path, [args.actual.as_path(), args.expected.as_path()])?;
    }
    let read = |path: &Path| {
        let (rgb, translucent) = image_io::read_picture_counting_alpha(path)?;
        if translucent > 0 {
            eprintln!(
                "raycast: warning: {}: {} of {} pixels are not opaque; compare reads the colour channels only (alpha is \
                 not compared)",
                path.display(),
                crate::units::thousands(translucent as u64),
                crate::units::thousands(u64::from(rgb.width) * u64::from(rgb.height))
            );
        }
        Ok::<_, String>(rgb)
    };
    let path = |p: &Path| crate::units::json_str(&p.display().to_string());
    let compared = read(&args.actual).and_then(|actual| {
        let expected = read(&args.expected)?;
        image_io::compare(&actual, &expected, args.tolerance)
    });
    let diff = match compared {
        Ok(diff) => diff,
        // With --json a grader still gets its object: the pictures could
        // not be compared (sizes that differ, a file that is no picture).
        Err(e) if args.json => {
            crate::output::emit_line(&format!(
                "{{\"actual\":{},\"expected\":{},\"error\":{},\"passes\":false}}",
                path(&args.actual),
                path(&args.expected),
                crate::units::json_str(&e)
            ))?;
            return Err(e.into());
        }
        Err(e) => return Err(e.into()),
    };
    let passes = diff.fraction() * 100.0 <= args.max_percent;
    if let Some(path) = &args.output {
        image_io::write_png(path, &diff.diff_image)?;
    }
    if args.json {
        crate::output::emit_line(&format!(
            "{{\"actual\":{},\"expected\":{},{},\"max_percent\":{},\"passes\":{passes},\"diff_image\":{}}}",
            path(&args.actual),
            path(&args.expected),
            diff.json_fields(),
            args.max_percent,
            args.output.as_deref().map_or("null".to_string(), path)
        ))?;
    } else {
        outln!("{diff}");
        if let Some(path) = &args.output {
            outln!("wrote {} (red: pixels that differ)", path.display());
        }
    }
    if !passes {
        return Err(Error::Mismatch {
            command: "compare",
            message: format!(
                "{:.4}% of pixels differ, more than --max-percent {}",
                diff.fraction() * 100.0,
                args.max_percent
            ),
        });
    }
    Ok(())
}
