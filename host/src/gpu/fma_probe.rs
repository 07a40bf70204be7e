//! Whether a device's `fma()` rounds once, seen by running it: the GPU
//! kernels' division correction then takes its residuals from `fma()`
//! (`Division::CorrectedFma`, raycast.glsl FUSED_FMA), one operation where
//! Dekker's exact product takes seventeen. The Vulkan specification does
//! not promise a fused `fma` (lavapipe's rounds the product first, NVIDIA's
//! does not), and a residual from an unfused one is the very error the
//! correction measures, so nothing is assumed: shaders/fma_probe.comp
//! computes `fma(a, b, c)` for `CASES` cases on the device, and only if
//! every result has the bits of a once-rounded fma (`f32::mul_add`) does
//! the device get the FUSED_FMA kernels.

use super::{kernel_spirv, GpuContext, GpuError, Kernel};
use crate::layout::{self, FmaCase};

/// How many cases the probe runs (one workgroup of fma_probe.comp).
const CASES: usize = 64;

/// The cases: a b + c where the product's rounding error is all that is
/// left, so a fused fma gives that error and an unfused one (nearly always)
/// 0. The first is (1 + 2^-23)(1 - 2^-23) - 1 = -2^-46; the others have a
/// and b spread over [1, 2) by a fixed sequence and c = -(a b rounded).
pub(crate) fn cases() -> Vec<FmaCase> {
    let mut cases = vec![FmaCase { a: 1.0 + f32::EPSILON, b: 1.0 - f32::EPSILON, c: -1.0, r: 0.0 }];
    let mut state: u32 = 0x2545_f491;
    let mut next = || {
        // xorshift32: the same cases on every run.
        state ^= state << 13;
        state ^= state >> 17;
        state ^= state << 5;
        f32::from_bits(0x3f80_0000 | (state >> 9)) // [1, 2)
    };
    while cases.len() < CASES {
        let (a, b) = (next(), next());
        cases.push(FmaCase { a, b, c: -(a * b), r: 0.0 });
    }
    cases
}

/// True when the device computes every case's `fma(a, b, c)` with one
/// rounding; false when any result differs (an unfused fma, or a mix).
pub fn fma_rounds_once(ctx: &GpuContext) -> Result<bool, GpuError> {
    let spirv = kernel_spirv("fma_probe").expect("build.rs embeds shaders/fma_probe.comp");
    let kernel = Kernel::new(ctx, "fma_probe", spirv, &layout::fma_probe_bindings())?;
    let cases = cases();
    let bytes: &[u8] = bytemuck::cast_slice(&cases);
    let groups = [cases.len().div_ceil(64) as u32, 1, 1];
    let (out, _) =
        ctx.run(&kernel, &[(layout::BINDING_FMA_CASES, bytes)], (layout::BINDING_FMA_RESULTS, bytes.len()), 0, groups)?;
    let results: Vec<FmaCase> = bytemuck::pod_collect_to_vec(&out);
    Ok(cases.iter().zip(&results).all(|(c, r)| r.r.to_bits() == c.a.mul_add(c.b, c.c).to_bits()))
}
