//! XML → [`SceneFile`]: every element and attribute of the CS1230 scene
//! format, checked, with `file:line:col` on every error and warning.
//!
//! Policy: what cannot mean anything sensible (a bad number, a missing
//! required attribute, an unknown primitive, a broken reference) is an
//! error; what can be skipped without changing the meaning of the rest (an
//! unknown element or attribute, a duplicate, a texture that cannot be found)
//! is a warning.
//!
//! One file per part: the document and `<globaldata>` (document.rs), the
//! camera, the lights, the object trees and their transforms, primitives
//! and their materials, where images and meshes are found (assets.rs);
//! beneath them, reading elements and values (values.rs), the format's
//! names and suggestions (names.rs), positions (position.rs) and the XML
//! itself (xml.rs).

mod assets;
mod camera;
mod document;
mod light;
mod names;
mod position;
mod primitive;
#[cfg(test)]
mod tests;
mod tree;
mod values;
mod xml;

use super::model::*;
use position::{line_starts, sat_u32};
use roxmltree::{Document, ParsingOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Deepest nesting of `<transblock>`s (through inline trees) accepted.
pub const MAX_NESTING: usize = 256;

/// Deepest nesting of XML elements accepted (a scene within
/// [`MAX_NESTING`] needs about twice that).
pub const MAX_XML_DEPTH: usize = 1024;

/// Options of the parser.
#[derive(Clone, Debug, Default)]
pub struct ParseOptions {
    /// Extra folders to look for textures in, after the XML file's folder.
    pub assets: Vec<PathBuf>,
    /// Textures are not wanted (`--no-textures`): their files are not
    /// looked for, so a missing one is no warning.
    pub skip_textures: bool,
}

/// Reads and parses a scene file.
pub fn parse_file(path: &Path, opts: &ParseOptions) -> Result<SceneFile, SceneError> {
    let file = Arc::new(path.to_path_buf());
    // A file this machine cannot hold parsed is refused before it is read,
    // with the numbers, rather than ending in the kernel's out-of-memory
    // kill. (Its size bound, MAX_INPUT_BYTES, is `read`'s.)
    let size = std::fs::metadata(path).map_or(0, |m| m.len());
    let need = size.saturating_mul(crate::bounded::LOAD_BYTES_PER_XML_BYTE);
    let checked = size <= crate::bounded::MAX_INPUT_BYTES; // a larger one is `read`'s error
    if let Some(available) = crate::bounded::memory_available().filter(|&a| checked && need > a) {
        return Err(SceneError {
            loc: None,
            file: file.clone(),
            message: format!(
                "scene file \"{}\" is {} of XML, which takes about {} of memory to load ({} times its size); this machine \
                 has {} available: write repeated parts once as masters (<object type=\"master\">) or split the scene",
                path.display(),
                crate::units::fmt_bytes(size),
                crate::units::fmt_bytes(need),
                crate::bounded::LOAD_BYTES_PER_XML_BYTE,
                crate::units::fmt_bytes(available)
            ),
        });
    }
    let bytes = crate::bounded::read(path, crate::bounded::MAX_INPUT_BYTES).map_err(|e| SceneError {
        loc: None,
        file: file.clone(),
        message: match e {
            crate::bounded::ReadError::Io(e) => format!("cannot read scene file \"{}\": {e}", path.display()),
            too_large => format!("scene file \"{}\" is {too_large}: not a scene file raycast can read", path.display()),
        },
    })?;
    let text = match String::from_utf8(bytes) {
        Ok(t) => t,
        Err(e) => {
            let good = e.utf8_error().valid_up_to();
            let bytes = e.as_bytes();
            let prefix = std::str::from_utf8(&bytes[..good]).unwrap_or("");
            let starts = line_starts(prefix);
            let line = starts.len();
            let col = prefix[starts[line - 1]..].chars().count() + 1;
            let byte = bytes.get(good).copied().unwrap_or(0);
            return Err(SceneError {
                loc: Some(SourceLoc { file: file.clone(), line: sat_u32(line), col: sat_u32(col) }),
                file,
                message: format!("the file is not valid UTF-8 (byte 0x{byte:02X} at offset {good}); save it as UTF-8"),
            });
        }
    };
    parse_text(&text, file, opts)
}

/// Parses scene-file text. `path` names the file in messages and is the base
/// folder for relative texture paths.
pub fn parse_str(text: &str, path: &Path, opts: &ParseOptions) -> Result<SceneFile, SceneError> {
    parse_text(text, Arc::new(path.to_path_buf()), opts)
}

fn parse_text(text: &str, file: Arc<PathBuf>, opts: &ParseOptions) -> Result<SceneFile, SceneError> {
    // A UTF-8 byte-order mark is invisible in editors: drop it so columns on
    // line 1 match what the user sees.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let base_dir = match file.parent() {
        Some(p) if !p.as_os_str().is_empty() => p.to_path_buf(),
        _ => PathBuf::from("."),
    };
    let line_starts = line_starts(text);
    let mut cx = Ctx {
        file: file.clone(),
        text,
        line_starts,
        opts,
        base_dir,
        warnings: Default::default(),
        trees: Vec::new(),
        declared: HashMap::new(),
        all_names: HashMap::new(),
        current_tree: None,
        col_cache: std::cell::Cell::new((0, 0, 0)),
        images: HashMap::new(),
    };
    // roxmltree's tokenizer recurses once per nested element: bound the
    // depth first so a hostile file cannot overflow the stack.
    if let Some(pos) = xml::too_deep(text, MAX_XML_DEPTH) {
        return Err(cx.err(
            cx.loc(pos),
            format!("elements are nested more than {MAX_XML_DEPTH} deep; this is not a usable scene file"),
        ));
    }
    // No DTDs: entity definitions could expand into elements the depth
    // check above does not see.
    let doc = match Document::parse_with_options(text, ParsingOptions::default()) {
        Ok(d) => d,
        Err(e) => return Err(cx.xml_error(&e)),
    };
    cx.scenefile(&doc)
}

/// What the parser's steps return: the value, or the located error.
type R<T> = Result<T, SceneError>;

/// One file's parse: its text, where its lines start, what has been read
/// so far. Each file of this module adds the methods of its part.
struct Ctx<'a> {
    file: Arc<PathBuf>,
    text: &'a str,
    line_starts: Vec<usize>,
    opts: &'a ParseOptions,
    base_dir: PathBuf,
    /// In a cell: a number's reading (`number`, `&self`) warns too.
    warnings: std::cell::RefCell<Vec<Warning>>,
    trees: Vec<NamedTree>,
    /// Trees fully parsed so far: name → index in `trees`.
    declared: HashMap<String, usize>,
    /// Every top-level tree name in the file → line and column of its first declaration.
    all_names: HashMap<String, (u32, u32)>,
    current_tree: Option<String>,
    /// (byte position, 0-based line, 0-based column) of the last position
    /// asked for.
    col_cache: std::cell::Cell<(usize, usize, usize)>,
    /// Images looked up so far (`resolve`): (element, file as written) →
    /// where it is and the warning it gives.
    images: HashMap<(String, String), (Option<PathBuf>, Option<String>)>,
}
