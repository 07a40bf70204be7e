//! Scene files: parsing (XML, with file:line:col errors), the scene model,
//! and flattening trees and masters into drawn primitives.

pub mod model;
pub use model::*;
