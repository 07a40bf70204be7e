//! raycast: a ray caster that runs as a Vulkan compute shader over
//! CS1230/CS123/Comp175 XML scenes.
//!
//! Parts (see README "Architecture"): `scene` reads scene files, `frame`
//! turns a scene into the buffers of `layout`, `gpu` runs kernels on a
//! Vulkan device, `render` runs the render kernel, `image_io` reads, writes
//! and compares pictures, `bounded` reads text inputs up to a size,
//! `uint_defines` reads the shaders' `#define`d constants, `units` writes
//! byte counts for people, `info` describes a scene and its hierarchy,
//! `conformance` holds the course's renders' comparison rule, `cli` is the
//! command line.

/// `println!` that goes on when stdout is closed (`raycast render | head`):
/// the status lines are for reading, the work (the PNG, the exit status)
/// is what counts, and `println!` panics on a broken pipe.
macro_rules! outln {
    () => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout());
    }};
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($arg)*);
    }};
}

/// `print!`, going on when stdout is closed (`outln!`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = write!(std::io::stdout(), $($arg)*);
    }};
}

/// A command's product on stdout (`gen`'s scene, a `--json` report):
/// written and flushed here, its error returned, where `outln!` lets
/// status lines go (and the flush at exit would lose it): what a program
/// reads is not lost while the command says it succeeded.
pub(crate) fn emit(text: &str) -> std::io::Result<()> {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// [`emit`] of one line (`--json`), its error as `cannot write to standard output: …`.
pub(crate) fn emit_line(text: &str) -> Result<(), String> {
    emit(&format!("{text}\n")).map_err(|e| format!("cannot write to standard output: {e}"))
}

/// `eprintln!`, going on when stderr is closed (`outln!`).
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stderr(), $($arg)*);
    }};
}

pub mod bench;
pub mod bounded;
pub mod bvh;
pub mod check;
pub mod cli;
pub mod conformance;
pub mod cpu;
pub mod frame;
pub mod gen;
pub mod gpu;
pub mod harness;
pub mod image_io;
pub mod info;
pub mod layout;
pub mod preview;
pub mod progress;
pub mod render;
pub mod scene;
pub mod trace;
pub mod uint_defines;
pub mod units;
pub mod versus;
