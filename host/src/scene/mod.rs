//! Scene files: parsing (XML, with file:line:col errors), the scene model,
//! and flattening trees and masters into drawn primitives.

pub mod bounds;
pub mod camera_control;
pub mod flatten;
pub mod mesh;
pub mod model;
#[doc(hidden)]
pub mod mutate;
#[cfg(test)]
mod mutation_tests;
pub mod parse;
pub mod shape;

pub use bounds::{scene_bounds, Bounds};
pub use camera_control::CameraControl;
pub use flatten::{flatten, load, FlattenLimits};
pub use model::*;
pub use parse::{parse_file, parse_str, ParseOptions};
pub use shape::{Shape, ShapeKind, SHAPES};

/// Tests: the scene of `xml`, named `name` in messages, parsed and
/// flattened with the default options and limits (panics on an error).
#[cfg(test)]
pub fn from_xml(xml: impl AsRef<str>, name: &str) -> Scene {
    let file =
        parse_str(xml.as_ref(), std::path::Path::new(name), &ParseOptions::default()).unwrap_or_else(|e| panic!("{e}"));
    flatten(&file, &FlattenLimits::default()).unwrap_or_else(|e| panic!("{e}"))
}

/// Tests: a scene file of `n` unit cubes in a row along x, one apart, all
/// in the root tree: more than a leaf holds, so its hierarchy has inner nodes.
#[cfg(test)]
pub fn row_of_cubes_xml(n: usize) -> String {
    let cubes: String = (0..n)
        .map(|i| {
            format!(
                r#"<transblock><translate x="{i}" y="0" z="0"/><object type="primitive" name="cube"/></transblock>"#
            )
        })
        .collect();
    format!(r#"<scenefile><object type="tree" name="root">{cubes}</object></scenefile>"#)
}
