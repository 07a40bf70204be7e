//! Vulkan: instance and device selection, validation, buffers, compute
//! pipelines, dispatch and readback; naga validation and layout reflection.
//!
//! Knows nothing of scenes: callers hand it SPIR-V, the expected
//! `layout::BindingLayout`s and raw buffer bytes.

include!("glslang_args.rs");

mod compile;
mod context;
mod error;
mod kernel;
pub mod reflect;
#[cfg(test)]
mod tests;

pub use compile::compile_kernel;
pub use context::{list_devices, DeviceInfo, DeviceSelector, GpuContext, GpuOptions, RunTimings};
pub use error::GpuError;
pub use kernel::Kernel;
