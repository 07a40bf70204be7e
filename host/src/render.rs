//! The seam between what to draw and who draws it. A backend takes a
//! packed frame ([`FrameData`]) and returns its [`Picture`] with where the
//! time went ([`Timings`]); the commands and the preview hold backends
//! through [`Renderer`] (a whole frame at a time) and [`Progressive`] (a
//! sample at a time), and know no more of them than these traits say.
//! `gpu::GpuRenderer` (a Vulkan device) and `cpu::CpuRenderer` (the C++
//! build of the same GLSL) implement both. Everything here is backend
//! neutral: it names no Vulkan type and no command.

mod cut_short;
mod kernel_info;
mod lanes;
mod picture;
mod specialization;
mod timings;

pub use cut_short::{finish_cut_short, refuse_cut_short, render_advice, CutShort};
pub use kernel_info::{Executable, KernelInfo, Statistic, StatisticValue};
pub use lanes::{compacted, in_step, LaneUse, Walk, WARPS};
pub use picture::Picture;
pub(crate) use picture::{try_filled, try_with_capacity};
pub use specialization::{SceneFeatures, Specialization};
pub use timings::{DevicePhases, Timings};

use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, PixelOut, PreviewFrame};
use std::ops::Range;
use std::time::Duration;

/// How far a frame's render is, told as it goes (`render`'s progress line).
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    /// Done, from 0 to 1.
    pub fraction: f64,
    /// What is done, in the backend's steps: "sample 3 of 16", "row 120 of 384".
    pub detail: String,
}

/// Told the progress of a render, from whichever thread does the work.
pub type Told<'a> = &'a (dyn Fn(Progress) + Sync);

/// Where the shared code runs (`--backend`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Backend {
    /// A Vulkan device.
    Gpu,
    /// The C++ build of the shared GLSL on every core.
    Cpu,
    /// The device, unless it runs on the CPU (lavapipe) or none opens: then
    /// the CPU build (each command says when the device is kept).
    Auto,
}

/// Who renders, as the status lines, `check`, `conformance` and `bench`
/// name it.
#[derive(Clone, Debug, Default)]
pub struct BackendInfo {
    /// The `device:` line: a device's name, type, driver and API version;
    /// the CPU build with its threads.
    pub summary: String,
    /// As messages name it: the device's name (`llvmpipe (LLVM 15.0.6, 256
    /// bits)`); `the CPU build`.
    pub name: String,
    /// A table's column: `llvmpipe (LLVM 15.0.6, 256 bits) (cpu)`; `CPU build, 2 threads`.
    pub label: String,
    /// How the device's kernels divide, as a clause after `label`
    /// (`Division::kernels_clause`); empty for the CPU build.
    pub kernels_clause: String,
    /// The CPU build of the shared GLSL, not a Vulkan device.
    pub cpu_build: bool,
    /// A Vulkan device that runs on the CPU (lavapipe), where the CPU build
    /// runs the same code without Vulkan's start-up.
    pub device_on_cpu: bool,
    /// The threads the CPU build renders on (None on a device).
    pub threads: Option<usize>,
}

/// Renders whole frames: `render`, `check`, `bench` and `conformance` draw
/// through it. What only some backends have (a kernel to describe, a
/// validation layer, memory on a device) comes back empty from the others.
pub trait Renderer {
    /// Who renders.
    fn info(&self) -> BackendInfo;

    /// One frame of `data`, telling its progress as it goes, with where the
    /// time went; an error ([`CutShort`]) where the device cut pixels short.
    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), Error>;

    /// `render_frame`, but pixels the device cut short are left marked
    /// (RAYS_CUT_SHORT in `rays`) for [`finish_cut_short`].
    fn render_marked(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), Error> {
        self.render_frame(data, told)
    }

    /// Rows `rows` of the frame (each below its height), in that order:
    /// another backend's picture finished ([`finish_cut_short`]).
    fn render_rows(&self, data: &FrameData, rows: &[u32], told: Told) -> Result<Vec<Vec<PixelOut>>, Error> {
        let (picture, _) = self.render_frame(data, told)?;
        let width = picture.width as usize;
        Ok(rows.iter().map(|&row| picture.pixels[row as usize * width..][..width].to_vec()).collect())
    }

    /// The kernel that draws `data`, built now where it was not before;
    /// None where the backend has no kernel to tell of (the CPU build).
    fn kernel(&self, _data: &FrameData) -> Result<Option<KernelInfo>, Error> {
        Ok(None)
    }

    /// The driver's statistics of `data`'s kernel (registers, occupancy);
    /// None where it reports none.
    fn kernel_statistics(&self, _data: &FrameData) -> Result<Option<Vec<Executable>>, Error> {
        Ok(None)
    }

    /// Bytes a frame of `data` puts on a device (`measure::device_bytes`);
    /// None without one.
    fn device_bytes(&self, _data: &FrameData) -> Result<Option<u64>, Error> {
        Ok(None)
    }

    /// What the validation layer said since last asked (empty without one).
    fn take_messages(&self) -> Vec<String> {
        Vec::new()
    }
}

/// Draws a picture a sample at a time into running sums it keeps: the
/// preview's way (shaders/preview_main.glsl), where [`Renderer`] draws a
/// whole frame at once. The preview kernel on a device
/// (the preview's `PreviewRenderer`) and the CPU build (`cpu::CpuProgressive`)
/// implement it; the preview window asks whichever draws for each sample,
/// its time and its pixels.
pub trait Progressive {
    /// The backend as status lines name it: the device, or the CPU build with its threads.
    fn describe(&self) -> String;

    /// Adds sample `preview.sample_index` (its jitter in `preview`) of
    /// `frame`'s rows `preview.row_offset` to `row_end`, drawn with `data`'s
    /// scene, into the running sums: those rows' pixels become the average
    /// of the samples so far. `frame` is at most the picture's size. May
    /// return before the sample is drawn: `wait` waits for it.
    fn add_sample(
        &mut self,
        data: &FrameData,
        frame: &layout::Frame,
        preview: &PreviewFrame,
        row_end: u32,
    ) -> Result<(), Error>;

    /// Waits for the sample in flight; the time it took, where known.
    fn wait(&mut self) -> Result<Option<Duration>, Error>;

    /// The bytes `bytes` of the frame's pixels (`PixelOut`s, frame.width a
    /// row), once the sample in flight is drawn.
    fn pixel_bytes(&mut self, bytes: Range<usize>) -> Result<&[u8], Error>;

    /// How many pixels of the last sample the device cut short (Mesa's loop
    /// budget per invocation: sampling.glsl loop_budget_ok); they are wrong.
    fn cut_short(&mut self) -> Result<u32, Error>;

    /// Running sums for a picture of `size` pixels from now on; the samples start over.
    fn resize(&mut self, size: [u32; 2]) -> Result<(), Error>;

    /// The host threads that draw, where the host draws (the CPU build).
    fn threads(&self) -> Option<usize> {
        None
    }
}
