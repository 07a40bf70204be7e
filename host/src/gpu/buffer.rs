//! Persistent resources for kernels that run many times (the preview):
//! `Buffer`, a host-visible storage buffer that stays mapped, and
//! `DescriptorSet`, a kernel's set 0 bound to buffers and storage images.
//! One-shot work uses `GpuContext::run` instead.

use std::sync::Arc;

use ash::vk;

use super::device::Inner;
use super::memory::{buffer_size, create_buffer, Place, RunResources};
use super::{DataImage, GpuContext, GpuError, ImageFormat, Kernel, StorageImage};

/// A storage buffer in host-visible, host-coherent memory, mapped for its
/// whole life. Reads and writes are plain copies: the caller makes sure the
/// device is not using it (`FrameLoop::wait`).
pub struct Buffer {
    pub(crate) buffer: vk::Buffer,
    memory: vk::DeviceMemory,
    mapped: *mut u8,
    /// Bytes the caller asked for (the buffer may be larger).
    len: usize,
    what: String,
    inner: Arc<Inner>,
}

impl Buffer {
    /// A buffer of at least `len` bytes, every byte zero. `readback` prefers
    /// host-cached memory (for buffers the host reads); `what` names it in errors.
    pub fn new(ctx: &GpuContext, len: usize, readback: bool, what: &str) -> Result<Buffer, GpuError> {
        let size = buffer_size(len);
        let (buffer, memory) = ctx.inner.create_owned_buffer(size, readback, what)?;
        let mut b = Buffer {
            buffer,
            memory,
            mapped: std::ptr::null_mut(),
            len,
            what: what.to_string(),
            inner: ctx.inner.clone(),
        };
        let ptr = unsafe { ctx.inner.device.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
            .map_err(GpuError::vk("vkMapMemory"))?;
        b.mapped = ptr as *mut u8;
        // SAFETY: the mapping covers the whole allocation, at least `size` bytes.
        unsafe { std::ptr::write_bytes(b.mapped, 0, size as usize) };
        Ok(b)
    }

    /// A buffer holding `bytes`.
    pub fn with_data(ctx: &GpuContext, bytes: &[u8], what: &str) -> Result<Buffer, GpuError> {
        let b = Buffer::new(ctx, bytes.len(), false, what)?;
        b.write(0, bytes);
        Ok(b)
    }

    /// The length asked for at creation.
    pub fn len(&self) -> usize {
        self.len
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Copies `bytes` to `offset`. Panics when they do not fit.
    pub fn write(&self, offset: usize, bytes: &[u8]) {
        assert!(
            offset + bytes.len() <= self.len,
            "{}: write of {} bytes at {offset} past its end",
            self.what,
            bytes.len()
        );
        // SAFETY: in bounds of the mapping (checked above); host-coherent memory.
        unsafe { std::ptr::copy_nonoverlapping(bytes.as_ptr(), self.mapped.add(offset), bytes.len()) };
    }

    /// Copies `len` bytes from `offset`. Panics when they are out of range.
    pub fn read(&self, offset: usize, len: usize) -> Vec<u8> {
        assert!(offset + len <= self.len, "{}: read of {len} bytes at {offset} past its end", self.what);
        let mut out = vec![0u8; len];
        // SAFETY: in bounds of the mapping (checked above).
        unsafe { std::ptr::copy_nonoverlapping(self.mapped.add(offset), out.as_mut_ptr(), len) };
        out
    }

    /// The `len` bytes from `offset`, in place in the mapping: copied from
    /// there to another mapping (`write`), they cross once (66 MB of pixels
    /// a frame cost 32 ms on lavapipe through `read`'s fresh pages). The
    /// caller makes sure the device does not write them while they are
    /// borrowed. Panics when they are out of range.
    pub fn bytes(&self, offset: usize, len: usize) -> &[u8] {
        assert!(offset + len <= self.len, "{}: read of {len} bytes at {offset} past its end", self.what);
        // SAFETY: in bounds of the mapping (checked above), which lives as
        // long as `self`; host-coherent memory the device does not write
        // while borrowed (the caller's waits).
        unsafe { std::slice::from_raw_parts(self.mapped.add(offset), len) }
    }
}

impl Drop for Buffer {
    fn drop(&mut self) {
        if !self.inner.may_destroy() {
            return;
        }
        let d = &self.inner.device;
        unsafe {
            if !self.mapped.is_null() {
                d.unmap_memory(self.memory);
            }
            d.destroy_buffer(self.buffer, None);
            d.free_memory(self.memory, None);
        }
    }
}

/// What a binding of a `DescriptorSet` is bound to.
#[derive(Clone, Copy)]
pub enum Resource<'a> {
    Buffer(&'a Buffer),
    /// A picture (an `ImageFormat::Rgba8` binding).
    Image(&'a StorageImage),
    /// Data (an `ImageFormat::Rgba32Uint` binding).
    Data(&'a DataImage),
}

impl Resource<'_> {
    /// An image's view (null for a buffer).
    fn image_view(&self) -> vk::ImageView {
        match self {
            Resource::Buffer(_) => vk::ImageView::null(),
            Resource::Image(i) => i.view,
            Resource::Data(i) => i.view,
        }
    }
}

/// A kernel's descriptor set 0 with every binding bound. Rebuild it when a
/// resource is replaced (and only while no frame that uses it is in flight).
pub struct DescriptorSet {
    pool: vk::DescriptorPool,
    pub(crate) set: vk::DescriptorSet,
    /// The kernel's pipeline layout it was made for, checked at dispatch.
    pub(crate) set_layout: vk::DescriptorSetLayout,
    inner: Arc<Inner>,
}

impl DescriptorSet {
    /// Binds each of the kernel's bindings (storage buffers and storage
    /// images) to a resource; every binding must be given exactly once, with
    /// the kind the kernel declares.
    pub fn new(kernel: &Kernel, resources: &[(u32, Resource<'_>)]) -> Result<DescriptorSet, GpuError> {
        let bad = |message: String| GpuError::BadRun { kernel: kernel.name().to_string(), message };
        let inner = &kernel.inner;
        if let Some((given, wanted)) = kernel.binding_mismatch(resources.iter().map(|(b, _)| *b)) {
            return Err(bad(format!(
                "the descriptor set was given bindings {given:?}, the kernel declares {wanted:?}; \
                 pass each binding exactly once"
            )));
        }
        for (binding, resource) in resources {
            let image = kernel.images().iter().find(|i| i.binding == *binding).map(|i| i.format);
            let same_device = match resource {
                Resource::Buffer(b) => Arc::ptr_eq(&b.inner, inner),
                Resource::Image(i) => Arc::ptr_eq(i.inner(), inner),
                Resource::Data(i) => Arc::ptr_eq(i.inner(), inner),
            };
            if !same_device {
                return Err(bad(format!("binding {binding}: the resource was created on another GpuContext")));
            }
            match (resource, image) {
                (Resource::Image(_) | Resource::Data(_), None) => {
                    return Err(bad(format!("{} is a storage buffer, not an image", kernel.binding_label(*binding))))
                }
                (Resource::Buffer(_), Some(_)) => {
                    return Err(bad(format!("binding {binding} is a storage image, not a buffer")))
                }
                (Resource::Image(_), Some(ImageFormat::Rgba32Uint)) => {
                    return Err(bad(format!("binding {binding} is a data image (rgba32ui), not a picture")))
                }
                (Resource::Data(_), Some(ImageFormat::Rgba8)) => {
                    return Err(bad(format!("binding {binding} is a picture (rgba8), not a data image")))
                }
                _ => {}
            }
        }

        let descriptor_type = |binding: u32, r: &Resource<'_>| match r {
            Resource::Buffer(_) => kernel.descriptor_type(binding),
            Resource::Image(_) | Resource::Data(_) => vk::DescriptorType::STORAGE_IMAGE,
        };
        let mut sizes: Vec<vk::DescriptorPoolSize> = Vec::new();
        for (binding, r) in resources {
            let ty = descriptor_type(*binding, r);
            match sizes.iter_mut().find(|s| s.ty == ty) {
                Some(s) => s.descriptor_count += 1,
                None => sizes.push(vk::DescriptorPoolSize::default().ty(ty).descriptor_count(1)),
            }
        }
        let d = &inner.device;
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        let pool =
            unsafe { d.create_descriptor_pool(&pool_info, None) }.map_err(GpuError::vk("vkCreateDescriptorPool"))?;
        let mut out =
            DescriptorSet { pool, set: vk::DescriptorSet::null(), set_layout: kernel.set_layout, inner: inner.clone() };
        let set_layouts = [kernel.set_layout];
        let alloc = vk::DescriptorSetAllocateInfo::default().descriptor_pool(pool).set_layouts(&set_layouts);
        out.set = unsafe { d.allocate_descriptor_sets(&alloc) }.map_err(GpuError::vk("vkAllocateDescriptorSets"))?[0];

        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = resources
            .iter()
            .map(|(_, r)| match r {
                Resource::Buffer(b) => {
                    [vk::DescriptorBufferInfo::default().buffer(b.buffer).offset(0).range(vk::WHOLE_SIZE)]
                }
                Resource::Image(_) | Resource::Data(_) => [vk::DescriptorBufferInfo::default()],
            })
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = resources
            .iter()
            .map(|(_, r)| match r {
                Resource::Buffer(_) => [vk::DescriptorImageInfo::default()],
                Resource::Image(_) | Resource::Data(_) => [vk::DescriptorImageInfo::default()
                    .image_view(r.image_view())
                    .image_layout(vk::ImageLayout::GENERAL)],
            })
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = resources
            .iter()
            .enumerate()
            .map(|(k, (binding, r))| {
                let w = vk::WriteDescriptorSet::default().dst_set(out.set).dst_binding(*binding);
                let w = w.descriptor_type(descriptor_type(*binding, r));
                match r {
                    Resource::Buffer(_) => w.buffer_info(&buffer_infos[k]),
                    Resource::Image(_) | Resource::Data(_) => w.image_info(&image_infos[k]),
                }
            })
            .collect();
        unsafe { d.update_descriptor_sets(&writes, &[]) };
        Ok(out)
    }
}

impl Drop for DescriptorSet {
    fn drop(&mut self) {
        if !self.inner.may_destroy() {
            return;
        }
        // Destroying the pool frees its set.
        unsafe { self.inner.device.destroy_descriptor_pool(self.pool, None) };
    }
}

impl Inner {
    /// One storage buffer as `create_buffer` makes it, owned by the caller
    /// (destroy and free it); `size` is checked against the device limits.
    pub(crate) fn create_owned_buffer(
        &self,
        size: u64,
        readback: bool,
        what: &str,
    ) -> Result<(vk::Buffer, vk::DeviceMemory), GpuError> {
        self.check_storage_size(size, || what.to_string())?;
        let mut res = RunResources::new(self.device.clone());
        let made = create_buffer(
            &self.device,
            &self.memory,
            &mut res,
            size,
            if readback { Place::Readback } else { Place::Upload },
            what,
        )?;
        // Hand it over: `res` must not destroy it.
        res.buffers.clear();
        Ok(made)
    }
}
