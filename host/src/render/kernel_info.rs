//! What a backend says of the kernel that draws a frame: its name, how it
//! was built, what its specialization kept, and the driver's statistics.

use std::time::Duration;

/// The kernel that draws a frame, as the status lines and `bench` tell it.
#[derive(Clone, Debug)]
pub struct KernelInfo {
    /// Its file's stem: `render`, `render_uniform`.
    pub name: String,
    /// Where it keeps the scene's arrays: `storage` or `uniform` (bench's
    /// backend column: `gpu storage`).
    pub arrays: &'static str,
    /// How its division and square root are corrected, as a clause
    /// (`Division::describe`; empty where they are the device's own).
    pub division: String,
    /// How it was built: a shader object, a pipeline specialised ahead.
    pub how_built: Option<String>,
    /// What its specialization keeps and leaves out (`Specialization::describe`).
    pub specialization: String,
    /// The time this call took to check and build it (zero when built before).
    pub build_time: Duration,
}

/// One executable of a pipeline (a compute pipeline has one, or a few
/// where the driver compiles several variants) and the driver's statistics
/// of it (`Kernel::statistics`).
#[derive(Clone, Debug, serde::Serialize)]
pub struct Executable {
    pub name: String,
    pub description: String,
    pub subgroup_size: u32,
    pub statistics: Vec<Statistic>,
}

/// One statistic of an executable, as the driver names and describes it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Statistic {
    pub name: String,
    pub description: String,
    pub value: StatisticValue,
}

/// A statistic's value in the driver's format (in JSON: a bare value).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
#[serde(untagged)]
pub enum StatisticValue {
    Bool(bool),
    Int(i64),
    Uint(u64),
    Float(f64),
}

impl std::fmt::Display for StatisticValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            StatisticValue::Bool(b) => write!(f, "{b}"),
            StatisticValue::Int(v) => write!(f, "{v}"),
            StatisticValue::Uint(v) => write!(f, "{v}"),
            StatisticValue::Float(v) => write!(f, "{v}"),
        }
    }
}
