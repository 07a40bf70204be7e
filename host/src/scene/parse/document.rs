//! The document: `<scenefile>`, its top-level elements in any order (a
//! second camera or globals ignored with a warning), `<globaldata>`, and
//! the tree named root.

use super::names::{home, suggest, GLOBAL_ELEMENTS};
use super::position::line_col;
use super::{Ctx, R};
use crate::scene::model::*;
use roxmltree::{Document, Node as XNode};
use std::collections::HashMap;

impl Ctx<'_> {
    pub(super) fn scenefile(&mut self, doc: &Document) -> R<SceneFile> {
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
}
