//! IEEE NaN, infinity and subnormal semantics for every kernel, where the
//! device promises them (VK_KHR_shader_float_controls).
//!
//! Without the SPIR-V execution mode `SignedZeroInfNanPreserve`, Vulkan
//! lets a driver assume no NaN, infinity or signed zero reaches a float
//! operation. The shared GLSL relies on them: `min_f`/`max_f` are ternaries
//! in GLM's operand order so that a slab test on an axis-parallel ray
//! (0 · inf = NaN) takes the same branch on every backend
//! (docs/exactness.md#nan-and-infinities). NVIDIA's driver (580, H100) turned
//! `min_f(NaN, 1)` into a hardware min that returns 1 where lavapipe and the
//! CPU build return the NaN; with the mode it returns the NaN. Likewise,
//! without `DenormPreserve` a driver may flush subnormal results to zero
//! where the CPU build keeps them (a specular highlight of 1e-40 that adds a
//! shadow ray on one and not the other).
//!
//! glslang cannot ask for the modes without an extension naga does not read,
//! so the host adds them to the words it hands the driver, after naga has
//! checked the module as compiled, and only those the device reports
//! (`shaderSignedZeroInfNanPreserveFloat32`, `shaderDenormPreserveFloat32`).

use super::spirv::{
    checked_instructions, CAPABILITY_DENORM_PRESERVE, CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE, MODE_DENORM_PRESERVE,
    MODE_SIGNED_ZERO_INF_NAN_PRESERVE, OP_CAPABILITY, OP_ENTRY_POINT, OP_EXECUTION_MODE, OP_EXTENSION,
};

/// Which modes a device's kernels get.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub(crate) struct Modes {
    pub preserve_nan: bool,
    pub preserve_denorms: bool,
}

const EXTENSION: &str = "SPV_KHR_float_controls";

/// A literal string as SPIR-V words: UTF-8, NUL-terminated, padded to 4 bytes.
fn string_words(s: &str) -> Vec<u32> {
    let mut bytes = s.as_bytes().to_vec();
    bytes.push(0);
    bytes.resize(bytes.len().div_ceil(4) * 4, 0);
    bytes.chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// `words` with the execution modes of `modes` (each with its capability,
/// for every entry point, on 32-bit floats) and `OpExtension
/// "SPV_KHR_float_controls"`. Modes the module has already are not added
/// again; with none to add, the words come back unchanged.
pub(crate) fn add_modes(words: &[u32], modes: Modes) -> Result<Vec<u32>, String> {
    let wanted: Vec<(u32, u32)> = [
        (modes.preserve_nan, CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE, MODE_SIGNED_ZERO_INF_NAN_PRESERVE),
        (modes.preserve_denorms, CAPABILITY_DENORM_PRESERVE, MODE_DENORM_PRESERVE),
    ]
    .into_iter()
    .filter(|w| w.0)
    .map(|(_, capability, mode)| (capability, mode))
    .collect();
    if wanted.is_empty() {
        return Ok(words.to_vec());
    }
    let instructions = checked_instructions(words)?;
    let has = |op: u32, operand: usize, value: u32| {
        instructions.iter().any(|&(_, o, ops)| o == op && ops.get(operand - 1) == Some(&value))
    };
    let missing: Vec<(u32, u32)> = wanted.into_iter().filter(|&(_, mode)| !has(OP_EXECUTION_MODE, 2, mode)).collect();
    if missing.is_empty() {
        return Ok(words.to_vec());
    }
    let name = string_words(EXTENSION);
    let has_extension = instructions.iter().any(|&(_, op, ops)| op == OP_EXTENSION && ops == &name[..]);
    // Capabilities come first, then extensions; entry points before execution modes.
    let last_capability = instructions.iter().rfind(|i| i.1 == OP_CAPABILITY).map(|i| i.0 + 1 + i.2.len());
    let entry_points: Vec<(usize, u32)> = instructions
        .iter()
        .filter(|i| i.1 == OP_ENTRY_POINT && i.2.len() >= 2)
        .map(|&(at, _, ops)| (at + 1 + ops.len(), ops[1]))
        .collect();
    let (Some(after_capabilities), Some(&(after_entry_points, _))) = (last_capability, entry_points.last()) else {
        return Err("a module without OpCapability or OpEntryPoint".into());
    };

    let mut out = Vec::with_capacity(words.len() + 32);
    out.extend_from_slice(&words[..after_capabilities]);
    for &(capability, _) in &missing {
        if !has(OP_CAPABILITY, 1, capability) {
            out.extend([(2 << 16) | OP_CAPABILITY, capability]);
        }
    }
    if !has_extension {
        out.push(((1 + name.len() as u32) << 16) | OP_EXTENSION);
        out.extend(&name);
    }
    out.extend_from_slice(&words[after_capabilities..after_entry_points]);
    for &(_, id) in &entry_points {
        for &(_, mode) in &missing {
            out.extend([(4 << 16) | OP_EXECUTION_MODE, id, mode, 32]);
        }
    }
    out.extend_from_slice(&words[after_entry_points..]);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(spv: &[u8]) -> Vec<u32> {
        ash::util::read_spv(&mut std::io::Cursor::new(spv)).unwrap()
    }

    const BOTH: Modes = Modes { preserve_nan: true, preserve_denorms: true };

    /// The patched render kernel passes spirv-val for Vulkan 1.1 and says,
    /// in its disassembly, what was added; a second patch changes nothing,
    /// and neither does one with no modes.
    #[test]
    fn the_render_kernel_gains_the_modes_and_stays_valid() {
        let original = words(crate::gpu::kernel_spirv("render").unwrap());
        assert_eq!(add_modes(&original, Modes::default()).unwrap(), original);
        let nan = add_modes(&original, Modes { preserve_nan: true, preserve_denorms: false }).unwrap();
        assert_eq!(nan.len(), original.len() + 2 + 1 + string_words(EXTENSION).len() + 4);
        let patched = add_modes(&nan, BOTH).unwrap();
        assert_eq!(patched.len(), nan.len() + 2 + 4, "the denormal mode added to the NaN one");
        assert_eq!(add_modes(&patched, BOTH).unwrap(), patched, "patching twice");

        let path = std::env::temp_dir().join(format!("raycast-float-controls-{}.spv", std::process::id()));
        std::fs::write(&path, bytemuck::cast_slice::<u32, u8>(&patched)).unwrap();
        let val =
            std::process::Command::new("spirv-val").arg("--target-env").arg("vulkan1.1").arg(&path).output().unwrap();
        assert!(val.status.success(), "spirv-val: {}", String::from_utf8_lossy(&val.stderr));
        let dis = std::process::Command::new("spirv-dis").arg(&path).output().unwrap();
        let _ = std::fs::remove_file(&path);
        let text = String::from_utf8_lossy(&dis.stdout);
        for line in [
            "OpCapability SignedZeroInfNanPreserve",
            "OpCapability DenormPreserve",
            "OpExtension \"SPV_KHR_float_controls\"",
            "OpExecutionMode %main SignedZeroInfNanPreserve 32",
            "OpExecutionMode %main DenormPreserve 32",
        ] {
            assert_eq!(text.matches(line).count(), 1, "{line} once in\n{}", &text[..text.len().min(2000)]);
        }
    }

    #[test]
    fn bad_modules_are_errors() {
        assert!(add_modes(&[1, 2, 3], BOTH).unwrap_err().contains("magic"));
        // A header and an instruction claiming 9 words of 2.
        assert!(add_modes(&[0x0723_0203, 0x10300, 0, 10, 0, (9 << 16) | OP_CAPABILITY, 1], BOTH)
            .unwrap_err()
            .contains("word count"));
        assert!(add_modes(&[0x0723_0203, 0x10300, 0, 10, 0], BOTH).unwrap_err().contains("without"));
    }
}
