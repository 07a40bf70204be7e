//! Device memory: memory types chosen for buffers and images, allocation
//! with fallback to the next type, and `RunResources`, the objects of one
//! run. Works on the `ash::Device` and its memory properties alone, below
//! the context that owns them.

use ash::vk;

use super::GpuError;
use crate::layout::IMAGE_WIDTH;

/// Storage buffers cannot be empty; zero-length inputs get this many bytes.
const MIN_BUFFER: u64 = 16;

/// Who touches a buffer's memory (`create_buffer`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Place {
    /// The host writes it, the device reads it.
    Upload,
    /// The device writes it, the host reads it.
    Readback,
    /// Only the device.
    Device,
}

/// A storage buffer's size for `len` bytes: not empty, whole words.
pub(crate) fn buffer_size(len: usize) -> u64 {
    (len as u64).max(MIN_BUFFER).next_multiple_of(4)
}

/// A storage buffer in memory for `place`: host-visible and
/// host-coherent for `Place::Upload` and `Place::Readback`, any for
/// `Place::Device`. Memory types are tried best first (device-local;
/// host-cached for readback), falling back to the next when an
/// allocation fails.
pub(crate) fn create_buffer(
    d: &ash::Device,
    properties: &vk::PhysicalDeviceMemoryProperties,
    res: &mut RunResources,
    size: u64,
    place: Place,
    what: &str,
) -> Result<(vk::Buffer, vk::DeviceMemory), GpuError> {
    let info = vk::BufferCreateInfo::default()
        .size(size)
        .usage(
            vk::BufferUsageFlags::STORAGE_BUFFER
                | vk::BufferUsageFlags::UNIFORM_BUFFER
                | vk::BufferUsageFlags::TRANSFER_SRC
                | vk::BufferUsageFlags::TRANSFER_DST,
        )
        .sharing_mode(vk::SharingMode::EXCLUSIVE);
    let buffer = unsafe { d.create_buffer(&info, None) }.map_err(GpuError::vk("vkCreateBuffer"))?;
    res.buffers.push((buffer, vk::DeviceMemory::null()));
    let req = unsafe { d.get_buffer_memory_requirements(buffer) };

    let needed = match place {
        Place::Device => vk::MemoryPropertyFlags::empty(),
        Place::Upload | Place::Readback => {
            vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT
        }
    };
    let types = &properties.memory_types[..properties.memory_type_count as usize];
    let mut candidates: Vec<(u32, u32)> = types
        .iter()
        .enumerate()
        .filter(|(i, t)| {
            req.memory_type_bits & (1 << i) != 0
                && t.property_flags.contains(needed)
                && properties.memory_heaps[t.heap_index as usize].size >= req.size
        })
        .map(|(i, t)| {
            let f = t.property_flags;
            let local = f.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL) as u32;
            let cached = f.contains(vk::MemoryPropertyFlags::HOST_CACHED) as u32;
            let score = if place == Place::Readback { cached * 2 + local } else { local * 2 };
            (i as u32, score)
        })
        .collect();
    candidates.sort_by_key(|(_, score)| std::cmp::Reverse(*score)); // stable: type order within a score
    let mut last = vk::Result::ERROR_OUT_OF_DEVICE_MEMORY;
    for (type_index, _) in &candidates {
        let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(*type_index);
        match unsafe { d.allocate_memory(&alloc, None) } {
            Ok(memory) => {
                res.buffers.last_mut().expect("pushed above").1 = memory;
                unsafe { d.bind_buffer_memory(buffer, memory, 0) }.map_err(GpuError::vk("vkBindBufferMemory"))?;
                return Ok((buffer, memory));
            }
            Err(e @ (vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY)) => last = e,
            Err(e) => return Err(GpuError::vk("vkAllocateMemory")(e)),
        }
    }
    let kind = if place == Place::Device { "" } else { "host-visible, host-coherent " };
    let detail = if candidates.is_empty() {
        format!("no {kind}memory type is large enough")
    } else {
        format!("vkAllocateMemory failed with {last:?} for every {kind}memory type")
    };
    Err(GpuError::OutOfMemory { what: what.to_string(), bytes: req.size, detail })
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
    d: &ash::Device,
    properties: &vk::PhysicalDeviceMemoryProperties,
    format: vk::Format,
    size: [u32; 2],
    usage: vk::ImageUsageFlags,
    what: String,
) -> Result<(vk::Image, vk::DeviceMemory, vk::ImageView), GpuError> {
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
        let types = &properties.memory_types[..properties.memory_type_count as usize];
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

/// The format of a run's data images (`ImageFormat::Rgba32Uint`).
pub(crate) const DATA_FORMAT: vk::Format = vk::Format::R32G32B32A32_UINT;

/// The width and rows of a data image of `texels` (`Inner::check_data_image`).
pub(crate) fn data_image_size(texels: u64) -> [u64; 2] {
    let width = u64::from(IMAGE_WIDTH);
    if texels <= width {
        [texels, 1]
    } else {
        [width, texels.div_ceil(width)]
    }
}

/// A run's read-only data image, filled from its input buffer `source`.
pub(crate) struct RunImage {
    /// Copy `source` into the image when the run starts: its bytes are
    /// new (a kept run whose input is unchanged leaves it as it was).
    pub(crate) upload: bool,
    pub(crate) binding: u32,
    pub(crate) source: vk::Buffer,
    pub(crate) texels: u32,
    pub(crate) image: vk::Image,
    pub(crate) view: vk::ImageView,
    pub(crate) memory: vk::DeviceMemory,
}

/// A finished run's resources, kept for the next run (`Inner::kept`):
/// scene buffers stay on the device across frames, and a frame allocates
/// nothing. The next run takes them when it has the same kernel and the
/// same bindings at the same lengths; of its inputs it writes only those
/// whose bytes changed (by `dispatch::input_hash`), and copies only their data
/// images again. The cleared buffers and the output are filled again
/// before every run's first pass, as for new ones.
pub(crate) struct KeptRun {
    /// The kernel's `Kernel::id`.
    pub(crate) kernel: u64,
    /// Every binding's length (`RunBuffers::lengths`).
    pub(crate) lengths: Vec<(u32, usize)>,
    /// Each input's hash (`dispatch::input_hash`), in the run's order.
    pub(crate) inputs: Vec<u64>,
    pub(crate) res: RunResources,
    pub(crate) set: vk::DescriptorSet,
}

/// The Vulkan objects of one run, destroyed on drop (also on every error path).
pub(crate) struct RunResources {
    device: ash::Device,
    pub(crate) buffers: Vec<(vk::Buffer, vk::DeviceMemory)>,
    pub(crate) bindings: Vec<(u32, vk::Buffer)>,
    /// Buffers the device fills before the first pass, and each one's word.
    pub(crate) fills: Vec<(vk::Buffer, u32)>,
    /// The memory of the buffer read back.
    pub(crate) output: vk::DeviceMemory,
    /// Where the kernel's output is device-local (`Inner::output_copy`):
    /// it, the host-visible buffer it is copied to after the last pass,
    /// and the bytes copied.
    pub(crate) output_copy: Option<(vk::Buffer, vk::Buffer, u64)>,
    pub(crate) images: Vec<RunImage>,
    pub(crate) descriptor_pool: vk::DescriptorPool,
    pub(crate) command_pool: vk::CommandPool,
    pub(crate) fence: vk::Fence,
    /// The run's timestamps (`dispatch::RUN_QUERIES`); null where the queue has none.
    pub(crate) queries: vk::QueryPool,
}

impl RunResources {
    pub(crate) fn new(device: ash::Device) -> Self {
        RunResources {
            device,
            buffers: Vec::new(),
            bindings: Vec::new(),
            fills: Vec::new(),
            output: vk::DeviceMemory::null(),
            output_copy: None,
            images: Vec::new(),
            descriptor_pool: vk::DescriptorPool::null(),
            command_pool: vk::CommandPool::null(),
            fence: vk::Fence::null(),
            queries: vk::QueryPool::null(),
        }
    }
}

impl Drop for RunResources {
    fn drop(&mut self) {
        let d = &self.device;
        // Destroying a null handle is a no-op in Vulkan.
        unsafe {
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.command_pool, None);
            d.destroy_descriptor_pool(self.descriptor_pool, None);
            d.destroy_query_pool(self.queries, None);
            for image in self.images.drain(..) {
                destroy_image(d, (image.image, image.memory, image.view));
            }
            for (buffer, memory) in self.buffers.drain(..) {
                d.destroy_buffer(buffer, None);
                d.free_memory(memory, None);
            }
        }
    }
}
