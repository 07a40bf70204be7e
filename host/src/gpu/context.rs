//! `GpuContext`: what a caller opens and runs kernels on. It owns the
//! instance (instance.rs) and the device chosen (device.rs) through
//! `Inner`, which kernels, buffers and images share; memory (memory.rs) and
//! dispatch (dispatch.rs) work on that. This file holds the public face:
//! opening, the device's limits, and the runs.

use std::sync::Arc;

use ash::vk;

use super::device::{DeviceInfo, GpuOptions, Inner};
use super::dispatch::{RunBuffers, RunTimings};
use super::environment;
use super::instance::{InstanceParts, Surface};
use super::{fma_probe, Division, GpuError, Kernel};

/// An open Vulkan device with one compute queue. Kernels made from it keep it alive.
pub struct GpuContext {
    pub(crate) inner: Arc<Inner>,
}

/// The residuals RAYCAST_FMA_RESIDUALS forces past the fma probe: 1 fma's,
/// 0 Dekker's (`GpuContext::division`); None when it is unset or another value.
pub fn forced_residuals() -> Option<Division> {
    environment::switch("RAYCAST_FMA_RESIDUALS")
        .map(|fma| if fma { Division::CorrectedFma } else { Division::Corrected })
}

impl GpuContext {
    /// Opens the selected (or best) device with one compute queue.
    pub fn new(opts: &GpuOptions) -> Result<GpuContext, GpuError> {
        let parts = InstanceParts::new(opts.validation)?;
        Ok(GpuContext { inner: Arc::new(Inner::open(opts, parts, None)?) })
    }

    /// Opens a device that can also present to a window: creates the instance
    /// with `instance_extensions` (the window system's, e.g. from
    /// glfwGetRequiredInstanceExtensions), lets `create_surface` make the
    /// window's surface on it, and opens the selected (or best) device whose
    /// compute queue can present to that surface, with VK_KHR_swapchain.
    /// `refuse` is the window system's veto, asked of each device before its
    /// driver is (some drivers crash when asked about a surface they cannot
    /// serve): Some(why) and the device cannot present; an error names why
    /// when it is the one selected.
    pub fn with_surface(
        opts: &GpuOptions,
        instance_extensions: &[String],
        create_surface: impl FnOnce(vk::Instance) -> Result<vk::SurfaceKHR, String>,
        refuse: impl Fn(&DeviceInfo) -> Option<String>,
    ) -> Result<GpuContext, GpuError> {
        let parts = InstanceParts::new_with(opts.validation, instance_extensions)?;
        let handle = create_surface(parts.instance.handle())
            .map_err(|e| GpuError::Presentation { what: format!("cannot create the window's Vulkan surface: {e}") })?;
        let surface = Surface { loader: ash::khr::surface::Instance::new(&parts.entry, &parts.instance), handle };
        // On an error below `surface` is dropped before `parts`: surface, then instance.
        Ok(GpuContext { inner: Arc::new(Inner::open(opts, parts, Some((surface, &refuse)))?) })
    }

    /// How many storage images one kernel may bind
    /// (maxPerStageDescriptorStorageImages, and the set's own limit).
    pub fn storage_image_limit(&self) -> u32 {
        let l = &self.inner.limits;
        l.max_per_stage_descriptor_storage_images.min(l.max_descriptor_set_storage_images)
    }

    /// How kernels for this device compile division and square root
    /// (glslang_args.rs): fast where `GpuOptions::kernel` chose the fast
    /// kernels (`KernelChoice::fast_on`); else as given on a CPU device,
    /// corrected on every other (unless RAYCAST_INEXACT_DIVISION says, which
    /// only the exact kernels heed), and there with residuals by
    /// fma() where the device's fma was seen to round once (fma_probe.rs,
    /// run on the first call; a probe that cannot run leaves Dekker's
    /// residuals, exact on any device, and says so on stderr).
    /// RAYCAST_FMA_RESIDUALS=0 or 1 overrides the probe, to measure the
    /// difference or to show what an unfused fma does to the pictures.
    pub fn division(&self) -> Division {
        if self.inner.fast {
            return Division::Fast;
        }
        if !self.inner.inexact_division {
            return Division::AsGiven;
        }
        *self.inner.division.get_or_init(|| match forced_residuals() {
            Some(division) => division,
            None => match fma_probe::fma_rounds_once(self) {
                Ok(true) => Division::CorrectedFma,
                Ok(false) => Division::Corrected,
                Err(e) => {
                    errln!("raycast: the fma probe could not run on {} ({e}); the division correction takes Dekker's residuals, exact but slower", self.inner.info.name);
                    Division::Corrected
                }
            },
        })
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.inner.info
    }

    /// Validation-layer messages captured since the last call (empty when validation is off).
    pub fn take_validation_messages(&self) -> Vec<String> {
        std::mem::take(&mut *self.inner.parts.messages.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// The message list itself, to inspect what arrives while the device and instance are destroyed.
    #[cfg(test)]
    pub(crate) fn message_sink(&self) -> Arc<std::sync::Mutex<Vec<String>>> {
        self.inner.parts.messages.clone()
    }

    /// The largest storage buffer (one binding) the device can address.
    pub fn max_storage_buffer_range(&self) -> u64 {
        self.inner.limits.max_storage_buffer_range as u64
    }

    /// The largest storage buffer the device can both address in one
    /// binding and allocate: the lesser of maxStorageBufferRange and
    /// maxMemoryAllocationSize.
    pub fn max_storage_bytes(&self) -> u64 {
        self.max_storage_buffer_range().min(self.inner.max_allocation)
    }

    /// Fails when a storage buffer of `bytes` exceeds maxStorageBufferRange
    /// or maxMemoryAllocationSize (`what` names it in the error).
    pub fn check_storage_size(&self, bytes: u64, what: impl Fn() -> String) -> Result<(), GpuError> {
        self.inner.check_storage_size(bytes, what)
    }

    /// The most work groups one dispatch may have, per dimension.
    pub fn max_compute_work_group_count(&self) -> [u32; 3] {
        self.inner.limits.max_compute_work_group_count
    }

    /// Upload each input to a storage buffer at its binding, create the output
    /// storage buffer (`out_bytes` long, every u32 word pre-filled with
    /// `fill`), dispatch `groups`, wait (with the timeout), read the output back.
    ///
    /// Every binding of the kernel must be given exactly once.
    pub fn run(
        &self,
        kernel: &Kernel,
        inputs: &[(u32, &[u8])],
        output: (u32, usize),
        fill: u32,
        groups: [u32; 3],
    ) -> Result<(Vec<u8>, RunTimings), GpuError> {
        self.run_passes(kernel, &RunBuffers { inputs, cleared: &[], output, fill }, groups, 1)
    }

    /// `run` with `passes` dispatches of `groups`, each seeing the writes
    /// of the one before (a kernel that keeps its own state in its buffers,
    /// like render.comp's one sample per pass), and with buffers the device
    /// clears (`RunBuffers::cleared`). The passes go in submissions of
    /// about `CHUNK_AIM` each (the first pass alone), so the timeout bounds
    /// one submission, not the whole run.
    pub fn run_passes(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
        groups: [u32; 3],
        passes: u32,
    ) -> Result<(Vec<u8>, RunTimings), GpuError> {
        self.run_passes_read(kernel, buffers, groups, passes, false, <[u8]>::to_vec, |_| {})
    }

    /// `run_passes`, the output given to `read` where the device left it
    /// (mapped), instead of copied out first: a caller that keeps it in a
    /// shape of its own copies it once (a 512x384 picture's pixel records
    /// are 6 MiB; two more copies took 10 ms of lavapipe's whole command).
    /// `done` is told the passes finished after each submission (a
    /// fraction where a pass is split: rows of its work groups apart).
    /// `slow`: the caller expects a pass to take long (seconds on this
    /// device), so it is split from the first whatever its size.
    #[allow(clippy::too_many_arguments)]
    pub fn run_passes_read<R>(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
        groups: [u32; 3],
        passes: u32,
        slow: bool,
        read: impl FnOnce(&[u8]) -> R,
        done: impl FnMut(f64),
    ) -> Result<(R, RunTimings), GpuError> {
        if !Arc::ptr_eq(&kernel.inner, &self.inner) {
            return Err(GpuError::BadRun {
                kernel: kernel.name().to_string(),
                message: "the kernel was created on another GpuContext".into(),
            });
        }
        self.inner.run_passes_read(kernel, buffers, groups, passes, slow, read, done)
    }
}
