// The one place that says how GLSL becomes SPIR-V. Included by build.rs
// (build time) and by the host (runtime recompiles); CMakeLists.txt calls the
// same tool with the same arguments.

/// The glslang compiler (Debian package glslang-tools).
pub const GLSLANG: &str = "glslangValidator";

/// Arguments for compiling `src` (a `.comp` kernel) to the SPIR-V file `spv`,
/// with `include` on the include path: Vulkan 1.1 semantics, debug names
/// kept (naga reads struct and member names from them).
pub fn glslang_args(src: &std::path::Path, include: &std::path::Path, spv: &std::path::Path) -> Vec<std::ffi::OsString> {
    vec![
        "-V".into(),
        "--target-env".into(),
        "vulkan1.1".into(),
        "--quiet".into(),
        format!("-I{}", include.display()).into(),
        "-o".into(),
        spv.as_os_str().to_owned(),
        src.as_os_str().to_owned(),
    ]
}
