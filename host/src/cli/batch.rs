//! Several scenes in one command: each loaded, packed and run, failures
//! reported as they happen and named at the end.

use crate::cli::options::*;
use crate::error::Error;
use crate::frame::FrameData;
use crate::output::*;
use crate::scene::{FlattenLimits, ParseOptions, Scene};
use crate::source::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// A scene loaded and packed for rendering, with what it took.
pub(crate) struct Prepared {
    pub(crate) scene: Scene,
    pub(crate) data: FrameData,
    pub(crate) load: Duration,
}

/// `scene` (None: the embedded default scene) loaded and packed as `o` asks.
pub(crate) fn prepare(scene: Option<&Path>, o: &RenderOptions) -> Result<Prepared, Error> {
    let (settings, like) = o.settings_for(scene);
    settings.validate().map_err(Error::usage)?;
    if let Some(said) = like {
        detail!("{said}");
    }
    let start = Instant::now();
    let parse = ParseOptions { skip_textures: !settings.textures, ..o.parse_options() };
    let scene = load_scene(scene, &parse, &FlattenLimits { max_primitives: o.max_primitives })?;
    let data = pack(&scene, &settings)?;
    Ok(Prepared { scene, data, load: start.elapsed() })
}

/// The scenes a command was given: each path, or None for the embedded default scene.
pub(crate) fn scene_list(scenes: &[PathBuf]) -> Vec<Option<&Path>> {
    if scenes.is_empty() {
        vec![None]
    } else {
        scenes.iter().map(|s| Some(s.as_path())).collect()
    }
}

/// A scene as the command's messages name it (`source::scene_label`).
pub(crate) fn scene_name(scene: Option<&Path>) -> String {
    scene_label(scene.map(Path::to_string_lossy).as_deref())
}

/// What came of the scenes of a command that takes several (`each_scene`).
pub(crate) struct Batch<T> {
    /// Each scene that went through, by name, with what it gave.
    pub(crate) done: Vec<(String, T)>,
    /// The scenes that failed (already reported), by name.
    pub(crate) failed: Vec<String>,
}

impl<T> Batch<T> {
    /// `K of N scenes failed: …` (exit 1), with `also` added, where any failed.
    pub(crate) fn failure(&self, also: &str) -> Option<Error> {
        let n = self.done.len() + self.failed.len();
        (!self.failed.is_empty()).then(|| {
            Error::Failed(format!("{} of {n} scenes failed: {}{also}", self.failed.len(), self.failed.join(", ")))
        })
    }
}

/// Each of `scenes` loaded as `o` asks and given to `each` with its output
/// path, on the backend that `open` makes for the first scene that loads
/// (kept in `backend`; its failure ends the command). One scene's failure
/// ends the command as it always did; of several, a scene that fails is
/// reported and named in the batch, and the others go on.
pub(crate) fn each_scene<B, T>(
    scenes: &[Option<&Path>],
    outputs: &[PathBuf],
    o: &RenderOptions,
    backend: &mut Option<B>,
    open: impl Fn() -> Result<B, Error>,
    mut each: impl FnMut(&B, Prepared, &Path) -> Result<T, Error>,
) -> Result<Batch<T>, Error> {
    let pairs: Vec<(Option<&Path>, &Path)> = scenes.iter().copied().zip(outputs.iter().map(PathBuf::as_path)).collect();
    each_named(
        &pairs,
        |(scene, _)| scene_name(scene),
        |(scene, output)| {
            let prepared = prepare(scene, o).and_then(|p| {
                refuse_overwriting(
                    output,
                    scene.into_iter().chain(p.scene.texture_files().iter().map(PathBuf::as_path)),
                )?;
                Ok(p)
            });
            Ok(match prepared {
                Ok(p) => {
                    if backend.is_none() {
                        // The backend's failure ends the command.
                        *backend = Some(open()?);
                    }
                    each(backend.as_ref().expect("opened above"), p, output)
                }
                Err(e) => Err(e),
            })
        },
    )
}

/// The scenes named on a command line as `bench`, `info` and `bench
/// --versus` take them (a file or a generated scene's name), None (the
/// embedded default scene) where none is.
pub(crate) fn scene_names(scenes: &[String]) -> Vec<Option<&str>> {
    if scenes.is_empty() {
        vec![None]
    } else {
        scenes.iter().map(|s| Some(s.as_str())).collect()
    }
}

/// Each of `names` given to `one`, whose inner result is that one's (a
/// failure of its own) and whose outer error ends the command (a device
/// that does not open). Of several, one that fails is reported on stderr
/// as it happens and named in the batch while the others go on; one alone
/// ends the command with its error. `render`, `check`, `bench` and
/// `bench --versus` (`name` says how each is named).
pub(crate) fn each_named<N: Copy, T>(
    names: &[N],
    name: impl Fn(N) -> String,
    mut one: impl FnMut(N) -> Result<Result<T, Error>, Error>,
) -> Result<Batch<T>, Error> {
    let mut batch = Batch { done: Vec::new(), failed: Vec::new() };
    for &n in names {
        match one(n)? {
            Ok(t) => batch.done.push((name(n), t)),
            Err(e) if names.len() == 1 => return Err(e),
            Err(e) => {
                errln!("{}", e.line());
                batch.failed.push(name(n));
            }
        }
    }
    Ok(batch)
}
