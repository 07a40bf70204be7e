//! Scene sources: where a command's scene comes from, read once here for
//! every command. A name on the command line is one of
//! - none: the embedded default scene (scenes/default.xml);
//! - `-`: XML on standard input (textures relative to the current folder);
//! - a file's path;
//! - `gen:FAMILY:LEVELS`: a generated scale-test scene (`raycast gen`),
//!   where no file has that name (a file of that name wins).

use crate::error::Error;
use crate::frame::{self, FrameData, RenderSettings};
use crate::gen::{self, GenOptions};
use crate::scene::{self, FlattenLimits, ParseOptions, Scene, SceneFile};
use std::path::Path;

/// The embedded default scene (scenes/default.xml): all four primitives and
/// three kinds of light.
pub const DEFAULT_SCENE: &str = include_str!("../../scenes/default.xml");

/// The default scene as messages name it.
pub const DEFAULT_SCENE_NAME: &str = "<default scene>";

/// A scene read from standard input, as messages name it.
pub const STDIN_NAME: &str = "<stdin>";

/// The name that reads a scene from standard input.
pub const STDIN: &str = "-";

/// `name` as a generated scene's name (`gen:FAMILY:LEVELS`), where no file
/// has that name: a file of that name wins.
pub fn generated_name(name: &str) -> Option<&str> {
    Some(name).filter(|n| !Path::new(n).exists() && gen::parse_scene_name(n).is_some())
}

/// Whether `name` is a file to follow for changes (not stdin, not generated).
pub fn is_file(name: &Path) -> bool {
    name != Path::new(STDIN) && name.to_str().is_none_or(|n| generated_name(n).is_none())
}

/// The scene `name` names (None: the embedded default scene), parsed, its
/// masters kept as masters. Errors name `file:line:col`.
pub fn parse_scene(name: Option<&str>, opts: &ParseOptions) -> Result<SceneFile, Error> {
    let located = |e: scene::SceneError| Error::Scene(e.to_string());
    match name {
        None => scene::parse_str(DEFAULT_SCENE, Path::new(DEFAULT_SCENE_NAME), opts).map_err(located),
        Some(STDIN) => {
            let bytes = crate::bounded::read(Path::new("/dev/stdin"), crate::bounded::MAX_INPUT_BYTES)
                .map_err(|e| Error::Failed(format!("cannot read the scene from standard input: {e}")))?;
            let text = String::from_utf8(bytes).map_err(|e| {
                Error::Failed(format!(
                    "the scene on standard input is not UTF-8 text (byte offset {})",
                    e.utf8_error().valid_up_to()
                ))
            })?;
            scene::parse_str(&text, Path::new(STDIN_NAME), opts).map_err(located)
        }
        Some(n) => match generated_name(n).and_then(gen::parse_scene_name) {
            Some(Ok((family, levels))) => {
                let xml = gen::generate(family, levels, &GenOptions::default())?;
                scene::parse_str(&xml, Path::new(n), opts).map_err(located)
            }
            Some(Err(e)) => Err(e),
            None => scene::parse_file(Path::new(n), opts).map_err(|e| match crate::image_io::picture_format(Path::new(n)) {
                // A picture where the scene goes (explain's arguments swapped, say).
                Some(format) => Error::Scene(format!(
                    "{n}: error: this is a {format} picture, not a scene file: raycast reads scenes in the CS1230 XML format"
                )),
                None => located(e),
            }),
        },
    }
}

/// [`parse_scene`] of a path (None: the embedded default scene), then
/// flattened; its warnings printed on stderr. Returns the file as parsed
/// (masters kept) beside the scene.
pub fn load_scene_file(
    path: Option<&Path>,
    opts: &ParseOptions,
    limits: &FlattenLimits,
) -> Result<(SceneFile, Scene), Error> {
    let name = path.map(|p| p.to_string_lossy());
    let file = parse_scene(name.as_deref(), opts)?;
    let scene = scene::flatten(&file, limits).map_err(|e| Error::Scene(e.to_string()))?;
    print_warnings(&scene);
    Ok((file, scene))
}

/// The scene's warnings on stderr, a line each, repeats of one folded into
/// its first (`scene::warning_lines`): as every command and the preview say them.
pub fn print_warnings(scene: &Scene) {
    for line in scene::warning_lines(&scene.warnings) {
        errln!("{line}");
    }
}

/// `scene` packed for rendering with `settings` (`frame::build`), its
/// notes said on stderr.
pub fn pack(scene: &Scene, settings: &RenderSettings) -> Result<FrameData, Error> {
    let data = frame::build(scene, settings)?;
    print_notes(&data);
    Ok(data)
}

/// What packing the scene noted (masters written out, a hierarchy made
/// shallower), on stderr.
pub fn print_notes(data: &FrameData) {
    for note in &data.notes {
        errln!("raycast: note: {note}");
    }
}

/// [`load_scene_file`]'s scene alone.
pub fn load_scene(path: Option<&Path>, opts: &ParseOptions, limits: &FlattenLimits) -> Result<Scene, Error> {
    Ok(load_scene_file(path, opts, limits)?.1)
}

/// A scene as batch reports name it (None: the default scene).
pub fn scene_label(name: Option<&str>) -> String {
    match name {
        None => DEFAULT_SCENE_NAME.to_string(),
        Some(STDIN) => STDIN_NAME.to_string(),
        Some(n) => n.to_string(),
    }
}
