//! Typed values of the shared GLSL and their flattening to u32 words: one
//! word per scalar (float bits, int, uint, bool as 0 / 1), vectors by
//! component, matrices by column, structs member by member in declaration
//! order. The device kernels and the C++ wrappers read and write exactly
//! this order.

use std::fmt::Write;
use std::sync::Arc;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    Float,
    Int,
    Uint,
    Bool,
}

impl Scalar {
    pub fn glsl_name(self) -> &'static str {
        match self {
            Scalar::Float => "float",
            Scalar::Int => "int",
            Scalar::Uint => "uint",
            Scalar::Bool => "bool",
        }
    }
}

/// A type that crosses the harness's buffers.
#[derive(Clone, Debug, PartialEq)]
pub enum Type {
    Scalar(Scalar),
    /// `vecN`, `ivecN`, `uvecN`, `bvecN`.
    Vector(Scalar, usize),
    /// `matN`: N columns of N floats.
    Matrix(usize),
    Struct(Arc<StructDef>),
}

/// A struct of the shared GLSL, members in declaration order.
#[derive(Debug, PartialEq)]
pub struct StructDef {
    pub name: String,
    pub members: Vec<(String, Type)>,
}

/// One scalar of a flattened type.
#[derive(Clone, Debug, PartialEq)]
pub struct Leaf {
    /// For people: `normal.x`, `t`, `[2][1]`; empty for a lone scalar.
    pub label: String,
    /// For code, appended to the variable: `.normal[0]`, `.t`, `[2][1]`.
    pub access: String,
    pub scalar: Scalar,
}

const COMPONENTS: [&str; 4] = ["x", "y", "z", "w"];

impl Type {
    pub fn glsl_name(&self) -> String {
        match self {
            Type::Scalar(s) => s.glsl_name().to_string(),
            Type::Vector(s, n) => {
                let p = match s {
                    Scalar::Float => "",
                    Scalar::Int => "i",
                    Scalar::Uint => "u",
                    Scalar::Bool => "b",
                };
                format!("{p}vec{n}")
            }
            Type::Matrix(n) => format!("mat{n}"),
            Type::Struct(s) => s.name.clone(),
        }
    }

    /// How many u32 words the type flattens to.
    pub fn words(&self) -> usize {
        match self {
            Type::Scalar(_) => 1,
            Type::Vector(_, n) => *n,
            Type::Matrix(n) => n * n,
            Type::Struct(s) => s.members.iter().map(|(_, t)| t.words()).sum(),
        }
    }

    /// Every scalar in flattening order.
    pub fn leaves(&self) -> Vec<Leaf> {
        let mut out = Vec::new();
        self.push_leaves("", "", &mut out);
        out
    }

    fn push_leaves(&self, label: &str, access: &str, out: &mut Vec<Leaf>) {
        let join =
            |label: &str, part: &str| if label.is_empty() { part.to_string() } else { format!("{label}.{part}") };
        match self {
            Type::Scalar(s) => out.push(Leaf { label: label.to_string(), access: access.to_string(), scalar: *s }),
            Type::Vector(s, n) => {
                for (k, c) in COMPONENTS.iter().enumerate().take(*n) {
                    out.push(Leaf { label: join(label, c), access: format!("{access}[{k}]"), scalar: *s });
                }
            }
            Type::Matrix(n) => {
                for c in 0..*n {
                    for r in 0..*n {
                        out.push(Leaf {
                            label: format!("{label}[{c}][{r}]"),
                            access: format!("{access}[{c}][{r}]"),
                            scalar: Scalar::Float,
                        });
                    }
                }
            }
            Type::Struct(s) => {
                for (name, t) in &s.members {
                    t.push_leaves(&join(label, name), &format!("{access}.{name}"), out);
                }
            }
        }
    }
}

/// A value of a [`Type`]. Vectors and matrices (by column) are lists.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Float(f32),
    Int(i32),
    Uint(u32),
    Bool(bool),
    List(Vec<Value>),
    /// Members by name; for inputs every member must be given.
    Struct(Vec<(String, Value)>),
}

impl From<f32> for Value {
    fn from(x: f32) -> Value {
        Value::Float(x)
    }
}
impl From<i32> for Value {
    fn from(x: i32) -> Value {
        Value::Int(x)
    }
}
impl From<u32> for Value {
    fn from(x: u32) -> Value {
        Value::Uint(x)
    }
}
impl From<bool> for Value {
    fn from(x: bool) -> Value {
        Value::Bool(x)
    }
}
impl<const N: usize> From<[f32; N]> for Value {
    fn from(v: [f32; N]) -> Value {
        Value::List(v.iter().map(|x| Value::Float(*x)).collect())
    }
}
impl From<glam::Vec2> for Value {
    fn from(v: glam::Vec2) -> Value {
        v.to_array().into()
    }
}
impl From<glam::Vec3> for Value {
    fn from(v: glam::Vec3) -> Value {
        v.to_array().into()
    }
}
impl From<glam::Vec4> for Value {
    fn from(v: glam::Vec4) -> Value {
        v.to_array().into()
    }
}
impl From<glam::Mat4> for Value {
    fn from(m: glam::Mat4) -> Value {
        Value::List(m.to_cols_array_2d().iter().map(|c| Value::from(*c)).collect())
    }
}

impl Value {
    /// A struct value: `Value::record([("origin", o.into()), ("direction", d.into())])`.
    pub fn record<'a>(members: impl IntoIterator<Item = (&'a str, Value)>) -> Value {
        Value::Struct(members.into_iter().map(|(n, v)| (n.to_string(), v)).collect())
    }

    /// A `Ray { origin, direction }`.
    pub fn ray(origin: impl Into<Value>, direction: impl Into<Value>) -> Value {
        Value::record([("origin", origin.into()), ("direction", direction.into())])
    }

    /// The member `name` of a struct value.
    pub fn get(&self, name: &str) -> Option<&Value> {
        match self {
            Value::Struct(m) => m.iter().find(|(n, _)| n == name).map(|(_, v)| v),
            _ => None,
        }
    }

    pub fn as_f32(&self) -> Option<f32> {
        match self {
            Value::Float(x) => Some(*x),
            _ => None,
        }
    }

    pub fn as_u32(&self) -> Option<u32> {
        match self {
            Value::Uint(x) => Some(*x),
            _ => None,
        }
    }

    /// A float vector's components.
    pub fn as_floats(&self) -> Option<Vec<f32>> {
        match self {
            Value::List(v) => v.iter().map(Value::as_f32).collect(),
            _ => None,
        }
    }

    /// The words of this value as type `ty`. `zero_fill`: struct members not
    /// given are zero (for scene buffers); otherwise every member must be given.
    pub fn encode(&self, ty: &Type, zero_fill: bool) -> Result<Vec<u32>, String> {
        let mut out = Vec::with_capacity(ty.words());
        self.encode_into(ty, zero_fill, "", &mut out)?;
        Ok(out)
    }

    fn encode_into(&self, ty: &Type, zero_fill: bool, path: &str, out: &mut Vec<u32>) -> Result<(), String> {
        let at = |what: String| if path.is_empty() { what } else { format!("{path}: {what}") };
        match (ty, self) {
            (Type::Scalar(s), v) => out.push(scalar_word(*s, v).map_err(at)?),
            (Type::Vector(s, n), Value::List(items)) if items.len() == *n => {
                for (k, v) in items.iter().enumerate() {
                    out.push(scalar_word(*s, v).map_err(|e| at(format!("component {k}: {e}")))?);
                }
            }
            (Type::Matrix(n), Value::List(cols)) if cols.len() == *n => {
                for (c, col) in cols.iter().enumerate() {
                    col.encode_into(&Type::Vector(Scalar::Float, *n), zero_fill, &format!("{path}[{c}]"), out)?;
                }
            }
            // A scalar for a matrix is its diagonal, as GLSL's mat4(1.0).
            (Type::Matrix(n), v @ (Value::Float(_) | Value::Int(_) | Value::Uint(_))) => {
                let d = scalar_word(Scalar::Float, v).map_err(at)?;
                for c in 0..*n {
                    for r in 0..*n {
                        out.push(if c == r { d } else { 0 });
                    }
                }
            }
            (Type::Struct(def), Value::Struct(members)) => {
                for (name, _) in members {
                    if !def.members.iter().any(|(n, _)| n == name) {
                        let known: Vec<&str> = def.members.iter().map(|(n, _)| n.as_str()).collect();
                        return Err(at(format!("{} has no member {name:?} (members: {})", def.name, known.join(", "))));
                    }
                }
                for (name, t) in &def.members {
                    let sub = if path.is_empty() { name.clone() } else { format!("{path}.{name}") };
                    match members.iter().find(|(n, _)| n == name) {
                        Some((_, v)) => v.encode_into(t, zero_fill, &sub, out)?,
                        None if zero_fill => out.extend(std::iter::repeat_n(0, t.words())),
                        None => return Err(at(format!("member {name:?} of {} is missing", def.name))),
                    }
                }
            }
            (t, v) => return Err(at(format!("expected a {}, got {}", describe_type(t), v.describe()))),
        }
        Ok(())
    }

    /// The value of type `ty` in `words` (exactly `ty.words()` of them).
    pub fn decode(ty: &Type, words: &[u32]) -> Value {
        let mut at = 0;
        Value::decode_from(ty, words, &mut at)
    }

    fn decode_from(ty: &Type, words: &[u32], at: &mut usize) -> Value {
        let mut next = |s: Scalar| {
            let w = words.get(*at).copied().unwrap_or(0);
            *at += 1;
            scalar_value(s, w)
        };
        match ty {
            Type::Scalar(s) => next(*s),
            Type::Vector(s, n) => Value::List((0..*n).map(|_| next(*s)).collect()),
            Type::Matrix(n) => {
                Value::List((0..*n).map(|_| Value::List((0..*n).map(|_| next(Scalar::Float)).collect())).collect())
            }
            Type::Struct(def) => {
                Value::Struct(def.members.iter().map(|(n, t)| (n.clone(), Value::decode_from(t, words, at))).collect())
            }
        }
    }

    fn describe(&self) -> String {
        match self {
            Value::Float(x) => format!("the float {x:?}"),
            Value::Int(x) => format!("the int {x}"),
            Value::Uint(x) => format!("the uint {x}"),
            Value::Bool(x) => format!("the bool {x}"),
            Value::List(v) => format!("a list of {}", v.len()),
            Value::Struct(_) => "a struct".to_string(),
        }
    }

    /// GLSL-like text: `1.75`, `(0, 0.25, 0.5)`, `{ t = 1.75, normal = (…) }`.
    pub fn text(&self) -> String {
        match self {
            Value::Float(x) => float_text(*x),
            Value::Int(x) => x.to_string(),
            Value::Uint(x) => format!("{x}u"),
            Value::Bool(x) => x.to_string(),
            Value::List(v) => format!("({})", v.iter().map(Value::text).collect::<Vec<_>>().join(", ")),
            Value::Struct(m) => {
                let mut s = String::from("{ ");
                for (k, (n, v)) in m.iter().enumerate() {
                    let _ = write!(s, "{}{n} = {}", if k > 0 { ", " } else { "" }, v.text());
                }
                s.push_str(" }");
                s
            }
        }
    }
}

fn describe_type(t: &Type) -> String {
    match t {
        Type::Scalar(s) => s.glsl_name().to_string(),
        Type::Vector(_, n) => format!("{} (a list of {n})", t.glsl_name()),
        Type::Matrix(n) => format!("mat{n} (a list of {n} columns, or one number for the diagonal)"),
        Type::Struct(d) => format!("{} (a table of its members)", d.name),
    }
}

/// Shortest text that reads back as the same float.
pub fn float_text(x: f32) -> String {
    if x.is_nan() {
        "nan".into()
    } else if x.is_infinite() {
        if x > 0.0 {
            "inf".into()
        } else {
            "-inf".into()
        }
    } else {
        format!("{x:?}")
    }
}

fn scalar_word(s: Scalar, v: &Value) -> Result<u32, String> {
    let exact_f32 = |x: f64| -> Result<u32, String> {
        let f = x as f32;
        if f64::from(f) == x {
            Ok(f.to_bits())
        } else {
            Err(format!("the integer {x} is not exactly a float; write it as a float"))
        }
    };
    match (s, v) {
        (Scalar::Float, Value::Float(x)) => Ok(x.to_bits()),
        (Scalar::Float, Value::Int(x)) => exact_f32(f64::from(*x)),
        (Scalar::Float, Value::Uint(x)) => exact_f32(f64::from(*x)),
        (Scalar::Int, Value::Int(x)) => Ok(*x as u32),
        (Scalar::Int, Value::Uint(x)) if *x <= i32::MAX as u32 => Ok(*x),
        (Scalar::Uint, Value::Uint(x)) => Ok(*x),
        (Scalar::Uint, Value::Int(x)) if *x >= 0 => Ok(*x as u32),
        (Scalar::Bool, Value::Bool(b)) => Ok(u32::from(*b)),
        (s, v) => Err(format!("expected a {}, got {}", s.glsl_name(), v.describe())),
    }
}

fn scalar_value(s: Scalar, w: u32) -> Value {
    match s {
        Scalar::Float => Value::Float(f32::from_bits(w)),
        Scalar::Int => Value::Int(w as i32),
        Scalar::Uint => Value::Uint(w),
        Scalar::Bool => Value::Bool(w != 0),
    }
}

/// One word as a person reads it: `1.75 (0x3fe00000)`, `-1 (0xffffffff)`.
pub fn word_text(s: Scalar, w: u32) -> String {
    match s {
        Scalar::Float => format!("{} (0x{w:08x})", float_text(f32::from_bits(w))),
        Scalar::Int => format!("{} (0x{w:08x})", w as i32),
        Scalar::Uint => format!("{w} (0x{w:08x})"),
        Scalar::Bool => format!("{} (0x{w:08x})", w != 0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray_type() -> Type {
        let v3 = Type::Vector(Scalar::Float, 3);
        Type::Struct(Arc::new(StructDef {
            name: "Ray".into(),
            members: vec![("origin".into(), v3.clone()), ("direction".into(), v3)],
        }))
    }

    #[test]
    fn structs_flatten_member_by_member_and_back() {
        let t = ray_type();
        assert_eq!(t.words(), 6);
        let leaves: Vec<String> = t.leaves().iter().map(|l| format!("{} {}", l.label, l.access)).collect();
        assert_eq!(leaves[0], "origin.x .origin[0]");
        assert_eq!(leaves[5], "direction.z .direction[2]");
        let v = Value::ray([1.0, 2.0, 3.0], [0.0, -1.0, 0.5]);
        let words = v.encode(&t, false).unwrap();
        assert_eq!(words[1], 2.0f32.to_bits());
        assert_eq!(Value::decode(&t, &words), v);
    }

    #[test]
    fn errors_name_the_member() {
        let t = ray_type();
        let e = Value::record([("origin", [1.0f32, 2.0, 3.0].into())]).encode(&t, false).unwrap_err();
        assert!(e.contains("\"direction\" of Ray is missing"), "{e}");
        let e = Value::ray([1.0f32, 2.0], [0.0f32, 0.0, 0.0]).encode(&t, false).unwrap_err();
        assert!(e.contains("origin: expected a vec3"), "{e}");
        assert_eq!(Value::record([]).encode(&t, true).unwrap(), vec![0; 6]);
    }

    #[test]
    fn matrix_from_a_scalar_is_its_diagonal() {
        let w = Value::Float(2.0).encode(&Type::Matrix(2), false).unwrap();
        assert_eq!(w, vec![2.0f32.to_bits(), 0, 0, 2.0f32.to_bits()]);
    }

    #[test]
    fn words_read_in_decimal_and_hex() {
        assert_eq!(word_text(Scalar::Float, 1.75f32.to_bits()), "1.75 (0x3fe00000)");
        assert_eq!(word_text(Scalar::Int, u32::MAX), "-1 (0xffffffff)");
        assert_eq!(word_text(Scalar::Float, f32::NAN.to_bits()), "nan (0x7fc00000)");
    }
}
