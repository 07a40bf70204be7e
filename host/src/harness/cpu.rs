//! The CPU side of a case: the C++ build of the tested functions, generated
//! by `codegen::cpp_source`, compiled at run time against host/cpu/shared.hpp
//! with the CPU library's exactness flags (host/cpu/exactness-flags.txt,
//! which host/cpu/CMakeLists.txt reads too) into a shared library, loaded
//! with libloading. Libraries are cached by the hash of everything that goes
//! into them, so a second run with the same shaders compiles nothing.

use std::collections::hash_map::DefaultHasher;
use std::hash::{Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::Command;

use super::codegen;
use super::glsl::{Function, ShaderInfo};

/// The C++ compiler (Debian: g++ through the c++ alternative).
const CXX: &str = "c++";
/// How long one build of a case library may take before it is stopped
/// (a few seconds on a 2-core machine): a compiler that hangs fails the run.
const CXX_LIMIT: std::time::Duration = std::time::Duration::from_secs(600);
/// The flags file shared with host/cpu/CMakeLists.txt.
const EXACTNESS_FLAGS: &str = include_str!("../../cpu/exactness-flags.txt");

/// Flags of every run-time build: the shared exactness flags, then what a
/// loadable library needs.
pub fn compile_flags() -> Vec<String> {
    let mut flags: Vec<String> = EXACTNESS_FLAGS
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && !l.starts_with('#'))
        .map(String::from)
        .collect();
    flags.extend(["-std=c++17", "-O2", "-fPIC", "-shared", "-Wdouble-promotion"].map(String::from));
    flags
}

type Entry = unsafe extern "C" fn(*const *const std::ffi::c_void, *const u32, *mut u32);

/// A loaded library of case runners.
pub struct CpuLibrary {
    lib: libloading::Library,
    pub path: PathBuf,
}

impl CpuLibrary {
    /// Compiles (or finds in the cache) the C++ build of `functions` for the
    /// shaders of `info`; `cpu_dir` holds shared.hpp.
    pub fn build(
        info: &ShaderInfo,
        cpu_dir: &Path,
        default_shaders: &Path,
        functions: &[&Function],
    ) -> Result<CpuLibrary, String> {
        let source = codegen::cpp_source(info, functions);
        let flags = compile_flags();
        // -I: the shaders under test first, then the source tree's (shared.hpp's own folder is searched first of all).
        let includes = [info.dir.clone(), cpu_dir.to_path_buf(), default_shaders.to_path_buf()];

        let mut h = DefaultHasher::new();
        source.hash(&mut h);
        flags.hash(&mut h);
        for dir in &includes {
            dir.hash(&mut h);
            let mut entries: Vec<PathBuf> = std::fs::read_dir(dir)
                .map_err(|e| format!("cannot read {}: {e}", dir.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("h" | "hpp" | "glsl")))
                .collect();
            entries.sort();
            for p in entries {
                p.hash(&mut h);
                std::fs::read(&p).unwrap_or_default().hash(&mut h);
            }
        }
        let cache = std::env::temp_dir().join("raycast-harness-cache");
        std::fs::create_dir_all(&cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
        let lib_path = cache.join(format!("cases-{:016x}.so", h.finish()));

        if !lib_path.exists() {
            let unique = format!("{}-{:?}", std::process::id(), std::thread::current().id()).replace(['(', ')'], "");
            let cpp = cache.join(format!("cases-{:016x}-{unique}.cpp", h.finish()));
            let tmp = cache.join(format!("cases-{:016x}-{unique}.so.tmp", h.finish()));
            std::fs::write(&cpp, &source).map_err(|e| format!("cannot write {}: {e}", cpp.display()))?;
            let mut cmd = Command::new(CXX);
            cmd.args(&flags);
            for dir in &includes {
                cmd.arg(format!("-I{}", dir.display()));
            }
            cmd.arg("-o").arg(&tmp).arg(&cpp);
            let described = format!("{cmd:?}");
            let out = crate::gpu::run_tool(CXX, "g++", cmd, CXX_LIMIT)?;
            if !out.status.success() {
                return Err(format!(
                    "the C++ build of {} failed ({described}):\n{}{}",
                    functions.iter().map(|f| f.name.as_str()).collect::<Vec<_>>().join(", "),
                    String::from_utf8_lossy(&out.stdout),
                    String::from_utf8_lossy(&out.stderr)
                ));
            }
            let _ = std::fs::remove_file(&cpp);
            // Atomic: a concurrent run sees the whole library or none.
            std::fs::rename(&tmp, &lib_path).map_err(|e| format!("cannot move {} into place: {e}", tmp.display()))?;
        }
        // SAFETY: the library is ours, generated above; its initialisers are
        // those of the C++ standard library and thread_local variables.
        let lib = unsafe { libloading::Library::new(&lib_path) }
            .map_err(|e| format!("cannot load {}: {e}", lib_path.display()))?;
        Ok(CpuLibrary { lib, path: lib_path })
    }

    /// Runs the cases of `key` (`Function::key`): `input` as for the kernel, `out_words` long
    /// output pre-filled with the sentinel.
    pub fn run(&self, key: &str, scene: &[&[u32]], input: &[u32], out_words: usize) -> Result<Vec<u32>, String> {
        let symbol = codegen::cpp_symbol(key);
        // SAFETY: the symbol was generated with exactly this signature.
        let entry: libloading::Symbol<Entry> = unsafe { self.lib.get(symbol.as_bytes()) }
            .map_err(|e| format!("{}: no symbol {symbol}: {e}", self.path.display()))?;
        let mut out = vec![codegen::SENTINEL; out_words];
        let pointers: Vec<*const std::ffi::c_void> = scene.iter().map(|b| b.as_ptr().cast()).collect();
        // SAFETY: every scene buffer holds at least one whole struct of its
        // type (checked by the caller) and at least as many as the scene's
        // counts say; `input` holds its case count and every case's words;
        // `out` has room for every case's written word and result.
        unsafe { entry(pointers.as_ptr(), input.as_ptr(), out.as_mut_ptr()) };
        Ok(out)
    }
}
