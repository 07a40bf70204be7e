//! Where a texture's image or a mesh's OBJ file is: beside the scene, in
//! the assets folders, or in the folders above the scene's (a corpus
//! root), each looked for once.

use super::Ctx;
use crate::scene::model::SourceLoc;
use std::path::{Path, PathBuf};

/// How many folders above a scene's own a relative image path is looked
/// for in, after the scene's folder and the assets folders: a corpus root
/// is one or two above its scenes.
const FOLDERS_ABOVE: usize = 3;

impl Ctx<'_> {
    /// Finds an image (`lookup`), once for each element name and file as
    /// written: a flat scene names the same texture in every primitive, and
    /// each lookup is a file-system stat or more. Its warning, if any, is
    /// given at every place that names it.
    pub(super) fn resolve(&mut self, el: &str, file: &str, loc: &SourceLoc) -> Option<PathBuf> {
        let key = (el.to_string(), file.to_string());
        let (found, warning) = match self.images.get(&key) {
            Some(known) => known.clone(),
            None => {
                let looked_up = self.lookup(el, file);
                self.images.insert(key, looked_up.clone());
                looked_up
            }
        };
        if let Some(msg) = warning {
            self.warn(loc.clone(), msg);
        }
        found
    }

    /// Where an image is: relative paths against the XML file's folder, then
    /// each assets folder, then the `FOLDERS_ABOVE` folders above the XML
    /// file's (with a warning); absolute paths as they are, else (with a
    /// warning) their trailing parts, longest first, in those folders: a
    /// scene written on the course's machines names
    /// /course/cs123/data/image/x.png, which a corpus root holds as
    /// image/x.png. With what to warn about, if anything.
    pub(super) fn lookup(&self, el: &str, file: &str) -> (Option<PathBuf>, Option<String>) {
        let p = Path::new(file);
        let mut dirs = vec![self.base_dir.clone()];
        dirs.extend(self.opts.assets.iter().cloned());
        let scene_dir = std::fs::canonicalize(&self.base_dir).unwrap_or_else(|_| self.base_dir.clone());
        // The course's paths are relative to the corpus root, a folder that
        // holds the scene's (corpus/test_x/scene.xml names image/y.png): the
        // folders above the scene's, nearest first.
        let above: Vec<&Path> = scene_dir.ancestors().skip(1).take(FOLDERS_ABOVE).collect();
        let mut tried: Vec<PathBuf> = Vec::new();
        if p.is_absolute() {
            if p.is_file() {
                return (Some(p.to_path_buf()), None);
            }
            tried.push(p.to_path_buf());
            let parts: Vec<&std::ffi::OsStr> = p
                .components()
                .filter_map(|c| match c {
                    std::path::Component::Normal(part) => Some(part),
                    _ => None,
                })
                .collect();
            for k in 0..parts.len() {
                let trailing: PathBuf = parts[k..].iter().collect();
                for d in dirs.iter().map(PathBuf::as_path).chain(above.iter().copied()) {
                    let c = d.join(&trailing);
                    if c.is_file() {
                        let msg = format!("<{el}> file \"{file}\" does not exist; using \"{}\" instead", c.display());
                        return (Some(c), Some(msg));
                    }
                }
            }
            // The message names the file name in the first folders.
            if let Some(name) = parts.last() {
                tried.extend(dirs.iter().map(|d| d.join(name)));
            }
        } else {
            for d in &dirs {
                let c = d.join(p);
                if c.is_file() {
                    return (Some(c), None);
                }
                tried.push(c);
            }
            for (up, folder) in above.iter().enumerate().map(|(i, a)| (i + 1, a)) {
                let c = folder.join(p);
                if c.is_file() {
                    let folders = if up == 1 { "folder" } else { "folders" };
                    let msg = format!(
                        "<{el}> file \"{file}\" found {up} {folders} above the scene's, in \"{}\" (the format's paths are relative to the corpus root): using it; --assets {} says so and quiets this",
                        folder.display(),
                        folder.display()
                    );
                    return (Some(c), Some(msg));
                }
            }
        }
        // One that is there and is no file (a folder, a device): said so,
        // not "not found".
        if let Some((there, metadata)) = tried.iter().find_map(|t| Some((t, std::fs::metadata(t).ok()?))) {
            let what = if metadata.is_dir() { "a folder" } else { "not a regular file" };
            let msg = format!(
                "<{el}> file \"{file}\" is {what} (\"{}\"), not a picture: name the picture's file, or render with \
                 --no-textures",
                there.display()
            );
            return (None, Some(msg));
        }
        let tried: Vec<String> = tried.iter().map(|t| format!("\"{}\"", t.display())).collect();
        let above = if p.is_absolute() {
            format!(", and its trailing folders in those and the {FOLDERS_ABOVE} folders above the scene's")
        } else {
            format!(" and the {FOLDERS_ABOVE} folders above the scene's")
        };
        // A mistyped --assets shows here, where it matters.
        let missing: String = self
            .opts
            .assets
            .iter()
            .filter(|d| !d.is_dir())
            .map(|d| format!("; --assets {} is not a folder", d.display()))
            .collect();
        let msg = format!(
            "<{el}> file \"{file}\" not found (tried {}{above}){missing}: pass the folder that holds it with --assets DIR, or render with --no-textures",
            tried.join(", ")
        );
        (None, Some(msg))
    }
}
