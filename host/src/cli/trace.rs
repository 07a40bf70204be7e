//! `raycast trace`: one sample of one pixel, step by step, from the CPU build.

use crate::cli::batch::*;
use crate::cli::options::*;
use crate::cli::status::*;
use crate::cli::values::*;
use crate::cpu::CpuRenderer;
use crate::error::Error;
use crate::frame::Aov;
use crate::layout;
use crate::source::*;
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct TraceArgs {
    /// An XML file or gen:FAMILY:LEVELS [default: built in]
    ///
    /// A scene file (XML) or a generated scene (gen:FAMILY:DEPTH). Without one, the embedded default scene.
    #[arg(value_name = "SCENE")]
    scene: Option<PathBuf>,
    /// The pixel: X columns from the left, Y rows from the top
    #[arg(long, value_name = "X,Y", value_parser = parse_pixel, allow_hyphen_values = true, help_heading = "Picture")]
    pixel: (u32, u32),
    /// Which of the pixel's --spp samples
    ///
    /// Which of the pixel's `--spp` samples (0 is the pixel centre when there is one).
    #[arg(long, default_value_t = 0, value_name = "S", help_heading = "Picture")]
    sample: u32,
    /// One JSON object instead of text
    ///
    /// One JSON object instead of text: the pixel, the sample, every step with its numbers as computed (floats in
    /// shortest round-trip digits) and, at one sample a pixel, the render's pixel and whether the trace agrees with it.
    #[arg(long, help_heading = "Output")]
    json: bool,
    /// The picture's settings, as `render` takes them (the colour only; the CPU build traces).
    #[command(flatten)]
    render: RenderOptions,
}

/// What `trace --json` says: the pixel, the sample, its steps and, at one
/// sample a pixel, the render's pixel.
#[derive(Serialize)]
struct Traced {
    scene: String,
    pixel: [u32; 2],
    sample: u32,
    spp: u32,
    rays: usize,
    steps: Vec<crate::trace::Step>,
    /// Under --supersample course: every sample the scheme took at the pixel.
    #[serde(skip_serializing_if = "Option::is_none")]
    course_samples: Option<Vec<crate::cpu::CourseSample>>,
    render: Option<RenderedPixel>,
}

/// The render's pixel, and whether the trace agrees with it (its 8-bit
/// colour, its rays and its first hit).
#[derive(Serialize)]
struct RenderedPixel {
    rgba8: [u8; 4],
    rays: u32,
    agrees: bool,
}

/// `raycast trace`: the steps of one sample of one pixel (crate::trace),
/// from the CPU build; at one sample a pixel, checked against the render of
/// that pixel (its 8-bit colour, its rays, and its first hit).
pub fn run(args: &TraceArgs) -> Result<(), Error> {
    let o = &args.render;
    let k = &o.kernel;
    let given = k.device_only_given();
    if !given.is_empty() {
        return Err(Error::Usage(format!(
            "trace runs the CPU build of the shared code: {} {} for the commands that render on a \
                 device (`raycast check --pixel X,Y` runs one pixel on both)",
            crate::units::listed(&given, "and"),
            if given.len() == 1 { "is" } else { "are" }
        )));
    }
    if o.aov != Aov::Color {
        return Err(Error::Usage("trace follows the colour's rays; --aov is for render and check".to_string()));
    }
    // Usage errors before any work (the picture's size and samples are the options').
    o.settings().validate().map_err(Error::usage)?;
    let (x, y) = args.pixel;
    if x >= o.width || y >= o.height {
        return Err(Error::usage(format!("--pixel {x},{y} is outside the {}x{} picture", o.width, o.height)));
    }
    let course = o.supersample == crate::frame::Supersample::Course;
    if !course && args.sample >= o.spp.max(1) {
        return Err(Error::usage(format!(
            "--sample {} is not one of the pixel's {} (0 to {})",
            args.sample,
            o.spp.max(1),
            o.spp.max(1) - 1
        )));
    }
    let p = prepare(args.scene.as_deref(), o)?;
    if !args.json {
        outln!("{}", scene_line(&p));
    }
    let cpu = CpuRenderer::new()?;
    // The course's scheme: the samples it took decide how many there are.
    let course_samples = if course { Some(cpu.course_samples(&p.data, &p.data.frame, x, y)?) } else { None };
    let spp = course_samples.as_ref().map_or(p.data.frame.spp.max(1), |c| c.len() as u32);
    if args.sample >= spp {
        return Err(Error::usage(format!(
            "--sample {} is not one of the {spp} samples the course's scheme took at this pixel (0 to {})",
            args.sample,
            spp - 1
        )));
    }
    let steps = cpu.trace(&p.data, &p.data.frame, x, y, args.sample)?;
    // At one sample a pixel, the render's pixel: the same 8-bit colour, rays and first hit.
    let render = (spp == 1).then(|| cpu.render_rows_told(&p.data, &[y], &|_| {})[0][x as usize]);
    let rays = steps.iter().filter(|s| s.is_ray()).count();
    let first = steps.iter().find(|s| s.kind == layout::TRACE_CAMERA);
    let colour = steps.iter().find(|s| s.kind == layout::TRACE_PIXEL).map(|s| s.id);
    let agrees = |pixel: &layout::PixelOut| {
        colour == Some(pixel.rgba)
            && rays == pixel.rays as usize
            && first.is_some_and(|c| {
                c.id == pixel.id && (c.id == layout::NO_HIT || c.value[3].to_bits() == pixel.t.to_bits())
            })
    };
    if args.json {
        let traced = Traced {
            scene: args.scene.as_deref().map_or(DEFAULT_SCENE_NAME.to_string(), |s| s.display().to_string()),
            pixel: [x, y],
            sample: args.sample,
            spp,
            rays,
            steps: crate::trace::json(&p.scene, &steps),
            course_samples: course_samples.clone(),
            render: render.map(|pixel| RenderedPixel {
                rgba8: pixel.rgba.to_le_bytes(),
                rays: pixel.rays,
                agrees: agrees(&pixel),
            }),
        };
        crate::output::emit_line(&crate::units::to_json(&traced))?;
    } else {
        outln!("pixel ({x}, {y}), sample {} of {spp}:", args.sample);
        for line in crate::trace::describe(&p.scene, &steps) {
            outln!("{line}");
        }
        if let Some(samples) = &course_samples {
            outln!("the course's adaptive supersampling took {spp} samples at this pixel (offsets from its centre):");
            for (k, c) in samples.iter().enumerate() {
                let [r, g, b] = c.color;
                let [dx, dy] = c.offset;
                outln!("  {k:2}: ({dx:+.4}, {dy:+.4}) level {}  colour ({r:.4}, {g:.4}, {b:.4})", c.level);
            }
            outln!("(the pixel is the mean of its squares' means: `--sample S` traces another)");
        } else if spp > 1 {
            outln!("(the pixel is the mean of its {spp} samples: `--sample S` traces another)");
        }
    }
    let Some(pixel) = render else { return Ok(()) };
    if !agrees(&pixel) {
        return Err(Error::Failed(format!(
            "the trace and the render of pixel ({x}, {y}) disagree: render RGBA {:#010x}, {} rays, id {}; \
                 trace {:?}, {rays} rays, first hit {:?}",
            pixel.rgba,
            pixel.rays,
            pixel.id,
            colour,
            first.map(|c| c.id)
        )));
    }
    if !args.json {
        outln!("the render's pixel: the same 8-bit colour, {rays} rays and first hit");
    }
    Ok(())
}
