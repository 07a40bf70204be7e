//! Where a command's pictures go: names, folders, checks before any work.

use crate::cli::batch::*;
use crate::error::Error;
use crate::image_io;
use std::path::{Path, PathBuf};

/// `<scene stem><suffix>.png` ("default" for the embedded scene) in `dir`,
/// or in the current folder.
pub(crate) fn default_output(scene: Option<&Path>, suffix: &str, dir: Option<&Path>) -> PathBuf {
    let stem = scene.and_then(|s| s.file_stem()).map(|s| s.to_string_lossy().into_owned());
    // gen:recursive-spheres:6 → recursive-spheres-6.
    let stem = stem.map(|s| s.strip_prefix("gen:").map_or(s.clone(), |g| g.replace(':', "-")));
    let name = format!("{}{suffix}.png", stem.as_deref().unwrap_or("default"));
    dir.map_or_else(|| PathBuf::from(&name), |d| d.join(&name))
}

/// Where each scene's picture goes (`render`: `<scene name>.png`; `check`:
/// `<scene name>-check.png`, its diff image): `-o` for one scene, else in
/// `--out-dir` (made here) or the current folder. Checked before any work:
/// -o with several scenes, a path that cannot be written, two scenes
/// writing one file.
pub(crate) fn output_paths(
    output: &Option<PathBuf>,
    out_dir: &Option<PathBuf>,
    suffix: &str,
    scenes: &[Option<&Path>],
) -> Result<Vec<PathBuf>, Error> {
    if output.is_some() && scenes.len() > 1 {
        return Err(Error::Usage(format!(
            "-o names one picture, but {} scenes were given: use --out-dir DIR (each picture <scene name>{suffix}.png)",
            scenes.len()
        )));
    }
    if let Some(dir) = out_dir {
        std::fs::create_dir_all(dir)
            .map_err(|e| format!("cannot make the folder {} (--out-dir): {e}", dir.display()))?;
    }
    let outputs: Vec<PathBuf> = scenes
        .iter()
        .map(|scene| output.clone().unwrap_or_else(|| default_output(*scene, suffix, out_dir.as_deref())))
        .collect();
    for (i, path) in outputs.iter().enumerate() {
        image_io::check_output(path)?;
        if let Some(j) = outputs[..i].iter().position(|earlier| earlier == path) {
            return Err(Error::Usage(format!(
                "{} and {} would both be written to {}: give them in separate commands, or rename one",
                scene_name(scenes[j]),
                scene_name(scenes[i]),
                path.display()
            )));
        }
    }
    Ok(outputs)
}
