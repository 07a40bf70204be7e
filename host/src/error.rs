//! `Error`: every way a command can fail, each variant with its exit code.
//! The exit codes live in one table, [`EXIT_CODES`], which `raycast --help`
//! prints and the README repeats. `main` prints the error that ends a
//! command and ends the process with its code; a command that goes on past
//! a failure (one scene of several, a round of `render --watch`) prints that
//! failure's line (`Error::line`) as it happens and fails at the end.

use crate::gpu::GpuError;

/// The exit codes of every command, with what each means.
pub const EXIT_CODES: [(u8, &str); 5] = [
    (0, "success"),
    (1, "an error: a scene, a file, the device or the CPU build failed"),
    (2, "a usage error: a flag or a value out of range (clap's own, or found before any work)"),
    (3, "the Vulkan validation layer reported a message (--validate, RAYCAST_VALIDATION=1)"),
    (4, "a comparison found differences (check, compare, explain, conformance, shader-test)"),
];

/// [`EXIT_CODES`] as the text `raycast --help` ends with.
pub fn exit_codes_help() -> String {
    let mut text = String::from("Exit codes:\n");
    for (code, meaning) in EXIT_CODES {
        text.push_str(&format!("  {code}  {meaning}\n"));
    }
    text
}

/// A failure of a command, as the library reports it.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    /// A flag or value out of range, or options that contradict each other (exit 2).
    #[error("{0}")]
    Usage(String),
    /// A scene that does not load: the message names `file:line:col` itself (exit 1).
    #[error("{0}")]
    Scene(String),
    /// The Vulkan device (exit 1).
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// The device cut pixels short, so the picture would be wrong (exit 1).
    #[error(transparent)]
    CutShort(#[from] CutShort),
    /// Anything else that stopped the work: a file, the CPU build, a write (exit 1).
    #[error("{0}")]
    Failed(String),
    /// The validation layer reported this many messages, printed as they came (exit 3).
    #[error("the Vulkan validation layer reported {0} message(s)")]
    Validation(usize),
    /// `command` compared and found differences; `message` says which (exit 4).
    #[error("{message}")]
    Mismatch { command: &'static str, message: String },
}

impl Error {
    /// The process's exit status for this error ([`EXIT_CODES`]).
    pub fn exit_code(&self) -> u8 {
        match self {
            Error::Usage(_) => 2,
            Error::Scene(_) | Error::Gpu(_) | Error::CutShort(_) | Error::Failed(_) => 1,
            Error::Validation(_) => 3,
            Error::Mismatch { .. } => 4,
        }
    }

    /// The line printed on stderr: `raycast: error: …`, a scene's own
    /// `file:line:col: error: …`, or `raycast: COMMAND failed: …`.
    pub fn line(&self) -> String {
        match self {
            Error::Scene(m) => m.clone(),
            Error::Mismatch { command, message } => format!("raycast: {command} failed: {message}"),
            e => format!("raycast: error: {e}"),
        }
    }

    /// A usage error (exit 2) saying `e`.
    pub fn usage(e: impl std::fmt::Display) -> Error {
        Error::Usage(e.to_string())
    }

    /// A scene error (exit 1): `e` already reads `file:line:col: error: …`.
    pub fn scene(e: impl std::fmt::Display) -> Error {
        Error::Scene(e.to_string())
    }
}

impl From<String> for Error {
    fn from(e: String) -> Self {
        Error::Failed(e)
    }
}

impl From<&str> for Error {
    fn from(e: &str) -> Self {
        Error::Failed(e.to_string())
    }
}

impl From<std::io::Error> for Error {
    fn from(e: std::io::Error) -> Self {
        Error::Failed(e.to_string())
    }
}

impl From<std::fmt::Error> for Error {
    fn from(e: std::fmt::Error) -> Self {
        Error::Failed(e.to_string())
    }
}

/// Whether the Khronos validation layer is asked for: `--validate`, or RAYCAST_VALIDATION=1.
pub fn validation_wanted(flag: bool) -> bool {
    flag || std::env::var("RAYCAST_VALIDATION").is_ok_and(|v| v == "1")
}

/// Fails with [`Error::Validation`] (exit 3) if the validation layer said
/// anything, each message printed on stderr.
pub fn check_validation(messages: Vec<String>) -> Result<(), Error> {
    if messages.is_empty() {
        return Ok(());
    }
    for m in &messages {
        errln!("raycast: validation: {m}");
    }
    Err(Error::Validation(messages.len()))
}

/// The device ended some pixels' loops early (`PixelOut.rays` has
/// RAYS_CUT_SHORT): `count` of `total`, the first at `first` (x, y);
/// `advice` says what the command's user can do.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct CutShort {
    pub device: String,
    pub count: usize,
    pub total: usize,
    pub first: (u32, u32),
    pub advice: String,
}

impl std::fmt::Display for CutShort {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let CutShort { device, count, total, first, advice } = self;
        write!(
            f,
            "{device} cut {count} of {total} pixels short (the first at ({}, {})), so the picture would be wrong and \
             nothing was written. Mesa's software Vulkan device (lavapipe, llvmpipe) gives each shader invocation \
             65535 loop iterations in all, then ends every loop early without a word (LP_MAX_TGSI_LOOP_ITERATIONS); \
             these pixels need more: each node visited, each primitive tested, each light and each mirror bounce \
             of a sample takes some (samples run one per dispatch, so --spp does not add up). {advice}",
            first.0, first.1
        )
    }
}

impl std::error::Error for CutShort {}
