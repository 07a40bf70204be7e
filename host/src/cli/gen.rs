//! `raycast gen`: writes a scale-test scene (the library's `gen`).

use crate::error::Error;
use crate::gen::{self, generate, generate_flat, Family, GenOptions};
use crate::output::{emit, write_whole};
use clap::Args;
use std::path::PathBuf;

/// What `raycast gen` writes: a recursive family's scene, or a mesh.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GenKind {
    /// recursiveSpheres1..4: masters, each level rotated to grow outwards.
    RecursiveSpheres,
    /// recursiveCones4: the same placements, every cone upright.
    RecursiveCones,
    /// recursiveCubes4: the same placements, every cube axis-aligned.
    RecursiveCubes,
    /// A sphere of radius 0.5 tessellated into --triangles N (an OBJ file beside the scene).
    MeshSphere,
}

impl GenKind {
    /// The recursive family, None for a mesh.
    pub fn family(self) -> Option<Family> {
        match self {
            GenKind::RecursiveSpheres => Some(Family::RecursiveSpheres),
            GenKind::RecursiveCones => Some(Family::RecursiveCones),
            GenKind::RecursiveCubes => Some(Family::RecursiveCubes),
            GenKind::MeshSphere => None,
        }
    }
}

/// `raycast gen`.
#[derive(Args, Debug)]
#[command(after_long_help = gen::CONSTRUCTION)]
pub struct GenArgs {
    /// recursive-spheres, recursive-cones, recursive-cubes or mesh-sphere
    #[arg(value_enum, hide_possible_values = true,
          long_help = super::values::with_values::<GenKind>("Which corpus scene to extend, or a mesh to write."))]
    pub family: GenKind,
    /// Levels deep: 4 is the corpus scene (187 primitives)
    ///
    /// Levels of the recursion: 4 is the corpus scene (187 primitives), 10 about 2.9 million.
    #[arg(long, alias = "depth", value_name = "N", value_parser = clap::value_parser!(u32).range(i64::from(gen::MIN_DEPTH)..=i64::from(gen::MAX_DEPTH)),
          required_unless_present = "triangles", help_heading = "Picture")]
    pub levels: Option<u32>,
    /// mesh-sphere: N triangles or more (and -o FILE.xml)
    ///
    /// mesh-sphere: a sphere of at least N triangles (8 to 16,000,000), written as FILE.obj beside the scene
    /// -o FILE.xml names.
    #[arg(long, value_name = "N", conflicts_with_all = ["levels", "flat"], help_heading = "Picture")]
    pub triangles: Option<u64>,
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
    let Some(family) = args.family.family() else { return mesh_sphere(args) };
    let Some(levels) = args.levels else {
        return Err(Error::Usage(format!("gen {}: --triangles is mesh-sphere's; give --levels N", family.name())));
    };
    let options = GenOptions { texture: (!args.no_textures).then(|| args.texture.clone()) };
    let xml = if args.flat { generate_flat(family, levels, &options) } else { generate(family, levels, &options) }?;
    match &args.output {
        None => emit(&xml).map_err(|e| Error::Failed(format!("cannot write the scene to standard output: {e}")))?,
        Some(path) => {
            write_whole(path, xml.as_bytes())?;
            let expanded = family.expanded_count(levels);
            let in_file = if args.flat { expanded } else { family.unique_count(levels) };
            errln!(
                "wrote {} ({} --levels {}{}: {expanded} primitives expanded, {in_file} in the file, {} bytes)",
                path.display(),
                family.name(),
                levels,
                if args.flat { " --flat" } else { "" },
                xml.len()
            );
        }
    }
    Ok(())
}

/// `gen mesh-sphere --triangles N -o FILE.xml`: FILE.obj and the scene
/// drawing it.
fn mesh_sphere(args: &GenArgs) -> Result<(), Error> {
    let Some(triangles) = args.triangles else {
        return Err(Error::Usage("gen mesh-sphere: give --triangles N (not --levels)".into()));
    };
    let Some(xml_path) = &args.output else {
        return Err(Error::Usage(
            "gen mesh-sphere writes two files: name the scene with -o FILE.xml (the mesh goes beside it as FILE.obj)"
                .into(),
        ));
    };
    let obj_path = xml_path.with_extension("obj");
    let obj_name = obj_path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    if obj_path == *xml_path || obj_name.is_empty() {
        return Err(Error::Usage(format!("{}: name the scene FILE.xml (the mesh is FILE.obj)", xml_path.display())));
    }
    let (obj, count) = gen::mesh_sphere_obj(triangles)?;
    write_whole(&obj_path, obj.as_bytes())?;
    let xml = gen::mesh_sphere_xml(&obj_name, count);
    write_whole(xml_path, xml.as_bytes())?;
    errln!(
        "wrote {} and {} (mesh-sphere --triangles {triangles}: {count} triangles, {} bytes of OBJ)",
        xml_path.display(),
        obj_path.display(),
        obj.len()
    );
    Ok(())
}
