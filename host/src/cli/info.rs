//! `raycast info`: scenes described without rendering them.

use crate::cli::batch::*;
use crate::error::Error;
use crate::scene::{FlattenLimits, ParseOptions};
use crate::source::*;
use clap::Args;
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct InfoArgs {
    /// XML files or gen:FAMILY:LEVELS [default: built in]
    ///
    /// Scene files (XML) or generated scenes (gen:FAMILY:DEPTH). Without any, the embedded default scene.
    #[arg(value_name = "SCENE")]
    scenes: Vec<String>,
    /// Extra folder to find textures in (repeatable)
    ///
    /// Extra folder to find textures in, after the scene file's folder (repeatable).
    #[arg(long, value_name = "DIR", help_heading = "Picture")]
    assets: Vec<PathBuf>,
    /// Most primitives per scene
    ///
    /// Refuse scenes that expand to more primitives than this.
    #[arg(long, default_value_t = FlattenLimits::default().max_primitives, value_name = "N", help_heading = "Quality")]
    max_primitives: usize,
    /// One JSON object a line, a scene each, instead of text
    #[arg(long, help_heading = "Output")]
    json: bool,
}

/// `raycast info`: each scene loaded and packed as a default render packs
/// it, and described. A scene that fails is reported and the others go on;
/// the command then fails naming it.
pub fn run(args: &InfoArgs) -> Result<(), Error> {
    let names = scene_names(&args.scenes);
    let parse = ParseOptions { assets: args.assets.clone(), ..ParseOptions::default() };
    let limits = FlattenLimits { max_primitives: args.max_primitives };
    let batch = each_named(&names, scene_label, |name| {
        let label = scene_label(name);
        // Warnings on stderr as every command prints them; the notes are in the description.
        let described = load_scene(name.map(Path::new), &parse, &limits).and_then(|scene| {
            let data = crate::info::pack(&scene)?;
            Ok(crate::info::Info::of(&label, &scene, &data))
        });
        Ok(match described {
            Ok(info) if args.json => Ok(crate::output::emit_line(&info.json())?),
            Ok(info) => {
                out!("{}", info.text());
                Ok(())
            }
            Err(e) => Err(Error::scene(e)),
        })
    })?;
    batch.failure("").map_or(Ok(()), Err)
}
