//! The format's names, and how messages name things: what an element or
//! attribute was probably meant to be, where a misplaced element goes,
//! lists, and values shortened.

pub(super) const MATERIAL_ELEMENTS: &[&str] = &[
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
pub(super) const TRANSBLOCK_ELEMENTS: &[&str] = &["translate", "rotate", "scale", "matrix", "object"];
pub(super) const GLOBAL_ELEMENTS: &[&str] = &["ambientcoeff", "diffusecoeff", "specularcoeff", "transparentcoeff"];
pub(super) const CAMERA_ELEMENTS: &[&str] =
    &["pos", "focus", "look", "up", "heightangle", "aspectratio", "aperture", "focallength"];
pub(super) const LIGHT_ELEMENTS: &[&str] =
    &["id", "type", "color", "position", "direction", "function", "angle", "penumbra", "width", "height"];

/// Where an element of the format belongs, for one found elsewhere; None
/// for a name the format does not have.
pub(super) fn home(name: &str) -> Option<&'static str> {
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
pub(super) const OBJECT_ATTRIBUTES: &[&str] = &["type", "name", "meshfile", "filename"];

/// Levenshtein distance, case-insensitive: strsim's, of the names lowercased.
pub(super) fn edit_distance(a: &str, b: &str) -> usize {
    strsim::levenshtein(&a.to_lowercase(), &b.to_lowercase())
}

/// The candidate `name` was probably meant to be: within edit distance 2
/// (and closer than replacing it outright), or equal but for case.
pub(super) fn suggest<'c>(name: &str, candidates: &[&'c str]) -> Option<&'c str> {
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
pub(super) fn or_list(items: &[&str]) -> String {
    join_list(items, "or")
}

pub(super) fn join_list(items: &[&str], last: &str) -> String {
    match items {
        [] => String::new(),
        [one] => (*one).to_string(),
        [init @ .., tail] => format!("{} {last} {tail}", init.join(", ")),
    }
}

/// Shortens a value for a message.
pub(super) fn shown(s: &str) -> String {
    let mut out: String = s.chars().take(40).collect();
    if s.chars().count() > 40 {
        out.push('…');
    }
    format!("{out:?}")
}
