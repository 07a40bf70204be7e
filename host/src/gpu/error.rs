//! `GpuError`: every way the gpu part can fail, each with a message that
//! says what happened and what to do.

use crate::units::fmt_bytes;
use std::fmt;
use std::time::Duration;

use ash::vk;

use super::DeviceInfo;

/// `GpuError::TooLarge`'s advice where nothing more specific is known.
pub const LESS_DATA: &str = "use less data (e.g. render a smaller image)";

/// An error of the gpu part. `Display` gives one actionable paragraph.
#[derive(Debug)]
#[non_exhaustive]
pub enum GpuError {
    /// `libvulkan.so.1` could not be loaded (`detail`: the loader's reason).
    LoaderMissing { detail: String },
    /// The loader is older than the Vulkan version raycast needs.
    LoaderTooOld { version: String },
    /// Instance creation or device enumeration found no usable device.
    NoDevice { detail: String },
    /// `--device` matched none of the devices.
    DeviceNotFound { selector: String, available: Vec<DeviceInfo> },
    /// The chosen device has no queue family with compute support.
    NoComputeQueue { device: String },
    /// Validation was requested but the layer (or its debug extension) is missing.
    ValidationUnavailable { what: String },
    /// A Vulkan call failed.
    Vk { call: &'static str, result: vk::Result },
    /// No memory type could hold a buffer.
    OutOfMemory { what: String, bytes: u64, detail: String },
    /// A buffer exceeds a device limit (`limit_name`, e.g. maxStorageBufferRange);
    /// `advice` says what to do (`LESS_DATA` where nothing more specific is known).
    TooLarge { what: String, bytes: u64, limit: u64, limit_name: &'static str, advice: &'static str },
    /// The dispatch asks for more work groups than the device allows.
    TooManyGroups { groups: [u32; 3], limit: [u32; 3] },
    /// The fence did not signal within the timeout.
    Timeout { after: Duration },
    /// A run before timed out on this device, which may still be running
    /// it: the next is not made (it would wait behind it and time out too:
    /// a batch's next scenes, conformance's next cases, shader-test's next
    /// functions).
    StillRunning,
    /// naga could not parse or validate the SPIR-V, or it lacks a compute `main`.
    InvalidSpirv { kernel: String, message: String },
    /// The shader's bindings or struct layouts differ from the host's.
    LayoutMismatch { kernel: String, mismatches: Vec<String> },
    /// `GpuContext::run` was called with buffers that do not fit the kernel.
    BadRun { kernel: String, message: String },
    /// A window surface, swapchain or presentation problem (`what` says which and what to do).
    Presentation { what: String },
}

impl GpuError {
    pub(crate) fn vk(call: &'static str) -> impl FnOnce(vk::Result) -> GpuError {
        move |result| GpuError::Vk { call, result }
    }

    /// The "no device" error, naming the driver environment variables that are set.
    pub(crate) fn no_device(what: &str) -> GpuError {
        // VK_LOADER_DRIVERS_DISABLE only when the user set it: raycast's own
        // (gpu::skip_drivers_without_devices) leaves out drivers that could find no device.
        let set: Vec<String> = super::DRIVER_CHOICE_VARS
            .iter()
            .filter(|var| **var != "VK_LOADER_DRIVERS_DISABLE" || super::user_disabled_drivers())
            .filter_map(|var| std::env::var_os(var).map(|v| format!("{var}={:?}", v.to_string_lossy())))
            .collect();
        let hint = if set.is_empty() {
            "install a Vulkan driver (e.g. Debian's mesa-vulkan-drivers for the lavapipe software device) \
             and check that its ICD file is in /usr/share/vulkan/icd.d"
                .to_string()
        } else {
            format!(
                "the driver search is restricted by {}; unset it or point it at an existing ICD file \
                 (e.g. /usr/share/vulkan/icd.d/lvp_icd.x86_64.json for lavapipe)",
                set.join(" and ")
            )
        };
        GpuError::NoDevice { detail: format!("{what}; {hint}") }
    }

    /// A `TooLarge` with `advice` in place of its own (a caller that knows
    /// what the buffer holds knows better what to do); other errors as they are.
    pub fn with_advice(self, advice: &'static str) -> GpuError {
        match self {
            GpuError::TooLarge { what, bytes, limit, limit_name, .. } => {
                GpuError::TooLarge { what, bytes, limit, limit_name, advice }
            }
            other => other,
        }
    }
}

impl fmt::Display for GpuError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            GpuError::LoaderMissing { detail } => write!(
                f,
                "cannot load the Vulkan loader libvulkan.so.1 ({detail}); install libvulkan1 and a driver, \
                 e.g. Debian's mesa-vulkan-drivers for the lavapipe software device"
            ),
            GpuError::LoaderTooOld { version } => write!(
                f,
                "the Vulkan loader supports only Vulkan {version}, raycast needs 1.1; update libvulkan1"
            ),
            GpuError::NoDevice { detail } => write!(f, "no Vulkan device found: {detail}"),
            GpuError::DeviceNotFound { selector, available } => {
                write!(f, "no Vulkan device matches {selector}; available devices:")?;
                for d in available {
                    write!(f, "\n  {}: {} ({}, Vulkan {}, {})", d.index, d.name, d.kind, d.api_version, d.driver)?;
                }
                write!(f, "\nselect one by index or by part of its name")
            }
            GpuError::NoComputeQueue { device } => write!(
                f,
                "the Vulkan device {device} has no queue family that supports compute; select another device"
            ),
            GpuError::ValidationUnavailable { what } => write!(f, "validation was requested but {what}"),
            GpuError::Vk { call, result } => {
                write!(f, "the Vulkan call {call} failed with {result:?} ({result})")?;
                let hint = match *result {
                    vk::Result::ERROR_OUT_OF_HOST_MEMORY | vk::Result::ERROR_OUT_OF_DEVICE_MEMORY => {
                        "; the device ran out of memory: use less data (e.g. render a smaller image)"
                    }
                    vk::Result::ERROR_DEVICE_LOST => {
                        "; the device was lost (driver crash or reset, often a dispatch that ran too long): \
                         render a smaller image or try another device"
                    }
                    vk::Result::ERROR_INITIALIZATION_FAILED | vk::Result::ERROR_INCOMPATIBLE_DRIVER => {
                        "; check the Vulkan driver installation (vulkaninfo --summary)"
                    }
                    _ => "",
                };
                f.write_str(hint)
            }
            GpuError::OutOfMemory { what, bytes, detail } => write!(
                f,
                "cannot allocate {} of memory for {what} ({detail}); use less data \
                 (e.g. render a smaller image) or select a device with more memory",
                fmt_bytes(*bytes)
            ),
            GpuError::TooLarge { what, bytes, limit, limit_name, advice } => write!(
                f,
                "{what} needs {}, more than this device's {limit_name} of {}; {advice}",
                fmt_bytes(*bytes),
                fmt_bytes(*limit)
            ),
            GpuError::TooManyGroups { groups, limit } => write!(
                f,
                "the dispatch needs {}x{}x{} work groups, more than this device's maxComputeWorkGroupCount \
                 of {}x{}x{}; render a smaller image",
                groups[0], groups[1], groups[2], limit[0], limit[1], limit[2]
            ),
            GpuError::Timeout { after } => write!(
                f,
                "the dispatch did not finish within {} s (one submission: a sample of the picture or of a band of \
                 its rows, part of one, or several); a kernel that never ends (a shader edit's endless loop)? Else render a smaller \
                 or simpler picture, or raise the limit (--timeout SECONDS)",
                after.as_secs_f64()
            ),
            GpuError::StillRunning => write!(
                f,
                "not run: a run before it on this device did not finish within the timeout, and the device may still \
                 be running it"
            ),
            GpuError::InvalidSpirv { kernel, message } => write!(
                f,
                "kernel {kernel}: the SPIR-V is not valid: {message}; where the shaders are an edit of yours \
                 (--shaders, --versus), glslang took that edit and naga refuses what it made (two resources on one \
                 binding, say: layout.h's BINDING_* numbers); else rebuild the shaders (cargo build) and check \
                 glslangValidator's output"
            ),
            GpuError::LayoutMismatch { kernel, mismatches } => {
                write!(
                    f,
                    "kernel {kernel}: the shader's buffers do not match the host's ({} mismatch{}); make \
                     shaders/layout.h and its Rust mirror host/src/layout.rs agree:",
                    mismatches.len(),
                    if mismatches.len() == 1 { "" } else { "es" }
                )?;
                for m in mismatches {
                    write!(f, "\n  {m}")?;
                }
                Ok(())
            }
            GpuError::BadRun { kernel, message } => write!(f, "kernel {kernel}: {message}"),
            GpuError::Presentation { what } => write!(f, "cannot show the picture in a window: {what}"),
        }
    }
}

impl std::error::Error for GpuError {}
