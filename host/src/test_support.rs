//! Test support shared by the library's own tests and the integration
//! tests (tests/common/mod.rs re-exports it): a test that leaves something
//! out for want of a requirement says so in a way ci/suite.sh counts.
//! Public, as scene::mutate is, so that the integration tests reach it.

use std::path::{Path, PathBuf};

/// Records that a test leaves something out for want of a requirement
/// (the corpus, a device, a display): prints `SKIPPED: reason` and, where
/// ci/suite.sh runs the suite (ctest), appends the reason, one line, to the
/// file RAYCAST_SKIP_FILE names, so that the suite counts as Skipped, not
/// Passed.
pub fn skip(reason: &str) {
    let file = std::env::var_os("RAYCAST_SKIP_FILE").filter(|f| !f.is_empty());
    record_skip(reason, file.as_deref().map(Path::new));
}

/// [`skip`], the reason appended to `file` where there is one.
fn record_skip(reason: &str, file: Option<&Path>) {
    use std::io::Write;
    let reason = reason.replace('\n', " ");
    println!("SKIPPED: {reason}");
    if let Some(file) = file {
        let mut f = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(file)
            .unwrap_or_else(|e| panic!("RAYCAST_SKIP_FILE={}: {e}", file.display()));
        f.write_all(format!("{reason}\n").as_bytes()).unwrap();
    }
}

/// The cs1230 corpus (RAYCAST_CORPUS), or None where it is unset or empty,
/// after `skip` says that `what` needs it. Set to something that is not a
/// folder, it fails: a relative path is taken from host/, where cargo runs
/// the tests (ci/test.sh makes it absolute).
pub fn corpus(what: &str) -> Option<PathBuf> {
    let Some(corpus) = std::env::var_os("RAYCAST_CORPUS").filter(|c| !c.is_empty()).map(PathBuf::from) else {
        skip(&format!(
            "{what}: RAYCAST_CORPUS is not set (point it at the cs1230 corpus, e.g. ../shared/corpus/cs1230)"
        ));
        return None;
    };
    assert!(
        corpus.is_dir(),
        "RAYCAST_CORPUS={} is not a folder (from {}: a relative path is taken from there)",
        corpus.display(),
        std::env::current_dir().map(|d| d.display().to_string()).unwrap_or_default()
    );
    Some(corpus)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A skip's reason is appended to the skip file, one line each (its
    /// line breaks made spaces). (`record_skip` rather than `skip`: setting
    /// RAYCAST_SKIP_FILE here would take the suite's own away from the
    /// tests running beside this one.)
    #[test]
    fn a_skip_is_recorded_in_the_skip_file_a_line_each() {
        let folder = tempfile::tempdir().unwrap();
        let file = folder.path().join("skipped.txt");
        record_skip("first\nreason", Some(&file));
        record_skip("second", Some(&file));
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "first reason\nsecond\n");
        record_skip("no file", None);
        assert_eq!(std::fs::read_to_string(&file).unwrap(), "first reason\nsecond\n");
    }
}
