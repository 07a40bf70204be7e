//! raycast's cache folder: what a run made for a kernel and a later run can
//! use instead of making it again (a shader object's binary,
//! shader_object.rs; SPIR-V specialised ahead of the driver,
//! specialize.rs).
//!
//! A cache file holds the whole key it was made for and a checksum of what
//! it keeps; it answers only a key equal byte for byte whose checksum
//! holds, so a damaged, foreign or stale file is made again, never used.
//! Files are written through a temporary file renamed over the old one
//! (a reader never sees half of one); each kind of file (its extension)
//! keeps its newest ones, a number the kind names.

use std::path::{Path, PathBuf};

/// The folder: RAYCAST_CACHE_DIR, else $XDG_CACHE_HOME/raycast, else
/// ~/.cache/raycast; None when none of them is set.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RAYCAST_CACHE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Some(Path::new(&d).join("raycast"));
    }
    std::env::var_os("HOME").filter(|d| !d.is_empty()).map(|h| Path::new(&h).join(".cache/raycast"))
}

/// A kind of cache file: its extension and how many of them the folder keeps.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Kind {
    pub extension: &'static str,
    pub keep: usize,
}

/// The file in `dir` for `key` of a kernel named `name`: NAME-HASH.EXT.
pub(crate) fn file_for(dir: &Path, kind: Kind, name: &str, key: &[u8]) -> PathBuf {
    dir.join(format!("{name}-{:016x}.{}", fnv1a(key), kind.extension))
}

/// `parts`, each with its length before it, so that no two lists of parts
/// make the same key.
pub(crate) fn key(parts: &[&[u8]]) -> Vec<u8> {
    let mut key = Vec::new();
    for part in parts {
        key.extend_from_slice(&(part.len() as u64).to_le_bytes());
        key.extend_from_slice(part);
    }
    key
}

/// What `file` keeps for exactly `key`, if anything, and if its checksum
/// holds (a driver need not survive a damaged binary).
pub(crate) fn read(file: &Path, key: &[u8]) -> Option<Vec<u8>> {
    let bytes = std::fs::read(file).ok()?;
    let len = usize::try_from(u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?)).ok()?;
    let key_end = 8usize.checked_add(len)?;
    if bytes.get(8..key_end)? != key {
        return None;
    }
    let sum = u64::from_le_bytes(bytes.get(key_end..key_end + 8)?.try_into().ok()?);
    let kept = &bytes[key_end + 8..];
    (fnv1a(kept) == sum).then(|| kept.to_vec())
}

/// Writes `key` and `kept` to `file` (through a temporary file renamed
/// over it), then keeps the newest `kind.keep` files of its kind in the
/// folder.
pub(crate) fn write(file: &Path, kind: Kind, key: &[u8], kept: &[u8]) -> std::io::Result<()> {
    let dir = file.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut bytes = (key.len() as u64).to_le_bytes().to_vec();
    bytes.extend_from_slice(key);
    bytes.extend_from_slice(&fnv1a(kept).to_le_bytes());
    bytes.extend_from_slice(kept);
    // Beside it (a rename within the folder), unique to this process and call; not of its kind.
    let name = file.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let unique = super::environment::temp_file(&format!("{name}.tmp"));
    let tmp = dir.join(unique.file_name().unwrap_or_default());
    std::fs::write(&tmp, &bytes)?;
    std::fs::rename(&tmp, file)?;
    let mut files: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == kind.extension))
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    files.sort_by_key(|f| std::cmp::Reverse(f.0));
    for (_, old) in files.into_iter().skip(kind.keep) {
        let _ = std::fs::remove_file(old);
    }
    Ok(())
}

/// 64-bit FNV-1a: the cache file's name and its checksum (the file holds
/// the whole key).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cache_file_answers_only_its_own_key() {
        const KIND: Kind = Kind { extension: "bin", keep: 8 };
        let dir = std::env::temp_dir().join(format!("raycast-cache-test-{}", std::process::id()));
        let file = dir.join("k.bin");
        write(&file, KIND, b"key one", b"binary").unwrap();
        assert_eq!(read(&file, b"key one").as_deref(), Some(&b"binary"[..]));
        assert_eq!(read(&file, b"key two"), None);
        assert_eq!(read(&file, b"key on"), None);
        // Cut short: nothing, no panic.
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..10]).unwrap();
        assert_eq!(read(&file, b"key one"), None);
        std::fs::write(&file, [0xffu8; 8]).unwrap();
        assert_eq!(read(&file, b"key one"), None);
        // A changed byte of what it keeps: its checksum fails.
        write(&file, KIND, b"key one", b"binary").unwrap();
        let mut bytes = std::fs::read(&file).unwrap();
        *bytes.last_mut().unwrap() ^= 1;
        std::fs::write(&file, &bytes).unwrap();
        assert_eq!(read(&file, b"key one"), None);
        // The folder keeps the newest `keep` files of a kind, and leaves other kinds alone.
        const OTHER: Kind = Kind { extension: "spv", keep: 2 };
        for i in 0..3 {
            write(&dir.join(format!("{i}.spv")), OTHER, b"k", b"s").unwrap();
        }
        for i in 0..KIND.keep + 5 {
            write(&dir.join(format!("{i}.bin")), KIND, b"k", b"b").unwrap();
        }
        let count = |ext: &str| {
            std::fs::read_dir(&dir).unwrap().filter(|e| e.as_ref().unwrap().path().extension().unwrap() == ext).count()
        };
        assert_eq!((count("bin"), count("spv")), (KIND.keep, OTHER.keep), "files kept");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn keys_keep_their_parts_apart() {
        assert_ne!(key(&[b"ab", b"c"]), key(&[b"a", b"bc"]));
        assert_eq!(key(&[b"ab", b"c"]), key(&[b"ab", b"c"]));
    }

    #[test]
    fn fnv1a_is_the_published_function() {
        // Published test vectors of 64-bit FNV-1a.
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
