//! Input files read with a bound on their size, so that a device such as
//! /dev/zero, or a wrong path to a huge file, is an error rather than all
//! of memory.

use std::io::Read as _;
use std::path::Path;

/// The most bytes a text input may have (a scene file, a shader test file,
/// a shader source): far beyond any real one (the course's largest scenes
/// are kilobytes; a million primitives written out flat are about 300 MB).
pub const MAX_INPUT_BYTES: u64 = 1 << 30;

/// Memory a scene file's load takes at its peak, per byte of XML: the
/// text, roxmltree's tree of it and the parsed model together. Measured
/// (peak RSS over file size) 10.7 on 200,000 primitives each with a
/// translate, a scale and a diffuse colour (37 MB, 406 MB), 8.9 on `gen
/// recursive-spheres --depth 8 --flat` (82 MB, 729 MB; docs/scale.md#instancing); about the larger, so that only
/// a load that would very likely fail is refused.
pub const LOAD_BYTES_PER_XML_BYTE: u64 = 10;

/// Memory this process may still take: MemAvailable plus SwapFree from
/// /proc/meminfo, or RAYCAST_MEMORY_AVAILABLE (bytes; for tests). None
/// where neither says.
pub fn memory_available() -> Option<u64> {
    if let Some(v) = std::env::var("RAYCAST_MEMORY_AVAILABLE").ok().and_then(|v| v.trim().parse().ok()) {
        return Some(v);
    }
    let info = std::fs::read_to_string("/proc/meminfo").ok()?;
    let kib = |key: &str| {
        info.lines().find_map(|l| l.strip_prefix(key)?.trim().strip_suffix("kB")?.trim().parse::<u64>().ok())
    };
    Some((kib("MemAvailable:")? + kib("SwapFree:").unwrap_or(0)) * 1024)
}

/// Why `read` gave no bytes.
#[derive(Debug)]
pub enum ReadError {
    Io(std::io::Error),
    /// More than the bound, which is given.
    TooLarge(u64),
}

impl std::fmt::Display for ReadError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            ReadError::Io(e) => e.fmt(f),
            ReadError::TooLarge(max) if *max >= 1 << 20 => write!(f, "larger than {} MiB", max >> 20),
            ReadError::TooLarge(max) => write!(f, "larger than {max} bytes"),
        }
    }
}

/// The bytes of `path`, at most `max` of them.
pub fn read(path: &Path, max: u64) -> Result<Vec<u8>, ReadError> {
    let file = std::fs::File::open(path).map_err(ReadError::Io)?;
    // Room for the whole file at once (a doubling Vec held up to twice it);
    // the bound still decides, as the size can change under us.
    let size = file.metadata().map_or(0, |m| m.len()).min(max + 1);
    let mut bytes = Vec::with_capacity(usize::try_from(size).unwrap_or(0));
    file.take(max + 1).read_to_end(&mut bytes).map_err(ReadError::Io)?;
    if bytes.len() as u64 > max {
        return Err(ReadError::TooLarge(max));
    }
    Ok(bytes)
}

/// `read` as UTF-8 text, at most MAX_INPUT_BYTES.
pub fn read_text(path: &Path) -> Result<String, crate::error::Error> {
    let bytes = read(path, MAX_INPUT_BYTES).map_err(|e| e.to_string())?;
    String::from_utf8(bytes)
        .map_err(|e| format!("not UTF-8 text (byte offset {})", e.utf8_error().valid_up_to()).into())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// On Linux /proc/meminfo says how much memory is left: some, and less
    /// than 2^50 bytes (the parse of its kB lines).
    #[test]
    fn memory_available_reads_meminfo() {
        if std::env::var_os("RAYCAST_MEMORY_AVAILABLE").is_some() {
            println!("skipped: RAYCAST_MEMORY_AVAILABLE is set");
            return;
        }
        let m = memory_available().expect("MemAvailable in /proc/meminfo");
        assert!(m > 1 << 20 && m < 1 << 50, "{m}");
    }

    /// /dev/zero ends at the bound; a file at the bound is read whole, one
    /// byte over it is refused.
    #[test]
    fn reads_stop_at_the_bound() {
        assert_eq!(read(Path::new("/dev/zero"), 4096).unwrap_err().to_string(), "larger than 4096 bytes");
        let path = std::env::temp_dir().join(format!("raycast-bound-{}.txt", std::process::id()));
        std::fs::write(&path, b"<scenefile/>").unwrap();
        assert_eq!(read(&path, 12).unwrap(), b"<scenefile/>");
        assert!(matches!(read(&path, 11), Err(ReadError::TooLarge(11))));
        std::fs::remove_file(&path).unwrap();
        assert_eq!(ReadError::TooLarge(MAX_INPUT_BYTES).to_string(), "larger than 1024 MiB");
        assert!(read_text(Path::new("/nonexistent/x")).unwrap_err().to_string().contains("No such file"));
    }
}
