//! raycast: a ray caster that runs as a Vulkan compute shader over
//! CS1230/CS123/Comp175 XML scenes.
//!
//! Parts (see docs/architecture.md): `source` says where a scene comes
//! from and `scene` reads it, `frame` turns a scene into the buffers of
//! `layout`, `render` is the seam every backend implements (`Renderer`,
//! `Progressive`, the picture and its timings), `gpu` runs kernels on a
//! Vulkan device (`gpu::GpuRenderer`), `cpu` the C++ build of the same
//! GLSL (`cpu::CpuRenderer`), `image_io` reads, writes and compares pictures, `output` writes a
//! command's products, `error` is the one error type and its exit codes,
//! `bounded` reads text inputs up to a size, `uint_defines` reads the
//! shaders' `#define`d constants, `units` writes numbers for people,
//! `measure` memory, `info` describes a scene and its hierarchy,
//! `conformance` holds the course's renders' comparison rule, `harness`
//! runs shader unit tests, `preview` is the window, and `cli` is the
//! command line (one module per command, named by nothing outside it).

/// `println!` that goes on when stdout is closed (`raycast render | head`):
/// the status lines are for reading, the work (the PNG, the exit status)
/// is what counts, and `println!` panics on a broken pipe. On stderr where
/// the product goes to stdout (`status_to_stderr`).
macro_rules! outln {
    () => {{
        out!("\n")
    }};
    ($($arg:tt)*) => {{
        out!("{}\n", format_args!($($arg)*))
    }};
}

/// `print!`, going on when stdout is closed (`outln!`); a progress line
/// on the terminal steps aside for it (`progress::suspend`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        $crate::progress::suspend(|| {
            if $crate::status_on_stderr() {
                let _ = write!(std::io::stderr(), $($arg)*);
            } else {
                let _ = write!(std::io::stdout(), $($arg)*);
            }
        })
    }};
}

static STATUS_ON_STDERR: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Sends the status lines (`outln!`) to stderr from now on: a picture is
/// written to stdout (`render -o /dev/stdout | …`), which they would corrupt.
pub(crate) fn status_to_stderr() {
    STATUS_ON_STDERR.store(true, std::sync::atomic::Ordering::Relaxed);
}

/// Whether `status_to_stderr` was called.
pub(crate) fn status_on_stderr() -> bool {
    STATUS_ON_STDERR.load(std::sync::atomic::Ordering::Relaxed)
}

/// How much a command says on stderr about its work: nothing (`-q`), one
/// summary line (the default), or the device, times, rates and kernel
/// (`-v`). Data (a report, a table, `--json`) goes to stdout whatever it is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub enum Verbosity {
    Quiet = 0,
    Summary = 1,
    Verbose = 2,
}

static VERBOSITY: std::sync::atomic::AtomicU8 = std::sync::atomic::AtomicU8::new(Verbosity::Summary as u8);

/// Sets how much the status lines say from now on (`-q`, `-v`).
pub fn set_verbosity(v: Verbosity) {
    VERBOSITY.store(v as u8, std::sync::atomic::Ordering::Relaxed);
}

/// Whether status lines of `level` are printed.
pub fn says(level: Verbosity) -> bool {
    VERBOSITY.load(std::sync::atomic::Ordering::Relaxed) >= level as u8
}

/// A detail of the work on stderr, with `-v` only: the device, the scene,
/// times, rates, the kernel.
macro_rules! detail {
    ($($arg:tt)*) => {{
        if $crate::says($crate::Verbosity::Verbose) {
            errln!($($arg)*);
        }
    }};
}

/// A command's summary line on stderr (what it wrote, in how long), unless `-q`.
macro_rules! summary {
    ($($arg:tt)*) => {{
        if $crate::says($crate::Verbosity::Summary) {
            errln!($($arg)*);
        }
    }};
}

/// `eprintln!`, going on when stderr is closed (`outln!`); a progress
/// line on the terminal steps aside for it (`progress::suspend`).
macro_rules! errln {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        $crate::progress::suspend(|| {
            let _ = writeln!(std::io::stderr(), $($arg)*);
        })
    }};
}

#[cfg(test)]
mod area_light_tests;
pub mod bounded;
pub mod bvh;
pub mod check;
pub mod cli;
pub mod conformance;
pub mod cpu;
pub mod error;
pub mod explain;
pub mod frame;
pub mod gen;
pub mod gpu;
pub mod harness;
pub mod image_io;
pub mod info;
pub mod layout;
pub mod measure;
pub mod mitsuba;
pub mod output;
pub mod pov;
pub mod preview;
pub mod progress;
pub mod render;
pub mod scene;
pub mod source;
#[doc(hidden)]
pub mod test_support;
pub mod trace;
pub mod uint_defines;
pub mod units;
pub mod watch;
