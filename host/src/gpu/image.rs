//! `StorageImage`: a 2D RGBA8 image a kernel writes with `imageStore` and a
//! `FrameLoop` copies to the swapchain; `DataImage`: an rgba32ui image of
//! data (rows of IMAGE_WIDTH texels) a kernel reads with `imageLoad`;
//! `ImageBinding`: how a kernel declares either.

use std::sync::Arc;

use ash::vk;

use super::context::Inner;
use super::{GpuContext, GpuError, LESS_DATA};

/// The one storage-image format: `layout(rgba8) uniform image2D` in GLSL.
pub(crate) const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

/// A storage image binding of a kernel (descriptor set 0): a 2D
/// `layout(rgba8) uniform image2D` or `layout(rgba32ui) uniform uimage2D`,
/// checked by naga's reflection like the storage buffers
/// (`Kernel::with_images`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageBinding {
    pub binding: u32,
    /// True when the kernel writes it (not `readonly`).
    pub writable: bool,
    pub format: ImageFormat,
}

/// What a storage image holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// A picture (`StorageImage`): `layout(rgba8) uniform image2D`.
    Rgba8,
    /// Data, 16 bytes a texel, in rows of IMAGE_WIDTH (`DataImage`, or
    /// `GpuContext::run_passes` from an input's bytes):
    /// `layout(rgba32ui) readonly uniform uimage2D`.
    Rgba32Uint,
}

impl ImageFormat {
    pub(crate) fn naga(self) -> naga::StorageFormat {
        match self {
            ImageFormat::Rgba8 => naga::StorageFormat::Rgba8Unorm,
            ImageFormat::Rgba32Uint => naga::StorageFormat::Rgba32Uint,
        }
    }

    /// How the shader declares it.
    pub(crate) fn glsl(self) -> &'static str {
        match self {
            ImageFormat::Rgba8 => "layout(rgba8) uniform image2D",
            ImageFormat::Rgba32Uint => "layout(rgba32ui) uniform uimage2D",
        }
    }
}

/// A device-local RGBA8 image with a view. A `FrameLoop` moves it to GENERAL
/// for each dispatch and to TRANSFER_SRC_OPTIMAL for the blit.
pub struct StorageImage {
    pub(crate) image: vk::Image,
    pub(crate) view: vk::ImageView,
    /// Its layout when the last recorded frame ends (FrameLoop::submit):
    /// UNDEFINED until the first, then GENERAL or TRANSFER_SRC_OPTIMAL.
    pub(crate) layout: std::cell::Cell<vk::ImageLayout>,
    memory: vk::DeviceMemory,
    width: u32,
    height: u32,
    inner: Arc<Inner>,
}

impl StorageImage {
    pub fn new(ctx: &GpuContext, width: u32, height: u32) -> Result<StorageImage, GpuError> {
        let inner = &ctx.inner;
        let features = unsafe { inner.parts.instance.get_physical_device_format_properties(inner.physical, FORMAT) }
            .optimal_tiling_features;
        let needed = vk::FormatFeatureFlags::STORAGE_IMAGE | vk::FormatFeatureFlags::BLIT_SRC;
        if !features.contains(needed) {
            return Err(GpuError::Presentation {
                what: format!("the device cannot use {FORMAT:?} as a storage image and blit source ({features:?})"),
            });
        }
        let max = inner.limits.max_image_dimension2_d;
        if width == 0 || height == 0 || width > max || height > max {
            return Err(GpuError::TooLarge {
                what: format!("a {width}x{height} storage image"),
                bytes: u64::from(width.max(height)),
                limit: u64::from(max),
                limit_name: "maxImageDimension2D (pixels)",
                advice: LESS_DATA,
            });
        }
        let (image, memory, view) = create_image(
            inner,
            FORMAT,
            [width, height],
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC,
            format!("a {width}x{height} storage image"),
        )?;
        Ok(StorageImage {
            image,
            view,
            layout: std::cell::Cell::new(vk::ImageLayout::UNDEFINED),
            memory,
            width,
            height,
            inner: inner.clone(),
        })
    }

    pub fn width(&self) -> u32 {
        self.width
    }

    pub fn height(&self) -> u32 {
        self.height
    }

    pub(crate) fn inner(&self) -> &Arc<Inner> {
        &self.inner
    }
}

/// The barrier that moves colour image `image` (`color_range`) from layout
/// `old` to `new`, after accesses `src` and before accesses `dst`, on one
/// queue family.
pub(crate) fn layout_barrier(
    image: vk::Image,
    old: vk::ImageLayout,
    new: vk::ImageLayout,
    src: vk::AccessFlags,
    dst: vk::AccessFlags,
) -> vk::ImageMemoryBarrier<'static> {
    vk::ImageMemoryBarrier::default()
        .old_layout(old)
        .new_layout(new)
        .src_access_mask(src)
        .dst_access_mask(dst)
        .src_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .dst_queue_family_index(vk::QUEUE_FAMILY_IGNORED)
        .image(image)
        .subresource_range(color_range())
}

/// The one mip level and layer of a colour image.
pub(crate) fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .base_mip_level(0)
        .level_count(1)
        .base_array_layer(0)
        .layer_count(1)
}

/// A 2D `format` image of `size`, optimal tiling, in memory of its own
/// (device-local first), and a view of it; on an error, whatever was made
/// is destroyed. `what` names it in errors.
pub(crate) fn create_image(
    inner: &Inner,
    format: vk::Format,
    size: [u32; 2],
    usage: vk::ImageUsageFlags,
    what: String,
) -> Result<(vk::Image, vk::DeviceMemory, vk::ImageView), GpuError> {
    let d = &inner.device;
    let mut made = (vk::Image::null(), vk::DeviceMemory::null(), vk::ImageView::null());
    let result = (|| {
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(format)
            .extent(vk::Extent3D { width: size[0], height: size[1], depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(usage)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        made.0 = unsafe { d.create_image(&info, None) }.map_err(GpuError::vk("vkCreateImage"))?;
        let req = unsafe { d.get_image_memory_requirements(made.0) };
        let types = &inner.memory.memory_types[..inner.memory.memory_type_count as usize];
        let mut candidates: Vec<u32> =
            (0..types.len() as u32).filter(|i| req.memory_type_bits & (1 << i) != 0).collect();
        candidates.sort_by_key(|&i| !types[i as usize].property_flags.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL));
        let mut last = vk::Result::ERROR_OUT_OF_DEVICE_MEMORY;
        for type_index in candidates {
            let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(type_index);
            match unsafe { d.allocate_memory(&alloc, None) } {
                Ok(m) => {
                    made.1 = m;
                    break;
                }
                Err(e @ (vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY)) => last = e,
                Err(e) => return Err(GpuError::vk("vkAllocateMemory")(e)),
            }
        }
        if made.1 == vk::DeviceMemory::null() {
            return Err(GpuError::OutOfMemory {
                what: what.clone(),
                bytes: req.size,
                detail: format!("vkAllocateMemory failed with {last:?} for every memory type"),
            });
        }
        unsafe { d.bind_image_memory(made.0, made.1, 0) }.map_err(GpuError::vk("vkBindImageMemory"))?;
        let view = vk::ImageViewCreateInfo::default()
            .image(made.0)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(format)
            .subresource_range(color_range());
        made.2 = unsafe { d.create_image_view(&view, None) }.map_err(GpuError::vk("vkCreateImageView"))?;
        Ok(())
    })();
    match result {
        Ok(()) => Ok(made),
        Err(e) => {
            // SAFETY: nothing uses them yet.
            unsafe { destroy_image(d, made) };
            Err(e)
        }
    }
}

/// Destroys what `create_image` made (null handles are no-ops).
///
/// # Safety
/// The device no longer uses them.
pub(crate) unsafe fn destroy_image(
    d: &ash::Device,
    (image, memory, view): (vk::Image, vk::DeviceMemory, vk::ImageView),
) {
    // SAFETY: the caller's.
    unsafe {
        d.destroy_image_view(view, None);
        d.destroy_image(image, None);
        d.free_memory(memory, None);
    }
}

impl Drop for StorageImage {
    fn drop(&mut self) {
        if !self.inner.may_destroy() {
            return;
        }
        // SAFETY: dropped when no frame in flight uses it (FrameLoop waits).
        unsafe { destroy_image(&self.inner.device, (self.image, self.memory, self.view)) };
    }
}

/// A device-local rgba32ui image (rows of IMAGE_WIDTH texels) holding data for a kernel that
/// runs many times (the preview's scene arrays; one-shot runs make their
/// own from their inputs, `GpuContext::run_passes`). Filled at creation
/// and left in GENERAL, read-only.
pub struct DataImage {
    pub(crate) view: vk::ImageView,
    image: vk::Image,
    memory: vk::DeviceMemory,
    inner: Arc<Inner>,
}

impl DataImage {
    /// An image of `bytes`: whole 16-byte texels, one row of up to
    /// IMAGE_WIDTH (layout.h) or whole rows of it; `what` names it in errors.
    pub fn new(ctx: &GpuContext, bytes: &[u8], what: &str) -> Result<DataImage, GpuError> {
        let inner = &ctx.inner;
        inner.check_data_image("(data image)", what, bytes.len())?;
        let texels = (bytes.len() / 16) as u32;
        let (image, memory, view) = create_image(
            inner,
            super::context::DATA_FORMAT,
            super::context::data_image_size(u64::from(texels)).map(|n| n as u32),
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
            format!("{what} (a data image of {texels} texels)"),
        )?;
        let made = DataImage { view, image, memory, inner: inner.clone() };
        let staging = super::Buffer::with_data(ctx, bytes, what)?;
        // SAFETY: the staging buffer and the image outlive the wait in submit_once.
        let res = super::context::RunResources::new(inner.device.clone());
        let done = inner.submit_once(res, |d, cmd, _| unsafe {
            super::context::record_image_upload(d, cmd, staging.buffer, made.image, texels)
        });
        if let Err(e @ GpuError::Timeout { .. }) = done {
            // The device may still copy: neither may go before the context does.
            std::mem::forget(staging);
            std::mem::forget(made);
            return Err(e);
        }
        done?;
        Ok(made)
    }

    pub(crate) fn inner(&self) -> &Arc<Inner> {
        &self.inner
    }
}

impl Drop for DataImage {
    fn drop(&mut self) {
        if !self.inner.may_destroy() {
            return;
        }
        // SAFETY: dropped when no frame in flight uses it (FrameLoop waits).
        unsafe { destroy_image(&self.inner.device, (self.image, self.memory, self.view)) };
    }
}
