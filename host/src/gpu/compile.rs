//! Compiling a GLSL kernel to SPIR-V at runtime with glslang, for kernels
//! loaded from a source folder (`--shaders DIR`, live reload).

use super::{glsl_to_spirv, Division};
use std::path::Path;

/// Compiles `src` (a `.comp` kernel) with its folder on the include path,
/// with `division`'s macros (`GpuContext::division`). The error
/// carries glslang's own messages (file:line: …).
pub fn compile_kernel(src: &Path, division: Division) -> Result<Vec<u8>, String> {
    if !src.is_file() {
        return Err(format!("kernel source {} does not exist", src.display()));
    }
    let include = src.parent().unwrap_or(Path::new("."));
    let out = super::environment::temp_file(&format!(
        "{}.spv",
        src.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
    ));
    let result = glsl_to_spirv(src, include, &out, division)
        .and_then(|()| std::fs::read(&out).map_err(|e| format!("cannot read {}: {e}", out.display())));
    let _ = std::fs::remove_file(&out);
    result
}

/// `dir/STEM.comp` compiled (`compile_kernel`) and, when the folder has
/// one, its uniform-block sibling `dir/STEM_uniform.comp`: a `--shaders`
/// folder's render or preview kernels.
pub fn compile_kernel_pair(dir: &Path, stem: &str, division: Division) -> Result<(Vec<u8>, Option<Vec<u8>>), String> {
    let storage = compile_kernel(&dir.join(format!("{stem}.comp")), division)?;
    let uniform_src = dir.join(format!("{stem}_uniform.comp"));
    let uniform = if uniform_src.is_file() { Some(compile_kernel(&uniform_src, division)?) } else { None };
    Ok((storage, uniform))
}
