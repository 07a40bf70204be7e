//! IEEE NaN and infinity semantics for every kernel, where the device
//! promises them (VK_KHR_shader_float_controls).
//!
//! Without the SPIR-V execution mode `SignedZeroInfNanPreserve`, Vulkan
//! lets a driver assume no NaN, infinity or signed zero reaches a float
//! operation. The shared GLSL relies on them: `min_f`/`max_f` are ternaries
//! in GLM's operand order so that a slab test on an axis-parallel ray
//! (0 · inf = NaN) takes the same branch on every backend
//! (../shared/docs/EXACTNESS.md). NVIDIA's driver (580, H100) turned
//! `min_f(NaN, 1)` into a hardware min that returns 1 where lavapipe and the
//! CPU build return the NaN; with the mode it returns the NaN.
//!
//! glslang cannot ask for the mode without an extension naga does not read,
//! so the host adds it to the words it hands the driver, after naga has
//! checked the module as compiled, and only on a device that reports
//! `shaderSignedZeroInfNanPreserveFloat32`.

/// SPIR-V opcodes, capability and execution mode (SPIR-V 1.6 spec, 3.x).
const OP_EXTENSION: u32 = 10;
const OP_CAPABILITY: u32 = 17;
const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE: u32 = 16;
const CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE: u32 = 4466;
const MODE_SIGNED_ZERO_INF_NAN_PRESERVE: u32 = 4461;
const EXTENSION: &str = "SPV_KHR_float_controls";

/// The module's instructions: (word offset, opcode, word count).
fn instructions(words: &[u32]) -> Result<Vec<(usize, u32, usize)>, String> {
    if words.len() < 5 || words[0] != 0x0723_0203 {
        return Err("not a SPIR-V module (no magic number)".into());
    }
    let mut out = Vec::new();
    let mut at = 5;
    while at < words.len() {
        let count = (words[at] >> 16) as usize;
        if count == 0 || at + count > words.len() {
            return Err(format!("instruction at word {at} has a bad word count {count}"));
        }
        out.push((at, words[at] & 0xffff, count));
        at += count;
    }
    Ok(out)
}

/// A literal string as SPIR-V words: UTF-8, NUL-terminated, padded to 4 bytes.
fn string_words(s: &str) -> Vec<u32> {
    let mut bytes = s.as_bytes().to_vec();
    bytes.push(0);
    bytes.resize(bytes.len().div_ceil(4) * 4, 0);
    bytes.chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect()
}

/// `words` with `OpCapability SignedZeroInfNanPreserve`, `OpExtension
/// "SPV_KHR_float_controls"` and, for every entry point,
/// `OpExecutionMode SignedZeroInfNanPreserve 32`. A module that has the
/// mode already comes back unchanged.
pub(crate) fn preserve_nan(words: &[u32]) -> Result<Vec<u32>, String> {
    let instructions = instructions(words)?;
    let has_mode = instructions
        .iter()
        .any(|&(at, op, count)| op == OP_EXECUTION_MODE && count >= 3 && words[at + 2] == MODE_SIGNED_ZERO_INF_NAN_PRESERVE);
    if has_mode {
        return Ok(words.to_vec());
    }
    let has_capability = instructions
        .iter()
        .any(|&(at, op, _)| op == OP_CAPABILITY && words[at + 1] == CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE);
    let name = string_words(EXTENSION);
    let has_extension = instructions.iter().any(|&(at, op, count)| op == OP_EXTENSION && words[at + 1..at + count] == name[..]);
    // Capabilities come first, then extensions; entry points before execution modes.
    let last_capability = instructions.iter().filter(|i| i.1 == OP_CAPABILITY).last().map(|i| i.0 + i.2);
    let entry_points: Vec<(usize, u32)> = instructions
        .iter()
        .filter(|i| i.1 == OP_ENTRY_POINT && i.2 >= 3)
        .map(|&(at, _, count)| (at + count, words[at + 2]))
        .collect();
    let (Some(after_capabilities), Some(&(after_entry_points, _))) = (last_capability, entry_points.last()) else {
        return Err("a module without OpCapability or OpEntryPoint".into());
    };

    let mut out = Vec::with_capacity(words.len() + 16);
    out.extend_from_slice(&words[..after_capabilities]);
    if !has_capability {
        out.extend([(2 << 16) | OP_CAPABILITY, CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE]);
    }
    if !has_extension {
        out.push(((1 + name.len() as u32) << 16) | OP_EXTENSION);
        out.extend(&name);
    }
    out.extend_from_slice(&words[after_capabilities..after_entry_points]);
    for &(_, id) in &entry_points {
        out.extend([(4 << 16) | OP_EXECUTION_MODE, id, MODE_SIGNED_ZERO_INF_NAN_PRESERVE, 32]);
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

    /// The patched render kernel passes spirv-val for Vulkan 1.1 and says,
    /// in its disassembly, what was added; a second patch changes nothing.
    #[test]
    fn the_render_kernel_gains_the_mode_and_stays_valid() {
        let original = words(crate::render::kernel_spirv("render").unwrap());
        let patched = preserve_nan(&original).unwrap();
        assert_eq!(patched.len(), original.len() + 2 + 1 + string_words(EXTENSION).len() + 4);
        assert_eq!(preserve_nan(&patched).unwrap(), patched, "patching twice");

        let path = std::env::temp_dir().join(format!("raycast-float-controls-{}.spv", std::process::id()));
        std::fs::write(&path, bytemuck::cast_slice::<u32, u8>(&patched)).unwrap();
        let val = std::process::Command::new("spirv-val").arg("--target-env").arg("vulkan1.1").arg(&path).output().unwrap();
        assert!(val.status.success(), "spirv-val: {}", String::from_utf8_lossy(&val.stderr));
        let dis = std::process::Command::new("spirv-dis").arg(&path).output().unwrap();
        let _ = std::fs::remove_file(&path);
        let text = String::from_utf8_lossy(&dis.stdout);
        for line in ["OpCapability SignedZeroInfNanPreserve", "OpExtension \"SPV_KHR_float_controls\"", "OpExecutionMode %main SignedZeroInfNanPreserve 32"] {
            assert_eq!(text.matches(line).count(), 1, "{line} once in\n{}", &text[..text.len().min(2000)]);
        }
    }

    #[test]
    fn bad_modules_are_errors() {
        assert!(preserve_nan(&[1, 2, 3]).unwrap_err().contains("magic"));
        // A header and an instruction claiming 9 words of 2.
        assert!(preserve_nan(&[0x0723_0203, 0x10300, 0, 10, 0, (9 << 16) | OP_CAPABILITY, 1]).unwrap_err().contains("word count"));
        assert!(preserve_nan(&[0x0723_0203, 0x10300, 0, 10, 0]).unwrap_err().contains("without"));
    }
}
