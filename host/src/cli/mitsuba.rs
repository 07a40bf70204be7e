//! `raycast mitsuba`: a scene written in Mitsuba 3's XML scene format.

use crate::error::Error;
use crate::frame::RenderSettings;
use crate::output::*;
use crate::scene::{FlattenLimits, ParseOptions};
use crate::source::*;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct MitsubaArgs {
    /// An XML file or gen:FAMILY:LEVELS [default: built in]
    ///
    /// A scene file (XML) or a generated scene (gen:FAMILY:DEPTH) [default: the embedded default scene].
    #[arg(value_name = "SCENE")]
    scene: Option<String>,
    /// Write the scene to FILE [default: standard output]
    ///
    /// Write the Mitsuba scene to FILE.xml [default: standard output]; the meshes it generates (cones, tori,
    /// spheres and cylinders under a non-uniform scale) go beside it, named FILE-cone.obj and so on.
    #[arg(short, long, value_name = "FILE", help_heading = "Output")]
    output: Option<PathBuf>,
    #[command(flatten)]
    picture: super::options::ExportOptions,
    /// Samples a pixel (the sampler's sample_count)
    #[arg(long, default_value_t = 1, value_name = "N", value_parser = crate::cli::values::parse_spp,
          help_heading = "Picture")]
    spp: u32,
    /// Most primitives a shape group holds
    ///
    /// Mitsuba cannot nest instances: each master that expands to at most N primitives becomes one shapegroup,
    /// placed by instances; the levels above are expanded (docs/cli.md#mitsuba).
    #[arg(long, default_value_t = crate::mitsuba::SHAPEGROUP_MAX, value_name = "N",
          value_parser = clap::value_parser!(u64).range(1..), help_heading = "Output")]
    shapegroup_max: u64,
}

/// `raycast mitsuba`: the scene, checked as `render` checks it (its
/// warnings on stderr, its errors located), written in Mitsuba 3's format
/// (crate::mitsuba); what Mitsuba draws otherwise said as notes.
pub fn run(args: &MitsubaArgs) -> Result<(), Error> {
    let settings = RenderSettings {
        width: args.picture.width,
        height: args.picture.height,
        spp: args.spp,
        ..RenderSettings::default()
    };
    settings.validate().map_err(Error::usage)?;
    let name = args.scene.as_deref();
    if let Some(out) = &args.output {
        if !out.extension().is_some_and(|e| e.eq_ignore_ascii_case("xml")) {
            return Err(Error::usage(format!("{}: a Mitsuba scene is written to a .xml file", out.display())));
        }
        refuse_overwriting(out, name.map(Path::new))?;
    }
    let parse = ParseOptions { assets: args.picture.assets.clone(), skip_textures: true };
    let (_, scene) = load_scene_file(name.map(Path::new), &parse, &FlattenLimits::default())?;
    let stem = match &args.output {
        Some(out) => out.file_stem().map_or("scene".into(), |s| s.to_string_lossy().into_owned()),
        None => "scene".into(),
    };
    let options = crate::mitsuba::Options { shapegroup_max: args.shapegroup_max, stem };
    let export = crate::mitsuba::export(&scene, &settings, &scene_label(name), &options);
    for note in &export.notes {
        errln!("raycast: note: Mitsuba draws this otherwise: {note}");
    }
    match &args.output {
        None => {
            if let Some((file, _)) = export.files.first() {
                return Err(Error::usage(format!(
                    "this scene needs meshes written beside the XML ({file}, ...): give -o FILE.xml"
                )));
            }
            crate::output::emit(&export.xml).map_err(|e| format!("cannot write the scene to standard output: {e}"))?
        }
        Some(path) => {
            let dir = path.parent().unwrap_or(Path::new(""));
            for (file, text) in &export.files {
                crate::output::write_whole(&dir.join(file), text.as_bytes())?;
            }
            crate::output::write_whole(path, export.xml.as_bytes())?;
            let c = export.counts;
            errln!(
                "wrote {} ({} bytes: {} shapes, {} shape groups, {} instances, {} emitters{}); render it with: {}",
                path.display(),
                export.xml.len(),
                c.shapes,
                c.shapegroups,
                c.instances,
                c.emitters,
                if export.files.is_empty() {
                    String::new()
                } else {
                    format!(", {} meshes beside it", export.files.len())
                },
                crate::mitsuba::mitsuba_command(
                    &path.display().to_string(),
                    &path.with_extension("png").display().to_string()
                )
            );
        }
    }
    Ok(())
}
