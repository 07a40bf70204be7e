//! Vulkan: instance and device selection, validation, buffers, compute
//! pipelines, dispatch and readback; naga validation and layout reflection.
//! For a window: persistent buffers and storage images bound in a
//! descriptor set (`buffer`, `image`), a swapchain (`present`) and a frame
//! loop that dispatches, copies the image to the swapchain and presents
//! (`frames`).
//!
//! Knows nothing of scenes: callers hand it SPIR-V, the expected
//! `layout::BindingLayout`s and raw buffer bytes.

include!("glslang_args.rs");

mod compile;
mod buffer;
mod context;
mod error;
mod float_controls;
mod frames;
mod image;
mod kernel;
mod present;
pub mod reflect;
#[cfg(test)]
mod tests;

pub use compile::compile_kernel;
pub use context::{list_devices, DeviceInfo, DeviceSelector, GpuContext, GpuOptions, RunBuffers, RunTimings};
pub use error::GpuError;
pub use buffer::{Buffer, DescriptorSet, Resource};
pub use frames::{FrameLoop, FrameStatus};
pub use image::{DataImage, ImageBinding, ImageFormat, StorageImage};
pub use kernel::Kernel;
pub use present::{PresentMode, Swapchain};

/// Mesa's lavapipe gives each of its threads (LP_NUM_THREADS, by default
/// one per core) one contiguous block of a dispatch's workgroups, so the
/// block that holds the costliest part of the picture decides when the
/// dispatch ends while the other threads wait. More threads than cores make
/// smaller blocks that the system interleaves: on 2 cores, 8 threads took
/// recursiveSpheres4's dispatch from 310 to 279 ms and the depth-10 scene's
/// from 2790 to 2350 ms, the same pixels (BENCHMARKS.md, "What made
/// lavapipe faster"). Sets LP_NUM_THREADS to 4 a core (at most Mesa's 32)
/// unless it is set already; other drivers ignore it. Call first thing in
/// the process: before any Vulkan instance exists, while no other thread
/// reads the environment.
pub fn spread_lavapipe_work() {
    if std::env::var_os("LP_NUM_THREADS").is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::env::set_var("LP_NUM_THREADS", (4 * cores).min(32).to_string());
    }
}
