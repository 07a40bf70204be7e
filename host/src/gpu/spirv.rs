//! The SPIR-V the host reads and edits itself, written once: a module's
//! words, its instruction walk, and the opcodes, decorations, storage
//! classes, capabilities and execution modes it looks for (SPIR-V 1.6
//! specification, chapter 3). Used by reflect.rs (the buffers' access and
//! the copy naga reads), float_controls.rs (execution modes added) and
//! specialize.rs (specialization constants frozen).

/// The first word of every module.
pub(super) const MAGIC: u32 = 0x0723_0203;

pub(super) const OP_EXTENSION: u32 = 10;
pub(super) const OP_ENTRY_POINT: u32 = 15;
pub(super) const OP_EXECUTION_MODE: u32 = 16;
pub(super) const OP_CAPABILITY: u32 = 17;
pub(super) const OP_TYPE_STRUCT: u32 = 30;
pub(super) const OP_TYPE_POINTER: u32 = 32;
pub(super) const OP_CONSTANT_TRUE: u32 = 41;
pub(super) const OP_CONSTANT_FALSE: u32 = 42;
pub(super) const OP_CONSTANT: u32 = 43;
pub(super) const OP_CONSTANT_NULL: u32 = 46;
pub(super) const OP_SPEC_CONSTANT_TRUE: u32 = 48;
pub(super) const OP_SPEC_CONSTANT_FALSE: u32 = 49;
pub(super) const OP_SPEC_CONSTANT: u32 = 50;
pub(super) const OP_FUNCTION: u32 = 54;
pub(super) const OP_VARIABLE: u32 = 59;
pub(super) const OP_DECORATE: u32 = 71;
pub(super) const OP_MEMBER_DECORATE: u32 = 72;
pub(super) const OP_COPY_OBJECT: u32 = 83;
/// OpGroupNonUniformElect to OpGroupNonUniformQuadSwap: the subgroup operations.
pub(super) const OP_GROUP_NON_UNIFORM_FIRST: u32 = 333;
pub(super) const OP_GROUP_NON_UNIFORM_LAST: u32 = 366;

pub(super) const DEC_SPEC_ID: u32 = 1;
pub(super) const DEC_BUILT_IN: u32 = 11;
pub(super) const DEC_NON_WRITABLE: u32 = 24;
pub(super) const DEC_NON_READABLE: u32 = 25;
pub(super) const DEC_BINDING: u32 = 33;
pub(super) const DEC_SET: u32 = 34;

pub(super) const BUILT_IN_LOCAL_INVOCATION_INDEX: u32 = 29;
pub(super) const BUILT_IN_SUBGROUP_SIZE: u32 = 36;
pub(super) const BUILT_IN_NUM_SUBGROUPS: u32 = 38;
pub(super) const BUILT_IN_SUBGROUP_ID: u32 = 40;
pub(super) const BUILT_IN_SUBGROUP_LOCAL_INVOCATION_ID: u32 = 41;

pub(super) const CLASS_UNIFORM: u32 = 2;
pub(super) const CLASS_STORAGE_BUFFER: u32 = 12;

pub(super) const CAPABILITY_DENORM_PRESERVE: u32 = 4464;
pub(super) const CAPABILITY_SIGNED_ZERO_INF_NAN_PRESERVE: u32 = 4466;
pub(super) const MODE_DENORM_PRESERVE: u32 = 4459;
pub(super) const MODE_SIGNED_ZERO_INF_NAN_PRESERVE: u32 = 4461;

/// A module's words in this machine's order, or None where it does not
/// start with SPIR-V's magic number (naga says what is wrong with it).
pub(super) fn words(spirv: &[u8]) -> Option<Vec<u32>> {
    let mut words: Vec<u32> = spirv.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect();
    if words.first() == Some(&MAGIC.swap_bytes()) {
        words.iter_mut().for_each(|w| *w = w.swap_bytes());
    }
    (words.len() >= 5 && words[0] == MAGIC).then_some(words)
}

/// One instruction: its first word's index, its opcode and its operands.
pub(super) type Instruction<'a> = (usize, u32, &'a [u32]);

/// The module's instructions after its header. Stops at a malformed
/// length (`checked_instructions` says where).
pub(super) fn instructions(words: &[u32]) -> impl Iterator<Item = Instruction<'_>> {
    let mut at = 5;
    std::iter::from_fn(move || {
        let (count, op) = ((*words.get(at)? >> 16) as usize, words[at] & 0xffff);
        if count == 0 || at + count > words.len() {
            return None;
        }
        let item = (at, op, &words[at + 1..at + count]);
        at += count;
        Some(item)
    })
}

/// Every instruction of the module, or an error for one without the magic
/// number or with an instruction whose length runs past its end.
pub(super) fn checked_instructions(words: &[u32]) -> Result<Vec<Instruction<'_>>, String> {
    if words.len() < 5 || words[0] != MAGIC {
        return Err("not a SPIR-V module (no magic number)".into());
    }
    let all: Vec<Instruction> = instructions(words).collect();
    let end = all.last().map_or(5, |(at, _, ops)| at + 1 + ops.len());
    if end != words.len() {
        return Err(format!("instruction at word {end} has a bad word count {}", words[end] >> 16));
    }
    Ok(all)
}
