//! Rendering a [`FrameData`] on a Vulkan device with the render kernel, and
//! the picture that comes back.

use crate::cpu::CpuRenderer;
use crate::frame::FrameData;
use crate::gpu::{GpuContext, GpuError, GpuOptions, Kernel};
use crate::layout::{self, PixelOut};
use std::time::{Duration, Instant};

/// The render kernel's SPIR-V, compiled from shaders/render.comp at build time.
pub fn render_spirv() -> &'static [u8] {
    kernel_spirv("render").expect("build.rs embeds shaders/render.comp")
}

include!(concat!(env!("OUT_DIR"), "/kernels.rs"));

/// A kernel of shaders/*.comp by file stem, as embedded at build time.
pub fn kernel_spirv(stem: &str) -> Option<&'static [u8]> {
    EMBEDDED_KERNELS.iter().find(|(name, _)| *name == stem).map(|(_, spv)| *spv)
}

/// Every pixel's output: colour (or AOV), t, hit id and normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<PixelOut>,
}

impl Picture {
    /// 8-bit RGB, row 0 at the top.
    pub fn rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| {
                let [r, g, b, _] = p.rgba.to_le_bytes();
                [r, g, b]
            })
            .collect()
    }

    /// Every ray the frame traced (camera, shadow and mirror): the sum of the pixels' counts.
    pub fn rays(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.rays)).sum()
    }
}

/// Where the time of one GPU render went.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuTimings {
    pub upload: Duration,
    pub dispatch: Duration,
    pub readback: Duration,
}

/// A Vulkan device with the render kernel built and checked.
pub struct GpuRenderer {
    // Field order is drop order: the kernel goes before its device.
    kernel: Kernel,
    context: GpuContext,
    /// Time to check the SPIR-V and build the pipeline.
    pub compile_time: Duration,
}

/// Recomputes with the CPU build the pixels of `picture` (a render of
/// `data`) that the device cut short; returns how many. The CPU build runs
/// the same shader code: on lavapipe, the only device known to cut pixels
/// short, its pixels are the device's bit for bit (what `raycast check`
/// and CI compare), so the finished picture is the one the device would
/// have made without its limit.
pub fn finish_cut_short(picture: &mut Picture, data: &FrameData, cpu: &CpuRenderer) -> usize {
    let width = picture.width as usize;
    let is_cut = |p: &PixelOut| p.rays & layout::RAYS_CUT_SHORT != 0;
    let mut rows: Vec<u32> = picture.pixels.chunks(width).enumerate().filter(|(_, row)| row.iter().any(is_cut)).map(|(i, _)| i as u32).collect();
    rows.dedup();
    let mut count = 0;
    for (row, cpu_row) in rows.iter().zip(cpu.render_rows(data, &rows)) {
        let device_row = &mut picture.pixels[*row as usize * width..][..width];
        for (d, c) in device_row.iter_mut().zip(cpu_row) {
            if is_cut(d) {
                *d = c;
                count += 1;
            }
        }
    }
    count
}

/// An error when the kernel marked pixels whose loops the device ended
/// early (raycast.glsl loop_budget_ok): such a picture is wrong.
pub fn refuse_cut_short(pixels: &[PixelOut], width: u32, device: &str) -> Result<(), GpuError> {
    let is_cut = |p: &PixelOut| p.rays & layout::RAYS_CUT_SHORT != 0;
    let Some(first) = pixels.iter().position(is_cut) else { return Ok(()) };
    let first = first as u32;
    Err(GpuError::CutShort {
        device: device.to_string(),
        count: pixels.iter().filter(|p| is_cut(p)).count(),
        total: pixels.len(),
        first: (first % width, first / width),
    })
}

impl GpuRenderer {
    /// The device of `options` with the embedded render kernel.
    pub fn new(options: &GpuOptions) -> Result<GpuRenderer, GpuError> {
        GpuRenderer::with_spirv(options, render_spirv())
    }

    /// The device of `options` with a render kernel of the caller's (for
    /// example compiled from `--shaders DIR`); checked like the embedded one.
    pub fn with_spirv(options: &GpuOptions, spirv: &[u8]) -> Result<GpuRenderer, GpuError> {
        let context = GpuContext::new(options)?;
        let start = Instant::now();
        let kernel = Kernel::new(&context, "render", spirv, &layout::render_bindings())?;
        Ok(GpuRenderer { kernel, context, compile_time: start.elapsed() })
    }

    pub fn context(&self) -> &GpuContext {
        &self.context
    }

    /// The frame on the device; an error when the device cut pixels short
    /// (`refuse_cut_short`).
    pub fn render(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        let (picture, t) = self.render_marked(data)?;
        refuse_cut_short(&picture.pixels, picture.width, &self.context.info().name)?;
        Ok((picture, t))
    }

    /// The frame as the device computed it, pixels it cut short still
    /// marked (RAYS_CUT_SHORT in `rays`): for `finish_cut_short`.
    pub fn render_marked(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        let f = &data.frame;
        let count = f.width as usize * f.height as usize;
        let groups = [f.width.div_ceil(layout::WORKGROUP_SIZE), f.height.div_ceil(layout::WORKGROUP_SIZE), 1];
        let mut inputs = vec![(layout::BINDING_FRAME, bytemuck::bytes_of(&data.frame))];
        inputs.extend(data.scene_buffers().iter().map(|&(binding, _, bytes)| (binding, bytes)));
        // The samples' running sums start at zero: sample 0 is next.
        let sums = vec![0u8; count * std::mem::size_of::<layout::SampleSum>()];
        inputs.push((layout::BINDING_SAMPLE_SUMS, &sums));
        let (bytes, t) = self.context.run_passes(
            &self.kernel,
            &inputs,
            (layout::BINDING_PIXELS, count * std::mem::size_of::<PixelOut>()),
            // Sentinel: a pixel the kernel never wrote reads as NaN t and id 0xffffffff.
            0xffff_ffff,
            groups,
            // One sample of every pixel per dispatch (render.comp).
            f.spp.max(1),
        )?;
        let pixels: Vec<PixelOut> = bytemuck::pod_collect_to_vec(&bytes);
        // Every pixel the kernel covers counts at least its camera ray, far
        // fewer than the sentinel.
        let unwritten = pixels.iter().filter(|p| p.rays == 0 || p.rays == 0xffff_ffff).count();
        if unwritten > 0 {
            return Err(GpuError::BadRun {
                kernel: "render".into(),
                message: format!("the kernel left {unwritten} of {count} pixels unwritten (the sentinel is still in place)"),
            });
        }
        let timings = GpuTimings { upload: t.upload, dispatch: t.dispatch, readback: t.readback };
        Ok((Picture { width: f.width, height: f.height, pixels }, timings))
    }
}
