//! Shader-test files: TOML, one `[[case]]` table per case (the format is in
//! docs/writing-shader-tests.md). Inputs and expected values are read with
//! the types of the function's signature, so `0` is a float where the
//! parameter is a float, and a struct is a table of its members.

use std::collections::BTreeMap;
use std::path::Path;
use std::sync::Arc;

use super::glsl::ShaderInfo;
use super::value::{Scalar, Type, Value};
use super::{Case, Expected, Rule, SceneBuffers};
use crate::error::Error;

const CASE_KEYS: [&str; 8] = ["name", "function", "inputs", "expected", "same_as_cpu", "rule", "scene", "cpu"];

/// The cases of one file. `shown` is how the file is named in locations
/// (`tests/shaders/cone.toml`). Errors read `file:line: error: …` (TOML's
/// own, `file:line:column: error: …`).
pub fn load(path: &Path, shown: &str, info: &ShaderInfo) -> Result<Vec<Case>, Error> {
    let text =
        crate::bounded::read_text(path).map_err(|e| Error::Scene(format!("{shown}: error: cannot read it: {e}")))?;
    parse(&text, shown, info).map_err(Error::Scene)
}

/// [`load`] for text already read.
pub fn parse(text: &str, shown: &str, info: &ShaderInfo) -> Result<Vec<Case>, String> {
    let doc: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        // Where, as line:column (the column in characters, from 1).
        let at = e.span().map(|s| {
            let before = text.get(..s.start).unwrap_or("");
            let column = before.rsplit('\n').next().unwrap_or("").chars().count() + 1;
            format!(":{}:{column}", line_of(text, s.start))
        });
        let message = e.message().trim().replace('\n', "; ");
        format!("{shown}{}: error: {message} (a case file is TOML: [[case]] tables)", at.unwrap_or_default())
    })?;
    let header_lines = |header: &str| -> Vec<usize> {
        text.lines().enumerate().filter(|(_, l)| l.trim_start().starts_with(header)).map(|(i, _)| i + 1).collect()
    };
    let case_lines = header_lines("[[case]]");

    for key in doc.keys() {
        if key != "case" && key != "scenes" {
            return Err(format!(
                "{shown}: error: unknown top-level key {key:?} (expected [[case]] tables and [scenes.NAME])"
            ));
        }
    }

    // Named scenes: [scenes.NAME]
    let mut scenes: BTreeMap<String, Arc<SceneBuffers>> = BTreeMap::new();
    if let Some(s) = doc.get("scenes") {
        let toml::Value::Table(t) = s else {
            return Err(format!("{shown}: error: `scenes` must be tables [scenes.NAME]"));
        };
        for (name, v) in t {
            let at =
                header_lines(&format!("[scenes.{name}]")).first().map_or(shown.to_string(), |l| format!("{shown}:{l}"));
            let scene = scene(v, info).map_err(|e| format!("{at}: error: scene {name}: {e}"))?;
            scenes.insert(name.clone(), Arc::new(scene));
        }
    }

    let Some(list) = doc.get("case") else {
        return Err(format!("{shown}: error: no [[case]] tables"));
    };
    let toml::Value::Array(list) = list else {
        return Err(format!("{shown}: error: `case` must be an array of tables: write each case under [[case]]"));
    };
    let mut cases = Vec::new();
    for (k, v) in list.iter().enumerate() {
        let at = match case_lines.get(k) {
            Some(l) => format!("{shown}:{l}"),
            None => shown.to_string(),
        };
        let toml::Value::Table(t) = v else {
            return Err(format!("{at}: error: a case must be a table"));
        };
        let case = case(t, info, &scenes).map_err(|e| format!("{at}: error: {e}"))?;
        cases.push(Case { location: Some(at), ..case });
    }
    Ok(cases)
}

fn line_of(text: &str, byte: usize) -> usize {
    text[..byte.min(text.len())].matches('\n').count() + 1
}

fn case(t: &toml::Table, info: &ShaderInfo, scenes: &BTreeMap<String, Arc<SceneBuffers>>) -> Result<Case, String> {
    for key in t.keys() {
        if !CASE_KEYS.contains(&key.as_str()) {
            return Err(format!("unknown key {key:?} in a case (keys: {})", CASE_KEYS.join(", ")));
        }
    }
    let string = |key: &str| -> Result<Option<&str>, String> {
        match t.get(key) {
            None => Ok(None),
            Some(toml::Value::String(s)) => Ok(Some(s)),
            Some(_) => Err(format!("`{key}` must be a string")),
        }
    };
    let boolean = |key: &str| -> Result<Option<bool>, String> {
        match t.get(key) {
            None => Ok(None),
            Some(toml::Value::Boolean(b)) => Ok(Some(*b)),
            Some(_) => Err(format!("`{key}` must be true or false")),
        }
    };
    let function = string("function")?.ok_or("a case needs `function = \"name\"`")?;
    // Among overloads, the one whose parameters the inputs name and fit.
    let inputs = match t.get("inputs") {
        Some(toml::Value::Table(inputs)) => Some(inputs),
        _ => None,
    };
    let f = info.function_where(function, |f| {
        inputs.is_some_and(|inputs| {
            f.takes(inputs.len(), |p, ty| inputs.get(p).is_some_and(|v| value(v, ty, info, false).is_ok()))
        })
    })?;
    let mut case = Case::new(function);
    if let Some(n) = string("name")? {
        case.name = n.to_string();
    }

    match t.get("inputs") {
        None => {}
        Some(toml::Value::Table(inputs)) => {
            for (name, v) in inputs {
                let Some((_, ty)) = f.params.iter().find(|(p, _)| p == name) else {
                    return Err(format!("{} has no parameter {name:?}", f.signature()));
                };
                case.inputs.push((name.clone(), value(v, ty, info, false).map_err(|e| format!("input {name}: {e}"))?));
            }
        }
        Some(_) => return Err("`inputs` must be a table of parameter = value".into()),
    }
    for (p, _) in &f.params {
        if !case.inputs.iter().any(|(n, _)| n == p) {
            return Err(format!("input {p} of {} is missing", f.signature()));
        }
    }

    let same = boolean("same_as_cpu")?.unwrap_or(false);
    let rule = string("rule")?.map(Rule::parse).transpose()?;
    case.expected = match (t.get("expected"), same) {
        (Some(_), true) => return Err("give either `expected` or `same_as_cpu = true`, not both".into()),
        (Some(v), false) => {
            if rule.is_none() {
                return Err("a case with `expected` states its rule: rule = \"exact\", \"ulp N\" or \"abs E\"".into());
            }
            Expected::Value(value(v, &f.ret, info, false).map_err(|e| format!("expected: {e}"))?)
        }
        (None, true) => Expected::SameAsCpu,
        (None, false) => return Err("a case needs `expected = …` or `same_as_cpu = true`".into()),
    };
    case.rule = rule.unwrap_or(Rule::Exact);
    case.cpu = boolean("cpu")?.unwrap_or(true);
    if same && !case.cpu {
        return Err("`same_as_cpu = true` compares with the C++ build, which `cpu = false` turns off: drop one".into());
    }

    case.scene = match t.get("scene") {
        None => None,
        Some(toml::Value::String(name)) => Some(
            scenes
                .get(name)
                .cloned()
                .ok_or_else(|| format!("no scene {name:?} in this file (define it under [scenes.{name}])"))?,
        ),
        Some(v) => Some(Arc::new(scene(v, info).map_err(|e| format!("scene: {e}"))?)),
    };
    Ok(case)
}

/// A scene: a table of scene_buffers.glsl's buffers, a struct as a table
/// (members not given are 0), an array buffer as an array of tables.
fn scene(v: &toml::Value, info: &ShaderInfo) -> Result<SceneBuffers, String> {
    let toml::Value::Table(t) = v else {
        return Err("a scene is a table of buffers (frame = {…}, primitives = [{…}], …)".into());
    };
    let mut s = SceneBuffers::new();
    for (name, v) in t {
        let Some(b) = info.scene_buffers.iter().find(|b| &b.name == name) else {
            let known: Vec<&str> = info.scene_buffers.iter().map(|b| b.name.as_str()).collect();
            return Err(format!("unknown buffer {name:?} (scene_buffers.glsl has {})", known.join(", ")));
        };
        let ty = Type::Struct(b.ty.clone());
        let items: Vec<&toml::Value> = match (b.array, v) {
            (true, toml::Value::Array(a)) => a.iter().collect(),
            (true, _) => return Err(format!("{name} is an array: write {name} = [{{…}}, …]")),
            (false, v) => vec![v],
        };
        let mut words = Vec::new();
        for (k, item) in items.iter().enumerate() {
            let v = value(item, &ty, info, true).map_err(|e| format!("{name}[{k}]: {e}"))?;
            words.extend(v.encode(&ty, true).map_err(|e| format!("{name}[{k}]: {e}"))?);
        }
        s = s.with_words(name, words);
    }
    Ok(s)
}

/// A TOML value as a value of `ty`. Numbers convert to the parameter's
/// scalar type when exact; strings are hex bits (`"0x3f800000"`), a
/// constant of raycast.glsl or layout.h (`"T_FAR"`, `"SHAPE_CONE"`), or a
/// number read as a float with one rounding (`"0.1"`, `"nan"`, `"-inf"`).
fn value(v: &toml::Value, ty: &Type, info: &ShaderInfo, zero_fill: bool) -> Result<Value, String> {
    match (ty, v) {
        (Type::Scalar(s), v) => scalar(*s, v, info),
        (Type::Vector(s, n), toml::Value::Array(a)) if a.len() == *n => {
            Ok(Value::List(a.iter().map(|x| scalar(*s, x, info)).collect::<Result<_, _>>()?))
        }
        (Type::Vector(_, n), _) => Err(format!("expected a {} (an array of {n})", ty.glsl_name())),
        (Type::Matrix(n), toml::Value::Array(cols)) if cols.len() == *n => Ok(Value::List(
            cols.iter()
                .enumerate()
                .map(|(c, col)| {
                    value(col, &Type::Vector(Scalar::Float, *n), info, zero_fill)
                        .map_err(|e| format!("column {c}: {e}"))
                })
                .collect::<Result<_, _>>()?,
        )),
        (Type::Matrix(_), v @ (toml::Value::Float(_) | toml::Value::Integer(_) | toml::Value::String(_))) => {
            scalar(Scalar::Float, v, info)
        }
        (Type::Matrix(n), _) => {
            Err(format!("expected a mat{n}: an array of {n} columns, or one number for the diagonal"))
        }
        (Type::Struct(def), toml::Value::Table(t)) => {
            let mut members = Vec::new();
            for (k, x) in t {
                let Some((_, mt)) = def.members.iter().find(|(m, _)| m == k) else {
                    let known: Vec<&str> = def.members.iter().map(|(m, _)| m.as_str()).collect();
                    return Err(format!("{} has no member {k:?} (members: {})", def.name, known.join(", ")));
                };
                members.push((k.clone(), value(x, mt, info, zero_fill).map_err(|e| format!("{k}: {e}"))?));
            }
            if !zero_fill {
                if let Some((m, _)) = def.members.iter().find(|(m, _)| !t.contains_key(m)) {
                    return Err(format!("member {m:?} of {} is missing", def.name));
                }
            }
            Ok(Value::Struct(members))
        }
        (Type::Struct(def), _) => Err(format!("expected a {} (a table of its members)", def.name)),
    }
}

fn scalar(s: Scalar, v: &toml::Value, info: &ShaderInfo) -> Result<Value, String> {
    let name = s.glsl_name();
    match (s, v) {
        (Scalar::Bool, toml::Value::Boolean(b)) => Ok(Value::Bool(*b)),
        (Scalar::Float, toml::Value::Float(x)) => {
            let f = *x as f32;
            if x.is_finite() && f.is_infinite() {
                return Err(format!("{x} is beyond the float range"));
            }
            Ok(Value::Float(f))
        }
        (Scalar::Float, toml::Value::Integer(i)) => {
            let f = *i as f32;
            if f as i64 != *i {
                return Err(format!("{i} is not exactly a float"));
            }
            Ok(Value::Float(f))
        }
        (Scalar::Int, toml::Value::Integer(i)) => {
            i32::try_from(*i).map(Value::Int).map_err(|_| format!("{i} is not an int"))
        }
        (Scalar::Uint, toml::Value::Integer(i)) => {
            u32::try_from(*i).map(Value::Uint).map_err(|_| format!("{i} is not a uint"))
        }
        (_, toml::Value::String(text)) => {
            if let Some(hex) = text.strip_prefix("0x") {
                let bits = u32::from_str_radix(hex, 16).map_err(|_| format!("{text:?} is not hex bits"))?;
                return Ok(match s {
                    Scalar::Float => Value::Float(f32::from_bits(bits)),
                    Scalar::Int => Value::Int(bits as i32),
                    Scalar::Uint => Value::Uint(bits),
                    Scalar::Bool => Value::Bool(bits != 0),
                });
            }
            if let Some(c) = info.constants.get(text.as_str()) {
                return match (s, c) {
                    (Scalar::Float, Value::Float(_))
                    | (Scalar::Int, Value::Int(_))
                    | (Scalar::Uint, Value::Uint(_)) => Ok(c.clone()),
                    (Scalar::Int, Value::Uint(u)) if *u <= i32::MAX as u32 => Ok(Value::Int(*u as i32)),
                    (Scalar::Float, Value::Uint(u)) if *u < (1 << 24) => Ok(Value::Float(*u as f32)),
                    _ => Err(format!("constant {text} is {}, not a {name}", c.text())),
                };
            }
            if s == Scalar::Float {
                if let Ok(f) = text.parse::<f32>() {
                    return Ok(Value::Float(f));
                }
            }
            Err(format!("{text:?} is not a {name}, hex bits (\"0x…\") or a constant of raycast.glsl / layout.h"))
        }
        (_, v) => Err(format!("expected a {name}, got {v}")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::Path;

    fn info() -> ShaderInfo {
        ShaderInfo::load(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../shaders")).unwrap()
    }

    #[test]
    fn a_case_with_typed_inputs_constants_and_a_scene() {
        let text = r#"
[scenes.one_cube]
frame = { primitive_count = 1 }
primitives = [{ object_from_world = 1.0, shape = "SHAPE_CUBE" }]

[[case]]
name = "x = -0.5 plane"
function = "plane_t"
inputs = { r = { origin = [-3, "0.1", 0.2], direction = [2.0, 0.0, 0.0] }, axis = 0, s = -0.5 }
expected = 1.25
rule = "exact"

# a comment
[[case]]
function = "trace"
inputs = { r = { origin = [0, 0, 2], direction = [0, 0, -1] } }
same_as_cpu = true
scene = "one_cube"
"#;
        let cases = parse(text, "t.toml", &info()).unwrap();
        assert_eq!(cases.len(), 2);
        assert_eq!(cases[0].location.as_deref(), Some("t.toml:6"));
        assert_eq!(cases[1].location.as_deref(), Some("t.toml:14"));
        assert_eq!(cases[0].expected, Expected::Value(Value::Float(1.25)));
        let r = &cases[0].inputs.iter().find(|(n, _)| n == "r").unwrap().1;
        assert_eq!(r.get("origin").unwrap().as_floats().unwrap(), vec![-3.0, 0.1, 0.2]);
        assert_eq!(cases[1].expected, Expected::SameAsCpu);
        assert_eq!(cases[1].rule, Rule::Exact);
        assert!(cases[1].scene.is_some());
    }

    #[test]
    fn mistakes_name_the_line() {
        let i = info();
        let e = parse("[[case]]\nfunction = \"plane_t\"\ninputs = { r = { origin = [0, 0, 0], direction = [1, 0, 0] }, axis = 0, s = 0.5 }\nexpected = 0.5\n", "t.toml", &i).unwrap_err();
        assert_eq!(
            e,
            "t.toml:1: error: a case with `expected` states its rule: rule = \"exact\", \"ulp N\" or \"abs E\""
        );
        let e = parse("\n[[case]]\nfunction = \"plane\"\n", "t.toml", &i).unwrap_err();
        assert!(e.starts_with("t.toml:2: error: ") && e.contains("no top-level function \"plane\""), "{e}");
        let e = parse(
            "[[case]]\nfunction = \"clamp01\"\ninputs = { x = 0.5 }\nsame_as_cpu = true\ncpu = false\n",
            "t.toml",
            &i,
        )
        .unwrap_err();
        assert!(
            e.contains(
                "t.toml:1: error: `same_as_cpu = true` compares with the C++ build, which `cpu = false` turns off"
            ),
            "{e}"
        );
        let e = parse("[[case]]\nfunction = \"dot3\"\ninputs = { a = [1, 2, 3] }\nsame_as_cpu = true\n", "t.toml", &i)
            .unwrap_err();
        assert!(e.contains("input b of float dot3(vec3 a, vec3 b) is missing"), "{e}");
        let e = parse(
            "[[case]]\nfunction = \"dot3\"\ninputs = { a = [1, 2], b = [1, 2, 3] }\nsame_as_cpu = true\n",
            "t.toml",
            &i,
        )
        .unwrap_err();
        assert!(e.contains("input a: expected a vec3"), "{e}");
        let e = parse("[[case]]\nfunction = \"dot3\"\nexpect = 1\n", "t.toml", &i).unwrap_err();
        assert!(e.contains("unknown key \"expect\""), "{e}");
        let e = parse("[[case]]\nfunction = \"dot3\"\ninputs = { a = [1, 2, 3], b = [1, 2, 3] }\nexpected = 14\nrule = \"close\"\n", "t.toml", &i).unwrap_err();
        assert!(e.contains("rule \"close\""), "{e}");
        let e = parse("[[case]\n", "t.toml", &i).unwrap_err();
        assert!(
            e.starts_with("t.toml:1:7: error: ")
                && !e.contains('\n')
                && e.ends_with("(a case file is TOML: [[case]] tables)"),
            "{e}"
        );
        // Not TOML at all (JSON): where TOML's reading stopped, by line and column.
        let e = parse("{\n  \"cases\": [1, 2]\n}\n", "t.json", &i).unwrap_err();
        assert!(e.starts_with("t.json:1:1: error: "), "{e}");
        let e = parse("# a comment\n[[case]]\nfunction = \"dot3\"\ninputs = { a = [1, 2, 3] b = 2 }\n", "t.toml", &i)
            .unwrap_err();
        assert!(e.starts_with("t.toml:4:26: error: "), "{e}");
    }
}
