//! Positions: a byte offset as `line:col` as an editor counts them (lines
//! ended by `\n`, `\r\n` or a lone `\r`, columns in characters), and the
//! errors and warnings that carry one.

use super::Ctx;
use crate::scene::model::{SceneError, SourceLoc, Warning};
use roxmltree::{Attribute, Node as XNode};

/// Where each line of `text` starts: after a `\n`, a `\r\n` or a `\r`
/// alone (old Mac files), each one line break as XML reads them.
pub(super) fn line_starts(text: &str) -> Vec<usize> {
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
pub(super) fn line_col(l: &SourceLoc) -> String {
    format!("{}:{}", l.line, l.col)
}

pub(super) fn sat_u32(v: usize) -> u32 {
    u32::try_from(v).unwrap_or(u32::MAX)
}

impl Ctx<'_> {
    pub(super) fn loc(&self, pos: usize) -> SourceLoc {
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

    pub(super) fn nloc(&self, n: XNode) -> SourceLoc {
        self.loc(n.range().start)
    }

    pub(super) fn aloc(&self, a: &Attribute) -> SourceLoc {
        self.loc(a.range().start)
    }

    pub(super) fn err(&self, loc: SourceLoc, message: String) -> SceneError {
        SceneError { loc: Some(loc), file: self.file.clone(), message }
    }

    pub(super) fn warn(&mut self, loc: SourceLoc, message: String) {
        self.note(loc, message);
    }

    /// [`Self::warn`] where the parser is borrowed, not its own (`number`).
    pub(super) fn note(&self, loc: SourceLoc, message: String) {
        self.warnings.borrow_mut().push(Warning { loc, message });
    }
}
