//! Following files for changes: the preview's live reload and `render
//! --watch`. notify wakes the follower when anything in a followed file's
//! folder changes; each file's stamp (modification time and length) then
//! says which changed, so a write beside it (the picture `render` writes)
//! changes nothing, and an editor's save of several writes is one change
//! once it holds still. Where notify cannot start (no inotify watches
//! left), the follower looks every `FALLBACK` instead.

use notify::{RecommendedWatcher, RecursiveMode, Watcher as _};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::time::{Duration, Instant, SystemTime};

/// How long a change must hold still before it counts: an editor's save
/// can be several writes.
pub const SETTLE: Duration = Duration::from_millis(100);

/// The longest the follower goes without looking at the stamps, events or
/// not: the safety net for an event notify missed (a folder replaced), and
/// the pace where notify cannot start.
pub const FALLBACK: Duration = Duration::from_millis(1000);

/// Modification time and length, or None where the file cannot be read:
/// what "changed" means.
pub type Stamp = Option<(SystemTime, u64)>;

fn stamp(path: &Path) -> Stamp {
    let m = std::fs::metadata(path).ok()?;
    Some((m.modified().ok()?, m.len()))
}

/// Whether `path` is a shader source a folder's kernels may include:
/// *.comp, *.glsl, *.h.
fn is_shader_source(path: &Path) -> bool {
    matches!(path.extension().and_then(|e| e.to_str()), Some("comp" | "glsl" | "h"))
}

/// Files and shader folders followed for changes.
pub struct FileWatch {
    /// None where notify could not start: the stamps are looked at every FALLBACK.
    watcher: Option<RecommendedWatcher>,
    events: Receiver<()>,
    /// The folders notify watches (each followed file's, each shader folder).
    watched: BTreeSet<PathBuf>,
    files: Vec<PathBuf>,
    folders: Vec<PathBuf>,
    /// Each followed path's stamp as last seen.
    stamps: BTreeMap<PathBuf, Stamp>,
    /// How many times the stamps were read (a test's count of wake-ups).
    looks: u64,
}

impl Default for FileWatch {
    fn default() -> Self {
        FileWatch::new()
    }
}

impl FileWatch {
    /// Following nothing yet.
    pub fn new() -> FileWatch {
        let (tx, events) = mpsc::channel();
        let watcher = notify::recommended_watcher(move |event: notify::Result<notify::Event>| {
            // A file read or a folder listed changes nothing (nor does the
            // access time they may set), and each look at the stamps lists
            // the shader folders: woken by those, the follower looked again
            // at once, tens of thousands of times a second.
            use notify::event::{EventKind, MetadataKind, ModifyKind};
            if let Ok(e) = &event {
                if e.kind.is_access() || e.kind == EventKind::Modify(ModifyKind::Metadata(MetadataKind::AccessTime)) {
                    return;
                }
            }
            // Which file does not matter: the stamps say.
            let _ = tx.send(());
        })
        .ok();
        FileWatch {
            watcher,
            events,
            watched: BTreeSet::new(),
            files: Vec::new(),
            folders: Vec::new(),
            stamps: BTreeMap::new(),
            looks: 0,
        }
    }

    /// From now on follows `files` and every shader source in `folders`. A
    /// path followed before keeps the stamp last seen (a change since is
    /// still a change); a new one is stamped as it is now; one no longer
    /// named is forgotten.
    pub fn follow(&mut self, files: &[PathBuf], folders: &[PathBuf]) {
        self.files = files.to_vec();
        self.folders = folders.to_vec();
        let now = self.current();
        self.stamps.retain(|path, _| now.contains_key(path));
        for (path, s) in now {
            self.stamps.entry(path).or_insert(s);
        }
        let dirs: BTreeSet<PathBuf> = files
            .iter()
            .map(|f| f.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")).to_path_buf())
            .chain(folders.iter().cloned())
            .collect();
        if let Some(w) = &mut self.watcher {
            for gone in self.watched.difference(&dirs) {
                let _ = w.unwatch(gone);
            }
            for dir in dirs.difference(&self.watched) {
                // A folder that cannot be watched (not there yet) is looked at every FALLBACK.
                let _ = w.watch(dir, RecursiveMode::NonRecursive);
            }
        }
        self.watched = dirs;
    }

    /// How many files are followed now (a shader folder's sources each).
    pub fn len(&self) -> usize {
        self.stamps.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stamps.is_empty()
    }

    /// Every followed path's stamp as it is now.
    fn current(&mut self) -> BTreeMap<PathBuf, Stamp> {
        self.looks += 1;
        let mut now: BTreeMap<PathBuf, Stamp> = self.files.iter().map(|f| (f.clone(), stamp(f))).collect();
        for dir in &self.folders {
            let Ok(entries) = std::fs::read_dir(dir) else { continue };
            for path in entries.filter_map(|e| e.ok().map(|e| e.path())).filter(|p| is_shader_source(p)) {
                let s = stamp(&path);
                now.insert(path, s);
            }
        }
        now
    }

    /// Waits up to `timeout` for a followed file to change and hold still
    /// for SETTLE; the paths whose stamps changed (empty: none did within
    /// `timeout`), their new stamps taken as seen.
    pub fn changes(&mut self, timeout: Duration) -> Vec<PathBuf> {
        let end = Instant::now() + timeout;
        loop {
            let now = self.current();
            if now != self.stamps {
                // Until it holds still.
                let mut settled = now;
                loop {
                    std::thread::sleep(SETTLE);
                    self.drain();
                    let again = self.current();
                    if again == settled {
                        break;
                    }
                    settled = again;
                }
                let changed: Vec<PathBuf> = settled
                    .iter()
                    .filter(|(path, s)| self.stamps.get(*path) != Some(s))
                    .map(|(path, _)| path.clone())
                    .chain(self.stamps.keys().filter(|p| !settled.contains_key(*p)).cloned())
                    .collect();
                self.stamps = settled;
                if !changed.is_empty() {
                    return changed;
                }
            }
            let left = end.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Vec::new();
            }
            // An event, or the fallback's pace, whichever first.
            match self.events.recv_timeout(left.min(FALLBACK)) {
                Ok(()) => self.drain(),
                Err(RecvTimeoutError::Timeout) => {}
                // The watcher is gone: look at the pace of FALLBACK.
                Err(RecvTimeoutError::Disconnected) => std::thread::sleep(left.min(FALLBACK)),
            }
        }
    }

    /// Events already queued, dropped: the stamps are about to be read.
    fn drain(&self) {
        while self.events.try_recv().is_ok() {}
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A followed file's change is reported once it holds still, by its
    /// path; a write beside it, or none, reports nothing; a shader folder's
    /// new source is a change; a file no longer followed is forgotten.
    #[test]
    fn changes_are_reported_by_path_once() {
        let dir = std::env::temp_dir().join(format!("raycast-watch-{}", std::process::id()));
        let shaders = dir.join("shaders");
        std::fs::create_dir_all(&shaders).unwrap();
        let scene = dir.join("s.xml");
        std::fs::write(&scene, "one").unwrap();
        std::fs::write(shaders.join("a.glsl"), "a").unwrap();
        let mut w = FileWatch::new();
        w.follow(std::slice::from_ref(&scene), std::slice::from_ref(&shaders));
        assert_eq!(w.len(), 2);
        assert!(w.changes(Duration::from_millis(200)).is_empty(), "nothing changed");
        std::fs::write(dir.join("beside.png"), "not followed").unwrap();
        assert!(w.changes(Duration::from_millis(300)).is_empty(), "a file beside is not followed");
        std::fs::write(&scene, "two, longer").unwrap();
        assert_eq!(w.changes(Duration::from_secs(5)), std::slice::from_ref(&scene));
        assert!(w.changes(Duration::from_millis(200)).is_empty(), "reported once");
        std::fs::write(shaders.join("b.h"), "b").unwrap();
        assert_eq!(w.changes(Duration::from_secs(5)), [shaders.join("b.h")]);
        w.follow(&[], std::slice::from_ref(&shaders));
        assert_eq!(w.len(), 2, "the scene forgotten, the folder's two sources followed");
        std::fs::write(&scene, "three, longer still").unwrap();
        assert!(w.changes(Duration::from_millis(300)).is_empty(), "a file no longer followed");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// With nothing changing, the follower sleeps: it does not wake on the
    /// events of its own looks (listing a shader folder is an access).
    #[test]
    fn nothing_changing_keeps_the_follower_asleep() {
        let dir = std::env::temp_dir().join(format!("raycast-watch-asleep-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("a.glsl"), "a").unwrap();
        let mut w = FileWatch::new();
        w.follow(&[], std::slice::from_ref(&dir));
        let before = w.looks;
        assert!(w.changes(Duration::from_millis(600)).is_empty(), "nothing changed");
        let looks = w.looks - before;
        let _ = std::fs::remove_dir_all(&dir);
        // One look on entry; the FALLBACK pace (1 s) adds none in 0.6 s.
        assert!(looks <= 2, "the stamps were read {looks} times in 0.6 s with nothing changing");
    }
}
