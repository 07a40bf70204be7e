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

/// `print!`, going on when stdout is closed (`outln!`).
macro_rules! out {
    ($($arg:tt)*) => {{
        use std::io::Write as _;
        if $crate::status_on_stderr() {
            let _ = write!(std::io::stderr(), $($arg)*);
        } else {
            let _ = write!(std::io::stdout(), $($arg)*);
        }
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

/// Whether standard output was closed as the process started (`raycast gen
/// >&-`): Rust's runtime then opens /dev/null in its place before `main`,
/// and every write would "succeed", so `emit` refuses instead. Noted by a
/// constructor (`.init_array`), which runs before the runtime's set-up.
static STDOUT_CLOSED: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

#[cfg(target_os = "linux")]
#[used]
#[link_section = ".init_array"]
static NOTE_CLOSED_STDOUT: extern "C" fn() = {
    extern "C" fn note() {
        extern "C" {
            fn fcntl(fd: i32, cmd: i32, ...) -> i32;
        }
        const F_GETFD: i32 = 1;
        // SAFETY: fcntl(F_GETFD) only asks whether the descriptor is open.
        if unsafe { fcntl(1, F_GETFD) } == -1 {
            STDOUT_CLOSED.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }
    note
};

/// A command's product on stdout (`gen`'s scene, a `--json` report):
/// written and flushed here, its error returned, where `outln!` lets
/// status lines go (and the flush at exit would lose it): what a program
/// reads is not lost while the command says it succeeded.
pub(crate) fn emit(text: &str) -> std::io::Result<()> {
    use std::io::Write as _;
    if STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(std::io::Error::other("it was closed when raycast started"));
    }
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// [`emit`] of one line (`--json`), its error as `cannot write to standard output: …`.
pub(crate) fn emit_line(text: &str) -> Result<(), String> {
    emit(&format!("{text}\n")).map_err(|e| format!("cannot write to standard output: {e}"))
}

/// A command's product in a file (a PNG, a generated scene, a table):
/// whole or not at all. A regular file (or a new one) is written beside
/// itself under a temporary name, then renamed over the old one, so a
/// picture viewer watching it never reads half a PNG, and a full disk or an
/// interrupted command leaves the last one as it was and no partial file; a
/// device or a pipe (`-o /dev/stdout`, `/dev/full`) is written as it is.
/// Errors read `cannot write PATH: …`.
pub(crate) fn write_whole(path: &std::path::Path, bytes: &[u8]) -> Result<(), String> {
    let cannot = |e: std::io::Error| format!("cannot write {}: {e}", path.display());
    if path == std::path::Path::new("/dev/stdout") && STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(cannot(std::io::Error::other("standard output was closed when raycast started")));
    }
    // A link is written through, as it was: renaming over it would replace the link.
    let regular = std::fs::symlink_metadata(path).map_or(true, |m| m.is_file());
    let name = path.file_name().filter(|_| regular);
    let Some(name) = name else { return std::fs::write(path, bytes).map_err(cannot) };
    let temporary = path.with_file_name(format!(".{}.{}.part", name.to_string_lossy(), std::process::id()));
    let written = std::fs::write(&temporary, bytes).and_then(|()| std::fs::rename(&temporary, path));
    match written {
        Ok(()) => Ok(()),
        // A folder that takes no new file, holding a file that may be
        // written: written in place, as before there was a temporary file.
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && path.exists() => {
            let _ = std::fs::remove_file(&temporary);
            std::fs::write(path, bytes).map_err(cannot)
        }
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            Err(cannot(e))
        }
    }
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
pub mod pov;
pub mod preview;
pub mod progress;
pub mod render;
pub mod scene;
pub mod trace;
pub mod uint_defines;
pub mod units;
pub mod versus;
