//! Build script: compiles the GLSL kernels in ../shaders to SPIR-V with
//! glslang (embedded into the binary), and turns the `#define`s of
//! shaders/layout.h, shapes.glsl and preview.h into Rust constants so they
//! are written once.
//!
//! Also links the CPU build of the shared GLSL (host/cpu, a CMake project).
//!
//! When CMake drives the build it compiles the SPIR-V and the CPU library
//! itself and passes their folders in RAYCAST_SPIRV_DIR and
//! RAYCAST_CPU_LIB_DIR; a plain `cargo build` does both here, the CPU
//! library by running CMake on host/cpu (one definition of its flags).

use std::path::{Path, PathBuf};
use std::process::Command;

include!("src/gpu/glslang_args.rs");
include!("src/uint_defines.rs");

fn main() {
    let manifest = PathBuf::from(std::env::var("CARGO_MANIFEST_DIR").unwrap());
    let shaders = manifest.join("../shaders").canonicalize().expect("shaders/ folder beside host/");
    let out = PathBuf::from(std::env::var("OUT_DIR").unwrap());
    println!("cargo:rerun-if-changed={}", shaders.display());
    println!("cargo:rerun-if-env-changed=RAYCAST_SPIRV_DIR");

    // layout.h and the shapes' registration (shapes.glsl), then the preview
    // kernel's own header (host/src/preview/layout.rs includes it).
    let read =
        |name: &str| std::fs::read_to_string(shaders.join(name)).unwrap_or_else(|e| panic!("shaders/{name}: {e}"));
    let (layout, shapes, preview) = (read("layout.h"), read("shapes.glsl"), read("preview.h"));
    let mut known = uint_defines(&layout, &[]);
    known.extend(uint_defines(&shapes, &known));
    write_consts(&known, &out.join("layout_consts.rs"));
    write_consts(&uint_defines(&preview, &known), &out.join("preview_consts.rs"));

    let prebuilt = std::env::var_os("RAYCAST_SPIRV_DIR").map(PathBuf::from);
    let mut kernels = Vec::new();
    for entry in std::fs::read_dir(&shaders).unwrap() {
        let path = entry.unwrap().path();
        println!("cargo:rerun-if-changed={}", path.display());
        if path.extension().and_then(|e| e.to_str()) != Some("comp") {
            continue;
        }
        let stem = path.file_stem().unwrap().to_str().unwrap().to_string();
        // As it is, corrected for GPUs (STEM_gpu, STEM_gpu_fma), and fast (STEM_fast): Division.
        for division in Division::ALL {
            let name = format!("{stem}{}", division.suffix());
            let spv = out.join(format!("{name}.spv"));
            match &prebuilt {
                Some(dir) => {
                    let from = dir.join(format!("{name}.spv"));
                    println!("cargo:rerun-if-changed={}", from.display());
                    std::fs::copy(&from, &spv)
                        .unwrap_or_else(|e| panic!("RAYCAST_SPIRV_DIR: cannot copy {}: {e}", from.display()));
                    // CMake ran glslang alone.
                    optimize_spirv(&spv).unwrap_or_else(|e| panic!("{e}"));
                }
                None => glsl_to_spirv(&path, &shaders, &spv, division).unwrap_or_else(|e| panic!("{e}")),
            }
            kernels.push(name);
        }
    }
    kernels.sort();
    link_cpu_library(&manifest, &out);
    let mut table = String::from("/// Every kernel of shaders/*.comp, compiled to SPIR-V at build time.\n");
    table.push_str("pub const EMBEDDED_KERNELS: &[(&str, &[u8])] = &[\n");
    for k in &kernels {
        table.push_str(&format!("    ({k:?}, include_bytes!(concat!(env!(\"OUT_DIR\"), \"/{k}.spv\"))),\n"));
    }
    table.push_str("];\n");
    std::fs::write(out.join("kernels.rs"), table).unwrap();
}

fn link_cpu_library(manifest: &Path, out: &Path) {
    println!("cargo:rerun-if-env-changed=RAYCAST_CPU_LIB_DIR");
    let dir = match std::env::var_os("RAYCAST_CPU_LIB_DIR") {
        Some(dir) => PathBuf::from(dir),
        None => {
            let src = manifest.join("cpu");
            for entry in std::fs::read_dir(&src).unwrap() {
                println!("cargo:rerun-if-changed={}", entry.unwrap().path().display());
            }
            let build = out.join("cpu-build");
            run(Command::new("cmake")
                .arg("-S")
                .arg(&src)
                .arg("-B")
                .arg(&build)
                .arg("-DRAYCAST_CPU_TESTS=OFF")
                .arg("-DCMAKE_BUILD_TYPE=Release"));
            run(Command::new("cmake").arg("--build").arg(&build).args(["--target", "raycast_cpu"]));
            build
        }
    };
    let lib = dir.join("libraycast_cpu.a");
    if !lib.exists() {
        panic!("{} does not exist: build the raycast_cpu target first", lib.display());
    }
    println!("cargo:rerun-if-changed={}", lib.display());
    println!("cargo:rustc-link-search=native={}", dir.display());
    println!("cargo:rustc-link-lib=static=raycast_cpu");
    println!("cargo:rustc-link-lib=dylib=stdc++");
}

fn run(cmd: &mut Command) {
    let output = cmd.output().unwrap_or_else(|e| panic!("cannot run {cmd:?} (is cmake installed?): {e}"));
    if !output.status.success() {
        panic!(
            "{cmd:?} failed:\n{}{}",
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        );
    }
}

/// (NAME, value) -> `pub const NAME: u32 = …;`
fn write_consts(defines: &[(&str, u32)], out: &Path) {
    let rs: String = defines.iter().map(|(name, v)| format!("pub const {name}: u32 = {v:#x};\n")).collect();
    std::fs::write(out, rs).unwrap();
}
