//! Writing a command's products: a picture or a scene in a file (whole or
//! not at all), a report on standard output, and the checks made before
//! any work (a name of the wrong kind, a file the command reads).

use crate::error::Error;
use std::path::{Path, PathBuf};

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
        // SAFETY: fcntl(F_GETFD) only asks whether the descriptor is open.
        if unsafe { libc::fcntl(libc::STDOUT_FILENO, libc::F_GETFD) } == -1 {
            STDOUT_CLOSED.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    }
    note
};

/// A command's product on stdout (`gen`'s scene, a `--json` report):
/// written and flushed here, its error returned, where `outln!` lets
/// status lines go (and the flush at exit would lose it): what a program
/// reads is not lost while the command says it succeeded.
pub fn emit(text: &str) -> std::io::Result<()> {
    use std::io::Write as _;
    if STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(std::io::Error::other("it was closed when raycast started"));
    }
    let mut out = std::io::stdout().lock();
    out.write_all(text.as_bytes())?;
    out.flush()
}

/// [`emit`] of one line (`--json`), its error as `cannot write to standard output: …`.
pub fn emit_line(text: &str) -> Result<(), Error> {
    emit(&format!("{text}\n")).map_err(|e| Error::Failed(format!("cannot write to standard output: {e}")))
}

/// A command's product in a file (a PNG, a generated scene, a table):
/// whole or not at all. A regular file (or a new one) is written beside
/// itself under a temporary name (tempfile's `.NAME.XXXXXX.part`), then
/// renamed over the old one, so a picture viewer watching it never reads
/// half a PNG, and a full disk or an interrupted command leaves the last
/// one as it was and no partial file; a device or a pipe (`-o /dev/stdout`,
/// `/dev/full`) is written as it is. Errors read `cannot write PATH: …`.
pub fn write_whole(path: &Path, bytes: &[u8]) -> Result<(), Error> {
    use std::io::Write as _;
    let cannot = |e: std::io::Error| Error::Failed(format!("cannot write {}: {e}", path.display()));
    if path == Path::new("/dev/stdout") && STDOUT_CLOSED.load(std::sync::atomic::Ordering::Relaxed) {
        return Err(cannot(std::io::Error::other("standard output was closed when raycast started")));
    }
    // A link is written through, as it was: renaming over it would replace the link.
    let regular = std::fs::symlink_metadata(path).map_or(true, |m| m.is_file());
    let name = path.file_name().filter(|_| regular);
    let Some(name) = name else { return std::fs::write(path, bytes).map_err(cannot) };
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    // Opened here rather than by `tempfile_in`, whose errors name the
    // temporary file: as `std::fs::write` opens a file (0666 less the
    // umask, not tempfile's owner-only 0600), so the product renamed into
    // place is what writing it in place would have made. A temporary file
    // left by an error (the write's or the rename's) is removed as it drops.
    let written = tempfile::Builder::new()
        .prefix(&format!(".{}.", name.to_string_lossy()))
        .suffix(".part")
        .make_in(folder, |temporary| std::fs::OpenOptions::new().write(true).create_new(true).open(temporary))
        .and_then(|mut temporary| {
            temporary.as_file_mut().write_all(bytes)?;
            temporary.persist(path).map_err(|e| e.error)
        });
    match written {
        Ok(_) => Ok(()),
        // A folder that takes no new file, holding a file that may be
        // written: written in place, as before there was a temporary file.
        Err(e) if e.kind() == std::io::ErrorKind::PermissionDenied && path.exists() => {
            std::fs::write(path, bytes).map_err(cannot)
        }
        Err(e) => Err(cannot(e)),
    }
}

/// A usage error where `output` is one of the files the command reads
/// (`inputs`: the same file, by device and inode, whatever the names say):
/// writing it would replace what it was made from (`render -o` a texture
/// of its scene, `compare -o` one of the pictures compared).
pub fn refuse_overwriting<'a>(output: &Path, inputs: impl IntoIterator<Item = &'a Path>) -> Result<(), Error> {
    use std::os::unix::fs::MetadataExt;
    let Ok(out) = std::fs::metadata(output) else { return Ok(()) };
    let same = |input: &Path| std::fs::metadata(input).is_ok_and(|m| (m.dev(), m.ino()) == (out.dev(), out.ino()));
    if !out.is_file() {
        return Ok(()); // a device (/dev/stdout) is no file the command reads
    }
    match inputs.into_iter().find(|input| same(input)) {
        Some(input) => Err(Error::Usage(format!(
            "{} would be written over {}, which this command reads: name another file",
            output.display(),
            input.display()
        ))),
        None => Ok(()),
    }
}

/// Status lines to stderr where `-o` sends the picture to stdout
/// (`render`, `check`'s and `compare`'s diff images): they would corrupt it.
pub fn status_beside(output: &Option<PathBuf>) {
    if output.as_deref().is_some_and(is_stdout) {
        crate::status_to_stderr();
    }
}

/// The name `-o` takes for standard output.
pub const STDOUT: &str = "-";

/// Whether `path` names standard output: `-`, or /dev/stdout.
pub fn is_stdout(path: &Path) -> bool {
    path == Path::new(STDOUT) || path == Path::new("/dev/stdout")
}

/// `-o`'s path as it is written to: `-` is /dev/stdout.
pub fn output_path(path: &Path) -> PathBuf {
    if path == Path::new(STDOUT) {
        PathBuf::from("/dev/stdout")
    } else {
        path.to_path_buf()
    }
}

/// `-o`'s value as clap takes it: `-` is standard output (/dev/stdout).
pub fn parse_output(s: &str) -> Result<PathBuf, String> {
    Ok(output_path(Path::new(s)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt as _;

    fn names_in(folder: &Path) -> Vec<String> {
        let mut names: Vec<String> =
            std::fs::read_dir(folder).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        names
    }

    /// A file written over is replaced whole, made as `std::fs::write`
    /// makes one (0666 less the umask), and no temporary file is left.
    #[test]
    fn a_file_is_replaced_whole_and_no_temporary_is_left() {
        let folder = tempfile::tempdir().unwrap();
        let path = folder.path().join("picture.png");
        write_whole(&path, b"first").unwrap();
        write_whole(&path, b"second").unwrap();
        assert_eq!(std::fs::read(&path).unwrap(), b"second");
        let plain = folder.path().join("plain");
        std::fs::write(&plain, b"x").unwrap();
        let mode = |p: &Path| std::fs::metadata(p).unwrap().permissions().mode() & 0o777;
        assert_eq!(mode(&path), mode(&plain), "made as std::fs::write makes a file");
        assert_eq!(names_in(folder.path()), ["picture.png", "plain"]);
    }

    /// A link is written through and stays a link; a device is written as it is.
    #[test]
    fn a_link_is_written_through_and_a_device_as_it_is() {
        let folder = tempfile::tempdir().unwrap();
        let target = folder.path().join("target.png");
        let link = folder.path().join("link.png");
        std::fs::write(&target, b"old").unwrap();
        std::os::unix::fs::symlink(&target, &link).unwrap();
        write_whole(&link, b"new").unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(std::fs::read(&target).unwrap(), b"new");
        assert_eq!(names_in(folder.path()), ["link.png", "target.png"]);
        write_whole(Path::new("/dev/null"), b"nothing").unwrap();
    }

    /// Errors name the product, and the system's reason as it gives it:
    /// never the temporary file.
    #[test]
    fn errors_read_cannot_write_the_path() {
        let folder = tempfile::tempdir().unwrap();
        let missing = folder.path().join("no-folder/picture.png");
        let e = write_whole(&missing, b"x").unwrap_err();
        assert_eq!(
            e.to_string(),
            format!("cannot write {}: No such file or directory (os error 2)", missing.display())
        );
        if Path::new("/dev/full").exists() {
            let e = write_whole(Path::new("/dev/full"), b"x").unwrap_err();
            assert_eq!(e.to_string(), "cannot write /dev/full: No space left on device (os error 28)");
        }
    }
}
