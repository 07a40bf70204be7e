//! `raycast explain SCENE MINE.png`: why a picture differs from raycast's
//! render of the scene (the library's `explain`), for people, `--json`, and
//! an annotated picture (`-o`).

use crate::cli::values::*;
use crate::cpu::CpuRenderer;
use crate::error::Error;
use crate::explain::{annotated, Explanation, Finding, Group, Rule};
use crate::frame::{RenderSettings, Supersample, TextureFilter};
use crate::image_io;
use crate::output::emit_line;
use crate::render::Progress;
use crate::scene::{FlattenLimits, ParseOptions};
use crate::units::{thousands, to_json};
use clap::Args;
use serde::Serialize;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ExplainArgs {
    /// The scene the picture shows: an XML file or gen:FAMILY:LEVELS
    #[arg(value_name = "SCENE")]
    scene: PathBuf,
    /// The picture to explain (a PNG): yours, or any renderer's
    #[arg(value_name = "MINE.png")]
    picture: PathBuf,
    /// The picture with each finding's pixels coloured and a legend
    ///
    /// Write the picture faded, each finding's pixels in its own colour, the
    /// pixels no finding explains in yellow, and a legend below.
    #[arg(short, long, value_name = "ANNOTATED.png", value_parser = crate::output::parse_output,
          help_heading = "Output")]
    output: Option<PathBuf>,
    /// One JSON object on stdout
    #[arg(long, help_heading = "Output")]
    json: bool,
    /// Extra folder to find textures in (repeatable)
    #[arg(long, value_name = "DIR", help_heading = "Picture")]
    assets: Vec<PathBuf>,
    /// Reference without shadow rays
    ///
    /// raycast's reference without shadow rays, where the picture was drawn
    /// so on purpose. Without this and the flags below, the reference is
    /// drawn as the course drew its renders of the picture's size (`render
    /// --like`).
    #[arg(long, help_heading = "Reference")]
    no_shadows: bool,
    /// Reference without mirror reflections
    #[arg(long, help_heading = "Reference")]
    no_reflections: bool,
    /// Reference without refraction
    #[arg(long, help_heading = "Reference")]
    no_refraction: bool,
    /// Reference without textures
    #[arg(long, help_heading = "Reference")]
    no_textures: bool,
    /// Reference's mirror bounces, 0 to 16
    #[arg(long, value_name = "N", value_parser = parse_bounces, help_heading = "Reference")]
    bounces: Option<u32>,
    /// Reference's samples a pixel (a fixed pattern)
    #[arg(long, value_name = "N", value_parser = parse_spp, help_heading = "Reference")]
    spp: Option<u32>,
    /// Reference's sampling: pattern or course
    #[arg(long, value_enum, value_name = "S", help_heading = "Reference")]
    supersample: Option<Supersample>,
    /// Reference's texture filter: nearest, bilinear or course
    #[arg(long, value_enum, value_name = "F", help_heading = "Reference")]
    texture_filter: Option<TextureFilter>,
}

/// What `--json` says.
#[derive(Serialize)]
struct ExplainedJson<'a> {
    scene: String,
    picture: String,
    reference: &'a str,
    #[serde(flatten)]
    explanation: &'a Explanation,
    traces: Vec<String>,
}

impl ExplainArgs {
    /// The reference's settings: the course's for the picture, then the flags.
    fn settings(&self, width: u32, height: u32) -> (RenderSettings, Rule, String) {
        let look = crate::conformance::course_look(Some(&self.scene), &self.picture, width, height);
        let mut s = look.apply(&RenderSettings::default());
        s.shadows &= !self.no_shadows;
        s.reflections &= !self.no_reflections;
        s.refraction &= !self.no_refraction;
        s.textures &= !self.no_textures;
        s.max_depth = self.bounces.unwrap_or(s.max_depth);
        s.spp = self.spp.unwrap_or(s.spp);
        s.supersample = self.supersample.unwrap_or(s.supersample);
        s.texture_filter = self.texture_filter.unwrap_or(s.texture_filter);
        let rule = Rule { max_fraction: look.max_fraction, min_psnr: look.min_psnr };
        (s, rule, look.because)
    }
}

/// `raycast trace …` for the pixel (x, y) under `s`: the flags that set
/// what differs from render's defaults.
fn trace_command(scene: &std::path::Path, (x, y): (u32, u32), s: &RenderSettings) -> String {
    let d = RenderSettings::default();
    let mut flags = vec![format!("raycast trace {} --pixel {x},{y}", shell_word(&scene.display().to_string()))];
    if (s.width, s.height) != (d.width, d.height) {
        flags.push(format!("--width {} --height {}", s.width, s.height));
    }
    for (off, flag) in [
        (!s.shadows, "--no-shadows"),
        (!s.reflections, "--no-reflections"),
        (!s.refraction, "--no-refraction"),
        (!s.textures, "--no-textures"),
        (s.supersample == Supersample::Course, "--supersample course"),
    ] {
        if off {
            flags.push(flag.to_string());
        }
    }
    if s.spp != d.spp {
        flags.push(format!("--spp {}", s.spp));
    }
    if s.max_depth != d.max_depth {
        flags.push(format!("--bounces {}", s.max_depth));
    }
    match s.texture_filter {
        TextureFilter::Nearest => {}
        TextureFilter::Bilinear => flags.push("--texture-filter bilinear".into()),
        TextureFilter::Course => flags.push("--texture-filter course".into()),
    }
    flags.join(" ")
}

/// A path as a shell word: quoted where it holds anything but the plain.
fn shell_word(w: &str) -> String {
    if w.chars().all(|c| c.is_ascii_alphanumeric() || "/._-:+,".contains(c)) {
        w.to_string()
    } else {
        format!("'{}'", w.replace('\'', "'\\''"))
    }
}

fn percent(x: f64) -> String {
    format!("{:.1}%", 100.0 * x)
}

/// "cone cap (scene.xml:42, :57) 81%, sphere (scene.xml:12) 19%".
fn on_text(groups: &[Group], total: usize) -> String {
    // The first, and the others of at least 1%, four at most.
    let listed = groups.iter().enumerate().filter(|(k, g)| *k == 0 || g.pixels * 100 >= total).count().min(4);
    let shown: Vec<String> = groups
        .iter()
        .take(listed)
        .map(|g| format!("{} {}", g.text(), percent(g.pixels as f64 / total.max(1) as f64)))
        .collect();
    let more = if groups.len() > listed { format!(", and {} more", groups.len() - listed) } else { String::new() };
    format!("{}{more}", shown.join(", "))
}

fn finding_text(k: usize, f: &Finding, trace: &str) -> String {
    let fit = match (f.matches, f.fit_db) {
        (false, _) => String::new(),
        (true, Some(db)) => format!("; the picture matches raycast drawn so at {db:.1} dB there"),
        (true, None) => "; the picture matches raycast drawn so exactly there".to_string(),
    };
    let against = if f.contradicted > 0 {
        format!(" (though drawn so {} other pixels would differ too)", thousands(f.contradicted as u64))
    } else {
        String::new()
    };
    let also = if f.also.is_empty() {
        String::new()
    } else {
        let names: Vec<&str> =
            f.also.iter().map(|id| crate::explain::variant(id).map_or(id.as_str(), |v| v.what)).collect();
        format!(", or as likely {} (the same picture here)", crate::units::listed(&names, "or"))
    };
    format!(
        "{}. {}{also} ({}): {} pixels, {} of those that differ{fit}{against}\n   on: {}\n   see: {trace}",
        k + 1,
        f.what,
        f.category.name(),
        thousands(f.pixels as u64),
        percent(f.share),
        on_text(&f.on, f.pixels)
    )
}

pub fn run(args: &ExplainArgs) -> Result<(), Error> {
    if args.json && args.output.as_deref().is_some_and(crate::output::is_stdout) {
        return Err(Error::Usage(
            "--json writes to standard output, and so does -o -: write the picture to a file".into(),
        ));
    }
    crate::output::status_beside(&args.output);
    let mine = image_io::read_picture(&args.picture).map_err(|e| {
        if image_io::picture_format(&args.scene).is_some() {
            Error::Usage(format!(
                "{e}; the scene is a picture: the arguments look swapped (raycast explain SCENE PICTURE)"
            ))
        } else {
            e
        }
    })?;
    let (settings, rule, because) = args.settings(mine.width, mine.height);
    settings.validate().map_err(Error::usage)?;
    if let Some(out) = &args.output {
        crate::output::refuse_overwriting(out, [args.scene.as_path(), args.picture.as_path()])?;
    }
    let parse = ParseOptions { assets: args.assets.clone(), skip_textures: !settings.textures };
    let scene = crate::source::load_scene(Some(&args.scene), &parse, &FlattenLimits::default())?;
    let data = crate::source::pack(&scene, &settings)?;
    let cpu = CpuRenderer::new()?;
    let explanation = crate::progress::told("explain", |told| {
        crate::explain::explain(&scene, &data, &mine, &cpu, rule, &|done, of| {
            told(Progress { fraction: done as f64 / of.max(1) as f64, detail: format!("picture {} of {of}", done + 1) })
        })
    })?;
    let traces: Vec<String> =
        explanation.findings.iter().map(|f| trace_command(&args.scene, f.pixel, &settings)).collect();
    let rule_text = match rule.min_psnr {
        Some(db) => format!("at most {} of pixels, or at least {db} dB", percent(rule.max_fraction)),
        None => format!("at most {} of pixels", percent(rule.max_fraction)),
    };
    if args.json {
        let json = ExplainedJson {
            scene: args.scene.display().to_string(),
            picture: args.picture.display().to_string(),
            reference: &because,
            explanation: &explanation,
            traces: traces.clone(),
        };
        emit_line(&to_json(&json))?;
    } else {
        outln!(
            "explain: {} ({}x{}) against raycast's render of {}, drawn as the course drew {because}",
            args.picture.display(),
            mine.width,
            mine.height,
            args.scene.display()
        );
        let psnr = explanation.psnr.map_or("identical".to_string(), |db| format!("PSNR {db:.1} dB"));
        outln!(
            "differ: {} of {} pixels ({}) by more than {}/255; {psnr}",
            thousands(explanation.differing as u64),
            thousands(explanation.total as u64),
            percent(explanation.differing as f64 / explanation.total.max(1) as f64),
            crate::explain::TOLERANCE
        );
        if explanation.passes {
            outln!("no finding: the picture matches raycast's render (rule: {rule_text})");
        }
        for (k, f) in explanation.findings.iter().enumerate() {
            outln!("{}", finding_text(k, f, &traces[k]));
        }
        if explanation.unexplained > 0 {
            outln!(
                "unexplained: {} pixels ({} of those that differ)\n   on: {}",
                thousands(explanation.unexplained as u64),
                percent(explanation.unexplained as f64 / explanation.differing.max(1) as f64),
                on_text(&explanation.unexplained_on, explanation.unexplained)
            );
        }
    }
    if let Some(out) = &args.output {
        image_io::write_png(out, &annotated(&mine, &explanation))?;
        summary!("wrote {} (each finding's pixels in its colour, the legend below)", out.display());
    }
    if explanation.passes {
        return Ok(());
    }
    Err(Error::Mismatch {
        command: "explain",
        message: format!(
            "{} pixels differ; {} finding{}",
            thousands(explanation.differing as u64),
            explanation.findings.len(),
            if explanation.findings.len() == 1 { "" } else { "s" }
        ),
    })
}
