//! Vulkan: instance and device selection, validation, buffers, compute
//! pipelines, dispatch and readback; naga validation and layout reflection.

include!("glslang_args.rs");
