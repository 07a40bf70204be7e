//! `raycast gen`: writes a scale-test scene (the library's `gen`).

use crate::error::Error;
use crate::gen::{self, generate, generate_flat, Family, GenOptions};
use crate::output::{emit, write_whole};
use clap::Args;
use std::path::PathBuf;

/// `raycast gen`.
#[derive(Args, Debug)]
#[command(after_long_help = gen::CONSTRUCTION)]
pub struct GenArgs {
    /// recursive-spheres, recursive-cones or recursive-cubes
    #[arg(value_enum, hide_possible_values = true,
          long_help = crate::args::with_values::<Family>("Which corpus scene to extend."))]
    pub family: Family,
    /// Levels deep: 4 is the corpus scene (187 primitives)
    ///
    /// Levels of the recursion: 4 is the corpus scene (187 primitives), 10 about 2.9 million.
    #[arg(long, alias = "depth", value_name = "N", value_parser = clap::value_parser!(u32).range(i64::from(gen::MIN_DEPTH)..=i64::from(gen::MAX_DEPTH)),
          help_heading = "Picture")]
    pub levels: u32,
    /// Write the scene to FILE [default: standard output]
    #[arg(short, long, value_name = "FILE", help_heading = "Output")]
    pub output: Option<PathBuf>,
    /// Texture every primitive names [default: the corpus's]
    ///
    /// The texture file every primitive names, as written into the XML
    /// [default: image/marsTexture.png, the corpus's, relative to its root].
    #[arg(long, value_name = "FILE", default_value = gen::CORPUS_TEXTURE, conflicts_with = "no_textures",
          help_heading = "Picture", hide_default_value = true)]
    pub texture: String,
    /// Write no texture (and no blend) into the materials
    #[arg(long, alias = "no-texture", help_heading = "Picture")]
    pub no_textures: bool,
    /// Every instance written out, no masters (depth at most 8)
    ///
    /// Write every instance out: each primitive its own transblock under the root with the matrix the renderer
    /// composes, no masters (as POV-Ray holds the scene), for comparing a flat file with the instanced one. Depth
    /// at most 8.
    #[arg(long, help_heading = "Output")]
    pub flat: bool,
}

pub fn run(args: &GenArgs) -> Result<(), Error> {
    let options = GenOptions { texture: (!args.no_textures).then(|| args.texture.clone()) };
    let xml = if args.flat {
        generate_flat(args.family, args.levels, &options)
    } else {
        generate(args.family, args.levels, &options)
    }?;
    match &args.output {
        None => emit(&xml).map_err(|e| Error::Failed(format!("cannot write the scene to standard output: {e}")))?,
        Some(path) => {
            write_whole(path, xml.as_bytes())?;
            let expanded = args.family.expanded_count(args.levels);
            let in_file = if args.flat { expanded } else { args.family.unique_count(args.levels) };
            errln!(
                "wrote {} ({} --levels {}{}: {expanded} primitives expanded, {in_file} in the file, {} bytes)",
                path.display(),
                args.family.name(),
                args.levels,
                if args.flat { " --flat" } else { "" },
                xml.len()
            );
        }
    }
    Ok(())
}
