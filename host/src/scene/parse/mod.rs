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
mod tests;
