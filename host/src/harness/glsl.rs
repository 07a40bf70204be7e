//! Reading what the harness needs from the shared GLSL, so that adding a
//! function to `raycast.glsl` or a file it includes needs no registry: the
//! top-level functions (`[precise] TYPE name(TYPE a, TYPE b) {`), the
//! structs of `layout.h` and the shared files, their constants (`const float
//! T_FAR = …;`, `#define NO_HIT 0xffffffffu`) and the scene buffers of
//! `scene_buffers.glsl`. `raycast.glsl` is read with the files it includes
//! (`#include "exact.glsl"`, from the same folder), each where its include
//! stands, so declarations come in the order the compiler sees them.
//!
//! This is not a GLSL parser: it reads the shapes the shared code is written
//! in (top-level declarations, brace-delimited bodies) and says so when it
//! meets something else.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::value::{Scalar, StructDef, Type, Value};
use crate::error::Error;

/// A top-level function of `raycast.glsl` or a file it includes.
#[derive(Clone, Debug, PartialEq)]
pub struct Function {
    pub name: String,
    pub ret: Type,
    pub params: Vec<(String, Type)>,
    /// The file it is written in (a path, as in messages).
    pub file: String,
    /// Line of its header in `file`.
    pub line: usize,
}

impl Function {
    /// `vec3 cone_quadratic(Ray r)`.
    pub fn signature(&self) -> String {
        let params: Vec<String> = self.params.iter().map(|(n, t)| format!("{} {n}", t.glsl_name())).collect();
        format!("{} {}({})", self.ret.glsl_name(), self.name, params.join(", "))
    }

    /// The name the harness gives this overload's kernel, wrapper and C
    /// symbol: `div_rn__vec3_float`, unique where GLSL overloads the name.
    pub fn key(&self) -> String {
        let types: Vec<String> = self.params.iter().map(|(_, t)| t.glsl_name()).collect();
        format!("{}__{}", self.name, if types.is_empty() { "void".to_string() } else { types.join("_") })
    }

    /// Whether a case's `count` inputs are exactly this overload's
    /// parameters: `fits(name, type)` says one is given under the
    /// parameter's name and its value fits the type.
    pub fn takes(&self, count: usize, fits: impl Fn(&str, &Type) -> bool) -> bool {
        self.params.len() == count && self.params.iter().all(|(p, ty)| fits(p, ty))
    }

    /// Words of all inputs, one u32 per scalar.
    pub fn input_words(&self) -> usize {
        self.params.iter().map(|(_, t)| t.words()).sum()
    }
}

/// One storage buffer of `scene_buffers.glsl`: `Frame frame;` or `Primitive primitives[];`.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneBuffer {
    /// The variable the shared code reads (`frame`, `primitives`).
    pub name: String,
    pub binding: u32,
    pub ty: Arc<StructDef>,
    pub array: bool,
}

/// What the harness knows about one folder of shaders.
#[derive(Clone, Debug)]
pub struct ShaderInfo {
    pub dir: PathBuf,
    pub functions: Vec<Function>,
    pub structs: BTreeMap<String, Arc<StructDef>>,
    /// `const` values of the shared files and numeric `#define`s of layout.h and the shared files, by name.
    pub constants: BTreeMap<String, Value>,
    pub scene_buffers: Vec<SceneBuffer>,
    /// Functions that could not be read (name, why, with the file and line
    /// of the function); an error only when used and no readable overload
    /// of the name fits.
    pub unsupported: BTreeMap<String, String>,
    /// The shared files read, by name, in include order: raycast.glsl first.
    pub shared_files: Vec<String>,
}

/// The files a harness kernel includes, in order (SHARED includes the rest
/// of the shared GLSL).
pub const LAYOUT: &str = "layout.h";
pub const SCENE_BUFFERS: &str = "scene_buffers.glsl";
pub const SHARED: &str = "raycast.glsl";

/// Reads `name` of `dir`.
fn read_in(dir: &Path, name: &str) -> Result<String, String> {
    let path = dir.join(name);
    crate::bounded::read_text(&path).map_err(|e| format!("cannot read {}: {e}", path.display()))
}

/// The file an `#include "FILE"` line names (`<FILE>` is not followed).
fn included(line: &str) -> Option<&str> {
    let rest = line.trim_start().strip_prefix('#')?.trim_start().strip_prefix("include")?;
    let name = rest.trim().strip_prefix('"')?;
    name.split_once('"').map(|(name, _)| name)
}

/// A stretch of one shared file between includes: the file's name and its
/// text with every line outside the stretch blank (so line numbers hold).
struct Piece {
    file: String,
    text: String,
}

/// `name` of `dir` cut at its `#include "FILE"` lines into pieces, each
/// included file's pieces in its place (recursively), appended to `out`.
/// A file already read is not read again (as an include guard would).
fn pieces(dir: &Path, name: &str, seen: &mut Vec<String>, out: &mut Vec<Piece>) -> Result<(), String> {
    seen.push(name.to_string());
    let text = read_in(dir, name)?;
    let lines: Vec<&str> = text.split('\n').collect();
    let mut start = 0;
    for (i, line) in lines.iter().enumerate() {
        let Some(child) = included(line) else { continue };
        out.push(Piece { file: name.to_string(), text: "\n".repeat(start) + &lines[start..i].join("\n") });
        start = i + 1;
        if !seen.iter().any(|s| s == child) {
            pieces(dir, child, seen, out)
                .map_err(|e| format!("{e} (included at {}:{})", dir.join(name).display(), i + 1))?;
        }
    }
    out.push(Piece { file: name.to_string(), text: "\n".repeat(start) + &lines[start..].join("\n") });
    Ok(())
}

impl ShaderInfo {
    /// Reads layout.h, scene_buffers.glsl and raycast.glsl of `dir`, with
    /// the files raycast.glsl includes.
    pub fn load(dir: &Path) -> Result<ShaderInfo, Error> {
        let (layout, buffers) = (read_in(dir, LAYOUT)?, read_in(dir, SCENE_BUFFERS)?);
        let mut shared_files = Vec::new();
        let mut shared = Vec::new();
        pieces(dir, SHARED, &mut shared_files, &mut shared)?;
        let mut info = ShaderInfo {
            dir: dir.to_path_buf(),
            functions: Vec::new(),
            structs: BTreeMap::new(),
            constants: BTreeMap::new(),
            scene_buffers: Vec::new(),
            unsupported: BTreeMap::new(),
            shared_files,
        };
        info.read_defines(&layout);
        for piece in &shared {
            info.read_defines(&piece.text); // shapes.glsl's SHAPE_* and SPEC_*
        }
        let at = |file: &str| dir.join(file).display().to_string();
        info.read_file(&layout, &at(LAYOUT))?;
        info.read_file(&buffers, &at(SCENE_BUFFERS))?;
        for piece in &shared {
            info.read_file(&piece.text, &at(&piece.file))?;
        }
        if info.scene_buffers.is_empty() {
            return Err(Error::Failed(format!("{}: no storage buffers found", at(SCENE_BUFFERS))));
        }
        Ok(info)
    }

    /// The function `name`, which must not be overloaded (`function_where` chooses among overloads).
    pub fn function(&self, name: &str) -> Result<&Function, String> {
        self.function_where(name, |_| false)
    }

    /// The function `name`: its one readable overload, or among several the
    /// one that `fits` (a case's inputs: their names and values) accepts.
    pub fn function_where(&self, name: &str, fits: impl Fn(&Function) -> bool) -> Result<&Function, String> {
        let shared = self.dir.join(SHARED).display().to_string();
        let overloads: Vec<&Function> = self.functions.iter().filter(|f| f.name == name).collect();
        match overloads[..] {
            [] => Err(match self.unsupported.get(name) {
                Some(why) => format!("function {name} cannot be tested: {why}"),
                None => {
                    let mut near: Vec<&str> = self
                        .functions
                        .iter()
                        .map(|f| f.name.as_str())
                        .filter(|n| n.contains(name) || name.contains(n))
                        .collect();
                    near.dedup();
                    let hint =
                        if near.is_empty() { String::new() } else { format!(" (did you mean {}?)", near.join(", ")) };
                    format!("{shared} (with the files it includes) has no top-level function {name:?}{hint}")
                }
            }),
            [only] => Ok(only),
            _ => {
                let fitting: Vec<&Function> = overloads.iter().copied().filter(|f| fits(f)).collect();
                let list = overloads
                    .iter()
                    .map(|f| format!("{} ({}:{})", f.signature(), f.file, f.line))
                    .collect::<Vec<_>>()
                    .join("; ");
                match fitting[..] {
                    [one] => Ok(one),
                    [] => Err(format!(
                        "{name} is overloaded and no overload takes these inputs (by name and type): {list}"
                    )),
                    _ => Err(format!("{name} is overloaded and the inputs fit more than one: {list}")),
                }
            }
        }
    }

    /// The type named `name` (`vec3`, `Ray`, `uint`).
    pub fn resolve(&self, name: &str) -> Option<Type> {
        builtin_type(name).or_else(|| self.structs.get(name).map(|s| Type::Struct(s.clone())))
    }

    /// The uint `#define`s (`uint_defines`) as constants; a define may
    /// name one read before.
    fn read_defines(&mut self, text: &str) {
        let known: Vec<(&str, u32)> = self
            .constants
            .iter()
            .filter_map(|(name, v)| match v {
                Value::Uint(v) => Some((name.as_str(), *v)),
                _ => None,
            })
            .collect();
        let defines: Vec<(String, u32)> =
            crate::uint_defines::uint_defines(text, &known).into_iter().map(|(n, v)| (n.to_string(), v)).collect();
        for (name, v) in defines {
            self.constants.insert(name, Value::Uint(v));
        }
    }

    fn read_file(&mut self, text: &str, file: &str) -> Result<(), String> {
        let clean = strip_comments_and_directives(text);
        for decl in top_level(&clean) {
            let header = decl.header.split_whitespace().collect::<Vec<_>>().join(" ");
            let at = format!("{file}:{}", decl.line);
            match &decl.body {
                Some(body) if header.starts_with("struct ") => {
                    let name = header["struct ".len()..].trim().to_string();
                    let def = self.read_struct(&name, body).map_err(|e| format!("{at}: struct {name}: {e}"))?;
                    self.structs.insert(name, Arc::new(def));
                }
                Some(body) if header.split(' ').any(|w| w == "buffer") => {
                    self.read_buffer(&header, body).map_err(|e| format!("{at}: {e}"))?;
                }
                Some(_) if header.contains('(') => self.read_function(&header, file, decl.line),
                Some(_) => {}
                None => self.read_const(&header),
            }
        }
        Ok(())
    }

    fn read_struct(&self, name: &str, body: &str) -> Result<StructDef, String> {
        let mut members = Vec::new();
        for stmt in body.split(';').map(str::trim).filter(|s| !s.is_empty()) {
            let words: Vec<&str> = stmt.split_whitespace().filter(|w| !is_qualifier(w)).collect();
            let Some((ty_name, names)) = words.split_first() else { continue };
            let ty = self.resolve(ty_name).ok_or_else(|| format!("member type {ty_name} is not known"))?;
            for n in names.join(" ").split(',').map(str::trim) {
                if n.contains('[') {
                    return Err(format!("array member {n} is not supported"));
                }
                members.push((n.to_string(), ty.clone()));
            }
        }
        if members.is_empty() {
            // GLSL has no empty structs; the harness would lay out one of no words.
            return Err("has no members".into());
        }
        Ok(StructDef { name: name.to_string(), members })
    }

    /// `layout(std430, binding = BINDING_FRAME) readonly buffer FrameBlock` { `Frame frame;` }
    fn read_buffer(&mut self, header: &str, body: &str) -> Result<(), String> {
        let binding_expr = header
            .split_once("binding")
            .and_then(|(_, rest)| rest.trim_start().strip_prefix('='))
            .map(|rest| {
                rest.trim_start().split(|c: char| c == ',' || c == ')' || c.is_whitespace()).next().unwrap_or("")
            })
            .ok_or_else(|| format!("buffer without a binding: {header}"))?;
        let binding = match self.constants.get(binding_expr) {
            Some(Value::Uint(v)) => *v,
            _ => binding_expr
                .parse::<u32>()
                .map_err(|_| format!("binding {binding_expr} is not a number or a #define"))?,
        };
        let member = body.split(';').map(str::trim).find(|s| !s.is_empty()).unwrap_or("");
        let words: Vec<&str> = member.split_whitespace().collect();
        let [ty_name, var] = words[..] else {
            return Err(format!(
                "expected one member `Type name;` or `Type name[];` in the buffer block, found {member:?}"
            ));
        };
        let Some(def) = self.structs.get(ty_name).cloned() else {
            return Err(format!("buffer member type {ty_name} is not a struct of layout.h"));
        };
        let (name, array) = match var.strip_suffix("[]") {
            Some(n) => (n.to_string(), true),
            None => (var.to_string(), false),
        };
        self.scene_buffers.push(SceneBuffer { name, binding, ty: def, array });
        Ok(())
    }

    fn read_function(&mut self, header: &str, file: &str, line: usize) {
        let Some((head, rest)) = header.split_once('(') else { return };
        let Some(params_text) = rest.strip_suffix(')') else { return };
        let words: Vec<&str> = head.split_whitespace().filter(|w| !is_qualifier(w)).collect();
        let [ret_name, name] = words[..] else { return };
        let name = name.to_string();
        if name == "main" {
            return;
        }
        // Why it cannot be tested, and where it is written.
        let at = |why: String| format!("{why} ({file}:{line})");
        let ret = match ret_name {
            "void" => {
                self.unsupported.insert(name, at("it returns void: the harness tests return values".into()));
                return;
            }
            n => match self.resolve(n) {
                Some(t) => t,
                None => {
                    self.unsupported.insert(name, at(format!("return type {n} is not supported")));
                    return;
                }
            },
        };
        let mut params = Vec::new();
        let text = params_text.trim();
        if !text.is_empty() && text != "void" {
            for p in text.split(',') {
                let words: Vec<&str> = p.split_whitespace().collect();
                if words.iter().any(|w| *w == "out" || *w == "inout") {
                    self.unsupported.insert(name, at(format!("parameter {:?} is out/inout", p.trim())));
                    return;
                }
                let words: Vec<&str> = words.into_iter().filter(|w| !is_qualifier(w) && *w != "in").collect();
                let [ty_name, pname] = words[..] else {
                    self.unsupported.insert(name, at(format!("cannot read parameter {:?}", p.trim())));
                    return;
                };
                match self.resolve(ty_name) {
                    Some(t) if !pname.contains('[') => params.push((pname.to_string(), t)),
                    _ => {
                        self.unsupported.insert(name, at(format!("parameter type of {:?} is not supported", p.trim())));
                        return;
                    }
                }
            }
        }
        self.functions.push(Function { name, ret, params, file: file.to_string(), line });
    }

    /// `const float T_FAR = 3.40282347e38f;`
    fn read_const(&mut self, header: &str) {
        let Some(rest) = header.strip_prefix("const ") else { return };
        let Some((lhs, rhs)) = rest.split_once('=') else { return };
        let words: Vec<&str> = lhs.split_whitespace().collect();
        let [ty, name] = words[..] else { return };
        let literal = rhs.trim();
        let value = match ty {
            "float" => literal.trim_end_matches(['f', 'F']).parse::<f32>().ok().map(Value::Float),
            "int" => literal.parse::<i32>().ok().map(Value::Int),
            "uint" => literal.trim_end_matches(['u', 'U']).parse::<u32>().ok().map(Value::Uint),
            _ => None,
        };
        if let Some(v) = value {
            self.constants.insert(name.to_string(), v);
        }
    }
}

fn is_qualifier(w: &str) -> bool {
    matches!(w, "precise" | "const" | "highp" | "mediump" | "lowp" | "invariant")
}

/// The GLSL built-in types the harness moves in and out of buffers.
pub fn builtin_type(name: &str) -> Option<Type> {
    let scalar = |s: &str| match s {
        "float" => Some(Scalar::Float),
        "int" => Some(Scalar::Int),
        "uint" => Some(Scalar::Uint),
        "bool" => Some(Scalar::Bool),
        _ => None,
    };
    if let Some(s) = scalar(name) {
        return Some(Type::Scalar(s));
    }
    let n = |c: char| c.to_digit(10).filter(|d| (2..=4).contains(d)).map(|d| d as usize);
    let last = name.chars().last()?;
    let prefix = &name[..name.len() - 1];
    match prefix {
        "vec" => n(last).map(|k| Type::Vector(Scalar::Float, k)),
        "ivec" => n(last).map(|k| Type::Vector(Scalar::Int, k)),
        "uvec" => n(last).map(|k| Type::Vector(Scalar::Uint, k)),
        "bvec" => n(last).map(|k| Type::Vector(Scalar::Bool, k)),
        "mat" => n(last).map(Type::Matrix),
        _ => None,
    }
}

/// Comments and preprocessor lines blanked, newlines kept (for line numbers).
fn strip_comments_and_directives(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let b = text.as_bytes();
    let mut i = 0;
    let mut line_start = true;
    while i < b.len() {
        let c = b[i];
        if line_start && text[i..].trim_start_matches([' ', '\t']).starts_with('#') {
            // A directive: up to the end of the line (continuations are not used here).
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'/') {
            while i < b.len() && b[i] != b'\n' {
                i += 1;
            }
            continue;
        }
        if c == b'/' && b.get(i + 1) == Some(&b'*') {
            i += 2;
            while i < b.len() && !(b[i] == b'*' && b.get(i + 1) == Some(&b'/')) {
                if b[i] == b'\n' {
                    out.push('\n');
                }
                i += 1;
            }
            i += 2;
            continue;
        }
        line_start = c == b'\n';
        // Keep multi-byte characters (in strings and comments only) intact.
        let ch = text[i..].chars().next().unwrap_or(' ');
        out.push(ch);
        i += ch.len_utf8();
    }
    out
}

/// A top-level declaration: its text up to `{` or `;`, and the body between
/// the braces when it has one.
struct Decl {
    header: String,
    body: Option<String>,
    /// 1-based line of the header's first non-blank character.
    line: usize,
}

fn top_level(text: &str) -> Vec<Decl> {
    let mut out = Vec::new();
    let mut header = String::new();
    let mut header_line = 0;
    let mut line = 1;
    let mut chars = text.chars().peekable();
    while let Some(c) = chars.next() {
        match c {
            '{' => {
                let mut depth = 1;
                let mut body = String::new();
                for c in chars.by_ref() {
                    if c == '\n' {
                        line += 1;
                    }
                    match c {
                        '{' => depth += 1,
                        '}' => {
                            depth -= 1;
                            if depth == 0 {
                                break;
                            }
                        }
                        _ => {}
                    }
                    body.push(c);
                }
                out.push(Decl { header: header.trim().to_string(), body: Some(body), line: header_line });
                header.clear();
                // A struct or block ends with `;` (possibly after an instance name): skip it.
                while let Some(&n) = chars.peek() {
                    if n == ';' {
                        chars.next();
                        break;
                    }
                    if !n.is_whitespace() {
                        break;
                    }
                    if n == '\n' {
                        line += 1;
                    }
                    chars.next();
                }
            }
            ';' => {
                if !header.trim().is_empty() {
                    out.push(Decl { header: header.trim().to_string(), body: None, line: header_line });
                }
                header.clear();
            }
            _ => {
                if c == '\n' {
                    line += 1;
                }
                if header.trim().is_empty() && !c.is_whitespace() {
                    header_line = line;
                }
                header.push(c);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fresh shader folder `name` (under the temp dir) with `layout` as
    /// layout.h, one storage buffer of `Thing`s as scene_buffers.glsl, and
    /// `shared` as raycast.glsl.
    fn shader_dir(name: &str, layout: &str, shared: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("raycast-glsl-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join(LAYOUT), layout).unwrap();
        std::fs::write(
            dir.join(SCENE_BUFFERS),
            "layout(std430, binding = BINDING_THING) readonly buffer ThingBlock { Thing things[]; };\n",
        )
        .unwrap();
        std::fs::write(dir.join(SHARED), shared).unwrap();
        dir
    }

    fn sample() -> ShaderInfo {
        let dir = shader_dir(
            "parse",
            "#define BINDING_THING 3 // x\n#define NO_HIT 0xffffffffu\nstruct Thing {\n  vec4 a; // c\n  uint b, c;\n};\n",
            "const float T_FAR = 3.40282347e38f;\n/* block\ncomment */\nstruct Ray {\n    vec3 origin;\n    vec3 direction;\n};\n\
             precise float\nsquare(float x) {\n  { return x * x; }\n}\nvoid nothing() {}\nRay make(vec3 o, const vec3 d) { Ray r; r.origin = o; r.direction = d; return r; }\n\
             uint count(Thing t, bool b) { return b ? t.b : 0u; }\nfloat bad(out float x) { x = 1.0f; return x; }\n\
             float twice(float x) { return 2.0f * x; }\nvec3 twice(vec3 x) { return 2.0f * x; }\nfloat twice(float x, float y) { return x + y; }\n",
        );
        let info = ShaderInfo::load(&dir).unwrap();
        let _ = std::fs::remove_dir_all(&dir);
        info
    }

    #[test]
    fn reads_functions_structs_constants_and_buffers() {
        let info = sample();
        let names: Vec<&str> = info.functions.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, ["square", "make", "count", "twice", "twice", "twice"]);
        assert_eq!(info.function("square").unwrap().signature(), "float square(float x)");
        assert_eq!(info.function("square").unwrap().line, 8);
        assert_eq!(info.function("make").unwrap().signature(), "Ray make(vec3 o, vec3 d)");
        assert_eq!(info.function("count").unwrap().input_words(), 7);
        assert!(info.function("bad").unwrap_err().contains("out/inout"), "{}", info.function("bad").unwrap_err());
        assert!(info.function("nothing").unwrap_err().contains("void"));
        assert!(info.function("squar").unwrap_err().contains("did you mean square"));
        // Overloads: a case's inputs choose one (here by their count and type); each has a key of its own.
        assert!(info.function("twice").unwrap_err().contains("overloaded"), "{}", info.function("twice").unwrap_err());
        let vec3 = |f: &Function| f.params.len() == 1 && f.params[0].1 == Type::Vector(Scalar::Float, 3);
        assert_eq!(info.function_where("twice", vec3).unwrap().signature(), "vec3 twice(vec3 x)");
        assert_eq!(info.function_where("twice", |f| f.params.len() == 2).unwrap().key(), "twice__float_float");
        let none = info.function_where("twice", |f| f.params.len() == 3).unwrap_err();
        assert!(
            none.contains("no overload takes these inputs") && none.contains("float twice(float x, float y)"),
            "{none}"
        );
        assert!(info.function_where("twice", |f| f.params.len() == 1).unwrap_err().contains("more than one"));
        let keys: std::collections::BTreeSet<String> = info.functions.iter().map(Function::key).collect();
        assert_eq!(keys.len(), info.functions.len(), "{keys:?}");
        assert_eq!(info.constants.get("T_FAR"), Some(&Value::Float(f32::MAX)));
        assert_eq!(info.constants.get("NO_HIT"), Some(&Value::Uint(u32::MAX)));
        let thing = &info.structs["Thing"];
        assert_eq!(thing.members.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>(), ["a", "b", "c"]);
        assert_eq!(info.scene_buffers.len(), 1);
        assert_eq!(
            (info.scene_buffers[0].name.as_str(), info.scene_buffers[0].binding, info.scene_buffers[0].array),
            ("things", 3, true)
        );
    }

    #[test]
    fn reads_the_real_shaders() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
        let info = ShaderInfo::load(&dir).unwrap();
        for name in ["dot3", "intersect_cube", "cone_quadratic", "trace", "camera_ray"] {
            info.function(name).unwrap();
        }
        // Each from the file that holds it, raycast.glsl's includes followed.
        let file_of = |name: &str| Path::new(&info.function(name).unwrap().file).file_name().unwrap().to_owned();
        assert_eq!(file_of("dot3"), "exact.glsl");
        assert_eq!(file_of("intersect_cube"), "shape_cube.glsl");
        assert_eq!(file_of("walk"), "traversal.glsl");
        assert_eq!(info.shared_files[0], SHARED);
        assert!(info.constants.contains_key("T_FAR") && info.structs.contains_key("SceneHit"));
        assert!(info.scene_buffers.iter().any(|b| b.name == "frame" && !b.array));
        assert!(info.scene_buffers.iter().any(|b| b.name == "primitives" && b.array));
    }

    /// A struct left with no members (a shader edit moved its one line
    /// away) is its file's located error: its layout of no words divided
    /// by zero when a case's scene was laid out (a panic, found by fuzzing).
    #[test]
    fn a_struct_without_members_is_a_located_error() {
        let dir = std::env::temp_dir().join(format!("raycast-glsl-empty-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let real = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders");
        // scene_buffers.glsl, raycast.glsl and the files it includes.
        for entry in std::fs::read_dir(&real).unwrap() {
            let path = entry.unwrap().path();
            if path.extension().is_some_and(|e| e == "glsl") {
                std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
            }
        }
        let layout = std::fs::read_to_string(real.join(LAYOUT)).unwrap();
        let member = "struct LeafItem {\n    uint item;";
        assert_eq!(layout.matches(member).count(), 1, "layout.h changed: update this test");
        std::fs::write(dir.join(LAYOUT), layout.replace(member, "struct LeafItem {\n")).unwrap();
        let e = ShaderInfo::load(&dir).err().unwrap().to_string();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(e.contains("layout.h:") && e.ends_with("struct LeafItem: has no members"), "{e}");
    }

    /// raycast.glsl's `#include "FILE"`s are read where they stand, nested
    /// ones too, each function with its own file and line; a file already
    /// read is not read again; a missing one is an error that says where it
    /// was included.
    #[test]
    fn follows_includes_in_order() {
        let dir = shader_dir(
            "includes",
            "#define BINDING_THING 3\nstruct Thing {\n  uint b;\n};\n",
            "// umbrella\n#ifndef G\n#define G\nfloat first(float x) { return x; }\n#include \"a.glsl\"\n\
             Pair last(float x) { Pair p; p.a = x; p.b = x; return p; }\n  #  include \"a.glsl\"\n#endif\n",
        );
        std::fs::write(
            dir.join("a.glsl"),
            "// a\nconst float A = 2.0f;\n#include \"b.glsl\"\nfloat in_a(Pair p) { return p.a; }\n",
        )
        .unwrap();
        std::fs::write(
            dir.join("b.glsl"),
            "struct Pair {\n  float a;\n  float b;\n};\n\nfloat in_b(float x) { return x; }\n",
        )
        .unwrap();
        let info = ShaderInfo::load(&dir).unwrap();
        let at: Vec<(&str, String, usize)> = info
            .functions
            .iter()
            .map(|f| (f.name.as_str(), Path::new(&f.file).file_name().unwrap().to_string_lossy().into_owned(), f.line))
            .collect();
        let want = [("first", SHARED, 4), ("in_b", "b.glsl", 6), ("in_a", "a.glsl", 4), ("last", SHARED, 6)];
        assert_eq!(at, want.map(|(n, f, l)| (n, f.to_string(), l)));
        assert_eq!(info.shared_files, [SHARED, "a.glsl", "b.glsl"]);
        assert_eq!(info.constants.get("A"), Some(&Value::Float(2.0)));
        assert_eq!(info.function("last").unwrap().ret, Type::Struct(info.structs["Pair"].clone()));
        std::fs::remove_file(dir.join("b.glsl")).unwrap();
        let e = ShaderInfo::load(&dir).err().unwrap().to_string();
        let _ = std::fs::remove_dir_all(&dir);
        assert!(e.contains("b.glsl") && e.contains("included at") && e.contains("a.glsl:3"), "{e}");
    }
}
