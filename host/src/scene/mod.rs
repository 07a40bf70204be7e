//! Scene files: parsing (XML, with file:line:col errors), the scene model,
//! and flattening trees and masters into drawn primitives.

pub mod flatten;
pub mod model;
pub mod parse;

pub use flatten::{flatten, load, FlattenLimits};
pub use model::*;
pub use parse::{parse_file, parse_str, ParseOptions};
