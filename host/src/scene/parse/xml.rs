//! The XML beneath the format: a depth bound checked before roxmltree
//! reads a file, and roxmltree's errors said in the format's words, at
//! the place they name.

use super::names::shown;
use super::Ctx;
use crate::scene::model::{SceneError, SourceLoc};
use roxmltree::{Document, ParsingOptions};

/// Byte position of the first start tag nested deeper than `limit`, by a
/// light scan of the markup (comments, CDATA, processing instructions,
/// declarations and quoted attribute values skipped).
pub(super) fn too_deep(text: &str, limit: usize) -> Option<usize> {
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

impl Ctx<'_> {
    pub(super) fn xml_error(&self, e: &roxmltree::Error) -> SceneError {
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
}
