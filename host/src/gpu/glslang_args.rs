// The one place that says how GLSL becomes SPIR-V: glslang, then spirv-opt.
// Included by build.rs (build time) and by the host (runtime recompiles);
// CMakeLists.txt calls glslang with the same arguments and build.rs runs
// spirv-opt on what it made.

/// The glslang compiler (Debian package glslang-tools).
pub const GLSLANG: &str = "glslangValidator";

/// The macro that makes raycast.glsl's div_rn and sqrt_rn correct a GPU's
/// division and square root (`GpuContext::corrects_division`).
pub const CORRECT_DIVISION: &str = "CORRECT_DIVISION";

/// The file stem suffix of an embedded kernel compiled with it
/// (`render_uniform_gpu` beside `render_uniform`).
pub const GPU_KERNEL_SUFFIX: &str = "_gpu";

/// Arguments for compiling `src` (a `.comp` kernel) to the SPIR-V file `spv`,
/// with `include` on the include path: Vulkan 1.1 semantics, debug names
/// kept (naga reads struct and member names from them); with
/// `correct_division`, CORRECT_DIVISION defined.
pub fn glslang_args(
    src: &std::path::Path,
    include: &std::path::Path,
    spv: &std::path::Path,
    correct_division: bool,
) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = vec![
        "-V".into(),
        "--target-env".into(),
        "vulkan1.1".into(),
        "--quiet".into(),
        format!("-I{}", include.display()).into(),
    ];
    if correct_division {
        args.push(format!("-D{CORRECT_DIVISION}").into());
    }
    args.extend(["-o".into(), spv.as_os_str().to_owned(), src.as_os_str().to_owned()]);
    args
}

/// The SPIR-V optimizer (Debian package spirv-tools).
pub const SPIRV_OPT: &str = "spirv-opt";

/// spirv-opt's passes. Lavapipe turns SPIR-V into NIR and optimises it on
/// every pipeline creation (only its LLVM step is cached), and glslang's
/// SPIR-V keeps every function call and local variable: with calls inlined
/// and locals in SSA form the render kernel's pipeline builds in about 60%
/// of the time (118 -> 72 ms on recursiveSpheres4), with the same pixels.
/// None of these passes folds or reorders floating-point arithmetic
/// (no -O: its constant folding and instruction simplification would be
/// a second compiler's arithmetic between the GLSL and the CPU build),
/// so the kernel computes exactly what glslang wrote. Calls whose function
/// returns early stay calls (inlining them needs --merge-return, which
/// made both the pipeline build and the kernel slower); spirv-opt says so
/// on stderr, which is kept only when it fails. No --redundancy-elimination:
/// it reuses a storage buffer's access chain across blocks, which naga's
/// reader turns into a local variable of pointer type and then rejects.
pub const SPIRV_OPT_PASSES: &[&str] = &[
    // Unused bindings stay declared: the host checks every binding it
    // expects against the kernel (naga), used or not.
    "--preserve-bindings",
    "--preserve-spec-constants",
    "--inline-entry-points-exhaustive",
    "--eliminate-dead-functions",
    "--private-to-local",
    "--eliminate-local-single-block",
    "--eliminate-local-single-store",
    "--scalar-replacement=100",
    "--ssa-rewrite",
    "--eliminate-dead-code-aggressive",
    "--merge-blocks",
    "--eliminate-dead-branches",
    "--cfg-cleanup",
    "--eliminate-dead-code-aggressive",
];

/// Optimizes the SPIR-V file `spv` in place (`SPIRV_OPT_PASSES`); the error
/// carries spirv-opt's messages.
pub fn optimize_spirv(spv: &std::path::Path) -> Result<(), String> {
    let output = std::process::Command::new(SPIRV_OPT)
        .args(SPIRV_OPT_PASSES)
        .arg(spv)
        .arg("-o")
        .arg(spv)
        .output()
        .map_err(|e| format!("cannot run {SPIRV_OPT} (Debian package spirv-tools): {e}"))?;
    tool_result(SPIRV_OPT, spv, &output)
}

/// Ok when `tool` succeeded on `path`, else its messages.
fn tool_result(tool: &str, path: &std::path::Path, output: &std::process::Output) -> Result<(), String> {
    if output.status.success() {
        return Ok(());
    }
    Err(format!(
        "{tool} failed on {}:\n{}{}",
        path.display(),
        String::from_utf8_lossy(&output.stdout).trim_end(),
        String::from_utf8_lossy(&output.stderr).trim_end()
    ))
}

/// Compiles the kernel `src` to the SPIR-V file `spv` (glslang with
/// `include` on the include path, CORRECT_DIVISION defined with
/// `correct_division`, then `optimize_spirv`); the error carries the tools'
/// messages (file:line: … for GLSL errors).
pub fn glsl_to_spirv(
    src: &std::path::Path,
    include: &std::path::Path,
    spv: &std::path::Path,
    correct_division: bool,
) -> Result<(), String> {
    let output = std::process::Command::new(GLSLANG)
        .args(glslang_args(src, include, spv, correct_division))
        .output()
        .map_err(|e| format!("cannot run {GLSLANG} (Debian package glslang-tools): {e}"))?;
    tool_result(GLSLANG, src, &output)?;
    optimize_spirv(spv)
}
