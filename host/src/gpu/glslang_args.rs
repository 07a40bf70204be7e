// The one place that says how GLSL becomes SPIR-V: glslang, then spirv-opt;
// and how such a tool is run (`run_tool`: both pipes read, stopped after a
// limit), which shader-test's C++ build uses too.
// Included by build.rs (build time) and by the host (runtime recompiles);
// CMakeLists.txt calls glslang with the same arguments and build.rs runs
// spirv-opt on what it made.

/// The glslang compiler (Debian package glslang-tools).
pub const GLSLANG: &str = "glslangValidator";

/// How a kernel's divisions and square roots are compiled (raycast.glsl
/// div_rn, sqrt_rn), chosen per device (`GpuContext::division`): each
/// embedded kernel exists in every one, named with its `suffix`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Division {
    /// As the device gives them: a CPU device (lavapipe), whose are IEEE's.
    AsGiven,
    /// Corrected to IEEE's, the residuals by Dekker's split product (IEEE
    /// +, - and * alone): exact on any device.
    Corrected,
    /// Corrected, the residuals by `fma()`: for a device whose `fma` was
    /// seen to round once (shaders/fma_probe.comp), where it is cheaper.
    CorrectedFma,
    /// The fast kernel (FAST_MATH, docs/exactness.md "The fast kernel"):
    /// the device's own division, square root and transcendentals, and no
    /// `precise`; not the CPU build's bits, so never for `check`.
    Fast,
}

impl Division {
    pub const ALL: [Division; 4] = [Division::AsGiven, Division::Corrected, Division::CorrectedFma, Division::Fast];

    /// The macros the kernels are compiled with: CORRECT_DIVISION for a
    /// correction, FUSED_FMA for its residuals by fma(), FAST_MATH for the
    /// fast kernel.
    pub fn defines(self) -> &'static [&'static str] {
        match self {
            Division::AsGiven => &[],
            Division::Corrected => &["CORRECT_DIVISION"],
            Division::CorrectedFma => &["CORRECT_DIVISION", "FUSED_FMA"],
            Division::Fast => &["FAST_MATH"],
        }
    }

    /// Whether kernels compiled this way give the CPU build's bits (on a
    /// device whose +, - and * are IEEE's): every way but `Fast`.
    pub fn exact(self) -> bool {
        self != Division::Fast
    }

    /// The file stem suffix of an embedded kernel compiled this way
    /// (`render_uniform_gpu` beside `render_uniform`).
    pub fn suffix(self) -> &'static str {
        match self {
            Division::AsGiven => "",
            Division::Corrected => "_gpu",
            Division::CorrectedFma => "_gpu_fma",
            Division::Fast => "_fast",
        }
    }

    /// How `render`'s and `check`'s `kernel:` line says it.
    pub fn describe(self) -> &'static str {
        match self {
            Division::AsGiven => "",
            Division::Corrected => " with CORRECT_DIVISION",
            Division::CorrectedFma => " with CORRECT_DIVISION and FUSED_FMA",
            Division::Fast => " with FAST_MATH",
        }
    }

    /// After a device's name in `shader-test`'s and `bench`'s header:
    /// ", kernels with CORRECT_DIVISION …", or nothing where it divides as given.
    pub fn kernels_clause(self) -> String {
        match self.describe() {
            "" => String::new(),
            how => format!(", kernels{how}"),
        }
    }
}

/// Arguments for compiling `src` (a `.comp` kernel) to the SPIR-V file `spv`,
/// with `include` on the include path: Vulkan 1.1 semantics, debug names
/// kept (naga reads struct and member names from them); `division`'s
/// macros defined.
pub fn glslang_args(
    src: &std::path::Path,
    include: &std::path::Path,
    spv: &std::path::Path,
    division: Division,
) -> Vec<std::ffi::OsString> {
    let mut args: Vec<std::ffi::OsString> = vec![
        "-V".into(),
        "--target-env".into(),
        "vulkan1.1".into(),
        "--quiet".into(),
        format!("-I{}", include.display()).into(),
    ];
    for define in division.defines() {
        args.push(format!("-D{define}").into());
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
    let mut command = std::process::Command::new(SPIRV_OPT);
    command.args(SPIRV_OPT_PASSES).arg(spv).arg("-o").arg(spv);
    let output = run_tool(SPIRV_OPT, "spirv-tools", command, TOOL_LIMIT)?;
    tool_result(SPIRV_OPT, spv, &output)
}

/// How long glslang or spirv-opt may take on one kernel before it is
/// stopped: each takes well under a second; a tool that hangs must not
/// hang the build, `--shaders` or a render with it.
pub const TOOL_LIMIT: std::time::Duration = std::time::Duration::from_secs(60);

/// Runs `command` (the tool `tool`, from the Debian package `package`)
/// with no input, its output and messages collected, and stops it after
/// `limit` (`TOOL_LIMIT`). The error says which, where it cannot be run or
/// was stopped, or where it exited but a process it started kept its output
/// open past `limit` (not waited for further); a tool that ran and failed is
/// Ok, its status in the output.
pub fn run_tool(
    tool: &str,
    package: &str,
    command: std::process::Command,
    limit: std::time::Duration,
) -> Result<std::process::Output, String> {
    run_tool_fed(tool, package, command, limit, None)
}

/// `run_tool` with `input` written to the tool's standard input (on a
/// thread of its own, as its output is read), or none.
pub fn run_tool_fed(
    tool: &str,
    package: &str,
    mut command: std::process::Command,
    limit: std::time::Duration,
    input: Option<Vec<u8>>,
) -> Result<std::process::Output, String> {
    use std::io::{Read, Write};
    use std::process::Stdio;
    let mut child = command
        .stdin(if input.is_some() { Stdio::piped() } else { Stdio::null() })
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| format!("cannot run {tool} (Debian package {package}): {e}"))?;
    if let (Some(bytes), Some(mut stdin)) = (input, child.stdin.take()) {
        // A tool that ends before reading it all closes the pipe: its status says why.
        std::thread::spawn(move || {
            let _ = stdin.write_all(&bytes);
        });
    }
    // Read on threads of their own, so that a tool that fills one pipe
    // while we wait on the other cannot stall; each sends what it read, by
    // pipe (0 stdout, 1 stderr), at the pipe's end.
    let (sender, read) = std::sync::mpsc::channel::<(usize, Vec<u8>)>();
    fn drain<R: Read + Send + 'static>(pipe: Option<R>, which: usize, sender: std::sync::mpsc::Sender<(usize, Vec<u8>)>) {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            let _ = sender.send((which, bytes));
        });
    }
    drain(child.stdout.take(), 0, sender.clone());
    drain(child.stderr.take(), 1, sender);
    let start = std::time::Instant::now();
    let status = loop {
        match child.try_wait() {
            Ok(Some(status)) => break status,
            Ok(None) if start.elapsed() < limit => std::thread::sleep(std::time::Duration::from_millis(2)),
            Ok(None) => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!("{tool} took more than {:.1} s and was stopped", limit.as_secs_f64()));
            }
            Err(e) => return Err(format!("{tool}: {e}")),
        }
    };
    // The pipes end when every process holding them has: the tool, and any
    // it left running with them (waited for until `limit`, no longer).
    let mut pipes = [Vec::new(), Vec::new()];
    for _ in 0..2 {
        match read.recv_timeout(limit.saturating_sub(start.elapsed())) {
            Ok((which, bytes)) => pipes[which] = bytes,
            Err(_) => {
                return Err(format!(
                    "{tool} exited ({status}), but a process it started kept its output open for more than {:.1} s",
                    limit.as_secs_f64()
                ))
            }
        }
    }
    let [stdout, stderr] = pipes;
    Ok(std::process::Output { status, stdout, stderr })
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
/// `include` on the include path and `division`'s macros, then
/// `optimize_spirv`); the error carries the tools' messages (file:line: …
/// for GLSL errors).
pub fn glsl_to_spirv(
    src: &std::path::Path,
    include: &std::path::Path,
    spv: &std::path::Path,
    division: Division,
) -> Result<(), String> {
    let mut command = std::process::Command::new(GLSLANG);
    command.args(glslang_args(src, include, spv, division));
    let output = run_tool(GLSLANG, "glslang-tools", command, TOOL_LIMIT)?;
    tool_result(GLSLANG, src, &output)?;
    optimize_spirv(spv)
}
