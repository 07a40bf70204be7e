//! Vulkan, a file per object: the instance and its validation messenger
//! (`instance`), device choice and the open device (`device`), memory and
//! buffers (`memory`), dispatch and readback (`dispatch`), owned by a
//! `GpuContext` (`context`); compute pipelines (`kernel`); naga validation
//! and layout reflection (`reflect`).
//! For a window: persistent buffers and storage images bound in a
//! descriptor set (`buffer`, `image`), a swapchain (`present`) and a frame
//! loop that dispatches, copies the image to the swapchain and presents
//! (`frames`).
//!
//! The render kernel as a `render::Renderer` (`renderer`): the one file
//! here that knows a packed frame (`FrameData`); the rest knows nothing of
//! scenes: callers hand it SPIR-V, the expected `layout::BindingLayout`s
//! and raw buffer bytes.

include!("glslang_args.rs");
include!(concat!(env!("OUT_DIR"), "/kernels.rs"));

/// A kernel of shaders/*.comp by file stem (with its `Division` suffix), as
/// embedded at build time.
pub fn kernel_spirv(stem: &str) -> Option<&'static [u8]> {
    EMBEDDED_KERNELS.iter().find(|(name, _)| *name == stem).map(|(_, spv)| *spv)
}

mod buffer;
mod cache;
mod compile;
mod context;
mod device;
mod dispatch;
mod environment;
mod error;
mod float_controls;
mod fma_probe;
mod frames;
mod image;
mod instance;
mod kernel;
mod memory;
mod present;
pub mod reflect;
mod renderer;
mod shader_object;
mod specialize;
mod spirv;
#[cfg(test)]
mod tests;

pub use crate::layout::{ImageBinding, ImageFormat};
pub use buffer::{Buffer, DescriptorSet, Resource};
pub use cache::cache_dir;
pub use compile::{compile_kernel, compile_kernel_pair};
pub use context::{forced_residuals, GpuContext};
pub use device::{list_devices, list_devices_with_default, DeviceInfo, DeviceSelector, GpuOptions, KernelChoice};
pub use dispatch::{device_left_running, RunBuffers, RunTimings};
pub(crate) use environment::switch;
pub(crate) use environment::{own_driver_choice, user_disabled_drivers, DRIVER_CHOICE_VARS};
pub use environment::{prepare_process, DRM_DRIVER_MANIFESTS};
pub use error::{GpuError, LESS_DATA};
pub use fma_probe::fma_rounds_once;
pub use frames::{FrameLoop, FrameStatus};
pub use image::{DataImage, StorageImage};
pub use kernel::Kernel;
pub use present::{PresentMode, Swapchain};
pub use renderer::{
    check_storage_arrays, fits_uniform, kernel_spirv_for, GpuRenderer, SceneBuffers, StorageAdvice,
    PREVIEW_CPU_STORAGE_ADVICE, PREVIEW_DEVICE_STORAGE_ADVICE, RENDER_STORAGE_ADVICE, UNIFORM_KERNEL,
};
pub(crate) use shader_object::ShaderSource;
pub(crate) use specialize::Specialised;
