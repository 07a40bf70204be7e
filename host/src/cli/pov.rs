//! `raycast pov`: a scene written in POV-Ray 3.7's language.

use crate::error::Error;
use crate::frame::RenderSettings;
use crate::output::*;
use crate::scene::{FlattenLimits, ParseOptions};
use crate::source::*;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct PovArgs {
    /// An XML file or gen:FAMILY:LEVELS [default: built in]
    ///
    /// A scene file (XML) or a generated scene (gen:FAMILY:DEPTH) [default: the embedded default scene].
    #[arg(value_name = "SCENE")]
    scene: Option<String>,
    /// Write the scene to FILE [default: standard output]
    ///
    /// Write the POV-Ray scene to FILE [default: standard output].
    #[arg(short, long, value_name = "FILE", help_heading = "Output")]
    output: Option<PathBuf>,
    #[command(flatten)]
    picture: super::options::ExportOptions,
    /// Lights cast no shadows (`shadowless`)
    ///
    /// Lights that cast no shadows (`shadowless`), as `render --no-shadows`.
    #[arg(long, help_heading = "Picture")]
    no_shadows: bool,
    /// No mirror reflections, as `render --no-reflections`
    #[arg(long, help_heading = "Picture")]
    no_reflections: bool,
    /// Transparent materials opaque, as `render --no-refraction`
    #[arg(long, help_heading = "Picture")]
    no_refraction: bool,
    /// No textures, as `render --no-textures`
    #[arg(long, help_heading = "Picture")]
    no_textures: bool,
    /// Mirror bounces, 0 to 16 (alias --depth)
    ///
    /// Mirror bounces (POV-Ray's max_trace_level is one more: it counts the camera ray).
    #[arg(long, alias = "depth", default_value_t = 4, value_name = "N", value_parser = crate::cli::values::parse_bounces,
          help_heading = "Picture")]
    bounces: u32,
}

/// `raycast pov`: the scene, checked as `render` checks it (its warnings on
/// stderr, its errors located), written in POV-Ray's language (crate::pov);
/// what POV-Ray draws otherwise said as notes.
pub fn run(args: &PovArgs) -> Result<(), Error> {
    let settings = RenderSettings {
        width: args.picture.width,
        height: args.picture.height,
        shadows: !args.no_shadows,
        reflections: !args.no_reflections,
        refraction: !args.no_refraction,
        textures: !args.no_textures,
        max_depth: args.bounces,
        ..RenderSettings::default()
    };
    settings.validate().map_err(Error::usage)?;
    let name = args.scene.as_deref();
    if let Some(out) = &args.output {
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("pov")) {
            return Err(Error::usage(format!("{}: a POV-Ray scene is written to a .pov file", out.display())));
        }
        refuse_overwriting(out, name.map(Path::new))?;
    }
    let parse = ParseOptions { assets: args.picture.assets.clone(), skip_textures: args.no_textures };
    let (file, _) = load_scene_file(name.map(Path::new), &parse, &FlattenLimits::default())?;
    let export = crate::pov::export(&file, &settings, &scene_label(name));
    for note in &export.notes {
        errln!("raycast: note: POV-Ray draws this otherwise: {note}");
    }
    match &args.output {
        None => {
            crate::output::emit(&export.sdl).map_err(|e| format!("cannot write the scene to standard output: {e}"))?
        }
        Some(path) => {
            crate::output::write_whole(path, export.sdl.as_bytes())?;
            errln!(
                "wrote {} ({} bytes); render it with: {}",
                path.display(),
                export.sdl.len(),
                crate::pov::povray_command(
                    &path.display().to_string(),
                    &path.with_extension("png").display().to_string(),
                    &settings,
                    crate::cpu::host_threads()
                )
            );
        }
    }
    Ok(())
}
