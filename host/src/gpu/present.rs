//! Presenting to a window: a `Swapchain` over the surface of
//! `GpuContext::with_surface` (instance.rs `Surface`), recreated when the
//! window's size changes.

use std::sync::Arc;

use ash::vk;

use super::device::Inner;
use super::{GpuContext, GpuError};

/// When a presented image replaces the one on screen.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PresentMode {
    /// Wait for vertical blank; every device supports it.
    #[default]
    Fifo,
    /// Replace the queued image; no tearing, no waiting.
    Mailbox,
    /// At once; may tear.
    Immediate,
}

impl PresentMode {
    fn vk(self) -> vk::PresentModeKHR {
        match self {
            PresentMode::Fifo => vk::PresentModeKHR::FIFO,
            PresentMode::Mailbox => vk::PresentModeKHR::MAILBOX,
            PresentMode::Immediate => vk::PresentModeKHR::IMMEDIATE,
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            PresentMode::Fifo => "fifo",
            PresentMode::Mailbox => "mailbox",
            PresentMode::Immediate => "immediate",
        }
    }
}

/// The swapchain of the context's surface. Its images receive a blit of the
/// kernel's storage image (`FrameLoop::submit`).
pub struct Swapchain {
    pub(crate) loader: ash::khr::swapchain::Device,
    pub(crate) handle: vk::SwapchainKHR,
    pub(crate) images: Vec<vk::Image>,
    /// Signalled by each frame's submit, waited on by its present: one per
    /// image, as an image's semaphore is free again once that image is acquired again.
    pub(crate) rendered: Vec<vk::Semaphore>,
    extent: vk::Extent2D,
    format: vk::SurfaceFormatKHR,
    mode: PresentMode,
    requested: PresentMode,
    inner: Arc<Inner>,
}

impl Swapchain {
    /// A swapchain of about `size` pixels (the surface's current extent when
    /// it has one) in `mode`, or FIFO when the surface does not offer `mode`.
    pub fn new(ctx: &GpuContext, size: [u32; 2], mode: PresentMode) -> Result<Swapchain, GpuError> {
        let inner = &ctx.inner;
        if inner.surface.is_none() {
            return Err(GpuError::Presentation {
                what: "the GpuContext was opened without a window surface (use GpuContext::with_surface)".into(),
            });
        }
        let mut sc = Swapchain {
            loader: ash::khr::swapchain::Device::new(&inner.parts.instance, &inner.device),
            handle: vk::SwapchainKHR::null(),
            images: Vec::new(),
            rendered: Vec::new(),
            extent: vk::Extent2D::default(),
            format: vk::SurfaceFormatKHR::default(),
            mode,
            requested: mode,
            inner: inner.clone(),
        };
        sc.recreate(size)?;
        Ok(sc)
    }

    /// Width and height of the images.
    pub fn extent(&self) -> [u32; 2] {
        [self.extent.width, self.extent.height]
    }

    /// The mode in use (FIFO when the requested one is not offered).
    pub fn mode(&self) -> PresentMode {
        self.mode
    }

    /// The mode asked for.
    pub fn requested_mode(&self) -> PresentMode {
        self.requested
    }

    /// The images' format, e.g. `B8G8R8A8_UNORM`.
    pub fn format_name(&self) -> String {
        format!("{:?}", self.format.format)
    }

    /// Rebuilds the swapchain for a window of `size` pixels. Waits for the
    /// device to be idle first: nothing may still use the old images.
    pub fn recreate(&mut self, size: [u32; 2]) -> Result<(), GpuError> {
        let inner = self.inner.clone();
        let surface = inner.surface.as_ref().expect("checked in new");
        let (pd, s) = (inner.physical, surface.handle);
        unsafe { inner.device.device_wait_idle() }.map_err(GpuError::vk("vkDeviceWaitIdle"))?;

        let caps = unsafe { surface.loader.get_physical_device_surface_capabilities(pd, s) }
            .map_err(GpuError::vk("vkGetPhysicalDeviceSurfaceCapabilitiesKHR"))?;
        let formats = unsafe { surface.loader.get_physical_device_surface_formats(pd, s) }
            .map_err(GpuError::vk("vkGetPhysicalDeviceSurfaceFormatsKHR"))?;
        let modes = unsafe { surface.loader.get_physical_device_surface_present_modes(pd, s) }
            .map_err(GpuError::vk("vkGetPhysicalDeviceSurfacePresentModesKHR"))?;

        // The picture's bytes are already sRGB-encoded: a UNORM format shows them as they are.
        let blit_dst = |f: vk::Format| {
            unsafe { inner.parts.instance.get_physical_device_format_properties(pd, f) }
                .optimal_tiling_features
                .contains(vk::FormatFeatureFlags::BLIT_DST)
        };
        let usable: Vec<vk::SurfaceFormatKHR> = formats.iter().copied().filter(|f| blit_dst(f.format)).collect();
        let format = usable
            .iter()
            .find(|f| matches!(f.format, vk::Format::B8G8R8A8_UNORM | vk::Format::R8G8B8A8_UNORM))
            .or_else(|| usable.first())
            .copied()
            .ok_or_else(|| GpuError::Presentation {
                what: format!("none of the surface's formats {formats:?} can be a blit destination"),
            })?;
        if !caps.supported_usage_flags.contains(vk::ImageUsageFlags::TRANSFER_DST) {
            return Err(GpuError::Presentation {
                what: format!(
                    "the surface's images cannot be copy destinations (usage {:?})",
                    caps.supported_usage_flags
                ),
            });
        }
        self.mode = if modes.contains(&self.requested.vk()) { self.requested } else { PresentMode::Fifo };

        // u32::MAX: the surface takes the swapchain's size.
        let extent = if caps.current_extent.width != u32::MAX {
            caps.current_extent
        } else {
            vk::Extent2D {
                width: size[0].clamp(caps.min_image_extent.width, caps.max_image_extent.width),
                height: size[1].clamp(caps.min_image_extent.height, caps.max_image_extent.height),
            }
        };
        let mut count = caps.min_image_count + 1;
        if caps.max_image_count > 0 {
            count = count.min(caps.max_image_count);
        }
        let alpha = [
            vk::CompositeAlphaFlagsKHR::OPAQUE,
            vk::CompositeAlphaFlagsKHR::INHERIT,
            vk::CompositeAlphaFlagsKHR::PRE_MULTIPLIED,
            vk::CompositeAlphaFlagsKHR::POST_MULTIPLIED,
        ]
        .into_iter()
        .find(|a| caps.supported_composite_alpha.contains(*a))
        .unwrap_or(vk::CompositeAlphaFlagsKHR::OPAQUE);
        let info = vk::SwapchainCreateInfoKHR::default()
            .surface(s)
            .min_image_count(count)
            .image_format(format.format)
            .image_color_space(format.color_space)
            .image_extent(extent)
            .image_array_layers(1)
            .image_usage(vk::ImageUsageFlags::TRANSFER_DST)
            .image_sharing_mode(vk::SharingMode::EXCLUSIVE)
            .pre_transform(caps.current_transform)
            .composite_alpha(alpha)
            .present_mode(self.mode.vk())
            .clipped(true)
            .old_swapchain(self.handle);
        let new = unsafe { self.loader.create_swapchain(&info, None) }.map_err(GpuError::vk("vkCreateSwapchainKHR"))?;
        self.destroy();
        self.handle = new;
        self.images =
            unsafe { self.loader.get_swapchain_images(new) }.map_err(GpuError::vk("vkGetSwapchainImagesKHR"))?;
        for _ in 0..self.images.len() {
            let sem = unsafe { inner.device.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
                .map_err(GpuError::vk("vkCreateSemaphore"))?;
            self.rendered.push(sem);
        }
        self.extent = extent;
        self.format = format;
        Ok(())
    }

    /// Destroys the swapchain and its semaphores (the device must be idle).
    fn destroy(&mut self) {
        unsafe {
            for s in self.rendered.drain(..) {
                self.inner.device.destroy_semaphore(s, None);
            }
            self.loader.destroy_swapchain(self.handle, None);
        }
        self.handle = vk::SwapchainKHR::null();
        self.images.clear();
    }

    pub(crate) fn inner(&self) -> &Arc<Inner> {
        &self.inner
    }
}

impl Drop for Swapchain {
    fn drop(&mut self) {
        if !self.inner.may_destroy() {
            return;
        }
        // Presentation may still read the images or wait on the semaphores.
        let _ = unsafe { self.inner.device.device_wait_idle() };
        self.destroy();
    }
}
