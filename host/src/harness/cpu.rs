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

/// `codegen::cpp_source`'s entry: the scene's buffers, their lengths in
/// words, the input words, the output words.
type Entry = unsafe extern "C" fn(*const *const std::ffi::c_void, *const u32, *const u32, *mut u32);

/// A library of case runners, built and known to load (each run loads it
/// in a process of its own: `run`).
pub struct CpuLibrary {
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
        drop(
            unsafe { libloading::Library::new(&lib_path) }
                .map_err(|e| format!("cannot load {}: {e}", lib_path.display()))?,
        );
        Ok(CpuLibrary { path: lib_path })
    }

    /// Runs the cases of `key` (`Function::key`): `input` as for the kernel, `out_words` long
    /// output pre-filled with the sentinel. In a process of its own
    /// (`run_in_child`), so that a tested function that never ends is
    /// stopped after `timeout`, and one that reads past the scene's arrays
    /// (a scene whose index points past them) fails its cases with what it
    /// read, rather than crash the command.
    pub fn run(
        &self,
        key: &str,
        scene: &[&[u32]],
        input: &[u32],
        out_words: usize,
        timeout: std::time::Duration,
    ) -> Result<Vec<u32>, String> {
        let mut fed: Vec<u32> = vec![scene.len() as u32];
        for b in scene {
            fed.push(b.len() as u32);
            fed.extend_from_slice(b);
        }
        fed.push(input.len() as u32);
        fed.extend_from_slice(input);
        let exe = std::env::current_exe().map_err(|e| format!("cannot find raycast's own program: {e}"))?;
        let mut command = Command::new(&exe);
        command.env(CHILD_ENV, format!("{}\t{key}\t{out_words}", self.path.display()));
        let bytes: Vec<u8> = bytemuck::cast_slice(&fed).to_vec();
        let out =
            crate::gpu::run_tool_fed("the C++ build's run", "raycast", command, timeout, Some(bytes)).map_err(|e| {
                if e.contains("was stopped") {
                    format!(
                        "the C++ build of {key} did not finish within --timeout {} s (a loop that never ends?)",
                        timeout.as_secs_f64()
                    )
                } else if let Some(why) = e.strip_prefix("cannot run the C++ build's run (Debian package raycast): ") {
                    format!(
                        "cannot start raycast's own program ({}) to run the C++ build of {key}: {why}",
                        exe.display()
                    )
                } else {
                    e
                }
            })?;
        if !out.status.success() {
            use std::os::unix::process::ExitStatusExt;
            let said = String::from_utf8_lossy(&out.stderr);
            if out.status.code() == Some(codegen::BUFFER_OVERRUN_EXIT) {
                return Err(format!(
                    "the C++ build of {key} {}: each count and index of the scene must fit its arrays \
                     (a buffer the scene leaves out is one zeroed element)",
                    said.trim()
                ));
            }
            let why = match out.status.signal() {
                Some(n) => format!("signal {n}"),
                None => format!("{}: {}", out.status, said.trim()),
            };
            return Err(format!("the C++ build of {key} crashed ({why})"));
        }
        if out.stdout.len() != out_words * 4 {
            return Err(format!(
                "the C++ build of {key} gave {} bytes, not {}: {}",
                out.stdout.len(),
                out_words * 4,
                String::from_utf8_lossy(&out.stderr).trim()
            ));
        }
        Ok(out.stdout.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }
}

/// The variable that starts a process as one run of a case library
/// (`CpuLibrary::run`): `LIBRARY<tab>KEY<tab>OUT_WORDS`, the scene's buffers
/// and the input on standard input (`run`'s words), the output words on
/// standard output.
const CHILD_ENV: &str = "RAYCAST_HARNESS_CPU_RUN";

/// Runs before `main` in every program that holds this library (raycast,
/// the test programs), so that `CpuLibrary::run` can start its own program
/// as the child: with CHILD_ENV set, the process is that run and exits.
#[cfg(target_os = "linux")]
#[used]
#[link_section = ".init_array"]
static RUN_AS_CHILD: extern "C" fn() = {
    extern "C" fn child() {
        if let Some(spec) = std::env::var_os(CHILD_ENV) {
            std::process::exit(match run_in_child(&spec.to_string_lossy()) {
                Ok(()) => 0,
                Err(e) => {
                    eprintln!("{e}");
                    1
                }
            });
        }
    }
    child
};

/// The child's side of `CpuLibrary::run`.
fn run_in_child(spec: &str) -> Result<(), String> {
    use std::io::{Read, Write};
    let mut parts = spec.split('\t');
    let (Some(path), Some(key), Some(out_words)) = (parts.next(), parts.next(), parts.next()) else {
        return Err(format!("{CHILD_ENV}: {spec:?} is not LIBRARY<tab>KEY<tab>OUT_WORDS"));
    };
    let out_words: usize = out_words.parse().map_err(|e| format!("{CHILD_ENV}: {e}"))?;
    let mut bytes = Vec::new();
    std::io::stdin().read_to_end(&mut bytes).map_err(|e| format!("standard input: {e}"))?;
    let words: Vec<u32> = bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    let mut at = 0usize;
    let mut take = |n: usize| -> Result<&[u32], String> {
        let slice = words.get(at..at + n).ok_or("standard input ends early")?;
        at += n;
        Ok(slice)
    };
    let buffers = take(1)?[0] as usize;
    let mut scene: Vec<Vec<u32>> = Vec::with_capacity(buffers);
    for _ in 0..buffers {
        let n = take(1)?[0] as usize;
        scene.push(take(n)?.to_vec());
    }
    let n = take(1)?[0] as usize;
    let input = take(n)?.to_vec();
    // SAFETY: the library is the parent's, built by `CpuLibrary::build`.
    let lib = unsafe { libloading::Library::new(path) }.map_err(|e| format!("cannot load {path}: {e}"))?;
    let symbol = codegen::cpp_symbol(key);
    // SAFETY: the symbol was generated with exactly this signature.
    let entry: libloading::Symbol<Entry> =
        unsafe { lib.get(symbol.as_bytes()) }.map_err(|e| format!("{path}: no symbol {symbol}: {e}"))?;
    let mut out = vec![codegen::SENTINEL; out_words];
    let pointers: Vec<*const std::ffi::c_void> = scene.iter().map(|b| b.as_ptr().cast()).collect();
    let lengths: Vec<u32> = scene.iter().map(|b| b.len() as u32).collect();
    // SAFETY: every scene buffer holds at least one whole struct of its type
    // (checked by the parent) and `lengths` says how many words; `input`
    // holds its case count and every case's words; `out` has room for every
    // case's written word and result. A read past the scene's arrays ends
    // this process with BUFFER_OVERRUN_EXIT (the library's checked
    // buffers), or on a signal should the check be missed: the command goes on.
    unsafe { entry(pointers.as_ptr(), lengths.as_ptr(), input.as_ptr(), out.as_mut_ptr()) };
    std::io::stdout().write_all(bytemuck::cast_slice(&out)).map_err(|e| format!("standard output: {e}"))?;
    Ok(())
}
