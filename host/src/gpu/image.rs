//! `StorageImage`: a 2D RGBA8 image a kernel writes with `imageStore` and a
//! `FrameLoop` copies to the swapchain; `DataImage`: a one-row rgba32ui
//! image of data a kernel reads with `imageLoad`; `ImageBinding`: how a
//! kernel declares either.

use std::sync::Arc;

use ash::vk;

use super::context::Inner;
use super::{GpuContext, GpuError};

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
    /// Data, 16 bytes a texel, one row (`GpuContext::run_passes` makes it
    /// from an input's bytes): `layout(rgba32ui) readonly uniform uimage2D`.
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
        let d = &inner.device;
        let features = unsafe {
            inner.parts.instance.get_physical_device_format_properties(inner.physical, FORMAT)
        }
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
            });
        }
        let mut img = StorageImage {
            image: vk::Image::null(),
            view: vk::ImageView::null(),
            layout: std::cell::Cell::new(vk::ImageLayout::UNDEFINED),
            memory: vk::DeviceMemory::null(),
            width,
            height,
            inner: inner.clone(),
        };
        // From here on, dropping `img` destroys whatever was created.
        let info = vk::ImageCreateInfo::default()
            .image_type(vk::ImageType::TYPE_2D)
            .format(FORMAT)
            .extent(vk::Extent3D { width, height, depth: 1 })
            .mip_levels(1)
            .array_layers(1)
            .samples(vk::SampleCountFlags::TYPE_1)
            .tiling(vk::ImageTiling::OPTIMAL)
            .usage(vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_SRC)
            .sharing_mode(vk::SharingMode::EXCLUSIVE)
            .initial_layout(vk::ImageLayout::UNDEFINED);
        img.image = unsafe { d.create_image(&info, None) }.map_err(GpuError::vk("vkCreateImage"))?;
        let req = unsafe { d.get_image_memory_requirements(img.image) };
        // Device-local first, then any type the image accepts.
        let types = &inner.memory.memory_types[..inner.memory.memory_type_count as usize];
        let mut candidates: Vec<u32> =
            (0..types.len() as u32).filter(|i| req.memory_type_bits & (1 << i) != 0).collect();
        candidates.sort_by_key(|&i| {
            !types[i as usize].property_flags.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
        });
        let mut last = vk::Result::ERROR_OUT_OF_DEVICE_MEMORY;
        for type_index in candidates {
            let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(type_index);
            match unsafe { d.allocate_memory(&alloc, None) } {
                Ok(m) => {
                    img.memory = m;
                    break;
                }
                Err(e @ (vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY)) => last = e,
                Err(e) => return Err(GpuError::vk("vkAllocateMemory")(e)),
            }
        }
        if img.memory == vk::DeviceMemory::null() {
            return Err(GpuError::OutOfMemory {
                what: format!("a {width}x{height} storage image"),
                bytes: req.size,
                detail: format!("vkAllocateMemory failed with {last:?} for every memory type"),
            });
        }
        unsafe { d.bind_image_memory(img.image, img.memory, 0) }.map_err(GpuError::vk("vkBindImageMemory"))?;
        let view = vk::ImageViewCreateInfo::default()
            .image(img.image)
            .view_type(vk::ImageViewType::TYPE_2D)
            .format(FORMAT)
            .subresource_range(color_range());
        img.view = unsafe { d.create_image_view(&view, None) }.map_err(GpuError::vk("vkCreateImageView"))?;
        Ok(img)
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

/// The one mip level and layer of a colour image.
pub(crate) fn color_range() -> vk::ImageSubresourceRange {
    vk::ImageSubresourceRange::default()
        .aspect_mask(vk::ImageAspectFlags::COLOR)
        .base_mip_level(0)
        .level_count(1)
        .base_array_layer(0)
        .layer_count(1)
}

impl Drop for StorageImage {
    fn drop(&mut self) {
        let d = &self.inner.device;
        // Null handles (a failed `new`) are no-ops.
        unsafe {
            d.destroy_image_view(self.view, None);
            d.destroy_image(self.image, None);
            d.free_memory(self.memory, None);
        }
    }
}

/// A device-local rgba32ui image of one row holding data for a kernel that
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
    /// An image of `bytes` (whole 16-byte texels, one texel a pixel of its
    /// one row); `what` names it in errors.
    pub fn new(ctx: &GpuContext, bytes: &[u8], what: &str) -> Result<DataImage, GpuError> {
        let inner = &ctx.inner;
        inner.check_data_image("(data image)", what, bytes.len())?;
        let texels = (bytes.len() / 16) as u32;
        let (image, memory, view) = inner.create_owned_data_image(texels, what)?;
        let made = DataImage { view, image, memory, inner: inner.clone() };
        let staging = super::Buffer::with_data(ctx, bytes, what)?;
        // SAFETY: the staging buffer and the image outlive the wait in submit_once.
        inner.submit_once(|d, cmd| unsafe {
            super::context::record_image_upload(d, cmd, staging.buffer, made.image, texels)
        })?;
        Ok(made)
    }

    pub(crate) fn inner(&self) -> &Arc<Inner> {
        &self.inner
    }
}

impl Drop for DataImage {
    fn drop(&mut self) {
        let d = &self.inner.device;
        unsafe {
            d.destroy_image_view(self.view, None);
            d.destroy_image(self.image, None);
            d.free_memory(self.memory, None);
        }
    }
}
