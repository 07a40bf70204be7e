//! `StorageImage`: a 2D RGBA8 image a kernel writes with `imageStore` and a
//! `FrameLoop` copies to the swapchain; `DataImage`: an rgba32ui image of
//! data (rows of IMAGE_WIDTH texels) a kernel reads with `imageLoad`;
//! `ImageBinding`: how a kernel declares either. Also the layout barriers
//! and a data image's checks and upload, which one-shot runs use too
//! (dispatch.rs); memory for images comes from memory.rs.

use std::sync::Arc;

use ash::vk;

use super::device::Inner;
use super::memory::{color_range, create_image, data_image_size, destroy_image, RunResources, DATA_FORMAT};
use super::{GpuContext, GpuError, LESS_DATA};
use crate::layout::{ImageFormat, IMAGE_WIDTH};

/// The one storage-image format: `layout(rgba8) uniform image2D` in GLSL.
pub(crate) const FORMAT: vk::Format = vk::Format::R8G8B8A8_UNORM;

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
            &inner.device,
            &inner.memory,
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

/// Records the copy of `image`'s input buffer into it, between the layout
/// changes it needs: UNDEFINED -> TRANSFER_DST_OPTIMAL -> GENERAL, read by
/// the compute shader.
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state.
pub(crate) unsafe fn record_image_upload(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    source: vk::Buffer,
    image: vk::Image,
    texels: u32,
) {
    let [width, height] = data_image_size(u64::from(texels)).map(|n| n as u32);
    let barrier = |old, new, src, dst| [layout_barrier(image, old, new, src, dst)];
    let region = [vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
        )
        .image_extent(vk::Extent3D { width, height, depth: 1 })];
    let to_copy = barrier(
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::AccessFlags::empty(),
        vk::AccessFlags::TRANSFER_WRITE,
    );
    let to_read = barrier(
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::ImageLayout::GENERAL,
        vk::AccessFlags::TRANSFER_WRITE,
        vk::AccessFlags::SHADER_READ,
    );
    let (top, transfer, compute) =
        (vk::PipelineStageFlags::TOP_OF_PIPE, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COMPUTE_SHADER);
    // SAFETY: the caller's; the buffer (filled and unmapped before recording) and the image live as long as the run.
    unsafe {
        d.cmd_pipeline_barrier(cmd, top, transfer, vk::DependencyFlags::empty(), &[], &[], &to_copy);
        d.cmd_copy_buffer_to_image(cmd, source, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &region);
        d.cmd_pipeline_barrier(cmd, transfer, compute, vk::DependencyFlags::empty(), &[], &[], &to_read);
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
            &inner.device,
            &inner.memory,
            DATA_FORMAT,
            data_image_size(u64::from(texels)).map(|n| n as u32),
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
            format!("{what} (a data image of {texels} texels)"),
        )?;
        let made = DataImage { view, image, memory, inner: inner.clone() };
        let staging = super::Buffer::with_data(ctx, bytes, what)?;
        // SAFETY: the staging buffer and the image outlive the wait in submit_once.
        let res = RunResources::new(inner.device.clone());
        let done = inner
            .submit_once(res, |d, cmd, _| unsafe { record_image_upload(d, cmd, staging.buffer, made.image, texels) });
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

impl Inner {
    /// A data image of `len` bytes (a run's rgba32ui input, a
    /// `DataImage`): whole texels, one row of up to IMAGE_WIDTH or whole
    /// rows of IMAGE_WIDTH (layout.h; the shaders address texel t at
    /// (t % IMAGE_WIDTH, t / IMAGE_WIDTH)), within maxImageDimension2D, a
    /// format the device can store. `kernel` and `what` name it in errors.
    pub(crate) fn check_data_image(&self, kernel: &str, what: &str, len: usize) -> Result<(), GpuError> {
        let bad =
            |message: String| GpuError::BadRun { kernel: kernel.to_string(), message: format!("{what}: {message}") };
        let max = u64::from(self.limits.max_image_dimension2_d);
        if len == 0 || !len.is_multiple_of(16) {
            return Err(bad(format!("{len} bytes are not whole 16-byte texels")));
        }
        let texels = (len / 16) as u64;
        let width = u64::from(IMAGE_WIDTH);
        if texels > width && !texels.is_multiple_of(width) {
            return Err(bad(format!("{texels} texels are more than one row and not whole rows of {width}")));
        }
        let [w, rows] = data_image_size(texels);
        if w > max || rows > max {
            return Err(GpuError::TooLarge {
                what: format!("{what} ({rows} rows of {w} texels)"),
                bytes: w.max(rows),
                limit: max,
                limit_name: "maxImageDimension2D (texels)",
                advice: LESS_DATA,
            });
        }
        let features = unsafe { self.parts.instance.get_physical_device_format_properties(self.physical, DATA_FORMAT) }
            .optimal_tiling_features;
        let needed = vk::FormatFeatureFlags::STORAGE_IMAGE | vk::FormatFeatureFlags::TRANSFER_DST;
        if !features.contains(needed) {
            return Err(bad(format!(
                "the device cannot use {DATA_FORMAT:?} as a storage image and copy target ({features:?})"
            )));
        }
        Ok(())
    }
}
