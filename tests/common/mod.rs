//! Helpers shared by the integration tests (each test file is its own crate
//! and includes this module with `mod common;`).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The repository root.
pub fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

/// `skip(reason)`: records that a test leaves something out for want of a
/// requirement, so that ci/suite.sh counts the suite as Skipped.
/// `corpus(what)`: RAYCAST_CORPUS, or None after a skip. The library's
/// own tests use the same two. (Not every test file uses both: as for
/// the functions here, `dead_code` above.)
#[allow(unused_imports)]
pub use raycast::test_support::{corpus, skip};

/// The corpus folders whose every scene the check suite renders (and the
/// cli suite's fast-kernel rule with it).
pub const CHECKED_CORPUS_GROUPS: [&str; 8] = [
    "test_unit",
    "test_intersect",
    "test_light",
    "test_efficiency",
    "test_feature",
    "test_dof",
    "test_area_light",
    "test_refract",
];

/// A scene in `dir` (made afresh) whose one sphere has a 5800x5800
/// texture: 33,640,000 texels, beyond lavapipe's storage buffers (128 MiB,
/// 33,554,432 texels). The picture is one grey, so its PNG is small.
pub fn big_texture_scene(dir: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap();
    let side = 5800u32;
    let picture = raycast::image_io::Rgb8 { width: side, height: side, data: vec![90; (side * side * 3) as usize] };
    raycast::image_io::write_png(&dir.join("big.png"), &picture).unwrap();
    let xml = std::fs::read_to_string(repo().join("tests/scenes/missing_texture.xml")).unwrap();
    let scene = dir.join("big.xml");
    std::fs::write(&scene, xml.replace("no/such/texture.png", "big.png")).unwrap();
    scene
}

/// A fresh copy of the source tree's shaders/ at `dir`, to plant changes in.
pub fn copy_of_shaders(dir: &Path) -> PathBuf {
    let _ = std::fs::remove_dir_all(dir);
    std::fs::create_dir_all(dir).unwrap();
    for entry in std::fs::read_dir(repo().join("shaders")).unwrap() {
        let path = entry.unwrap().path();
        std::fs::copy(&path, dir.join(path.file_name().unwrap())).unwrap();
    }
    dir.to_path_buf()
}

/// Plants a change in a copy of the shaders: `file` of `dir` with its one
/// `from` replaced by `to`; fails, asking for the test to be updated, where
/// `from` is not there exactly once.
pub fn plant(dir: &Path, file: &str, from: &str, to: &str) {
    let path = dir.join(file);
    let source = std::fs::read_to_string(&path).unwrap();
    assert_eq!(source.matches(from).count(), 1, "{file} changed ({from:?} is not in it once): update this test");
    std::fs::write(&path, source.replacen(from, to, 1)).unwrap();
}

/// The shader-binary cache the tests' commands use (RAYCAST_CACHE_DIR),
/// not the user's.
pub fn shader_cache() -> PathBuf {
    Path::new(env!("CARGO_TARGET_TMPDIR")).join("shader-cache")
}

/// The files of a cache folder (RAYCAST_CACHE_DIR) with extension `ext`,
/// sorted: `bin` for shader binaries, `spv` for specialised SPIR-V.
pub fn cache_files(dir: &Path, ext: &str) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map(|d| d.map(|e| e.unwrap().path()).filter(|p| p.extension().is_some_and(|x| x == ext)).collect())
        .unwrap_or_default();
    files.sort();
    files
}

/// A cache file's bytes damaged two ways, each named: cut short, and with
/// its last byte changed (its checksum no longer holds).
pub fn damaged(bytes: &[u8]) -> [(&'static str, Vec<u8>); 2] {
    let mut flipped = bytes.to_vec();
    *flipped.last_mut().unwrap() ^= 1;
    [("cut short", bytes[..bytes.len() / 3].to_vec()), ("a byte changed", flipped)]
}

/// Rewrites what the cache file `file` keeps (SPIR-V) with `edit`, its
/// checksum made anew, so that raycast takes the edited module as its own.
/// The file format and its FNV-1a checksum written here a second time, as
/// a check of host/src/gpu/cache.rs: [key length u64][key][checksum u64][kept].
pub fn rewrite_cache_file(file: &Path, edit: impl Fn(Vec<u32>) -> Vec<u32>) {
    let bytes = std::fs::read(file).unwrap();
    let key_len = u64::from_le_bytes(bytes[..8].try_into().unwrap()) as usize;
    let kept = &bytes[8 + key_len + 8..];
    let words = edit(kept.chunks_exact(4).map(|c| u32::from_le_bytes(c.try_into().unwrap())).collect());
    let kept: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
    let sum = kept.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3));
    let mut out = bytes[..8 + key_len].to_vec();
    out.extend_from_slice(&sum.to_le_bytes());
    out.extend_from_slice(&kept);
    std::fs::write(file, out).unwrap();
}

/// A SPIR-V module's words without its instructions of opcode `op`.
pub fn without_instruction(words: &[u32], op: u32) -> Vec<u32> {
    let mut out = words[..5].to_vec();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        if words[at] & 0xffff != op {
            out.extend_from_slice(&words[at..at + count]);
        }
        at += count.max(1);
    }
    out
}

/// `raycast ARGS` with `env` added to the environment, validation on
/// (RAYCAST_VALIDATION=1: any validation message fails the command), and
/// the tests' own shader-binary cache.
pub fn raycast(args: &[&str], env: &[(&str, &str)]) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_raycast"));
    cmd.args(args).env("RAYCAST_VALIDATION", "1").env("RAYCAST_CACHE_DIR", shader_cache());
    for (k, v) in env {
        cmd.env(k, v);
    }
    cmd.output().expect("run raycast")
}

/// A command's stdout and stderr as text.
pub fn text(o: &Output) -> (String, String) {
    (String::from_utf8_lossy(&o.stdout).into_owned(), String::from_utf8_lossy(&o.stderr).into_owned())
}

/// The kernel a `render` or `check` names in its first `kernel:` line, up to
/// the parenthesis that says how it was built (a shader object, a pipeline
/// specialised ahead) or the comma before what it was specialised for:
/// `render_uniform with CORRECT_DIVISION`.
pub fn kernel_name(stdout: &str) -> Option<&str> {
    let line = stdout.lines().find_map(|l| l.strip_prefix("kernel: "))?;
    Some(line[..line.find([',', '(']).unwrap_or(line.len())].trim_end())
}

/// How many loop passes a shader invocation on the default device gets in
/// all, if it has such a budget: Mesa 22's lavapipe ends every loop after
/// 65535 passes (LP_MAX_TGSI_LOOP_ITERATIONS, sampling.glsl
/// loop_budget_ok); later lavapipes (Mesa 25) and GPUs have none. Found by
/// running it, not by the driver's version: a loop of 70,000 passes,
/// planted in a copy of the shaders under `dir`, through `raycast
/// shader-test`; Some(passes it ran) where they fall short, None where it
/// ran them all. Prints what it found, so a test that branches on it says
/// which way it went.
pub fn device_loop_budget(dir: &Path) -> Option<u32> {
    const PASSES: u32 = 70_000;
    let shaders = copy_of_shaders(&dir.join("loop-probe-shaders"));
    let glsl = shaders.join("raycast.glsl");
    let mut source = std::fs::read_to_string(&glsl).unwrap();
    source.push_str(
        "\nuint loop_probe(uint n) {\n    uint c = 0u;\n    for (uint k = 0u; k < n; k++) {\n        c = c + 1u;\n    }\n    return c;\n}\n",
    );
    std::fs::write(&glsl, source).unwrap();
    let case = dir.join("loop-probe.toml");
    std::fs::write(
        &case,
        format!(
            "[[case]]\nfunction = \"loop_probe\"\ninputs = {{ n = {PASSES} }}\nexpected = {PASSES}\nrule = \"exact\"\n"
        ),
    )
    .unwrap();
    let o = raycast(&["shader-test", "--shaders", shaders.to_str().unwrap(), case.to_str().unwrap()], &[]);
    let (out, err) = text(&o);
    if o.status.success() {
        println!("loop budget: none (a loop of {PASSES} passes ran them all on the device)");
        return None;
    }
    // The failure's result row: `value  70000 (0x…) DEVICE (0x…) 70000 (0x…) …`.
    let row = out.lines().find(|l| l.trim_start().starts_with("value ")).unwrap_or_else(|| panic!("{out}{err}"));
    let words: Vec<&str> = row.split_whitespace().collect();
    assert_eq!((words[1], words[5]), (PASSES.to_string().as_str(), PASSES.to_string().as_str()), "{out}{err}");
    let ran: u32 = words[3].parse().unwrap_or_else(|_| panic!("{out}{err}"));
    assert!(ran < PASSES, "{out}{err}");
    println!("loop budget: {ran} passes (a loop of {PASSES} passes ran {ran} on the device)");
    Some(ran)
}
