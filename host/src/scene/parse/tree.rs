//! Object trees: top-level trees, transblocks and their transforms, inline
//! trees and masters (each named tree drawn where a master names it).

use super::names::{shown, suggest, OBJECT_ATTRIBUTES, TRANSBLOCK_ELEMENTS};
use super::position::line_col;
use super::{Ctx, MAX_NESTING, R};
use crate::scene::model::*;
use crate::units::{fmt_number, fmt_vector};
use glam::{DMat4, DVec3};
use roxmltree::Node as XNode;
use std::collections::HashMap;

/// The matrix of one transform.
fn transform_matrix(t: &Transform) -> DMat4 {
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

impl Ctx<'_> {
    pub(super) fn top_tree(&mut self, n: XNode) -> R<()> {
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
}
