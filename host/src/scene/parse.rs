//! XML → [`SceneFile`]: every element and attribute of the CS1230 scene
//! format, checked, with `file:line:col` on every error and warning.
//!
//! Policy: what cannot mean anything sensible (a bad number, a missing
//! required attribute, an unknown primitive, a broken reference) is an
//! error; what can be skipped without changing the meaning of the rest (an
//! unknown element or attribute, a duplicate, a texture that cannot be found)
//! is a warning.

use super::model::*;
use crate::units::{fmt_number, fmt_vector};
use glam::{DMat4, DVec3};
use roxmltree::{Attribute, Document, Node as XNode, ParsingOptions};
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Deepest nesting of `<transblock>`s (through inline trees) accepted.
pub const MAX_NESTING: usize = 256;

/// Deepest nesting of XML elements accepted (a scene within
/// [`MAX_NESTING`] needs about twice that).
pub const MAX_XML_DEPTH: usize = 1024;

/// Byte position of the first start tag nested deeper than `limit`, by a
/// light scan of the markup (comments, CDATA, processing instructions,
/// declarations and quoted attribute values skipped).
fn too_deep(text: &str, limit: usize) -> Option<usize> {
    let b = text.as_bytes();
    let find = |from: usize, pat: &[u8]| -> usize {
        b.get(from..)
            .and_then(|rest| rest.windows(pat.len()).position(|w| w == pat))
            .map_or(b.len(), |i| from + i + pat.len())
    };
    let mut depth = 0usize;
    let mut i = 0usize;
    while i < b.len() {
        if b[i] != b'<' {
            i += 1;
            continue;
        }
        let rest = &b[i..];
        if rest.starts_with(b"<!--") {
            i = find(i + 4, b"-->");
        } else if rest.starts_with(b"<![CDATA[") {
            i = find(i + 9, b"]]>");
        } else if rest.starts_with(b"<?") {
            i = find(i + 2, b"?>");
        } else if rest.starts_with(b"<!") {
            // A declaration, possibly with an internal subset in brackets.
            let mut j = i + 2;
            let mut brackets = 0usize;
            let mut quote = 0u8;
            while j < b.len() {
                let c = b[j];
                j += 1;
                if quote != 0 {
                    if c == quote {
                        quote = 0;
                    }
                } else if c == b'"' || c == b'\'' {
                    quote = c;
                } else if c == b'[' {
                    brackets += 1;
                } else if c == b']' {
                    brackets = brackets.saturating_sub(1);
                } else if c == b'>' && brackets == 0 {
                    break;
                }
            }
            i = j;
        } else if rest.starts_with(b"</") {
            depth = depth.saturating_sub(1);
            i = find(i + 2, b">");
        } else {
            let start = i;
            let mut j = i + 1;
            let mut quote = 0u8;
            let mut prev = 0u8;
            let mut closed = false;
            while j < b.len() {
                let c = b[j];
                j += 1;
                if quote != 0 {
                    if c == quote {
                        quote = 0;
                    }
                } else if c == b'"' || c == b'\'' {
                    quote = c;
                } else if c == b'>' {
                    closed = prev == b'/';
                    break;
                }
                prev = c;
            }
            if !closed {
                depth += 1;
                if depth > limit {
                    return Some(start);
                }
            }
            i = j;
        }
    }
    None
}

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

/// Where each line of `text` starts: after a `\n`, a `\r\n` or a `\r`
/// alone (old Mac files), each one line break as XML reads them.
fn line_starts(text: &str) -> Vec<usize> {
    let b = text.as_bytes();
    let mut starts = vec![0usize];
    starts.extend(
        b.iter()
            .enumerate()
            .filter(|&(i, &c)| c == b'\n' || (c == b'\r' && b.get(i + 1) != Some(&b'\n')))
            .map(|(i, _)| i + 1),
    );
    starts
}

/// `line:col` of a place, for a message that names another place.
fn line_col(l: &SourceLoc) -> String {
    format!("{}:{}", l.line, l.col)
}

fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

/// How many folders above a scene's own a relative image path is looked
/// for in, after the scene's folder and the assets folders: a corpus root
/// is one or two above its scenes.
const FOLDERS_ABOVE: usize = 3;

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
    if let Some(pos) = too_deep(text, MAX_XML_DEPTH) {
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

type R<T> = Result<T, SceneError>;

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

// ---------------------------------------------------------------------------
// Small text helpers

/// Levenshtein distance, case-insensitive.
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.to_lowercase().chars().collect();
    let b: Vec<char> = b.to_lowercase().chars().collect();
    let mut prev: Vec<usize> = (0..=b.len()).collect();
    let mut cur = vec![0usize; b.len() + 1];
    for i in 1..=a.len() {
        cur[0] = i;
        for j in 1..=b.len() {
            let sub = prev[j - 1] + usize::from(a[i - 1] != b[j - 1]);
            cur[j] = sub.min(prev[j] + 1).min(cur[j - 1] + 1);
        }
        std::mem::swap(&mut prev, &mut cur);
    }
    prev[b.len()]
}

/// The candidate `name` was probably meant to be: within edit distance 2
/// (and closer than replacing it outright), or equal but for case.
fn suggest<'c>(name: &str, candidates: &[&'c str]) -> Option<&'c str> {
    if name.chars().count() > 64 {
        return None;
    }
    candidates
        .iter()
        .map(|c| (edit_distance(name, c), *c))
        .filter(|&(d, c)| d == 0 || (d <= 2 && d < c.chars().count()))
        .min_by_key(|&(d, _)| d)
        .map(|(_, c)| c)
}

/// `a, b or c`.
fn or_list(items: &[&str]) -> String {
    join_list(items, "or")
}

fn join_list(items: &[&str], last: &str) -> String {
    match items {
        [] => String::new(),
        [one] => (*one).to_string(),
        [init @ .., tail] => format!("{} {last} {tail}", init.join(", ")),
    }
}

/// Shortens a value for a message.
fn shown(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    format!("{out:?}")
}

/// The matrix of one transform.
pub(crate) fn transform_matrix(t: &Transform) -> DMat4 {
    match t {
        Transform::Translate(v) => DMat4::from_translation(*v),
        Transform::Scale(v) => DMat4::from_scale(*v),
        Transform::Rotate { axis, angle_deg } => match unit(*axis) {
            Some(a) => DMat4::from_axis_angle(a, angle_deg.to_radians()),
            None => DMat4::IDENTITY,
        },
        Transform::Matrix(m) => **m,
    }
}

const PRIMITIVES: &[&str] = &["cube", "cone", "cylinder", "sphere", "torus", "mesh"];
const MATERIAL_ELEMENTS: &[&str] = &[
    "diffuse",
    "ambient",
    "specular",
    "reflective",
    "transparent",
    "emissive",
    "shininess",
    "ior",
    "blend",
    "texture",
    "bumpmap",
];
const TRANSBLOCK_ELEMENTS: &[&str] = &["translate", "rotate", "scale", "matrix", "object"];
const GLOBAL_ELEMENTS: &[&str] = &["ambientcoeff", "diffusecoeff", "specularcoeff", "transparentcoeff"];
const CAMERA_ELEMENTS: &[&str] =
    &["pos", "focus", "look", "up", "heightangle", "aspectratio", "aperture", "focallength"];
const LIGHT_ELEMENTS: &[&str] =
    &["id", "type", "color", "position", "direction", "function", "angle", "penumbra", "width", "height"];

/// Where an element of the format belongs, for one found elsewhere; None
/// for a name the format does not have.
fn home(name: &str) -> Option<&'static str> {
    Some(match name {
        "scenefile" => "it is the root element, and a file has one",
        "globaldata" | "cameradata" | "lightdata" => "it goes at the top level, in <scenefile>",
        "object" => "objects go in a <transblock> (or, as trees, at the top level)",
        "transblock" => "transblocks go in an <object type=\"tree\">",
        "translate" | "rotate" | "scale" | "matrix" => "transforms go in a <transblock>",
        "row0" | "row1" | "row2" | "row3" => "rows go in a <matrix>",
        n if MATERIAL_ELEMENTS.contains(&n) => "material elements go in an <object type=\"primitive\">",
        n if GLOBAL_ELEMENTS.contains(&n) => "it goes in a <globaldata>",
        n if CAMERA_ELEMENTS.contains(&n) => "it goes in a <cameradata>",
        n if LIGHT_ELEMENTS.contains(&n) => "it goes in a <lightdata>",
        _ => return None,
    })
}
/// Every attribute an `<object>` takes (a mesh's among them).
const OBJECT_ATTRIBUTES: &[&str] = &["type", "name", "meshfile", "filename"];

impl<'a> Ctx<'a> {
    // -- positions and messages -------------------------------------------

    fn loc(&self, pos: usize) -> SourceLoc {
        let idx = match self.line_starts.binary_search(&pos) {
            Ok(i) => i,
            Err(i) => i.saturating_sub(1),
        };
        let start = self.line_starts.get(idx).copied().unwrap_or(0);
        // Columns count characters. Positions are asked for mostly in
        // document order, so count on from the last one on the same line
        // (a file written on one long line stays linear).
        let (last_pos, last_line, last_col) = self.col_cache.get();
        let count = |a: usize, b: usize| match self.text.get(a..b) {
            Some(s) => s.chars().count(),
            None => b.saturating_sub(a),
        };
        let col = if last_line == idx && last_pos <= pos {
            last_col + count(last_pos, pos)
        } else if last_line == idx && pos - start > last_pos - pos {
            last_col.saturating_sub(count(pos, last_pos))
        } else {
            count(start, pos)
        };
        self.col_cache.set((pos, idx, col));
        SourceLoc { file: self.file.clone(), line: sat_u32(idx + 1), col: sat_u32(col + 1) }
    }

    fn nloc(&self, n: XNode) -> SourceLoc {
        self.loc(n.range().start)
    }

    fn aloc(&self, a: &Attribute) -> SourceLoc {
        self.loc(a.range().start)
    }

    fn err(&self, loc: SourceLoc, message: String) -> SceneError {
        SceneError { loc: Some(loc), file: self.file.clone(), message }
    }

    fn warn(&mut self, loc: SourceLoc, message: String) {
        self.note(loc, message);
    }

    /// [`Self::warn`] where the parser is borrowed, not its own (`number`).
    fn note(&self, loc: SourceLoc, message: String) {
        self.warnings.borrow_mut().push(Warning { loc, message });
    }

    fn xml_error(&self, e: &roxmltree::Error) -> SceneError {
        use roxmltree::Error as E;
        if let E::UnknownToken(p) = e {
            let at = self.xml_offset(*p);
            if let Some(what) = self.after_root(at) {
                return self.err(self.loc(at), format!("malformed XML: {what}"));
            }
        }
        let end = self.loc(self.text.len());
        let (loc, message) = match e {
            E::UnexpectedEndOfStream | E::UnclosedRootNode => {
                (end, "malformed XML: the file ends before every element is closed (an unclosed tag?)".to_string())
            }
            E::NoRootNode => (end, "malformed XML: the file has no root element (expected <scenefile>)".to_string()),
            E::UnexpectedCloseTag(expected, actual, _) => (
                self.text_pos(e),
                format!(
                    "malformed XML: found </{actual}> while <{expected}> is still open (an unclosed <{expected}>?)"
                ),
            ),
            _ => {
                let mut m = e.to_string();
                // roxmltree ends most messages with " at ROW:COL"; we give the
                // position ourselves.
                if let Some(i) = m.rfind(" at ") {
                    let tail = &m[i + 4..];
                    if !tail.is_empty() && tail.chars().all(|c| c.is_ascii_digit() || c == ':') {
                        m.truncate(i);
                    }
                }
                if matches!(e, E::DtdDetected) {
                    m = "a DTD with declarations is not supported; remove the <!DOCTYPE …> block".to_string();
                }
                let loc = match e {
                    E::DtdDetected | E::NodesLimitReached | E::AttributesLimitReached | E::NamespacesLimitReached => {
                        SourceLoc { file: self.file.clone(), line: 1, col: 1 }
                    }
                    _ => self.text_pos(e),
                };
                (loc, format!("malformed XML: {m}"))
            }
        };
        self.err(loc, message)
    }

    /// The byte position of one of roxmltree's positions (rows counted by
    /// `\n`, columns in characters).
    fn xml_offset(&self, p: roxmltree::TextPos) -> usize {
        let mut start = 0;
        for _ in 1..p.row {
            match self.text[start..].find('\n') {
                Some(i) => start += i + 1,
                None => break,
            }
        }
        let rest = &self.text[start..];
        start + rest.char_indices().nth(p.col.saturating_sub(1) as usize).map_or(rest.len(), |(i, _)| i)
    }

    /// What is wrong at byte `at` when the text before it is a whole
    /// document: something after its root element (a second root, text, a
    /// stray close tag), which roxmltree calls an unknown token.
    fn after_root(&self, at: usize) -> Option<String> {
        let before = self.text.get(..at)?;
        let doc = Document::parse_with_options(before, ParsingOptions::default()).ok()?;
        let root = doc.root_element().tag_name().name();
        let rest = &self.text[at..];
        let name = |s: &str| -> String {
            s.split(|c: char| c.is_whitespace() || c == '>' || c == '/').next().unwrap_or("").to_string()
        };
        Some(if let Some(tag) = rest.strip_prefix("</").map(name).filter(|n| !n.is_empty()) {
            format!("a close tag </{tag}> after the root element </{root}> has ended (one too many?); remove it")
        } else if let Some(tag) = rest.strip_prefix('<').map(name).filter(|n| !n.is_empty() && !n.starts_with('!')) {
            format!(
                "a second root element <{tag}> after </{root}>: a scene file has one <scenefile>, which holds everything; move it inside or remove it"
            )
        } else if rest.starts_with('<') {
            format!("markup after the root element </{root}>; a scene file ends there")
        } else {
            let line = rest.split(['\r', '\n']).next().unwrap_or("").trim();
            format!("text {} after the root element </{root}>; a scene file ends there: remove it", shown(line))
        })
    }

    /// Where roxmltree places `e`, in lines as [`line_starts`] counts them
    /// (roxmltree counts `\n` only).
    fn text_pos(&self, e: &roxmltree::Error) -> SourceLoc {
        self.loc(self.xml_offset(e.pos()))
    }

    // -- generic element and attribute access ------------------------------

    /// Child elements; warns about stray text.
    fn elements<'d, 'i>(&mut self, n: XNode<'d, 'i>) -> Vec<XNode<'d, 'i>> {
        let mut out = Vec::new();
        for c in n.children() {
            if c.is_element() {
                out.push(c);
            } else if c.is_text() {
                let t = c.text().unwrap_or("").trim();
                if !t.is_empty() {
                    let msg = format!("unexpected text {} inside <{}>; ignored", shown(t), n.tag_name().name());
                    let raw = c.text().unwrap_or("");
                    let lead = raw.len() - raw.trim_start().len();
                    let loc = self.loc(c.range().start + lead);
                    self.warn(loc, msg);
                }
            }
        }
        out
    }

    /// Warns about attributes of `n` not in `allowed`.
    fn check_attrs(&mut self, n: XNode, allowed: &[&str]) {
        for a in n.attributes() {
            if allowed.contains(&a.name()) {
                continue;
            }
            let el = n.tag_name().name();
            let msg = match suggest(a.name(), allowed) {
                Some(s) => format!("unknown attribute `{}` on <{el}> (did you mean `{s}`?); ignored", a.name()),
                None if allowed.is_empty() => {
                    format!("unknown attribute `{}` on <{el}> (it takes none); ignored", a.name())
                }
                None => format!("unknown attribute `{}` on <{el}> (expected {}); ignored", a.name(), or_list(allowed)),
            };
            let loc = self.aloc(&a);
            self.warn(loc, msg);
        }
    }

    /// Warns about an element that does not belong where it is: one of the
    /// format's elements in the wrong place, or an unknown one.
    fn unknown_element(&mut self, n: XNode, parent: &str, expected: &[&str]) {
        let name = n.tag_name().name();
        let msg = match home(name) {
            Some(home) => format!("<{name}> cannot be inside <{parent}>: {home}; skipped"),
            None => {
                let hint = match suggest(name, expected) {
                    Some(s) => format!("did you mean <{s}>?"),
                    None => format!("expected {}", or_list(expected)),
                };
                format!("unknown element <{name}> in <{parent}> ({hint}); skipped")
            }
        };
        let loc = self.nloc(n);
        self.warn(loc, msg);
    }

    fn attr<'d, 'i>(n: XNode<'d, 'i>, name: &str) -> Option<Attribute<'d, 'i>> {
        n.attributes().find(|a| a.name() == name)
    }

    /// The error for a missing required attribute, pointing at a misspelled
    /// attribute when there is one: one that `n` does not take (`takes`),
    /// as an attribute of its own is no typo.
    fn missing(&self, n: XNode, name: &str, takes: &[&str], expected: &str) -> SceneError {
        let el = n.tag_name().name();
        let misspelt = n
            .attributes()
            .find(|a| a.name() != name && !takes.contains(&a.name()) && suggest(a.name(), &[name]).is_some());
        match misspelt {
            Some(a) => self.err(
                self.aloc(&a),
                format!("<{el}> is missing attribute `{name}` (found `{}`: did you mean `{name}`?)", a.name()),
            ),
            None => self.err(self.nloc(n), format!("<{el}> is missing attribute `{name}` (expected {expected})")),
        }
    }

    /// Attribute `name` of `n`, which takes the attributes `takes`.
    fn req_attr<'d, 'i>(&self, n: XNode<'d, 'i>, name: &str, takes: &[&str], expected: &str) -> R<Attribute<'d, 'i>> {
        Self::attr(n, name).ok_or_else(|| self.missing(n, name, takes, expected))
    }

    fn number(&self, n: XNode, a: &Attribute) -> R<f64> {
        let raw = a.value();
        let t = raw.trim();
        // Formatted only for an error: this runs for every number of the file.
        let what = || format!("attribute `{}` of <{}>", a.name(), n.tag_name().name());
        if t.is_empty() {
            // The course's parser reads an empty number as 0 (its official
            // scenes have `<rotate z=""/>`): lenient too, and said.
            self.note(self.aloc(a), format!("{} is empty; read as 0, as the course's parser reads it", what()));
            return Ok(0.0);
        }
        match t.parse::<f64>() {
            Ok(v) if v.is_finite() => Ok(v),
            Ok(_) => Err(self.err(self.aloc(a), format!("{} is {} (expected a finite number)", what(), shown(raw)))),
            Err(_) => Err(self.err(
                self.aloc(a),
                format!(
                    "{} is {}, which is not a number (expected a decimal number such as 0.5); fix the value",
                    what(),
                    shown(raw)
                ),
            )),
        }
    }

    fn to_f32(&self, n: XNode, name: &str, v: f64) -> R<f32> {
        if crate::units::f32_holds(v) {
            return Ok(v as f32);
        }
        let loc = match Self::attr(n, name) {
            Some(a) => self.aloc(&a),
            None => self.nloc(n),
        };
        Err(self.err(
            loc,
            format!(
                "attribute `{name}` of <{}> is too large (expected a number of magnitude below 3.4e38)",
                n.tag_name().name()
            ),
        ))
    }

    fn req_num(&self, n: XNode, name: &str, takes: &[&str], expected: &str) -> R<f64> {
        let a = self.req_attr(n, name, takes, expected)?;
        self.number(n, &a)
    }

    fn opt_num(&self, n: XNode, name: &str) -> R<Option<f64>> {
        match Self::attr(n, name) {
            Some(a) => self.number(n, &a).map(Some),
            None => Ok(None),
        }
    }

    /// Checks leaf-ness (no child elements) of a value element.
    fn leaf(&mut self, n: XNode) {
        for c in self.elements(n) {
            let msg = format!(
                "unexpected element <{}> inside <{}> (it takes attributes only); skipped",
                c.tag_name().name(),
                n.tag_name().name()
            );
            let loc = self.nloc(c);
            self.warn(loc, msg);
        }
    }

    /// `<e x y z/>`.
    fn xyz(&mut self, n: XNode) -> R<DVec3> {
        const XYZ: &[&str] = &["x", "y", "z"];
        self.check_attrs(n, XYZ);
        self.leaf(n);
        let e = "x, y and z";
        Ok(DVec3::new(self.req_num(n, "x", XYZ, e)?, self.req_num(n, "y", XYZ, e)?, self.req_num(n, "z", XYZ, e)?))
    }

    /// `xyz` for a point the renderer takes as it is (the camera's
    /// position): each coordinate within f32's range, where the device
    /// and the CPU build compute (beyond it, an infinity).
    fn xyz_f32(&mut self, n: XNode) -> R<DVec3> {
        let v = self.xyz(n)?;
        for (name, x) in [("x", v.x), ("y", v.y), ("z", v.z)] {
            self.to_f32(n, name, x)?;
        }
        Ok(v)
    }

    /// `<e r g b/>`.
    fn rgb(&mut self, n: XNode) -> R<[f32; 3]> {
        const RGB: &[&str] = &["r", "g", "b"];
        self.check_attrs(n, RGB);
        self.leaf(n);
        let e = "r, g and b";
        let mut out = [0f32; 3];
        for (i, name) in RGB.iter().enumerate() {
            let v = self.req_num(n, name, RGB, e)?;
            out[i] = self.to_f32(n, name, v)?;
        }
        Ok(out)
    }

    /// `<e v/>`.
    fn v(&mut self, n: XNode) -> R<f64> {
        self.check_attrs(n, &["v"]);
        self.leaf(n);
        self.req_num(n, "v", &["v"], "v")
    }

    fn v32(&mut self, n: XNode) -> R<f32> {
        let v = self.v(n)?;
        self.to_f32(n, "v", v)
    }

    /// `<ior v/>`: an index of refraction, above 0 (Snell's law divides by it).
    fn ior(&mut self, n: XNode) -> R<f32> {
        let v = self.v32(n)?;
        if v > 0.0 {
            return Ok(v);
        }
        let a = self.req_attr(n, "v", &["v"], "v")?;
        Err(self.err(
            self.aloc(&a),
            format!("<ior> is {} (expected an index of refraction above 0; 1 is air)", fmt_number(v)),
        ))
    }

    /// An element whose values come in one of several spellings, e.g.
    /// `v1 v2 v3` or `x y z` or `a b c`.
    fn families(&mut self, n: XNode, fams: &[&[&str]]) -> R<Vec<f64>> {
        let all: Vec<&str> = fams.iter().flat_map(|f| f.iter().copied()).collect();
        self.check_attrs(n, &all);
        self.leaf(n);
        let el = n.tag_name().name();
        let spellings: Vec<String> = fams.iter().map(|f| f.join(" ")).collect();
        let spellings: Vec<&str> = spellings.iter().map(|s| s.as_str()).collect();
        let present: Vec<&[&str]> =
            fams.iter().copied().filter(|f| f.iter().any(|name| Self::attr(n, name).is_some())).collect();
        match present.as_slice() {
            [] => {
                // Point at a misspelling if there is one.
                for a in n.attributes() {
                    if let Some(s) = suggest(a.name(), &all) {
                        return Err(self.err(
                            self.aloc(&a),
                            format!(
                                "<{el}> has no values (found `{}`: did you mean `{s}`?); expected {}",
                                a.name(),
                                or_list(&spellings)
                            ),
                        ));
                    }
                }
                Err(self.err(self.nloc(n), format!("<{el}> has no values (expected {})", or_list(&spellings))))
            }
            [f] => {
                let expected = join_list(f, "and");
                f.iter().map(|name| self.req_num(n, name, &all, &expected)).collect()
            }
            _ => Err(self.err(
                self.nloc(n),
                format!(
                    "<{el}> mixes spellings of its values (expected exactly one of {}); use one",
                    or_list(&spellings)
                ),
            )),
        }
    }

    // -- the document -------------------------------------------------------

    fn scenefile(&mut self, doc: &Document) -> R<SceneFile> {
        let root = doc.root_element();
        let rname = root.tag_name().name();
        if rname != "scenefile" {
            return Err(self.err(
                self.nloc(root),
                format!("the root element is <{rname}>, expected <scenefile>; is this a CS1230 scene file?"),
            ));
        }
        self.check_attrs(root, &[]);
        let children = self.elements(root);

        // Every tree name, so that a master used before its tree can be told
        // apart from an unknown one.
        for c in &children {
            if c.tag_name().name() == "object" {
                if let Some(a) = Self::attr(*c, "name") {
                    let at = self.nloc(*c);
                    self.all_names.entry(a.value().to_string()).or_insert((at.line, at.col));
                }
            }
        }

        let mut globals: Option<(Globals, SourceLoc)> = None;
        let mut camera: Option<(Camera, SourceLoc)> = None;
        let mut lights = Vec::new();
        for c in children {
            match c.tag_name().name() {
                "globaldata" => {
                    let g = self.globaldata(c)?;
                    let here = self.nloc(c);
                    match &globals {
                        None => globals = Some((g, here)),
                        Some((_, first)) => {
                            let msg = format!("second <globaldata> (the first is at {}); ignored", line_col(first));
                            self.warn(self.nloc(c), msg);
                        }
                    }
                }
                "cameradata" => {
                    let cam = self.cameradata(c)?;
                    let here = self.nloc(c);
                    match &camera {
                        None => camera = Some((cam, here)),
                        Some((_, first)) => {
                            let msg = format!("second <cameradata> (the first is at {}); ignored", line_col(first));
                            self.warn(self.nloc(c), msg);
                        }
                    }
                }
                "lightdata" => lights.push(self.lightdata(c)?),
                "object" => self.top_tree(c)?,
                name => {
                    let msg = match home(name) {
                        Some(home) => format!("<{name}> cannot be at the top level: {home}; skipped"),
                        None => {
                            let hint = match suggest(name, &["globaldata", "cameradata", "lightdata", "object"]) {
                                Some(s) => format!("did you mean <{s}>?"),
                                None => "expected globaldata, cameradata, lightdata or object".to_string(),
                            };
                            format!("unknown top-level element <{name}> ({hint}); skipped")
                        }
                    };
                    self.warn(self.nloc(c), msg);
                }
            }
        }
        let Some(&root_idx) = self.declared.get("root") else {
            let names: Vec<&str> = self.trees.iter().map(|t| t.name.as_str()).collect();
            let found = if names.is_empty() {
                "the file has no trees".to_string()
            } else {
                format!("trees found: {}", names.join(", "))
            };
            return Err(self.err(
                self.nloc(root),
                format!(
                    "no tree named \"root\" ({found}); the tree to draw must be <object type=\"tree\" name=\"root\">"
                ),
            ));
        };
        Ok(SceneFile {
            path: self.file.clone(),
            globals: globals.map(|g| g.0).unwrap_or_default(),
            camera: camera.map(|c| c.0).unwrap_or_default(),
            lights,
            trees: std::mem::take(&mut self.trees),
            root: root_idx,
            warnings: self.warnings.take(),
        })
    }

    /// Warns about a repeated child element; the later one is used.
    fn dup(&mut self, seen: &mut HashMap<String, SourceLoc>, c: XNode, parent: &str) {
        let name = c.tag_name().name().to_string();
        let here = self.nloc(c);
        if let Some(first) = seen.insert(name.clone(), here) {
            let msg =
                format!("second <{name}> in <{parent}> (the first is at {}); the later one is used", line_col(&first));
            self.warn(self.nloc(c), msg);
        }
    }

    fn globaldata(&mut self, n: XNode) -> R<Globals> {
        self.check_attrs(n, &[]);
        let mut g = Globals::default();
        let mut seen = HashMap::new();
        for c in self.elements(n) {
            let slot = match c.tag_name().name() {
                "ambientcoeff" => &mut g.ka,
                "diffusecoeff" => &mut g.kd,
                "specularcoeff" => &mut g.ks,
                "transparentcoeff" => &mut g.kt,
                _ => {
                    self.unknown_element(c, "globaldata", GLOBAL_ELEMENTS);
                    continue;
                }
            };
            *slot = self.v32(c)?;
            self.dup(&mut seen, c, "globaldata");
        }
        Ok(g)
    }

    fn cameradata(&mut self, n: XNode) -> R<Camera> {
        self.check_attrs(n, &[]);
        let mut cam = Camera::default();
        let mut seen = HashMap::new();
        let mut aim: Option<(XNode, DVec3)> = None; // <focus> or <look>, value as written
        let mut up_node = None;
        let mut aperture_node = None;
        for c in self.elements(n) {
            let name = c.tag_name().name();
            match name {
                "pos" => cam.pos = self.xyz_f32(c)?,
                "focus" | "look" => {
                    let v = self.xyz(c)?;
                    if let Some((prev, _)) = aim {
                        let pname = prev.tag_name().name();
                        if pname != name {
                            let at = self.nloc(prev);
                            return Err(self.err(
                                self.nloc(c),
                                format!(
                                    "<cameradata> has both <{pname}> (at {}:{}) and <{name}>; use one (<focus> is a point to look at, <look> a direction)",
                                    at.line,
                                    at.col
                                ),
                            ));
                        }
                    }
                    aim = Some((c, v));
                }
                "up" => {
                    cam.up = self.xyz(c)?;
                    up_node = Some(c);
                }
                "heightangle" => {
                    let v = self.v(c)?;
                    if !(v > 0.0 && v < 180.0) {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self.err(
                            self.aloc(&a),
                            format!(
                                "<heightangle> is {} degrees (expected more than 0 and less than 180: the full vertical field of view)",
                                fmt_number(v)
                            ),
                        ));
                    }
                    cam.height_angle_deg = v;
                    cam.height_angle_loc = Some(self.nloc(c));
                }
                "aspectratio" => {
                    let v = self.v(c)?;
                    if v <= 0.0 {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self.err(
                            self.aloc(&a),
                            format!("<aspectratio> is {} (expected a positive width/height ratio)", fmt_number(v)),
                        ));
                    }
                    cam.aspect_ratio = Some(v);
                    let msg = "raycast takes the aspect ratio from the picture's size (--width and --height); <aspectratio> is ignored";
                    self.warn(self.nloc(c), msg.to_string());
                }
                // Depth of field (docs/scene-format.md#depth-of-field): a thin
                // lens, drawn where a sample has lens points (--spp above 1).
                "aperture" | "focallength" => {
                    let v = self.v(c)?;
                    let aperture = name == "aperture";
                    // An aperture may be 0 (a pinhole); the distance in focus may not.
                    if !(v.is_finite() && (v > 0.0 || (aperture && v == 0.0)) && v < f64::from(f32::MAX)) {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        let expected = if aperture {
                            "expected a lens size of 0 or more, 0 for a pinhole"
                        } else {
                            "expected the positive distance in focus, in world units"
                        };
                        return Err(self.err(self.aloc(&a), format!("<{name}> is {} ({expected})", fmt_number(v))));
                    }
                    if aperture {
                        cam.aperture = Some(v);
                        aperture_node = Some(c);
                    } else {
                        cam.focal_length = Some(v);
                    }
                }
                _ => {
                    self.unknown_element(c, "cameradata", CAMERA_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "cameradata");
        }
        if let (Some(c), None) = (aperture_node.filter(|_| cam.aperture > Some(0.0)), cam.focal_length) {
            let msg = "<aperture> without a <focallength>: a lens needs the distance in focus (add <focallength v=\"D\"/>, or give an aperture of 0 for a pinhole)";
            return Err(self.err(self.nloc(c), msg.to_string()));
        }
        let mut look_node = None;
        if let Some((c, v)) = aim {
            look_node = Some(c);
            cam.look = if c.tag_name().name() == "focus" { v - cam.pos } else { v };
            if unit(cam.look).is_none() {
                let msg = if c.tag_name().name() == "focus" {
                    if cam.look.is_finite() {
                        "<focus> is the same point as <pos>, so the camera looks nowhere; move one of them".to_string()
                    } else {
                        "<focus> is too far from <pos> (the look direction overflows)".to_string()
                    }
                } else {
                    "<look> is the zero vector (expected a direction to look along)".to_string()
                };
                return Err(self.err(self.nloc(c), msg));
            }
        }
        let look = unit(cam.look);
        let up = unit(cam.up);
        if up.is_none() {
            let loc = up_node.map(|u| self.nloc(u)).unwrap_or_else(|| self.nloc(n));
            return Err(self.err(loc, "<up> is the zero vector (expected a direction, usually 0 1 0)".to_string()));
        }
        if let (Some(l), Some(u)) = (look, up) {
            if l.cross(u).length() < 1e-9 {
                let (loc, which) = match (up_node, look_node) {
                    (Some(u), _) => (self.nloc(u), "<up>"),
                    (None, Some(l)) => {
                        (self.nloc(l), if l.tag_name().name() == "focus" { "<focus>" } else { "<look>" })
                    }
                    (None, None) => (self.nloc(n), "<cameradata>"),
                };
                return Err(self.err(
                    loc,
                    format!(
                        "{which}: the up vector {} is parallel to the look direction {}, so the camera's roll is undefined; choose an up that is not along the look direction",
                        fmt_vector(cam.up),
                        fmt_vector(cam.look)
                    ),
                ));
            }
        }
        Ok(cam)
    }

    fn lightdata(&mut self, n: XNode) -> R<Light> {
        self.check_attrs(n, &[]);
        let mut light = Light {
            id: 0,
            kind: LightKind::Point,
            color: [1.0; 3],
            position: DVec3::new(3.0, 3.0, 3.0),
            direction: DVec3::ZERO,
            attenuation: [1.0, 0.0, 0.0],
            angle_deg: 0.0,
            penumbra_deg: 0.0,
            width: 0.0,
            height: 0.0,
            loc: self.nloc(n),
        };
        let mut seen = HashMap::new();
        let mut dir_node = None;
        let mut size_nodes = [None, None]; // <width>, <height>
        let mut has_angle = false;
        for c in self.elements(n) {
            match c.tag_name().name() {
                "id" => {
                    let v = self.v(c)?;
                    if v.fract() != 0.0 || v < i32::MIN as f64 || v > i32::MAX as f64 {
                        let a = self.req_attr(c, "v", &["v"], "v")?;
                        return Err(self
                            .err(self.aloc(&a), format!("light <id> is {} (expected a whole number)", fmt_number(v))));
                    }
                    light.id = v as i32;
                }
                "type" => {
                    self.check_attrs(c, &["v"]);
                    self.leaf(c);
                    let a = self.req_attr(c, "v", &["v"], "point, directional, spot or area")?;
                    const KINDS: &[&str] = &["point", "directional", "spot", "area"];
                    light.kind = match a.value().trim() {
                        "point" => LightKind::Point,
                        "directional" => LightKind::Directional,
                        "spot" => LightKind::Spot,
                        "area" => LightKind::Area,
                        other => {
                            let hint = match suggest(other, KINDS) {
                                Some(s) => format!("; did you mean \"{s}\"?"),
                                None => String::new(),
                            };
                            return Err(self.err(
                                self.aloc(&a),
                                format!(
                                    "unknown light type {} (expected point, directional, spot or area{hint})",
                                    shown(other)
                                ),
                            ));
                        }
                    };
                }
                "color" => light.color = self.rgb(c)?,
                "position" => light.position = self.xyz(c)?,
                "direction" => {
                    light.direction = self.xyz(c)?;
                    dir_node = Some(c);
                }
                "function" => {
                    let v = self.families(c, &[&["v1", "v2", "v3"], &["x", "y", "z"], &["a", "b", "c"]])?;
                    for i in 0..3 {
                        light.attenuation[i] = v.get(i).copied().unwrap_or(0.0) as f32;
                        if !light.attenuation[i].is_finite() {
                            return Err(self.err(
                                self.nloc(c),
                                "<function> has a value too large (expected magnitudes below 3.4e38)".to_string(),
                            ));
                        }
                    }
                }
                "angle" => {
                    light.angle_deg = self.v32(c)?;
                    has_angle = true;
                }
                "penumbra" => light.penumbra_deg = self.v32(c)?,
                "width" => {
                    light.width = self.v32(c)?;
                    size_nodes[0] = Some(c);
                }
                "height" => {
                    light.height = self.v32(c)?;
                    size_nodes[1] = Some(c);
                }
                _ => {
                    self.unknown_element(c, "lightdata", LIGHT_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "lightdata");
        }
        if matches!(light.kind, LightKind::Directional | LightKind::Spot | LightKind::Area)
            && unit(light.direction).is_none()
        {
            let kind = match light.kind {
                LightKind::Spot => "a spot",
                LightKind::Area => "an area",
                _ => "a directional",
            };
            return Err(match dir_node {
                Some(d) => self.err(
                    self.nloc(d),
                    format!("{kind} light's <direction> is the zero vector (expected the direction the light travels)"),
                ),
                None => self.err(
                    self.nloc(n),
                    format!("{kind} light has no <direction> (expected <direction x y z/>: the direction the light travels)"),
                ),
            });
        }
        if light.kind == LightKind::Area {
            self.area_light_size(n, &light, size_nodes)?;
        }
        if light.kind == LightKind::Spot && !has_angle {
            let msg = "spot light has no <angle>; using 0 degrees, so it lights nothing".to_string();
            self.warn(self.nloc(n), msg);
        }
        Ok(light)
    }

    /// An area light's `<width>` and `<height>`: both given, each a
    /// positive finite size (docs/scene-format.md#area-lights); `nodes`
    /// are the elements that gave them.
    fn area_light_size(&self, n: XNode, light: &Light, nodes: [Option<XNode>; 2]) -> R<()> {
        for ((name, v), node) in [("width", light.width), ("height", light.height)].into_iter().zip(nodes) {
            let Some(c) = node else {
                return Err(self.err(
                    self.nloc(n),
                    format!("an area light has no <{name}> (expected <{name} v=\"S\"/>: the rectangle's size in world units)"),
                ));
            };
            if !(v.is_finite() && v > 0.0) {
                let a = self.req_attr(c, "v", &["v"], "v")?;
                return Err(self.err(
                    self.aloc(&a),
                    format!("an area light's <{name}> is {} (expected a positive size in world units)", fmt_number(v)),
                ));
            }
        }
        Ok(())
    }

    // -- object trees -----------------------------------------------------

    fn top_tree(&mut self, n: XNode) -> R<()> {
        self.check_attrs(n, &["type", "name"]);
        let t = self.req_attr(n, "type", &["type", "name"], "type=\"tree\"")?;
        if t.value() != "tree" {
            return Err(self.err(
                self.aloc(&t),
                format!(
                    "a top-level <object> has type={} (expected type=\"tree\"; primitives and masters go inside a <transblock> of a tree)",
                    shown(t.value())
                ),
            ));
        }
        let name_attr = self.req_attr(n, "name", &["type", "name"], "a name, such as name=\"root\"")?;
        let name = name_attr.value().to_string();
        if let Some(&i) = self.declared.get(&name) {
            let first = self.trees.get(i).map(|t| line_col(&t.loc)).unwrap_or_default();
            return Err(self.err(
                self.aloc(&name_attr),
                format!(
                    "a second tree named {} (the first is at {first}); tree names must be unique — rename one",
                    shown(&name)
                ),
            ));
        }
        if self.current_tree.is_some() {
            // Cannot happen: top-level trees do not nest.
            return Err(self.err(self.nloc(n), "internal error: nested top-level tree".to_string()));
        }
        self.current_tree = Some(name.clone());
        let blocks = self.blocks(n, 0);
        self.current_tree = None;
        let blocks = blocks?;
        let loc = self.nloc(n);
        self.declared.insert(name.clone(), self.trees.len());
        self.trees.push(NamedTree { name, blocks, loc });
        Ok(())
    }

    /// The transblocks of a tree at nesting `depth`.
    fn blocks(&mut self, n: XNode, depth: usize) -> R<Vec<TransBlock>> {
        // Exactly as many as there are: a flat scene's root holds one per
        // primitive, and a doubling Vec of them was the parse's largest
        // allocation after the XML tree itself.
        let children = self.elements(n);
        let mut out = Vec::with_capacity(children.iter().filter(|c| c.tag_name().name() == "transblock").count());
        for c in children {
            if c.tag_name().name() == "transblock" {
                out.push(self.transblock(c, depth + 1)?);
            } else {
                self.unknown_element(c, "object", &["transblock"]);
            }
        }
        Ok(out)
    }

    fn transblock(&mut self, n: XNode, depth: usize) -> R<TransBlock> {
        if depth > MAX_NESTING {
            return Err(self.err(
                self.nloc(n),
                format!("transblocks are nested more than {MAX_NESTING} deep; flatten the tree or use masters"),
            ));
        }
        self.check_attrs(n, &[]);
        let mut transforms = Vec::new();
        let mut objects: Vec<(Node, SourceLoc)> = Vec::new();
        for c in self.elements(n) {
            match c.tag_name().name() {
                "translate" => transforms.push(Transform::Translate(self.xyz(c)?)),
                "scale" => {
                    let v = self.xyz(c)?;
                    let zeros: Vec<String> = [("x", v.x), ("y", v.y), ("z", v.z)]
                        .iter()
                        .filter(|a| a.1 == 0.0)
                        .map(|a| format!("{} = 0", a.0))
                        .collect();
                    let problem = if !zeros.is_empty() {
                        let factors = if zeros.len() == 1 { "a zero factor" } else { "zero factors" };
                        Some(format!("<scale> has {factors} ({})", zeros.join(", ")))
                    } else if check_invertible(&DMat4::from_scale(v)) == Err(NotInvertible::Singular) {
                        Some(format!(
                            "<scale> {} is too small: the product of its factors is 0 in double precision",
                            fmt_vector(v)
                        ))
                    } else {
                        None
                    };
                    if let Some(problem) = problem {
                        return Err(self.err(
                            self.nloc(c),
                            format!(
                                "{problem}: the transform is singular (it flattens the shape, and cannot be inverted to cast rays into it); use a small non-zero scale such as 0.001"
                            ),
                        ));
                    }
                    transforms.push(Transform::Scale(v));
                }
                "rotate" => {
                    const ROTATE: &[&str] = &["x", "y", "z", "angle"];
                    self.check_attrs(c, ROTATE);
                    self.leaf(c);
                    let e = "x, y, z and angle";
                    let axis = DVec3::new(
                        self.req_num(c, "x", ROTATE, e)?,
                        self.req_num(c, "y", ROTATE, e)?,
                        self.req_num(c, "z", ROTATE, e)?,
                    );
                    let angle_deg = self.req_num(c, "angle", ROTATE, "an angle in degrees, e.g. angle=\"90\"")?;
                    if unit(axis).is_none() {
                        return Err(self.err(
                            self.nloc(c),
                            "<rotate> has the zero vector as its axis (expected x y z of the axis to rotate about)"
                                .to_string(),
                        ));
                    }
                    transforms.push(Transform::Rotate { axis, angle_deg });
                }
                "matrix" => {
                    let m = self.matrix(c)?;
                    if check_invertible(&m) == Err(NotInvertible::Singular) {
                        return Err(self.err(
                            self.nloc(c),
                            "<matrix> is singular: its columns are linearly dependent (or nearly so), so it flattens the shape and cannot be inverted to cast rays into it".to_string(),
                        ));
                    }
                    transforms.push(Transform::Matrix(Box::new(m)));
                }
                "object" => {
                    let here = self.nloc(c);
                    if let Some((_, first)) = objects.first() {
                        // The course's parser draws each with the transblock's
                        // transforms: so does raycast, and says so.
                        let message = format!(
                            "a second <object> in one <transblock> (the first is at {}); each is drawn with the \
                             transblock's transforms, as the course's parser does (a transblock holds one object \
                             in the format: put each in its own)",
                            line_col(first)
                        );
                        self.warn(here.clone(), message);
                    }
                    let node = self.object(c, depth)?;
                    objects.push((node, here));
                }
                _ => self.unknown_element(c, "transblock", TRANSBLOCK_ELEMENTS),
            }
        }
        let object = match objects.len() {
            0 => {
                return Err(self.err(
                    self.nloc(n),
                    "<transblock> has no <object> (expected exactly one: a primitive, a tree or a master)".to_string(),
                ))
            }
            1 => objects.pop().expect("one object").0,
            // Several: an inline tree of them, each under no transform of its own.
            _ => Node::Tree {
                loc: objects[0].1.clone(),
                blocks: objects
                    .into_iter()
                    .map(|(object, loc)| TransBlock { transforms: Vec::new(), matrix: DMat4::IDENTITY, object, loc })
                    .collect(),
            },
        };
        let matrix = transforms.iter().fold(DMat4::IDENTITY, |m, t| m * transform_matrix(t));
        // One or two transforms, where a pushed Vec holds room for four (136 bytes each).
        transforms.shrink_to_fit();
        Ok(TransBlock { transforms, matrix, object, loc: self.nloc(n) })
    }

    fn matrix(&mut self, n: XNode) -> R<DMat4> {
        self.check_attrs(n, &[]);
        const ROWS: &[&str] = &["row0", "row1", "row2", "row3"];
        let mut rows: [Option<[f64; 4]>; 4] = [None; 4];
        let mut row3_loc = None;
        let mut seen = HashMap::new();
        for c in self.elements(n) {
            let Some(i) = ROWS.iter().position(|r| *r == c.tag_name().name()) else {
                self.unknown_element(c, "matrix", ROWS);
                continue;
            };
            let v = self.families(c, &[&["v1", "v2", "v3", "v4"], &["a", "b", "c", "d"]])?;
            let mut row = [0.0; 4];
            for (k, x) in v.iter().take(4).enumerate() {
                row[k] = *x;
            }
            rows[i] = Some(row);
            if i == 3 {
                row3_loc = Some(self.nloc(c));
            }
            self.dup(&mut seen, c, "matrix");
        }
        let mut m = [[0.0f64; 4]; 4];
        for (i, r) in rows.iter().enumerate() {
            match r {
                Some(r) => m[i] = *r,
                None => {
                    return Err(self.err(
                        self.nloc(n),
                        format!("<matrix> has no <{}> (expected row0, row1, row2 and row3)", ROWS[i]),
                    ))
                }
            }
        }
        // The renderer's transforms are affine (it keeps three rows): the
        // last row is taken as 0 0 0 1 before anything is checked, so that
        // what is checked is what is drawn.
        if m[3] != [0.0, 0.0, 0.0, 1.0] {
            let msg = format!(
                "<matrix> row3 is {} {} {} {}, not 0 0 0 1: raycast's transforms are affine; the last row is ignored (taken as 0 0 0 1)",
                fmt_number(m[3][0]),
                fmt_number(m[3][1]),
                fmt_number(m[3][2]),
                fmt_number(m[3][3])
            );
            let loc = row3_loc.unwrap_or_else(|| self.nloc(n));
            self.warn(loc, msg);
            m[3] = [0.0, 0.0, 0.0, 1.0];
        }
        // Rows as written; glam stores columns.
        Ok(DMat4::from_cols_array_2d(&m).transpose())
    }

    /// `<object>` inside a transblock at nesting `depth`.
    fn object(&mut self, n: XNode, depth: usize) -> R<Node> {
        let t = self.req_attr(n, "type", OBJECT_ATTRIBUTES, "type=\"primitive\", \"tree\" or \"master\"")?;
        match t.value() {
            "primitive" => self.primitive(n),
            "tree" => {
                self.check_attrs(n, &["type", "name"]);
                let blocks = self.blocks(n, depth)?;
                Ok(Node::Tree { blocks, loc: self.nloc(n) })
            }
            "master" => {
                self.check_attrs(n, &["type", "name"]);
                for c in self.elements(n) {
                    let msg = format!(
                        "<{}> inside a master reference is ignored (a master's contents come from its tree)",
                        c.tag_name().name()
                    );
                    self.warn(self.nloc(c), msg);
                }
                let a = self.req_attr(n, "name", OBJECT_ATTRIBUTES, "the name of an earlier top-level tree")?;
                let name = a.value();
                if let Some(&tree) = self.declared.get(name) {
                    return Ok(Node::Master { tree, loc: self.nloc(n) });
                }
                let msg = if self.current_tree.as_deref() == Some(name) {
                    format!("tree {} uses itself as a master; a tree cannot contain itself", shown(name))
                } else if let Some((line, col)) = self.all_names.get(name) {
                    format!(
                        "master {} is used before its tree is declared (at {line}:{col}); move that tree above this one",
                        shown(name)
                    )
                } else {
                    let known: Vec<&str> = self.trees.iter().map(|t| t.name.as_str()).collect();
                    let hint = match suggest(name, &known) {
                        Some(s) => format!("; did you mean \"{s}\"?"),
                        None if known.is_empty() => "; no tree is declared before this point".to_string(),
                        None => format!("; trees declared so far: {}", known.join(", ")),
                    };
                    format!("unknown master {} (no top-level tree has that name{hint})", shown(name))
                };
                Err(self.err(self.aloc(&a), msg))
            }
            other => {
                let hint = match suggest(other, &["primitive", "tree", "master"]) {
                    Some(s) => format!("; did you mean \"{s}\"?"),
                    None => String::new(),
                };
                Err(self.err(
                    self.aloc(&t),
                    format!("unknown object type {} (expected primitive, tree or master{hint})", shown(other)),
                ))
            }
        }
    }

    fn primitive(&mut self, n: XNode) -> R<Node> {
        let name_attr = self.req_attr(n, "name", OBJECT_ATTRIBUTES, "cube, cone, cylinder, sphere, torus or mesh")?;
        let pname = name_attr.value().trim();
        let shape = match pname {
            "cube" => Shape::Cube,
            "cone" => Shape::Cone,
            "cylinder" => Shape::Cylinder,
            "sphere" => Shape::Sphere,
            "torus" => Shape::Torus,
            "mesh" => {
                self.check_attrs(n, OBJECT_ATTRIBUTES);
                let mf = Self::attr(n, "meshfile");
                let f = Self::attr(n, "filename");
                let file = match (mf, f) {
                    (Some(a), Some(_)) => {
                        let msg = "mesh has both meshfile= and filename=; using meshfile".to_string();
                        self.warn(self.nloc(n), msg);
                        a
                    }
                    (Some(a), None) | (None, Some(a)) => a,
                    (None, None) => {
                        return Err(self.err(
                            self.nloc(n),
                            "a mesh primitive needs meshfile=\"file.obj\" (or filename=)".to_string(),
                        ))
                    }
                };
                self.mesh_shape(&file)
            }
            other => {
                let hint = match suggest(other, PRIMITIVES) {
                    Some(s) => format!("; did you mean \"{s}\"?"),
                    None => String::new(),
                };
                return Err(self.err(
                    self.aloc(&name_attr),
                    format!(
                        "unknown primitive {} (expected cube, cone, cylinder, sphere, torus or mesh{hint})",
                        shown(other)
                    ),
                ));
            }
        };
        if !matches!(shape, Shape::Mesh { .. }) {
            self.check_attrs(n, &["type", "name"]);
        }
        let material = self.material(n)?;
        Ok(Node::Primitive { shape, material, loc: self.nloc(n) })
    }

    /// A mesh's OBJ file, looked for as a texture's image is (each name
    /// once); not found, flatten() says so, as an error.
    fn mesh_shape(&mut self, a: &Attribute) -> Shape {
        let file = a.value().to_string();
        let key = ("mesh".to_string(), file.clone());
        let (resolved, warning) = match self.images.get(&key) {
            Some(known) => known.clone(),
            None if file.trim().is_empty() => (None, None),
            None => {
                let (found, note) = self.lookup("object", &file);
                // Not found: flatten()'s error says so; a note is kept only with a file found.
                let looked_up = (found.clone(), note.filter(|_| found.is_some()));
                self.images.insert(key, looked_up.clone());
                looked_up
            }
        };
        if let Some(msg) = warning {
            self.warn(self.aloc(a), msg);
        }
        Shape::Mesh { file, resolved }
    }

    fn material(&mut self, n: XNode) -> R<Material> {
        let mut m = Material::default();
        let mut seen = HashMap::new();
        for c in self.elements(n) {
            match c.tag_name().name() {
                "diffuse" => m.diffuse = self.rgb(c)?,
                "ambient" => m.ambient = self.rgb(c)?,
                "specular" => m.specular = self.rgb(c)?,
                "reflective" => m.reflective = self.rgb(c)?,
                "transparent" => m.transparent = self.rgb(c)?,
                "emissive" => m.emissive = self.rgb(c)?,
                "shininess" => m.shininess = self.v32(c)?,
                "ior" => m.ior = self.ior(c)?,
                "blend" => m.blend = self.v32(c)?,
                "texture" => m.texture = Some(self.texture(c, true)?),
                "bumpmap" => {
                    // Kept (gen writes it back), but its image is not looked
                    // for: a warning that it is missing would advise
                    // --assets for a picture that is never used.
                    m.bumpmap = Some(self.texture(c, false)?);
                    self.warn(self.nloc(c), "raycast does no bump mapping; <bumpmap> is ignored".to_string());
                }
                _ => {
                    self.unknown_element(c, "object", MATERIAL_ELEMENTS);
                    continue;
                }
            }
            self.dup(&mut seen, c, "object");
        }
        Ok(m)
    }

    /// `<texture>` or `<bumpmap>`; its image looked for when `look_up`.
    fn texture(&mut self, n: XNode, look_up: bool) -> R<TextureRef> {
        const TEXTURE: &[&str] = &["file", "u", "v"];
        self.check_attrs(n, TEXTURE);
        self.leaf(n);
        let el = n.tag_name().name();
        let fa = self.req_attr(n, "file", TEXTURE, "file=\"path/to/image.png\"")?;
        let file = fa.value().to_string();
        let u = self.opt_num(n, "u")?.unwrap_or(1.0);
        let v = self.opt_num(n, "v")?.unwrap_or(1.0);
        let repeat_u = self.to_f32(n, "u", u)?;
        let repeat_v = self.to_f32(n, "v", v)?;
        let loc = self.nloc(n);
        let resolved = if self.opts.skip_textures || !look_up {
            None
        } else if file.trim().is_empty() {
            let msg = format!("<{el}> has an empty file=: name the image, or render with --no-textures");
            self.warn(self.aloc(&fa), msg);
            None
        } else {
            self.resolve(el, &file, &loc)
        };
        Ok(TextureRef { file, resolved, repeat_u, repeat_v, loc })
    }

    /// Finds an image (`lookup`), once for each element name and file as
    /// written: a flat scene names the same texture in every primitive, and
    /// each lookup is a file-system stat or more. Its warning, if any, is
    /// given at every place that names it.
    fn resolve(&mut self, el: &str, file: &str, loc: &SourceLoc) -> Option<PathBuf> {
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
    fn lookup(&self, el: &str, file: &str) -> (Option<PathBuf>, Option<String>) {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn opts() -> ParseOptions {
        ParseOptions::default()
    }

    fn p(xml: &str) -> Result<SceneFile, SceneError> {
        parse_str(xml, Path::new("/nonexistent-dir/test.xml"), &opts())
    }

    fn ok(xml: &str) -> SceneFile {
        match p(xml) {
            Ok(f) => f,
            Err(e) => panic!("unexpected error: {e}\n{xml}"),
        }
    }

    fn bad(xml: &str) -> SceneError {
        match p(xml) {
            Ok(_) => panic!("expected an error:\n{xml}"),
            Err(e) => e,
        }
    }

    /// `line:col` of an error.
    fn at(e: &SceneError) -> (u32, u32) {
        let l = e.loc.as_ref().expect("error has a location");
        (l.line, l.col)
    }

    /// 1-based line and column (in characters) of the only occurrence of
    /// `needle` in `text`, counted independently of the parser.
    fn pos_of(text: &str, needle: &str) -> (u32, u32) {
        assert_eq!(text.matches(needle).count(), 1, "{needle:?} must occur once");
        let i = text.find(needle).unwrap();
        let before = &text[..i];
        let line = before.matches('\n').count() + 1;
        let col = before.rsplit('\n').next().unwrap().chars().count() + 1;
        (line as u32, col as u32)
    }

    /// An error at the only occurrence of `needle` whose message contains `msg`.
    fn bad_at_str(xml: &str, needle: &str, msg: &str) -> SceneError {
        let (l, c) = pos_of(xml, needle);
        bad_at(xml, l, c, msg)
    }

    fn wat(w: &Warning) -> (u32, u32) {
        (w.loc.line, w.loc.col)
    }

    /// An error at `line:col` whose message contains `msg`.
    fn bad_at(xml: &str, line: u32, col: u32, msg: &str) -> SceneError {
        let e = bad(xml);
        assert_eq!(at(&e), (line, col), "wrong position for: {e}");
        assert!(e.message.contains(msg), "message {:?} lacks {msg:?}", e.message);
        e
    }

    /// The only warning containing `msg`, at `line:col`.
    fn warned_at(f: &SceneFile, line: u32, col: u32, msg: &str) {
        let ws: Vec<&Warning> = f.warnings.iter().filter(|w| w.message.contains(msg)).collect();
        assert_eq!(ws.len(), 1, "warnings with {msg:?}: {:?}", f.warnings);
        assert_eq!(wat(ws[0]), (line, col), "{}", ws[0]);
    }

    /// A scene whose root tree holds `body` (transblocks); line 1 is
    /// `<scenefile>`, line 2 the root tree, `body` starts on line 3.
    fn root(body: &str) -> String {
        format!("<scenefile>\n<object type=\"tree\" name=\"root\">\n{body}\n</object>\n</scenefile>\n")
    }

    /// A root tree with one transblock holding `inner` (line 4 onwards).
    fn block(inner: &str) -> String {
        root(&format!("<transblock>\n{inner}\n</transblock>"))
    }

    fn prim(name: &str, material: &str) -> String {
        block(&format!("<object type=\"primitive\" name=\"{name}\">\n{material}\n</object>"))
    }

    fn first_prim(f: &SceneFile) -> (&Shape, &Material) {
        match &f.trees[f.root].blocks[0].object {
            Node::Primitive { shape, material, .. } => (shape, material),
            other => panic!("not a primitive: {other:?}"),
        }
    }

    /// A scenefile with `top` before the root tree.
    fn with_top(top: &str) -> String {
        format!(
            "<scenefile>\n{top}\n<object type=\"tree\" name=\"root\"><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object>\n</scenefile>"
        )
    }

    fn camera(inner: &str) -> Result<SceneFile, SceneError> {
        p(&with_top(&format!("<cameradata>\n{inner}\n</cameradata>")))
    }

    fn light(inner: &str) -> Result<SceneFile, SceneError> {
        p(&with_top(&format!("<lightdata>\n{inner}\n</lightdata>")))
    }

    #[test]
    fn minimal_scene_has_all_defaults() {
        let f = ok(&prim("cube", ""));
        assert_eq!(f.globals, Globals { ka: 0.5, kd: 0.5, ks: 0.5, kt: 0.0 });
        assert_eq!(f.camera, Camera::default());
        assert_eq!(f.camera.pos, DVec3::splat(5.0));
        assert_eq!(f.camera.look, DVec3::splat(-1.0));
        assert_eq!(f.camera.up, DVec3::Y);
        assert_eq!(f.camera.height_angle_deg, 45.0);
        assert!(f.lights.is_empty());
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        let (shape, m) = first_prim(&f);
        assert_eq!(*shape, Shape::Cube);
        assert_eq!(*m, Material::default());
        assert_eq!(m.diffuse, [1.0; 3]);
        assert_eq!(m.ambient, [0.0; 3]);
        assert_eq!(m.specular, [0.0; 3]);
        assert_eq!(m.shininess, 0.0);
        assert_eq!(m.ior, 1.0);
        assert_eq!(m.blend, 0.0);
        assert!(m.texture.is_none() && m.bumpmap.is_none());
        let b = &f.trees[f.root].blocks[0];
        assert!(b.transforms.is_empty());
        assert_eq!(b.matrix, DMat4::IDENTITY);
        assert_eq!((b.loc.line, b.loc.col), (3, 1));
        assert_eq!(f.trees[f.root].name, "root");
    }

    #[test]
    fn globaldata_all_coefficients() {
        let f = ok(&with_top(
            "<globaldata><ambientcoeff v=\"0.1\"/><diffusecoeff v=\"0.2\"/><specularcoeff v=\"0.3\"/><transparentcoeff v=\"0.4\"/></globaldata>",
        ));
        assert_eq!(f.globals, Globals { ka: 0.1, kd: 0.2, ks: 0.3, kt: 0.4 });
        let f = ok(&with_top("<globaldata><diffusecoeff v=\"0.7\"/></globaldata>"));
        assert_eq!(f.globals, Globals { ka: 0.5, kd: 0.7, ks: 0.5, kt: 0.0 });
    }

    #[test]
    fn camera_all_elements() {
        let f = camera(
            "<pos x=\"1\" y=\"2\" z=\"3\"/><look x=\"0\" y=\"0\" z=\"-2\"/><up x=\"0\" y=\"3\" z=\"0\"/><heightangle v=\"60\"/>\
             <aspectratio v=\"1.5\"/><aperture v=\"0.08\"/><focallength v=\"15\"/>",
        )
        .unwrap();
        let c = f.camera;
        assert_eq!(c.pos, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(c.look, DVec3::new(0.0, 0.0, -2.0));
        assert_eq!(c.up, DVec3::new(0.0, 3.0, 0.0));
        assert_eq!(c.height_angle_deg, 60.0);
        assert_eq!(c.aspect_ratio, Some(1.5));
        assert_eq!(c.aperture, Some(0.08));
        assert_eq!(c.focal_length, Some(15.0));
    }

    #[test]
    fn camera_focus_becomes_look() {
        let f = camera("<pos x=\"0\" y=\"0\" z=\"6\"/><focus x=\"1\" y=\"2\" z=\"0\"/>").unwrap();
        assert_eq!(f.camera.look, DVec3::new(1.0, 2.0, -6.0));
        // Order does not matter: focus before pos.
        let f = camera("<focus x=\"1\" y=\"2\" z=\"0\"/><pos x=\"0\" y=\"0\" z=\"6\"/>").unwrap();
        assert_eq!(f.camera.look, DVec3::new(1.0, 2.0, -6.0));
        // Only pos: the default look direction stays.
        let f = camera("<pos x=\"0\" y=\"0\" z=\"6\"/>").unwrap();
        assert_eq!(f.camera.look, DVec3::splat(-1.0));
    }

    #[test]
    fn camera_errors() {
        // Lines: 1 <scenefile>, 2 <cameradata>, 3 the inner text.
        let e = camera("<focus x=\"0\" y=\"0\" z=\"0\"/><look x=\"0\" y=\"0\" z=\"-1\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 27));
        assert!(e.message.contains("both <focus> (at 3:1) and <look>"), "{e}");
        let e = camera("<look x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1));
        assert!(e.message.contains("<look> is the zero vector"), "{e}");
        let e = camera("<pos x=\"1\" y=\"1\" z=\"1\"/><focus x=\"1\" y=\"1\" z=\"1\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 25));
        assert!(e.message.contains("same point as <pos>"), "{e}");
        let e = camera("<up x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1));
        assert!(e.message.contains("<up> is the zero vector"), "{e}");
        let e = camera("<look x=\"0\" y=\"-2\" z=\"0\"/><up x=\"0\" y=\"1\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 27));
        assert!(e.message.starts_with("<up>: the up vector") && e.message.contains("parallel"), "{e}");
        // Parallel to the default up: the look element is blamed.
        let e = camera("<look x=\"0\" y=\"-2\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1));
        assert!(e.message.starts_with("<look>:"), "{e}");
        for (bad, shown) in [("0", "0"), ("180", "180"), ("-5", "-5"), ("200", "200"), ("1e30", "1e30")] {
            let e = camera(&format!("<heightangle v=\"{bad}\"/>")).unwrap_err();
            assert_eq!(at(&e), (3, 14), "{e}");
            assert!(
                e.message
                    .starts_with(&format!("<heightangle> is {shown} degrees (expected more than 0 and less than 180")),
                "{e}"
            );
        }
        let e = camera("<aspectratio v=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 14));
        // A position finite here but beyond the renderer's f32: at its attribute.
        let e = camera("<pos x=\"0\" y=\"-1e39\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 12), "{e}");
        assert!(e.message.contains("attribute `y` of <pos> is too large"), "{e}");
        let e = camera("<pos x=\"0\" y=\"1e-300\" z=\"1e38\"/><look x=\"0\" y=\"1e-300\" z=\"0\"/>").unwrap_err();
        assert!(e.message.contains("parallel to the look direction (0, 1e-300, 0)"), "numbers short: {e}");
    }

    #[test]
    fn second_camera_and_globals_are_ignored_with_warning() {
        let f = ok(&with_top(
            "<cameradata><heightangle v=\"30\"/></cameradata>\n<cameradata><heightangle v=\"60\"/></cameradata>",
        ));
        assert_eq!(f.camera.height_angle_deg, 30.0);
        warned_at(&f, 3, 1, "second <cameradata> (the first is at 2:1); ignored");
        let f = ok(&with_top("<globaldata/>\n<globaldata><ambientcoeff v=\"1\"/></globaldata>"));
        assert_eq!(f.globals.ka, 0.5);
        warned_at(&f, 3, 1, "second <globaldata>");
    }

    #[test]
    fn light_defaults() {
        let f = light("").unwrap();
        let l = &f.lights[0];
        assert_eq!(l.id, 0);
        assert_eq!(l.kind, LightKind::Point);
        assert_eq!(l.color, [1.0; 3]);
        assert_eq!(l.position, DVec3::splat(3.0));
        assert_eq!(l.attenuation, [1.0, 0.0, 0.0]);
        assert_eq!((l.angle_deg, l.penumbra_deg, l.width, l.height), (0.0, 0.0, 0.0, 0.0));
        assert_eq!((l.loc.line, l.loc.col), (2, 1));
    }

    #[test]
    fn light_all_elements() {
        let f = light(
            "<id v=\"7\"/><type v=\"spot\"/><color r=\"0.1\" g=\"0.2\" b=\"0.3\"/><position x=\"1\" y=\"2\" z=\"3\"/>\
             <direction x=\"0\" y=\"-1\" z=\"0\"/><function v1=\"0.8\" v2=\"0.05\" v3=\"0.01\"/><angle v=\"30\"/>\
             <penumbra v=\"20\"/><width v=\"2\"/><height v=\"3\"/>",
        )
        .unwrap();
        let l = &f.lights[0];
        assert_eq!(l.id, 7);
        assert_eq!(l.kind, LightKind::Spot);
        assert_eq!(l.color, [0.1, 0.2, 0.3]);
        assert_eq!(l.position, DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(l.direction, DVec3::new(0.0, -1.0, 0.0));
        assert_eq!(l.attenuation, [0.8, 0.05, 0.01]);
        assert_eq!((l.angle_deg, l.penumbra_deg, l.width, l.height), (30.0, 20.0, 2.0, 3.0));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        for (v, k) in [
            ("point", LightKind::Point),
            ("directional", LightKind::Directional),
            ("spot", LightKind::Spot),
            ("area", LightKind::Area),
        ] {
            let size = "<width v=\"1\"/><height v=\"1\"/>"; // an area light's; the others ignore it
            let f =
                light(&format!("<type v=\"{v}\"/><direction x=\"1\" y=\"0\" z=\"0\"/><angle v=\"1\"/>{size}")).unwrap();
            assert_eq!(f.lights[0].kind, k);
        }
        // Non-unique ids are fine; more than 8 lights are fine.
        let many = "<lightdata><id v=\"0\"/></lightdata>".repeat(12);
        let f = ok(&with_top(&many));
        assert_eq!(f.lights.len(), 12);
    }

    #[test]
    fn light_function_spellings() {
        for attrs in ["v1=\"1\" v2=\"2\" v3=\"3\"", "x=\"1\" y=\"2\" z=\"3\"", "a=\"1\" b=\"2\" c=\"3\""] {
            let f = light(&format!("<function {attrs}/>")).unwrap();
            assert_eq!(f.lights[0].attenuation, [1.0, 2.0, 3.0]);
        }
        let e = light("<function v1=\"1\" y=\"2\" z=\"3\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1));
        assert!(e.message.contains("mixes spellings"), "{e}");
        let e = light("<function v1=\"1\" v2=\"2\"/>").unwrap_err();
        assert!(e.message.contains("missing attribute `v3`"), "{e}");
        let e = light("<function/>").unwrap_err();
        assert!(e.message.contains("has no values (expected v1 v2 v3, x y z or a b c)"), "{e}");
    }

    #[test]
    fn light_errors_and_warnings() {
        let e = light("<type v=\"laser\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 7));
        assert!(e.message.contains("unknown light type \"laser\" (expected point, directional, spot or area)"), "{e}");
        let e = light("<type v=\"directonal\"/>").unwrap_err();
        assert!(e.message.contains("did you mean \"directional\"?"), "{e}");
        let e = light("<type v=\"directional\"/><direction x=\"0\" y=\"0\" z=\"0\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 24));
        assert!(e.message.contains("directional light's <direction> is the zero vector"), "{e}");
        let e = light("<type v=\"directional\"/>").unwrap_err();
        assert_eq!(at(&e), (2, 1));
        assert!(e.message.contains("has no <direction>"), "{e}");
        let e = light("<id v=\"1.5\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 5));
        // Numbers in messages are written short.
        let e = light("<id v=\"1e-38\"/>").unwrap_err();
        assert!(e.message.starts_with("light <id> is 1e-38 (expected a whole number)"), "{e}");
        let f = light("<type v=\"spot\"/><direction x=\"0\" y=\"-1\" z=\"0\"/>").unwrap();
        warned_at(&f, 2, 1, "spot light has no <angle>");
        // Light type absent means point.
        let f = light("<position x=\"1\" y=\"1\" z=\"1\"/>").unwrap();
        assert_eq!(f.lights[0].kind, LightKind::Point);
    }

    #[test]
    fn material_all_elements() {
        let f = ok(&prim(
            "sphere",
            "<diffuse r=\"0.1\" g=\"0.2\" b=\"0.3\"/><ambient r=\"0.4\" g=\"0.5\" b=\"0.6\"/>\
             <specular r=\"1\" g=\"1\" b=\"1\"/><reflective r=\"0.7\" g=\"0.7\" b=\"0.7\"/>\
             <transparent r=\"0.2\" g=\"0.2\" b=\"0.2\"/><emissive r=\"0.05\" g=\"0\" b=\"0\"/>\
             <shininess v=\"25\"/><ior v=\"1.5\"/><blend v=\"0.75\"/>\
             <texture file=\"a.png\" u=\"2\" v=\"3\"/><bumpmap file=\"b.png\"/>",
        ));
        let (_, m) = first_prim(&f);
        assert_eq!(m.diffuse, [0.1, 0.2, 0.3]);
        assert_eq!(m.ambient, [0.4, 0.5, 0.6]);
        assert_eq!(m.specular, [1.0; 3]);
        assert_eq!(m.reflective, [0.7; 3]);
        assert_eq!(m.transparent, [0.2; 3]);
        assert_eq!(m.emissive, [0.05, 0.0, 0.0]);
        assert_eq!((m.shininess, m.ior, m.blend), (25.0, 1.5, 0.75));
        let t = m.texture.as_ref().unwrap();
        assert_eq!((t.file.as_str(), t.repeat_u, t.repeat_v), ("a.png", 2.0, 3.0));
        assert_eq!((t.loc.line, t.loc.col), (5, 1 + "<diffuse r=\"0.1\" g=\"0.2\" b=\"0.3\"/><ambient r=\"0.4\" g=\"0.5\" b=\"0.6\"/><specular r=\"1\" g=\"1\" b=\"1\"/><reflective r=\"0.7\" g=\"0.7\" b=\"0.7\"/><transparent r=\"0.2\" g=\"0.2\" b=\"0.2\"/><emissive r=\"0.05\" g=\"0\" b=\"0\"/><shininess v=\"25\"/><ior v=\"1.5\"/><blend v=\"0.75\"/>".len() as u32));
        let b = m.bumpmap.as_ref().unwrap();
        assert_eq!((b.file.as_str(), b.repeat_u, b.repeat_v), ("b.png", 1.0, 1.0));
        // The texture does not exist: a warning, no error. The bump map is
        // ignored (a warning that says so), its image not looked for.
        assert_eq!(f.warnings.iter().filter(|w| w.message.contains("not found")).count(), 1);
        assert!(f.warnings.iter().any(|w| w.message.contains("<bumpmap> is ignored")), "{:?}", f.warnings);
    }

    #[test]
    fn material_duplicate_and_unknown_children() {
        let f = ok(&prim(
            "cube",
            "<diffuse r=\"1\" g=\"0\" b=\"0\"/>\n<diffuse r=\"0\" g=\"1\" b=\"0\"/>\n<glow v=\"1\"/>",
        ));
        assert_eq!(first_prim(&f).1.diffuse, [0.0, 1.0, 0.0]);
        warned_at(&f, 6, 1, "second <diffuse> in <object> (the first is at 5:1); the later one is used");
        warned_at(&f, 7, 1, "unknown element <glow> in <object>");
    }

    #[test]
    fn texture_resolution() {
        let dir = std::env::temp_dir().join(format!("raycast-parse-tex-{}", std::process::id()));
        let scene_dir = dir.join("scenes");
        let assets = dir.join("assets");
        std::fs::create_dir_all(scene_dir.join("img")).unwrap();
        std::fs::create_dir_all(assets.join("image")).unwrap();
        std::fs::write(scene_dir.join("img/local.png"), b"x").unwrap();
        std::fs::write(assets.join("image/a.png"), b"x").unwrap();
        std::fs::write(assets.join("x.png"), b"x").unwrap();
        let o = ParseOptions { assets: vec![assets.clone()], ..ParseOptions::default() };
        let xml_path = scene_dir.join("s.xml");
        let abs_ok = scene_dir.join("img/local.png");
        let tex = |file: &str| {
            let xml = prim("cube", &format!("<texture file=\"{file}\"/>"));
            let f = parse_str(&xml, &xml_path, &o).unwrap();
            let t = first_prim(&f).1.texture.clone().unwrap();
            (t.resolved, f.warnings)
        };
        // Relative to the XML file's folder.
        let (r, w) = tex("img/local.png");
        assert_eq!(r, Some(scene_dir.join("img/local.png")));
        assert!(w.is_empty());
        // Relative to an assets folder.
        let (r, w) = tex("image/a.png");
        assert_eq!(r, Some(assets.join("image/a.png")));
        assert!(w.is_empty());
        // Absolute and present.
        let (r, w) = tex(&abs_ok.display().to_string());
        assert_eq!(r, Some(abs_ok.clone()));
        assert!(w.is_empty());
        // Absolute and absent: its file name in the folders, with a warning.
        let (r, w) = tex("/course/cs123/data/image/x.png");
        assert_eq!(r, Some(assets.join("x.png")));
        assert_eq!(w.len(), 1);
        assert!(w[0].message.contains("does not exist; using"), "{}", w[0]);
        assert_eq!(wat(&w[0]), (5, 1));
        // Not found anywhere: None and a warning naming the places tried.
        let (r, w) = tex("image/missing.png");
        assert_eq!(r, None);
        assert_eq!(w.len(), 1);
        let m = &w[0].message;
        assert!(m.contains("not found") && m.contains(&scene_dir.join("image/missing.png").display().to_string()));
        assert!(m.contains(&assets.join("image/missing.png").display().to_string()), "{m}");
        assert!(m.contains("and the 3 folders above the scene's)"), "{m}");
        // In a folder above the scene's (a corpus root: paths relative to it),
        // after the scene's folder and the assets: used, with a warning
        // naming the folder; the scene's own folder and the assets first.
        let root = dir.canonicalize().unwrap();
        std::fs::create_dir_all(root.join("image")).unwrap();
        std::fs::write(root.join("image/up.png"), b"x").unwrap();
        std::fs::write(root.join("image/a.png"), b"x").unwrap();
        let (r, w) = tex("image/up.png");
        assert_eq!(r, Some(root.join("image/up.png")));
        assert_eq!(w.len(), 1);
        let m = &w[0].message;
        assert!(m.contains(&format!("found 1 folder above the scene's, in \"{}\"", root.display())), "{m}");
        assert!(m.contains(&format!("--assets {} says so", root.display())), "{m}");
        let (r, w) = tex("image/a.png");
        assert_eq!((r, w.len()), (Some(assets.join("image/a.png")), 0));
        // Absolute and absent, its trailing folders in a folder above the
        // scene's: the longest that is there wins, with a warning.
        let (r, w) = tex("/course/cs123/data/image/up.png");
        assert_eq!(r, Some(root.join("image/up.png")));
        assert!(
            w[0].message.contains(&format!("using \"{}\" instead", root.join("image/up.png").display())),
            "{}",
            w[0]
        );
        let (r, w) = tex("/course/cs123/data/image/a.png");
        assert_eq!(r, Some(assets.join("image/a.png")), "the assets before the folders above: {w:?}");
        let typo = ParseOptions { assets: vec![assets.clone(), dir.join("asets")], ..ParseOptions::default() };
        let f = parse_str(&prim("cube", "<texture file=\"image/gone.png\"/>"), &xml_path, &typo).unwrap();
        let m = &f.warnings[0].message;
        assert!(m.contains(&format!("; --assets {} is not a folder:", dir.join("asets").display())), "{m}");
        assert!(!m.contains(&format!("--assets {} is not", assets.display())), "{m}");
        let (r, w) = tex("/course/cs123/data/image/gone.png");
        assert_eq!(r, None);
        assert!(
            w[0].message.contains("and its trailing folders in those and the 3 folders above the scene's"),
            "{}",
            w[0]
        );
        assert!(w[0].message.contains(&assets.join("gone.png").display().to_string()), "{}", w[0]);
        // No further than FOLDERS_ABOVE: a scene four folders below the image.
        let deep = root.join("scenes/a/b/c");
        std::fs::create_dir_all(&deep).unwrap();
        let xml = prim("cube", "<texture file=\"image/up.png\"/>");
        let f = parse_str(&xml, &deep.join("s.xml"), &opts()).unwrap();
        assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
        let f = parse_str(&xml, &root.join("scenes/a/b/s.xml"), &opts()).unwrap();
        assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, Some(root.join("image/up.png")));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// The torus has one canonical size (docs/scene-format.md#torus): a
    /// radius written on it is warned about and ignored, a misspelling is
    /// an error with a suggestion, and it takes a material as any shape.
    #[test]
    fn torus_takes_no_size_and_a_material() {
        let f = ok(&block("<object type=\"primitive\" name=\"torus\" radius=\"2\" tube=\"0.1\"/>"));
        assert_eq!(*first_prim(&f).0, Shape::Torus);
        warned_at(&f, 4, 39, "unknown attribute `radius` on <object>");
        warned_at(&f, 4, 50, "unknown attribute `tube` on <object>");
        bad_at(&block("<object type=\"primitive\" name=\"tours\"/>"), 4, 26, "did you mean \"torus\"?");
        bad_at(&block("<object type=\"primitive\" name=\"Torus\"/>"), 4, 26, "unknown primitive \"Torus\"");
        let f = ok(&prim("torus", "<diffuse r=\"0.5\" g=\"0.25\" b=\"1\"/><reflective r=\"1\" g=\"1\" b=\"1\"/>"));
        let (shape, m) = first_prim(&f);
        assert_eq!((shape, m.diffuse, m.reflective), (&Shape::Torus, [0.5, 0.25, 1.0], [1.0, 1.0, 1.0]));
        bad_at(&prim("torus", "<diffuse r=\"x\" g=\"0\" b=\"0\"/>"), 5, 10, "");
    }

    #[test]
    fn primitive_shapes() {
        for (name, shape) in [
            ("cube", Shape::Cube),
            ("cone", Shape::Cone),
            ("cylinder", Shape::Cylinder),
            ("sphere", Shape::Sphere),
            ("torus", Shape::Torus),
        ] {
            assert_eq!(*first_prim(&ok(&prim(name, ""))).0, shape);
        }
        let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\"/>"));
        assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "a.obj".into(), resolved: None });
        let f = ok(&block("<object type=\"primitive\" name=\"mesh\" filename=\"b.obj\"/>"));
        assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "b.obj".into(), resolved: None });
        bad_at(&block("<object type=\"primitive\" name=\"mesh\"/>"), 4, 1, "needs meshfile=");
        bad_at(
            &block("<object type=\"primitive\" name=\"triangle\"/>"),
            4,
            26,
            "unknown primitive \"triangle\" (expected cube, cone, cylinder, sphere, torus or mesh)",
        );
        bad_at(&block("<object type=\"primitive\" name=\"shpere\"/>"), 4, 26, "did you mean \"sphere\"?");
        bad_at(&block("<object type=\"primitive\"/>"), 4, 1, "<object> is missing attribute `name`");
        bad_at(&block("<object type=\"thing\" name=\"cube\"/>"), 4, 9, "unknown object type \"thing\"");
        bad_at(&block("<object name=\"cube\"/>"), 4, 1, "<object> is missing attribute `type`");
    }

    /// The mesh element: meshfile= or filename=, both (a warning, meshfile
    /// wins), neither (an error at the element), a misspelt attribute, and
    /// meshfile= on another shape (ignored with a warning).
    #[test]
    fn mesh_element_cases() {
        let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\" filename=\"b.obj\"/>"));
        assert_eq!(*first_prim(&f).0, Shape::Mesh { file: "a.obj".into(), resolved: None });
        warned_at(&f, 4, 1, "mesh has both meshfile= and filename=; using meshfile");
        let e = bad_at(&block("<object type=\"primitive\" name=\"mesh\"/>"), 4, 1, "needs meshfile=\"file.obj\"");
        assert!(e.to_string().contains("test.xml:4:1: error:"), "{e}");
        bad_at(&block("<object type=\"primitive\" name=\"mesh\" meshfle=\"a.obj\"/>"), 4, 1, "needs meshfile=");
        let xml = block("<object type=\"primitive\" name=\"mesh\" meshfile=\"a.obj\" meshfle=\"b.obj\"/>");
        let (line, col) = pos_of(&xml, "meshfle=");
        warned_at(&ok(&xml), line, col, "unknown attribute `meshfle` on <object> (did you mean `meshfile`?)");
        let xml = block("<object type=\"primitive\" name=\"sphere\" meshfile=\"a.obj\"/>");
        let f = ok(&xml);
        assert_eq!(*first_prim(&f).0, Shape::Sphere);
        let (line, col) = pos_of(&xml, "meshfile=");
        warned_at(&f, line, col, "unknown attribute `meshfile` on <object>");
        // An empty name parses; flatten() refuses it as a file not found.
        let f = ok(&block("<object type=\"primitive\" name=\"mesh\" meshfile=\"\"/>"));
        assert_eq!(*first_prim(&f).0, Shape::Mesh { file: String::new(), resolved: None });
    }

    #[test]
    fn transforms_parse() {
        let f = ok(&block(
            "<translate x=\"1\" y=\"2\" z=\"3\"/><rotate x=\"0\" y=\"2\" z=\"0\" angle=\"90\"/><scale x=\"4\" y=\"5\" z=\"6\"/>\
             <object type=\"primitive\" name=\"cube\"/>",
        ));
        let b = &f.trees[f.root].blocks[0];
        assert_eq!(
            b.transforms,
            vec![
                Transform::Translate(DVec3::new(1.0, 2.0, 3.0)),
                Transform::Rotate { axis: DVec3::new(0.0, 2.0, 0.0), angle_deg: 90.0 },
                Transform::Scale(DVec3::new(4.0, 5.0, 6.0)),
            ]
        );
        let expect = DMat4::from_translation(DVec3::new(1.0, 2.0, 3.0))
            * DMat4::from_rotation_y(90f64.to_radians())
            * DMat4::from_scale(DVec3::new(4.0, 5.0, 6.0));
        assert!(b.matrix.abs_diff_eq(expect, 1e-12));
    }

    #[test]
    fn object_may_come_before_transforms() {
        let f = ok(&block("<object type=\"primitive\" name=\"cube\"/><translate x=\"1\" y=\"0\" z=\"0\"/>"));
        let b = &f.trees[f.root].blocks[0];
        assert_eq!(b.transforms.len(), 1);
        assert_eq!(b.matrix.transform_point3(DVec3::ZERO), DVec3::X);
    }

    #[test]
    fn rotate_axis_need_not_be_unit() {
        let f = ok(&block("<rotate x=\"0\" y=\"0\" z=\"5\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"));
        let m = f.trees[f.root].blocks[0].matrix;
        assert!(m.transform_point3(DVec3::X).abs_diff_eq(DVec3::Y, 1e-12));
        bad_at(
            &block("<rotate x=\"0\" y=\"0\" z=\"0\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            1,
            "<rotate> has the zero vector as its axis",
        );
    }

    #[test]
    fn matrix_is_row_major_with_translation_in_fourth_column() {
        let f = ok(&block(
            "<matrix>\
             <row0 v1=\"2\" v2=\"0\" v3=\"0\" v4=\"10\"/>\
             <row1 v1=\"0\" v2=\"3\" v3=\"0\" v4=\"20\"/>\
             <row2 a=\"0\" b=\"0\" c=\"4\" d=\"30\"/>\
             <row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/>\
             </matrix><object type=\"primitive\" name=\"cube\"/>",
        ));
        let b = &f.trees[f.root].blocks[0];
        assert_eq!(b.matrix.transform_point3(DVec3::ONE), DVec3::new(12.0, 23.0, 34.0));
        assert_eq!(b.matrix.w_axis, glam::DVec4::new(10.0, 20.0, 30.0, 1.0));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        // A shear entry lands where it is written: row 0, column 1.
        let f = ok(&block(
            "<matrix><row0 v1=\"1\" v2=\"5\" v3=\"0\" v4=\"0\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
             <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/></matrix>\
             <object type=\"primitive\" name=\"cube\"/>",
        ));
        assert_eq!(f.trees[f.root].blocks[0].matrix.transform_point3(DVec3::Y), DVec3::new(5.0, 1.0, 0.0));
        bad_at(
            &block("<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"0\"/></matrix><object type=\"primitive\" name=\"cube\"/>"),
            4,
            1,
            "<matrix> has no <row1>",
        );
        // The last row is ignored, with a warning at it: the renderer's
        // transforms are affine (matrix_last_row_is_ignored_with_a_warning).
        let xml = block(
            "<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"0\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
             <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"1\"/></matrix>\
             <object type=\"primitive\" name=\"cube\"/>",
        );
        let f = ok(&xml);
        let (line, col) = pos_of(&xml, "<row3");
        warned_at(
            &f,
            line,
            col,
            "<matrix> row3 is 0 0 1 1, not 0 0 0 1: raycast's transforms are affine; the last row is ignored",
        );
        assert_eq!(f.trees[f.root].blocks[0].matrix, DMat4::IDENTITY);
    }

    #[test]
    fn transblock_needs_an_object_and_takes_several_with_a_warning() {
        bad_at(&block("<translate x=\"1\" y=\"0\" z=\"0\"/>"), 3, 1, "<transblock> has no <object>");
        // Several, as the course's parser takes them: each drawn with the
        // transblock's transforms, the same as a transblock apiece.
        let two = "<object type=\"primitive\" name=\"cube\"/>\n<object type=\"primitive\" name=\"sphere\"/>";
        let f = ok(&block(&format!("<translate x=\"1\" y=\"2\" z=\"3\"/>\n{two}")));
        warned_at(&f, 6, 1, "a second <object> in one <transblock> (the first is at 5:1); each is drawn");
        let apart = ok(&root(
            "<transblock><translate x=\"1\" y=\"2\" z=\"3\"/><object type=\"primitive\" name=\"cube\"/></transblock>\n\
             <transblock><translate x=\"1\" y=\"2\" z=\"3\"/><object type=\"primitive\" name=\"sphere\"/></transblock>",
        ));
        let flat = |f: &SceneFile| {
            let s = crate::scene::flatten(f, &crate::scene::FlattenLimits::default()).unwrap();
            s.flat_primitives().into_iter().map(|p| (format!("{:?}", p.shape), p.world_from_object)).collect::<Vec<_>>()
        };
        assert_eq!(flat(&f), flat(&apart), "two objects in one transblock, against a transblock each");
        assert_eq!(flat(&f).len(), 2);
        let f = ok(&block("<object type=\"primitive\" name=\"cube\"/>\n<frobnicate/>"));
        warned_at(&f, 5, 1, "unknown element <frobnicate> in <transblock> (expected translate, rotate, scale, matrix or object); skipped");
    }

    #[test]
    fn missing_attributes_are_errors() {
        bad_at(
            &block("<translate x=\"1\" y=\"2\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            1,
            "<translate> is missing attribute `z` (expected x, y and z)",
        );
        bad_at(
            &block("<rotate x=\"0\" y=\"1\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            1,
            "<rotate> is missing attribute `angle`",
        );
        bad_at(&prim("cube", "<diffuse r=\"1\" g=\"1\"/>"), 5, 1, "<diffuse> is missing attribute `b`");
        bad_at(&prim("cube", "<shininess/>"), 5, 1, "<shininess> is missing attribute `v`");
        bad_at(&prim("cube", "<texture u=\"1\"/>"), 5, 1, "<texture> is missing attribute `file`");
    }

    #[test]
    fn bad_numbers_are_errors_at_the_attribute() {
        for (v, msg) in [
            ("=0.1", "is \"=0.1\", which is not a number"),
            ("abc", "is \"abc\", which is not a number"),
            ("1,5", "which is not a number"),
            ("nan", "is \"nan\" (expected a finite number)"),
            ("NaN", "expected a finite number"),
            ("inf", "expected a finite number"),
            ("-infinity", "expected a finite number"),
            ("1e400", "expected a finite number"),
        ] {
            let e = bad_at(
                &block(&format!("<translate x=\"0\" y=\"{v}\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>")),
                4,
                18,
                msg,
            );
            assert!(e.message.starts_with("attribute `y` of <translate>"), "{e}");
        }
        // f32 fields: finite in f64 but not in f32.
        bad_at(&prim("cube", "<shininess v=\"1e39\"/>"), 5, 12, "too large");
        // An empty number reads as 0, as the course's parser reads it, with a warning there.
        for v in ["", "  "] {
            let f = ok(&block(&format!(
                "<translate x=\"0\" y=\"{v}\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>"
            )));
            warned_at(&f, 4, 18, "attribute `y` of <translate> is empty; read as 0");
        }
        let f = ok(&block("<rotate x=\"0\" y=\"1\" z=\"\" angle=\"90\"/><object type=\"primitive\" name=\"cube\"/>"));
        warned_at(&f, 4, 21, "attribute `z` of <rotate> is empty; read as 0");
        // Whitespace around a number is tolerated.
        let f = ok(&prim("cube", "<shininess v=\" 12 \"/>"));
        assert_eq!(first_prim(&f).1.shininess, 12.0);
    }

    #[test]
    fn unknown_attributes_warn_with_suggestions() {
        let f = ok(&prim("cube", "<diffuse r=\"1\" g=\"1\" b=\"1\" alpha=\"1\"/>\n<shininess v=\"1\" V=\"2\"/>"));
        warned_at(&f, 5, 28, "unknown attribute `alpha` on <diffuse> (expected r, g or b); ignored");
        warned_at(&f, 6, 18, "unknown attribute `V` on <shininess> (did you mean `v`?); ignored");
        let f = ok(&block("<object type=\"primitive\" name=\"cube\" colour=\"red\"/>"));
        warned_at(&f, 4, 38, "unknown attribute `colour` on <object> (expected type or name)");
    }

    #[test]
    fn misspelled_type_warns_then_errors() {
        // Wild file: `typr="tree"` on the top-level tree.
        let xml = "<scenefile>\n  <object typr=\"tree\" name=\"root\">\n  </object>\n</scenefile>";
        let e = bad_at(xml, 2, 11, "<object> is missing attribute `type` (found `typr`: did you mean `type`?)");
        let _ = e;
        // Inside a transblock as well.
        bad_at(&block("<object typr=\"primitive\" name=\"cube\"/>"), 4, 9, "did you mean `type`?");
        // The warning is emitted on its own where the attribute is optional.
        let f = ok(&block("<object type=\"primitive\" name=\"cube\" nmae=\"x\"/>"));
        warned_at(&f, 4, 38, "unknown attribute `nmae` on <object> (did you mean `name`?)");
    }

    #[test]
    fn unknown_elements_warn_and_are_skipped() {
        let xml = "<scenefile>\n  <fog density=\"1\"/>\n  <lightdata><colour r=\"1\" g=\"1\" b=\"1\"/></lightdata>\n\
                   <object type=\"tree\" name=\"root\"><cube/><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object>\n</scenefile>";
        let f = ok(xml);
        warned_at(
            &f,
            2,
            3,
            "unknown top-level element <fog> (expected globaldata, cameradata, lightdata or object); skipped",
        );
        warned_at(&f, 3, 14, "unknown element <colour> in <lightdata> (did you mean <color>?); skipped");
        warned_at(&f, 4, 33, "unknown element <cube> in <object> (expected transblock)");
        assert_eq!(f.trees[f.root].blocks.len(), 1);
        let f = ok("<scenefile>\n<camreadata/>\n<object type=\"tree\" name=\"root\"/></scenefile>");
        warned_at(&f, 2, 1, "did you mean <cameradata>?");
    }

    #[test]
    fn trees_and_masters() {
        let xml = "<scenefile>\n\
            <object type=\"tree\" name=\"m\"><transblock><object type=\"primitive\" name=\"cone\"/></transblock></object>\n\
            <object type=\"tree\" name=\"root\">\n\
            <transblock><object type=\"master\" name=\"m\"/></transblock>\n\
            <transblock><object type=\"tree\"><transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>\n\
            </object>\n</scenefile>";
        let f = ok(xml);
        assert_eq!(f.trees.len(), 2);
        assert_eq!(f.root, 1);
        let blocks = &f.trees[1].blocks;
        assert!(matches!(blocks[0].object, Node::Master { tree: 0, .. }));
        match &blocks[1].object {
            Node::Tree { blocks, loc } => {
                assert_eq!((loc.line, loc.col), (5, 13));
                assert!(matches!(blocks[0].object, Node::Primitive { shape: Shape::Cube, .. }));
            }
            o => panic!("{o:?}"),
        }
    }

    #[test]
    fn master_errors() {
        let used_before = "<scenefile>\n\
            <object type=\"tree\" name=\"root\"><transblock><object type=\"master\" name=\"later\"/></transblock></object>\n\
            <object type=\"tree\" name=\"later\"><transblock><object type=\"primitive\" name=\"cone\"/></transblock></object>\n\
            </scenefile>";
        bad_at_str(used_before, "name=\"later\"/>", "master \"later\" is used before its tree is declared (at 3:1)");
        let unknown = root("<transblock><object type=\"master\" name=\"nope\"/></transblock>");
        bad_at(&unknown, 3, 35, "unknown master \"nope\"");
        let selfref = root("<transblock><object type=\"master\" name=\"root\"/></transblock>");
        bad_at(&selfref, 3, 35, "uses itself as a master");
        bad_at(&root("<transblock><object type=\"master\"/></transblock>"), 3, 13, "missing attribute `name`");
    }

    #[test]
    fn top_level_tree_errors() {
        bad_at(
            "<scenefile>\n<object type=\"primitive\" name=\"cube\"/>\n</scenefile>",
            2,
            9,
            "a top-level <object> has type=\"primitive\" (expected type=\"tree\"",
        );
        bad_at("<scenefile>\n<object type=\"tree\"/>\n</scenefile>", 2, 1, "missing attribute `name`");
        let dup = "<scenefile>\n<object type=\"tree\" name=\"a\"/>\n<object type=\"tree\" name=\"root\"/>\n  <object type=\"tree\" name=\"a\"/>\n</scenefile>";
        bad_at(dup, 4, 23, "a second tree named \"a\" (the first is at 2:1)");
        let e =
            bad_at("<scenefile>\n<object type=\"tree\" name=\"main\"/>\n</scenefile>", 1, 1, "no tree named \"root\"");
        assert!(e.message.contains("trees found: main"), "{e}");
        bad_at("<scenefile/>", 1, 1, "no tree named \"root\" (the file has no trees)");
    }

    #[test]
    fn xml_and_file_errors() {
        let e = bad_at(
            "<scenefile>\n<object type=\"tree\" name=\"root\">\n<transblock>\n</object>\n</scenefile>",
            4,
            1,
            "malformed XML",
        );
        assert!(e.message.contains("found </object> while <transblock> is still open"), "{e}");
        bad_at("<scenefile>\n<object", 2, 8, "malformed XML");
        bad_at("<scenefile>\n", 2, 1, "malformed XML: the file ends");
        bad_at("", 1, 1, "malformed XML");
        bad_at("<scene>\n</scene>", 1, 1, "the root element is <scene>, expected <scenefile>");
        bad_at("<scenefile><a x=\"1\" x=\"2\"/></scenefile>", 1, 21, "malformed XML: attribute 'x'");
        // A byte-order mark does not shift columns.
        let f = p(&format!("\u{feff}{}", prim("cube", "<glow/>"))).unwrap();
        warned_at(&f, 5, 1, "<glow>");

        let dir = std::env::temp_dir().join(format!("raycast-parse-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let missing = dir.join("missing.xml");
        let e = parse_file(&missing, &opts()).unwrap_err();
        assert!(e.loc.is_none());
        assert!(e.message.contains("missing.xml") && e.message.contains("cannot read"), "{e}");
        let latin1 = dir.join("latin1.xml");
        std::fs::write(&latin1, b"<scenefile>\n<!-- caf\xe9 -->\n</scenefile>").unwrap();
        let e = parse_file(&latin1, &opts()).unwrap_err();
        assert_eq!(at(&e), (2, 9));
        assert!(e.message.contains("not valid UTF-8"), "{e}");
        let good = dir.join("good.xml");
        std::fs::write(&good, prim("cube", "")).unwrap();
        let f = parse_file(&good, &opts()).unwrap();
        assert_eq!(*f.path, good);
        let _ = std::fs::remove_dir_all(&dir);
    }

    fn nested(depth: usize) -> String {
        let mut s = String::from("<scenefile><object type=\"tree\" name=\"root\">");
        for _ in 0..depth - 1 {
            s.push_str("<transblock><object type=\"tree\">");
        }
        s.push_str("<transblock><object type=\"primitive\" name=\"cube\"/></transblock>");
        for _ in 0..depth - 1 {
            s.push_str("</object></transblock>");
        }
        s.push_str("</object></scenefile>");
        s
    }

    #[test]
    fn nesting_is_limited() {
        ok(&nested(MAX_NESTING));
        let e = bad(&nested(MAX_NESTING + 1));
        assert!(e.message.contains("nested more than 256 deep"), "{e}");
        // Far deeper: still an error, not a stack overflow.
        let e = bad(&nested(50_000));
        assert!(e.message.contains("elements are nested more than 1024 deep"), "{e}");
        let pile = format!("<scenefile>\n{}", "<a>".repeat(100_000));
        bad_at(&pile, 2, 3070, "elements are nested more than 1024 deep");
        // Markup that does not nest is not counted.
        let flat = format!(
            "<scenefile><!-- <a><a> -->{}<![CDATA[<a><a>]]><?pi <a> ?></scenefile>",
            "<b x='<<' y=\"/>\"/><c></c>".repeat(5000)
        );
        assert_eq!(too_deep(&flat, 3), None);
        assert_eq!(too_deep("<a><b><c><d>", 3), Some(9));
        bad_at("<!DOCTYPE s [<!ENTITY e \"<a/>\">]>\n<scenefile/>", 1, 1, "a DTD with declarations is not supported");
    }

    #[test]
    fn wild_file_problems() {
        // Each problem of docs/scene-format.md#files-in-the-wild.
        // Misspelled attribute: see misspelled_type_warns_then_errors.
        // Unknown top-level element: a warning, the rest is read.
        let f = ok(&with_top("<include file=\"x.xml\"/>"));
        warned_at(&f, 2, 1, "unknown top-level element <include>");
        // A primitive named triangle.
        bad_at(&prim("triangle", ""), 4, 26, "unknown primitive \"triangle\"");
        // Numbers written "" (read as 0, as the course's parser reads it, with a warning) or "=0.1" (an error).
        let f = ok(&prim("cube", "<blend v=\"\"/>"));
        warned_at(&f, 5, 8, "attribute `v` of <blend> is empty; read as 0");
        bad_at(
            &prim("cube", "<blend v=\"=0.1\"/>"),
            5,
            8,
            "attribute `v` of <blend> is \"=0.1\", which is not a number",
        );
        // No root tree.
        bad_at("<scenefile>\n<object type=\"tree\" name=\"scene\"/>\n</scenefile>", 1, 1, "no tree named \"root\"");
        // Absolute texture path: a warning (not found), the scene still loads.
        let f = ok(&prim("cube", "<texture file=\"/course/cs123/data/image/x.png\"/>"));
        assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
        warned_at(&f, 5, 1, "<texture> file \"/course/cs123/data/image/x.png\" not found (tried \"/course/cs123/data/image/x.png\", \"/nonexistent-dir/x.png\", and its trailing folders in those and the 3 folders above the scene's)");
        // A texture that names a folder or a device: said so, not "not found".
        for (there, what) in [(std::env::temp_dir(), "a folder"), (PathBuf::from("/dev/null"), "not a regular file")] {
            let f = ok(&prim("cube", &format!("<texture file=\"{}\"/>", there.display())));
            assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
            warned_at(&f, 5, 1, &format!("<texture> file \"{0}\" is {what} (\"{0}\"), not a picture", there.display()));
        }
        // A rotate without angle.
        bad_at(
            &block("  <rotate x=\"1\" y=\"0\" z=\"0\"/>\n<object type=\"primitive\" name=\"cube\"/>"),
            4,
            3,
            "<rotate> is missing attribute `angle`",
        );
    }

    #[test]
    fn never_panics_on_mangled_input() {
        let base = with_top(
            "<globaldata><ambientcoeff v=\"0.5\"/></globaldata><cameradata><pos x=\"1\" y=\"2\" z=\"3\"/><focus x=\"0\" y=\"0\" z=\"0\"/></cameradata>\
             <lightdata><type v=\"spot\"/><direction x=\"0\" y=\"-1\" z=\"0\"/><function a=\"1\" b=\"0\" c=\"0\"/></lightdata>\
             <object type=\"tree\" name=\"m\"><transblock><rotate x=\"1\" y=\"0\" z=\"0\" angle=\"30\"/><object type=\"primitive\" name=\"sphere\"><diffuse r=\"1\" g=\"0\" b=\"0\"/><texture file=\"t.png\"/></object></transblock></object>",
        );
        // Every prefix.
        for (i, _) in base.char_indices() {
            let _ = p(&base[..i]);
        }
        // Deterministic byte edits.
        let chars: Vec<char> = base.chars().collect();
        let alphabet: Vec<char> = "<>/=\" x0.-e\u{e9}\n".chars().collect();
        let mut seed: u64 = 0x2545_f491_4f6c_dd1d;
        for _ in 0..3000 {
            let mut c = chars.clone();
            for _ in 0..3 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                let at = (seed as usize) % c.len();
                let ch = alphabet[(seed >> 32) as usize % alphabet.len()];
                match (seed >> 40) % 3 {
                    0 => c[at] = ch,
                    1 => c.insert(at, ch),
                    _ => {
                        c.remove(at);
                    }
                }
            }
            let s: String = c.into_iter().collect();
            if let Ok(f) = p(&s) {
                let _ = crate::scene::flatten(&f, &Default::default());
            }
        }
    }

    #[test]
    fn one_long_line_is_fast_and_positions_exact() {
        let blocks = "<transblock><object type=\"primitive\" name=\"cube\"/></transblock>".repeat(20_000);
        let xml = format!("<scenefile><object type=\"tree\" name=\"root\">{blocks}<transblock><object type=\"primitive\" name=\"cub\"/></transblock></object></scenefile>");
        let t = std::time::Instant::now();
        bad_at_str(&xml, "name=\"cub\"", "did you mean \"cube\"?");
        assert!(t.elapsed().as_secs_f64() < 2.0);
        // Positions asked for out of order are still right.
        let xml = "<scenefile><object type=\"tree\" name=\"a\"/><object type=\"tree\" name=\"a\"/></scenefile>";
        bad_at_str(xml, "name=\"a\"/></scenefile>", "a second tree named \"a\" (the first is at 1:12)");
    }

    #[test]
    fn edit_distance_and_suggestions() {
        assert_eq!(edit_distance("typr", "type"), 1);
        assert_eq!(edit_distance("", "abc"), 3);
        assert_eq!(suggest("typr", &["type", "name"]), Some("type"));
        assert_eq!(suggest("X", &["x", "y"]), Some("x"));
        assert_eq!(suggest("w", &["x", "y", "z"]), None);
        assert_eq!(suggest("colour", &["type", "name"]), None);
    }

    #[test]
    fn missing_attribute_suggests_only_names_the_element_does_not_take() {
        // `v1` is one of <function>'s own attributes, not a misspelt `v2`.
        let e = light("<function v1=\"1\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1), "{e}");
        assert_eq!(e.message, "<function> is missing attribute `v2` (expected v1, v2 and v3)");
        let e = bad_at(
            &block("<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\"/></matrix><object type=\"primitive\" name=\"cube\"/>"),
            4,
            9,
            "<row0> is missing attribute `v4` (expected v1, v2, v3 and v4)",
        );
        assert!(!e.message.contains("did you mean"), "{e}");
        let e = bad_at(
            &block("<translate x=\"1\" y=\"2\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            1,
            "<translate> is missing attribute `z` (expected x, y and z)",
        );
        assert!(!e.message.contains("did you mean"), "{e}");
        // A name the element does not take is still offered.
        let e = light("<function v1=\"1\" v2=\"2\" v33=\"3\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 25), "{e}");
        assert!(e.message.contains("missing attribute `v3` (found `v33`: did you mean `v3`?)"), "{e}");
        bad_at(
            &block("<rotate x=\"1\" y=\"0\" z=\"0\" angel=\"90\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            27,
            "<rotate> is missing attribute `angle` (found `angel`: did you mean `angle`?)",
        );
    }

    #[test]
    fn object_type_misspelt_or_in_the_wrong_case_gets_a_suggestion() {
        bad_at(
            &block("<object type=\"Primitive\" name=\"cube\"/>"),
            4,
            9,
            "unknown object type \"Primitive\" (expected primitive, tree or master; did you mean \"primitive\"?)",
        );
        bad_at(&block("<object type=\"mastr\" name=\"m\"/>"), 4, 9, "did you mean \"master\"?");
        let e = bad_at(&block("<object type=\"thing\" name=\"cube\"/>"), 4, 9, "unknown object type \"thing\"");
        assert!(!e.message.contains("did you mean"), "{e}");
    }

    #[test]
    fn what_follows_the_root_element_is_named() {
        let doc = "<scenefile>\n<object type=\"tree\" name=\"root\"/>\n</scenefile>\n";
        bad_at(
            &format!("{doc}<x a=\"1\"/>\n"),
            4,
            1,
            "malformed XML: a second root element <x> after </scenefile>: a scene file has one <scenefile>",
        );
        bad_at(&format!("{doc}  hello\n"), 4, 3, "malformed XML: text \"hello\" after the root element </scenefile>");
        bad_at(&format!("{doc}</scenefile>\n"), 4, 1, "malformed XML: a close tag </scenefile> after the root element");
        // Comments after the root are fine.
        ok(&format!("{doc}<!-- end -->\n"));
        // Inside the root, an unknown token is still reported as one.
        bad_at("<scenefile>\n<!x>\n</scenefile>", 2, 1, "malformed XML: unknown token");
    }

    #[test]
    fn a_lone_carriage_return_ends_a_line() {
        // Old Mac files end lines with CR alone; XML reads it as a line break.
        let cr = "<scenefile>\r\r<cameradata><heightangle v=\"x\"/></cameradata>\r</scenefile>";
        bad_at(cr, 3, 26, "attribute `v` of <heightangle> is \"x\"");
        bad_at(&cr.replace('\r', "\r\n"), 3, 26, "attribute `v` of <heightangle> is \"x\"");
        bad_at(&cr.replacen('\r', "\r\n", 1), 3, 26, "attribute `v` of <heightangle> is \"x\"");
        // Warnings, and the XML parser's own positions.
        let f = ok(&prim("cube", "<glow/>").replace('\n', "\r"));
        warned_at(&f, 5, 1, "<glow>");
        bad_at(
            "<scenefile>\r<object type=\"tree\" name=\"root\">\r<transblock>\r</object>\r</scenefile>",
            4,
            1,
            "found </object> while <transblock> is still open",
        );
        bad_at("<scenefile>\r<object", 2, 8, "malformed XML");
        bad_at("<scenefile>\r<a x=\"1\" x=\"2\"/></scenefile>", 2, 10, "malformed XML: attribute 'x'");
        // Bytes that are not UTF-8.
        let dir = std::env::temp_dir().join(format!("raycast-parse-cr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let latin1 = dir.join("latin1.xml");
        std::fs::write(&latin1, b"<scenefile>\r<!-- caf\xe9 -->\r</scenefile>").unwrap();
        let e = parse_file(&latin1, &opts()).unwrap_err();
        assert_eq!(at(&e), (2, 9), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    #[test]
    fn singular_transforms_are_errors_at_their_element() {
        bad_at(
            &block("<translate x=\"1\" y=\"0\" z=\"0\"/>\n  <scale x=\"1\" y=\"0\" z=\"1\"/>\n<object type=\"primitive\" name=\"cube\"/>"),
            5,
            3,
            "<scale> has a zero factor (y = 0): the transform is singular",
        );
        // Rotated, so the zero is not on the diagonal of the product.
        bad_at(
            &block("<rotate x=\"1\" y=\"1\" z=\"0\" angle=\"37\"/><scale x=\"0\" y=\"1\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/>"),
            4,
            39,
            "<scale> has zero factors (x = 0, z = 0)",
        );
        // In an enclosing transblock.
        bad_at(
            &root("<transblock><scale x=\"0\" y=\"0\" z=\"0\"/><object type=\"tree\">\n<transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>"),
            3,
            13,
            "<scale> has zero factors (x = 0, y = 0, z = 0)",
        );
        // A degenerate shear (dependent columns) in a matrix.
        bad_at(
            &block(
                "<rotate x=\"0\" y=\"1\" z=\"0\" angle=\"10\"/>\n<matrix><row0 v1=\"1\" v2=\"1\" v3=\"0\" v4=\"0\"/><row1 v1=\"1\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
                 <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/><row3 v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\"/></matrix><object type=\"primitive\" name=\"cube\"/>",
            ),
            5,
            1,
            "<matrix> is singular",
        );
    }

    #[test]
    fn duplicates_name_the_first_by_line_and_column() {
        let first = "<diffuse r=\"1\" g=\"0\" b=\"0\"/>";
        let f = ok(&prim("cube", &format!("{first}<diffuse r=\"0\" g=\"1\" b=\"0\"/>")));
        let col = first.len() as u32 + 1;
        warned_at(&f, 5, col, "second <diffuse> in <object> (the first is at 5:1); the later one is used");
        let f = ok(&with_top("<cameradata/> <cameradata/>"));
        warned_at(&f, 2, 15, "second <cameradata> (the first is at 2:1); ignored");
        let f = ok(&with_top(" <globaldata/><globaldata/>"));
        warned_at(&f, 2, 15, "second <globaldata> (the first is at 2:2); ignored");
        let f = ok(&block("<object type=\"primitive\" name=\"cube\"/><object type=\"primitive\" name=\"sphere\"/>"));
        warned_at(&f, 4, 39, "a second <object> in one <transblock> (the first is at 4:1)");
    }

    #[test]
    fn misplaced_known_elements_say_where_they_go() {
        let f = ok(&root(
            "<transblock><object type=\"tree\">\n<object type=\"primitive\" name=\"cube\"/>\n\
             <transblock><object type=\"primitive\" name=\"cube\"/></transblock></object></transblock>",
        ));
        warned_at(&f, 4, 1, "<object> cannot be inside <object>: objects go in a <transblock>");
        let f = ok(&prim("cube", "<translate x=\"1\" y=\"0\" z=\"0\"/>"));
        warned_at(&f, 5, 1, "<translate> cannot be inside <object>: transforms go in a <transblock>; skipped");
        let f = ok(&block("<diffuse r=\"1\" g=\"0\" b=\"0\"/><object type=\"primitive\" name=\"cube\"/>"));
        warned_at(
            &f,
            4,
            1,
            "<diffuse> cannot be inside <transblock>: material elements go in an <object type=\"primitive\">; skipped",
        );
        let f = ok(&with_top("<cameradata><color r=\"1\" g=\"1\" b=\"1\"/></cameradata>"));
        warned_at(&f, 2, 13, "<color> cannot be inside <cameradata>: it goes in a <lightdata>; skipped");
        let f = ok(&with_top("<transblock/>"));
        warned_at(
            &f,
            2,
            1,
            "<transblock> cannot be at the top level: transblocks go in an <object type=\"tree\">; skipped",
        );
        let f = ok(&with_top("<globaldata><lightdata/></globaldata>"));
        warned_at(&f, 2, 13, "<lightdata> cannot be inside <globaldata>: it goes at the top level, in <scenefile>");
        // Unknown names keep their suggestion.
        let f = ok(&with_top("<lightdata><colour r=\"1\" g=\"1\" b=\"1\"/></lightdata>"));
        warned_at(&f, 2, 12, "unknown element <colour> in <lightdata> (did you mean <color>?); skipped");
    }

    #[test]
    fn matrix_last_row_is_ignored_with_a_warning() {
        let rows = |row3: &str| {
            block(&format!(
                "<matrix><row0 v1=\"1\" v2=\"0\" v3=\"0\" v4=\"5\"/><row1 v1=\"0\" v2=\"1\" v3=\"0\" v4=\"0\"/>\
                 <row2 v1=\"0\" v2=\"0\" v3=\"1\" v4=\"0\"/>\n  <row3 {row3}/></matrix>\
                 <object type=\"primitive\" name=\"cube\"/>"
            ))
        };
        let affine = DMat4::from_translation(DVec3::new(5.0, 0.0, 0.0));
        for (row3, shown) in [
            ("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"2\"", "0 0 0 2"),
            ("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"0\"", "0 0 0 0"),
            ("a=\"0.5\" b=\"0\" c=\"1\" d=\"1\"", "0.5 0 1 1"),
        ] {
            let f = ok(&rows(row3));
            warned_at(
                &f,
                5,
                3,
                &format!(
                    "<matrix> row3 is {shown}, not 0 0 0 1: raycast's transforms are affine; the last row is ignored (taken as 0 0 0 1)"
                ),
            );
            let b = &f.trees[f.root].blocks[0];
            assert_eq!(b.matrix, affine, "{row3}");
            assert_eq!(b.transforms, vec![Transform::Matrix(Box::new(affine))]);
        }
        let f = ok(&rows("v1=\"0\" v2=\"0\" v3=\"0\" v4=\"1\""));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
    }

    #[test]
    fn elements_raycast_does_not_render_are_noted() {
        let f = ok(&prim(
            "sphere",
            "<transparent r=\"0.5\" g=\"0.5\" b=\"0.5\"/>\n<ior v=\"1.5\"/>\n<bumpmap file=\"bump.png\"/>",
        ));
        // Transparency and refraction are drawn (docs/scene-format.md#refraction).
        warned_at(&f, 7, 1, "raycast does no bump mapping; <bumpmap> is ignored");
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        // Values that change nothing are not worth a word.
        let f = ok(&prim("sphere", "<transparent r=\"0\" g=\"0\" b=\"0\"/><ior v=\"1.33\"/>"));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        let f = camera("<aperture v=\"0.08\"/>\n<focallength v=\"15\"/>\n<aspectratio v=\"1.5\"/>").unwrap();
        warned_at(
            &f,
            5,
            1,
            "raycast takes the aspect ratio from the picture's size (--width and --height); <aspectratio> is ignored",
        );
        // Depth of field: the course's renders draw none either (corpus
        // files carry an aperture), so no word.
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        let f = ok(&with_top("<globaldata><transparentcoeff v=\"0.3\"/></globaldata>"));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        assert_eq!(f.globals.kt, 0.3);
    }

    /// Refraction's inputs: `<transparent>`, `<ior>` and `<transparentcoeff>`
    /// are read as written; an index of refraction must be above 0 (NaN,
    /// infinity and a number 32-bit floats cannot hold are refused as for
    /// every number).
    #[test]
    fn refraction_inputs_and_bad_indices_of_refraction() {
        let f = ok(&prim("sphere", "<transparent r=\"0.8\" g=\"0.6\" b=\"0.4\"/><ior v=\"1.5\"/>"));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        let (_, m) = first_prim(&f);
        assert_eq!((m.transparent, m.ior), ([0.8, 0.6, 0.4], 1.5));
        // An index below 1 (a medium faster than air) is taken.
        assert_eq!(first_prim(&ok(&prim("sphere", "<ior v=\"0.5\"/>"))).1.ior, 0.5);
        for (v, shown) in [("0", "0"), ("-1.5", "-1.5"), ("-0", "-0"), ("1e-50", "0")] {
            let xml = prim("sphere", &format!("<ior v=\"{v}\"/>"));
            bad_at_str(
                &xml,
                &format!("v=\"{v}\""),
                &format!("<ior> is {shown} (expected an index of refraction above 0"),
            );
        }
        for v in ["NaN", "inf", "1e39"] {
            let xml = prim("sphere", &format!("<ior v=\"{v}\"/>"));
            let e = bad(&xml);
            assert_eq!(at(&e).0, 5, "{e}");
        }
        // The course's empty number reads as 0, which no index can be.
        let xml = prim("sphere", "<ior v=\"\"/>");
        bad_at_str(&xml, "v=\"\"", "<ior> is 0");
        let e = bad(&prim("sphere", "<transparent r=\"0.5\" g=\"x\" b=\"0.5\"/>"));
        assert_eq!(at(&e).0, 5, "{e}");
    }

    #[test]
    fn an_area_light_needs_a_positive_width_height_and_direction() {
        let area = |rest: &str| light(&format!("<type v=\"area\"/>\n{rest}"));
        let f = area("<direction x=\"0\" y=\"-1\" z=\"0\"/><width v=\"2\"/><height v=\"0.5\"/>").unwrap();
        let l = &f.lights[0];
        assert_eq!((l.kind, l.width, l.height), (LightKind::Area, 2.0, 0.5));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        // Missing: named at the <lightdata>.
        for (rest, missing) in [
            ("<direction x=\"0\" y=\"-1\" z=\"0\"/><height v=\"1\"/>", "<width>"),
            ("<direction x=\"0\" y=\"-1\" z=\"0\"/><width v=\"1\"/>", "<height>"),
            ("<width v=\"1\"/><height v=\"1\"/>", "<direction>"),
        ] {
            let e = area(rest).unwrap_err();
            assert_eq!(at(&e), (2, 1), "{e}");
            assert!(e.message.contains(&format!("an area light has no {missing}")), "{e}");
        }
        let e = area("<direction x=\"0\" y=\"0\" z=\"0\"/><width v=\"1\"/><height v=\"1\"/>").unwrap_err();
        assert!(e.message.contains("an area light's <direction> is the zero vector"), "{e}");
        // Bad sizes: named at the value.
        for (v, says) in [
            ("-1", "an area light's <width> is -1 (expected a positive size in world units)"),
            ("0", "an area light's <width> is 0 (expected a positive size in world units)"),
            ("nan", "is \"nan\" (expected a finite number)"),
            ("1e39", "too large"),
        ] {
            let e = area(&format!("<direction x=\"0\" y=\"-1\" z=\"0\"/>\n<width v=\"{v}\"/><height v=\"1\"/>"))
                .unwrap_err();
            assert_eq!(at(&e), (5, 8), "{v}: {e}");
            assert!(e.message.contains(says), "{v}: {e}");
        }
    }

    #[test]
    fn a_lens_needs_a_size_of_0_or_more_and_a_distance_in_focus() {
        let f = camera("<aperture v=\"0.008\"/>\n<focallength v=\"3\"/>").unwrap();
        assert_eq!((f.camera.aperture, f.camera.focal_length), (Some(0.008), Some(3.0)));
        assert!(f.warnings.is_empty(), "{:?}", f.warnings);
        // An aperture of 0 is a pinhole and needs no focal length.
        let f = camera("<aperture v=\"0\"/>").unwrap();
        assert_eq!(f.camera.aperture, Some(0.0));
        let e = camera("<aperture v=\"0.1\"/>").unwrap_err();
        assert_eq!(at(&e), (3, 1), "{e}");
        assert!(e.message.contains("<aperture> without a <focallength>"), "{e}");
        for (element, v, says) in [
            ("aperture", "-0.5", "<aperture> is -0.5 (expected a lens size of 0 or more, 0 for a pinhole)"),
            ("focallength", "0", "<focallength> is 0 (expected the positive distance in focus, in world units)"),
            ("focallength", "-2", "<focallength> is -2 (expected the positive distance in focus"),
            ("focallength", "nan", "is \"nan\" (expected a finite number)"),
        ] {
            let e = camera(&format!("<aperture v=\"1\"/>\n<{element} v=\"{v}\"/>")).unwrap_err();
            assert_eq!(at(&e).0, 4, "{element} {v}: {e}");
            assert!(e.message.contains(says), "{element} {v}: {e}");
        }
    }
}
