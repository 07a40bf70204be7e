//! Kernels specialised ahead of the driver, the result kept.
//!
//! A pipeline is built from SPIR-V on every run. The kernels hold every
//! feature a scene may use, each behind a specialization constant
//! (shaders/layout.h `SPEC_*`), and Mesa's lavapipe turns all of that into
//! NIR and optimises it before the constants let it drop what a scene does
//! not use: 67-92 ms (median 81) for recursiveSpheres4's render kernel on
//! Debian 12's lavapipe (only LLVM's machine code is in Mesa's own cache).
//! Here the constants are written into the SPIR-V as ordinary constants
//! first (`freeze`) and spirv-opt removes the code they rule out
//! (`SPECIALISE_PASSES`); the driver then gets a module 60% of the size and
//! builds its pipeline in 32-47 ms (median 43; docs/platforms.md#kernels-built-once-and-kept). spirv-opt takes about 0.1 s for that, so its result is kept in
//! the cache folder (cache.rs) and made once per kernel, constants and
//! SPIR-V.
//!
//! Done for pipelines on a device that runs on the CPU (`chosen`; a GPU's
//! driver keeps its own cache of pipelines, and shader objects keep the
//! driver's own result, shader_object.rs), unless RAYCAST_SPECIALIZE says
//! otherwise. Where spirv-opt cannot be run or fails, or the driver
//! refuses its module (which is then removed from the cache: `forget`),
//! the driver specialises the kernel as before, and `render`'s kernel line
//! says why.
//!
//! The passes are a constant propagation, an instruction simplification
//! and dead-code passes, on the module as the driver would get it (after
//! the build's own passes, `SPIRV_OPT_PASSES`, which touch no
//! arithmetic). On lavapipe that module declares SPV_KHR_float_controls'
//! SignedZeroInfNanPreserve (float_controls.rs), under which spirv-opt
//! folds no floating-point instruction at all (`IsFloatingPointFoldingAllowed`
//! in SPIRV-Tools); elsewhere it folds none that carries NoContraction,
//! which the shared code puts on its float arithmetic (`precise`,
//! docs/exactness.md#the-recipe). What it folds are the constants' booleans and the
//! branches on them. The pictures are the driver's specialisation's bit
//! for bit and every buffer the CPU build's
//! (tests/cli.rs `specialised_kernels_give_the_drivers_bits`).

use std::collections::HashMap;

use super::spirv::{
    self, checked_instructions, DEC_SPEC_ID, OP_CONSTANT, OP_CONSTANT_FALSE, OP_CONSTANT_TRUE, OP_DECORATE,
    OP_SPEC_CONSTANT, OP_SPEC_CONSTANT_FALSE, OP_SPEC_CONSTANT_TRUE,
};
use super::{cache, run_tool, SPIRV_OPT, TOOL_LIMIT};

/// Specialised SPIR-V in the cache folder: `.spv` files, the newest 128
/// kept (about 200 KB each with their keys; the whole test suite makes 38).
const CACHE: cache::Kind = cache::Kind { extension: "spv", keep: 128 };
/// The first part of every key; its number goes up whenever `freeze` or
/// the file's content changes meaning (the passes are in the key already).
const MAGIC: &[u8] = b"raycast specialised SPIR-V 1\n";

/// spirv-opt's passes on the frozen module, which has had the build's
/// (`SPIRV_OPT_PASSES`, run on every kernel: build.rs, and
/// `glsl_to_spirv` for `--shaders`): constants propagated and the branches,
/// blocks, functions and code they leave unreachable removed; the bindings
/// and the constants not frozen kept. (The build's passes again before
/// them make the same module in twice the time.)
pub const SPECIALISE_PASSES: &[&str] = &[
    "--preserve-bindings",
    "--preserve-spec-constants",
    "--ccp",
    "--simplify-instructions",
    "--eliminate-dead-branches",
    "--eliminate-dead-functions",
    "--eliminate-dead-code-aggressive",
    "--merge-blocks",
    "--cfg-cleanup",
];

/// Whether pipelines on a device are specialised ahead: on a device that
/// runs on the CPU (`cpu`), unless RAYCAST_SPECIALIZE says otherwise: 0
/// never, 1 on every device.
pub(crate) fn chosen(cpu: bool) -> bool {
    super::environment::switch("RAYCAST_SPECIALIZE").unwrap_or(cpu)
}

/// How a kernel's specialization constants were applied, for its pipeline.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Specialised {
    /// Ahead, by spirv-opt, in this run; its result kept in the cache
    /// folder (`kept`) or not (no folder, or not writable).
    Made { kept: bool },
    /// Ahead, in a run before: the SPIR-V kept in the cache folder.
    Kept,
    /// By the driver, as spirv-opt could not do it: why.
    ByTheDriver(String),
}

impl Specialised {
    /// How `render`'s kernel line says it.
    pub fn describe(&self) -> String {
        match self {
            Specialised::Made { kept: true } => "SPIR-V specialised ahead by spirv-opt, kept for the next run".into(),
            Specialised::Made { kept: false } => {
                "SPIR-V specialised ahead by spirv-opt, not kept: no cache folder, or not writable".into()
            }
            Specialised::Kept => "SPIR-V specialised ahead, kept by a run before".into(),
            Specialised::ByTheDriver(why) => format!("specialised by the driver: {why}"),
        }
    }
}

/// `words` (a kernel named `name`) with its specialization constants
/// 0 .. constants.len() applied ahead, from the cache folder when it holds
/// exactly this, else made by spirv-opt and kept; None (and why) where
/// that failed: the caller builds from `words` with the constants as
/// specialization info.
pub(crate) fn specialise(name: &str, words: &[u32], constants: &[u32]) -> (Option<Vec<u32>>, Specialised) {
    let (key, file) = cache_entry(name, words, constants);
    if let Some(kept) = file.as_deref().and_then(|f| cache::read(f, &key)) {
        if let Some(spirv) = spirv::words(&kept) {
            return (Some(spirv), Specialised::Kept);
        }
    }
    let made = freeze(words, constants).and_then(|frozen| optimise(name, &frozen));
    match made {
        Ok(spirv) => {
            // A cache that cannot be written is only slower.
            let kept = file.is_some_and(|f| cache::write(&f, CACHE, &key, bytemuck::cast_slice(&spirv)).is_ok());
            (Some(spirv), Specialised::Made { kept })
        }
        Err(why) => (None, Specialised::ByTheDriver(why)),
    }
}

/// Removes what `specialise` kept for this kernel, if anything: for a
/// module the driver refused (the kernel is then built as it was).
pub(crate) fn forget(name: &str, words: &[u32], constants: &[u32]) {
    if let (_, Some(file)) = cache_entry(name, words, constants) {
        let _ = std::fs::remove_file(file);
    }
}

/// The cache key of a kernel's specialisation and its file (None: no cache folder).
fn cache_entry(name: &str, words: &[u32], constants: &[u32]) -> (Vec<u8>, Option<std::path::PathBuf>) {
    let passes = SPECIALISE_PASSES.join(" ");
    let key = cache::key(&[
        MAGIC,
        passes.as_bytes(),
        name.as_bytes(),
        bytemuck::cast_slice(constants),
        bytemuck::cast_slice(words),
    ]);
    let file = cache::cache_dir().map(|d| cache::file_for(&d, CACHE, name, &key));
    (key, file)
}

/// `words` with each specialization constant whose SpecId is below
/// `constants.len()` made an ordinary constant of that value
/// (`constants[id]`: a bool is 0 or not, a 32-bit scalar the word itself),
/// and those SpecId decorations removed. An error for a module it cannot
/// walk (`spirv::checked_instructions`) or a constant wider than 32 bits.
pub(crate) fn freeze(words: &[u32], constants: &[u32]) -> Result<Vec<u32>, String> {
    let instructions = checked_instructions(words)?;
    let value = |id: &u32| constants.get(*id as usize).copied();
    let spec_ids: HashMap<u32, u32> = instructions
        .iter()
        .filter_map(|(_, op, ops)| match (*op, *ops) {
            (OP_DECORATE, [target, DEC_SPEC_ID, id]) if value(id).is_some() => Some((*target, *id)),
            _ => None,
        })
        .collect();
    let frozen = |result: &u32| spec_ids.get(result).and_then(value);
    let mut out = Vec::with_capacity(words.len());
    out.extend_from_slice(&words[..5]);
    for (at, op, ops) in instructions {
        let count = words[at] & 0xffff_0000;
        match (op, ops) {
            (OP_DECORATE, [target, DEC_SPEC_ID, _]) if spec_ids.contains_key(target) => {}
            (OP_SPEC_CONSTANT_TRUE | OP_SPEC_CONSTANT_FALSE, [_, result]) if frozen(result).is_some() => {
                let op = if frozen(result) != Some(0) { OP_CONSTANT_TRUE } else { OP_CONSTANT_FALSE };
                out.push(count | op);
                out.extend_from_slice(ops);
            }
            (OP_SPEC_CONSTANT, [ty, result, _]) if frozen(result).is_some() => {
                out.extend_from_slice(&[count | OP_CONSTANT, *ty, *result]);
                out.extend(frozen(result));
            }
            (OP_SPEC_CONSTANT, [_, result, ..]) if frozen(result).is_some() => {
                return Err(format!("specialization constant %{result} is wider than 32 bits"));
            }
            _ => out.extend_from_slice(&words[at..at + 1 + ops.len()]),
        }
    }
    Ok(out)
}

/// `frozen` through spirv-opt (`SPECIALISE_PASSES`), through temporary files
/// (spirv-opt writes its warnings to standard output, so its result cannot
/// go there); stopped after `TOOL_LIMIT` (it takes about 0.1 s).
fn optimise(name: &str, frozen: &[u32]) -> Result<Vec<u32>, String> {
    let temp = |what: &str| super::environment::temp_file(&format!("{name}-{what}.spv"));
    let (input, out) = (temp("frozen"), temp("specialised"));
    let result = (|| {
        std::fs::write(&input, bytemuck::cast_slice::<u32, u8>(frozen))
            .map_err(|e| format!("cannot write {}: {e}", input.display()))?;
        let mut command = std::process::Command::new(SPIRV_OPT);
        command.args(SPECIALISE_PASSES).arg(&input).arg("-o").arg(&out);
        let output = run_tool(SPIRV_OPT, "spirv-tools", command, TOOL_LIMIT)?;
        if !output.status.success() {
            let said = String::from_utf8_lossy(&output.stderr);
            let first = said.lines().find(|l| !l.trim().is_empty()).unwrap_or("no message");
            return Err(format!("{SPIRV_OPT} failed ({}): {first}", output.status));
        }
        let bytes = std::fs::read(&out).map_err(|e| format!("cannot read {SPIRV_OPT}'s result: {e}"))?;
        spirv::words(&bytes).ok_or_else(|| format!("{SPIRV_OPT} wrote no SPIR-V"))
    })();
    let _ = std::fs::remove_file(&input);
    let _ = std::fs::remove_file(&out);
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The render kernel as lavapipe gets it (every kernel's constants are bools).
    fn render_words() -> Vec<u32> {
        spirv::words(super::super::kernel_spirv("render_uniform").unwrap()).unwrap()
    }

    /// The spec constants of `words` by SpecId: (opcode, value word if any).
    fn spec_constants(words: &[u32]) -> Vec<(u32, u32)> {
        let ids: HashMap<u32, u32> = spirv::instructions(words)
            .filter_map(|(_, op, ops)| match (op, ops) {
                (OP_DECORATE, [target, DEC_SPEC_ID, id]) => Some((*target, *id)),
                _ => None,
            })
            .collect();
        let mut found: Vec<(u32, u32)> = spirv::instructions(words)
            .filter_map(|(_, op, ops)| match (op, ops) {
                (OP_SPEC_CONSTANT_TRUE | OP_SPEC_CONSTANT_FALSE | OP_SPEC_CONSTANT, [_, result, ..]) => {
                    ids.get(result).map(|id| (*id, op))
                }
                _ => None,
            })
            .collect();
        found.sort_unstable();
        found
    }

    #[test]
    fn freeze_makes_the_given_constants_ordinary_and_leaves_the_rest() {
        let words = render_words();
        let before = spec_constants(&words);
        assert_eq!(before.len(), crate::layout::SPEC_COUNT as usize, "{before:?}");
        // The first three given (true, false, true), the rest left to the driver.
        let frozen = freeze(&words, &[1, 0, 7]).unwrap();
        let after = spec_constants(&frozen);
        assert_eq!(after, before[3..].to_vec(), "only SpecIds 0, 1 and 2 frozen");
        // Each frozen constant is now an OpConstantTrue/False of its own result id, per its value.
        let results: Vec<(u32, u32)> = spirv::instructions(&words)
            .filter_map(|(_, op, ops)| match (op, ops) {
                (OP_DECORATE, [target, DEC_SPEC_ID, id]) if *id < 3 => Some((*id, *target)),
                _ => None,
            })
            .collect();
        assert_eq!(results.len(), 3);
        for (id, result) in results {
            let op = spirv::instructions(&frozen)
                .find_map(|(_, op, ops)| (ops.get(1) == Some(&result)).then_some(op))
                .unwrap_or_else(|| panic!("%{result} gone"));
            let want = if id == 1 { OP_CONSTANT_FALSE } else { OP_CONSTANT_TRUE };
            assert_eq!(op, want, "SpecId {id}");
        }
        // Three SpecId decorations (4 words each) fewer; nothing else changed in size.
        assert_eq!(frozen.len(), words.len() - 3 * 4);
        // Nothing given: the module as it was.
        assert_eq!(freeze(&words, &[]).unwrap(), words);
    }

    #[test]
    fn freeze_sets_a_32_bit_constant_and_refuses_what_it_cannot_walk() {
        // A hand-made module's tail: OpDecorate %5 SpecId 0; %5 = OpSpecConstant %4 9.
        let header = [0x0723_0203, 0x0001_0300, 0, 10, 0];
        let mut words = header.to_vec();
        words.extend_from_slice(&[(4 << 16) | OP_DECORATE, 5, DEC_SPEC_ID, 0]);
        words.extend_from_slice(&[(4 << 16) | OP_SPEC_CONSTANT, 4, 5, 9]);
        let frozen = freeze(&words, &[42]).unwrap();
        let mut want = header.to_vec();
        want.extend_from_slice(&[(4 << 16) | OP_CONSTANT, 4, 5, 42]);
        assert_eq!(frozen, want);
        // A 64-bit one is refused, as is a module whose last instruction runs past its end.
        let mut wide = header.to_vec();
        wide.extend_from_slice(&[(4 << 16) | OP_DECORATE, 5, DEC_SPEC_ID, 0]);
        wide.extend_from_slice(&[(5 << 16) | OP_SPEC_CONSTANT, 4, 5, 9, 0]);
        assert!(freeze(&wide, &[42]).unwrap_err().contains("wider than 32 bits"));
        let cut = &words[..words.len() - 1];
        assert!(freeze(cut, &[42]).unwrap_err().contains("bad word count"));
    }
}
