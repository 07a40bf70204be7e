//! Reading elements and their values: child elements, unknown attributes
//! and elements (warned about, with a suggestion), required attributes,
//! numbers, and the value elements `<e x y z/>`, `<e r g b/>`, `<e v/>`.

use super::names::{home, join_list, or_list, shown, suggest};
use super::position::line_col;
use super::{Ctx, R};
use crate::scene::model::{SceneError, SourceLoc};
use crate::units::fmt_number;
use glam::DVec3;
use roxmltree::{Attribute, Node as XNode};
use std::collections::HashMap;

impl Ctx<'_> {
    /// Child elements; warns about stray text.
    pub(super) fn elements<'d, 'i>(&mut self, n: XNode<'d, 'i>) -> Vec<XNode<'d, 'i>> {
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
    pub(super) fn check_attrs(&mut self, n: XNode, allowed: &[&str]) {
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
    pub(super) fn unknown_element(&mut self, n: XNode, parent: &str, expected: &[&str]) {
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

    pub(super) fn attr<'d, 'i>(n: XNode<'d, 'i>, name: &str) -> Option<Attribute<'d, 'i>> {
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
    pub(super) fn req_attr<'d, 'i>(
        &self,
        n: XNode<'d, 'i>,
        name: &str,
        takes: &[&str],
        expected: &str,
    ) -> R<Attribute<'d, 'i>> {
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

    pub(super) fn to_f32(&self, n: XNode, name: &str, v: f64) -> R<f32> {
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

    pub(super) fn req_num(&self, n: XNode, name: &str, takes: &[&str], expected: &str) -> R<f64> {
        let a = self.req_attr(n, name, takes, expected)?;
        self.number(n, &a)
    }

    pub(super) fn opt_num(&self, n: XNode, name: &str) -> R<Option<f64>> {
        match Self::attr(n, name) {
            Some(a) => self.number(n, &a).map(Some),
            None => Ok(None),
        }
    }

    /// Checks leaf-ness (no child elements) of a value element.
    pub(super) fn leaf(&mut self, n: XNode) {
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
    pub(super) fn xyz(&mut self, n: XNode) -> R<DVec3> {
        const XYZ: &[&str] = &["x", "y", "z"];
        self.check_attrs(n, XYZ);
        self.leaf(n);
        let e = "x, y and z";
        Ok(DVec3::new(self.req_num(n, "x", XYZ, e)?, self.req_num(n, "y", XYZ, e)?, self.req_num(n, "z", XYZ, e)?))
    }

    /// `xyz` for a point the renderer takes as it is (the camera's
    /// position): each coordinate within f32's range, where the device
    /// and the CPU build compute (beyond it, an infinity).
    pub(super) fn xyz_f32(&mut self, n: XNode) -> R<DVec3> {
        let v = self.xyz(n)?;
        for (name, x) in [("x", v.x), ("y", v.y), ("z", v.z)] {
            self.to_f32(n, name, x)?;
        }
        Ok(v)
    }

    /// `<e r g b/>`.
    pub(super) fn rgb(&mut self, n: XNode) -> R<[f32; 3]> {
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
    pub(super) fn v(&mut self, n: XNode) -> R<f64> {
        self.check_attrs(n, &["v"]);
        self.leaf(n);
        self.req_num(n, "v", &["v"], "v")
    }

    pub(super) fn v32(&mut self, n: XNode) -> R<f32> {
        let v = self.v(n)?;
        self.to_f32(n, "v", v)
    }

    /// `<ior v/>`: an index of refraction, above 0 (Snell's law divides by it).
    pub(super) fn ior(&mut self, n: XNode) -> R<f32> {
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
    pub(super) fn families(&mut self, n: XNode, fams: &[&[&str]]) -> R<Vec<f64>> {
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

    /// Warns about a repeated child element; the later one is used.
    pub(super) fn dup(&mut self, seen: &mut HashMap<String, SourceLoc>, c: XNode, parent: &str) {
        let name = c.tag_name().name().to_string();
        let here = self.nloc(c);
        if let Some(first) = seen.insert(name.clone(), here) {
            let msg =
                format!("second <{name}> in <{parent}> (the first is at {}); the later one is used", line_col(&first));
            self.warn(self.nloc(c), msg);
        }
    }
}
