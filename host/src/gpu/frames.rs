//! `FrameLoop`: one kernel dispatch per frame, its storage image blitted to a
//! swapchain image and presented. One frame is in flight at a time: the
//! host waits for it (`wait`) before it reads results or writes inputs.
//!
//! Each frame's commands:
//! ```text
//!   barrier: last frame's shader writes -> this dispatch's reads and writes,
//!            image UNDEFINED -> GENERAL (every pixel is written again)
//!   timestamp, dispatch, timestamp
//!   barrier: shader writes -> host reads (buffers), image GENERAL -> TRANSFER_SRC
//!   swapchain image UNDEFINED -> TRANSFER_DST, blit, -> PRESENT_SRC
//! ```
//! The submit waits on the acquire semaphore at the transfer stage and
//! signals the image's `rendered` semaphore, which the present waits on.

use std::sync::Arc;
use std::time::Duration;

use ash::vk;

use super::device::Inner;
use super::image::layout_barrier;
use super::{DescriptorSet, GpuContext, GpuError, Kernel, StorageImage, Swapchain};

/// What became of a frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FrameStatus {
    /// Dispatched, and presented when a swapchain was given.
    Done,
    /// Dispatched and presented, but the swapchain no longer matches the
    /// window: recreate it before the next frame.
    Suboptimal,
    /// The swapchain is out of date; nothing was submitted: recreate it and
    /// submit again.
    OutOfDate,
}

/// Command buffer, fence, acquire semaphore and timestamp queries for a frame at a time.
pub struct FrameLoop {
    pool: vk::CommandPool,
    cmd: vk::CommandBuffer,
    fence: vk::Fence,
    acquired: vk::Semaphore,
    /// Two timestamps around the dispatch; None when the queue has no timestamps.
    queries: Option<vk::QueryPool>,
    /// A submitted frame the host has not waited for yet.
    pending: bool,
    /// Whether the pending frame wrote its timestamps.
    timed: bool,
    inner: Arc<Inner>,
}

impl FrameLoop {
    pub fn new(ctx: &GpuContext) -> Result<FrameLoop, GpuError> {
        let inner = &ctx.inner;
        let d = &inner.device;
        let mut f = FrameLoop {
            pool: vk::CommandPool::null(),
            cmd: vk::CommandBuffer::null(),
            fence: vk::Fence::null(),
            acquired: vk::Semaphore::null(),
            queries: None,
            pending: false,
            timed: false,
            inner: inner.clone(),
        };
        (f.pool, f.cmd) = inner.command_buffer(vk::CommandPoolCreateFlags::RESET_COMMAND_BUFFER)?;
        f.fence =
            unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(GpuError::vk("vkCreateFence"))?;
        f.acquired = unsafe { d.create_semaphore(&vk::SemaphoreCreateInfo::default(), None) }
            .map_err(GpuError::vk("vkCreateSemaphore"))?;
        let families = unsafe { inner.parts.instance.get_physical_device_queue_family_properties(inner.physical) };
        let valid_bits = families.get(inner.queue_family as usize).map_or(0, |q| q.timestamp_valid_bits);
        if valid_bits > 0 && inner.limits.timestamp_period > 0.0 {
            let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(2);
            f.queries = Some(unsafe { d.create_query_pool(&info, None) }.map_err(GpuError::vk("vkCreateQueryPool"))?);
        }
        Ok(f)
    }

    /// Waits for the frame in flight, if any (with the context's timeout), and
    /// returns the device time of its dispatch when the queue has timestamps.
    pub fn wait(&mut self) -> Result<Option<Duration>, GpuError> {
        if !self.pending {
            return Ok(None);
        }
        let d = &self.inner.device;
        let timeout_ns = super::dispatch::nanos(self.inner.timeout);
        match unsafe { d.wait_for_fences(&[self.fence], true, timeout_ns) } {
            Ok(()) => {}
            Err(vk::Result::TIMEOUT) => return Err(GpuError::Timeout { after: self.inner.timeout }),
            Err(e) => return Err(GpuError::vk("vkWaitForFences")(e)),
        }
        unsafe { d.reset_fences(&[self.fence]) }.map_err(GpuError::vk("vkResetFences"))?;
        self.pending = false;
        let (Some(pool), true) = (self.queries, self.timed) else { return Ok(None) };
        let mut stamps = [0u64; 2];
        unsafe { d.get_query_pool_results(pool, 0, &mut stamps, vk::QueryResultFlags::TYPE_64) }
            .map_err(GpuError::vk("vkGetQueryPoolResults"))?;
        let ticks = stamps[1].wrapping_sub(stamps[0]) as f64;
        Ok(Some(Duration::from_secs_f64(ticks * f64::from(self.inner.limits.timestamp_period) * 1e-9)))
    }

    /// Dispatches `kernel` over `groups` work groups with `set`; then, with a
    /// swapchain, blits the top-left `extent` of `image` (which the kernel
    /// writes; at most its size) to the next swapchain image, scaled to fill
    /// it, and presents it. Waits for the previous frame first. Returns at
    /// once: call `wait` before reading what the kernel wrote or changing
    /// anything it uses.
    pub fn submit(
        &mut self,
        kernel: &Kernel,
        set: &DescriptorSet,
        groups: [u32; 3],
        image: &StorageImage,
        extent: [u32; 2],
        swapchain: Option<&mut Swapchain>,
    ) -> Result<FrameStatus, GpuError> {
        let bad = |message: String| GpuError::BadRun { kernel: kernel.name().to_string(), message };
        if extent[0] == 0 || extent[1] == 0 || extent[0] > image.width() || extent[1] > image.height() {
            return Err(bad(format!(
                "blit extent {}x{} is empty or outside the {}x{} image",
                extent[0],
                extent[1],
                image.width(),
                image.height()
            )));
        }
        if !Arc::ptr_eq(&kernel.inner, &self.inner) || !Arc::ptr_eq(image.inner(), &self.inner) {
            return Err(bad("the kernel or image was created on another GpuContext".into()));
        }
        if set.set_layout != kernel.set_layout {
            return Err(bad("the descriptor set was made for another kernel".into()));
        }
        let limit = self.inner.limits.max_compute_work_group_count;
        if groups.iter().zip(limit).any(|(g, l)| *g > l) {
            return Err(GpuError::TooManyGroups { groups, limit });
        }
        self.wait()?;
        let d = &self.inner.device;

        // The swapchain image to draw into.
        let target = match swapchain {
            None => None,
            Some(sc) => {
                if !Arc::ptr_eq(sc.inner(), &self.inner) {
                    return Err(bad("the swapchain was created on another GpuContext".into()));
                }
                let timeout_ns = super::dispatch::nanos(self.inner.timeout);
                match unsafe { sc.loader.acquire_next_image(sc.handle, timeout_ns, self.acquired, vk::Fence::null()) } {
                    Ok((index, _suboptimal)) => Some((sc, index)),
                    Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => return Ok(FrameStatus::OutOfDate),
                    Err(vk::Result::TIMEOUT | vk::Result::NOT_READY) => {
                        return Err(GpuError::Timeout { after: self.inner.timeout })
                    }
                    Err(e) => return Err(GpuError::vk("vkAcquireNextImageKHR")(e)),
                }
            }
        };

        let cmd = self.cmd;
        unsafe {
            d.reset_command_buffer(cmd, vk::CommandBufferResetFlags::empty())
                .map_err(GpuError::vk("vkResetCommandBuffer"))?;
            let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
            d.begin_command_buffer(cmd, &begin).map_err(GpuError::vk("vkBeginCommandBuffer"))?;

            // The previous frame's writes (accumulation, output) before this one's reads and writes;
            // its blit's read of the image before this dispatch writes it. The image keeps what
            // earlier frames wrote (a frame may write only some rows of it).
            let memory = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE | vk::AccessFlags::TRANSFER_READ)
                .dst_access_mask(vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE)];
            let to_general = [layout_barrier(
                image.image,
                image.layout.get(),
                vk::ImageLayout::GENERAL,
                vk::AccessFlags::empty(),
                vk::AccessFlags::SHADER_WRITE,
            )];
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER | vk::PipelineStageFlags::TRANSFER,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::DependencyFlags::empty(),
                &memory,
                &[],
                &to_general,
            );

            kernel.bind(cmd);
            d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, kernel.pipeline_layout, 0, &[set.set], &[]);
            if let Some(pool) = self.queries {
                d.cmd_reset_query_pool(cmd, pool, 0, 2);
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::TOP_OF_PIPE, pool, 0);
            }
            d.cmd_dispatch(cmd, groups[0], groups[1], groups[2]);
            if let Some(pool) = self.queries {
                d.cmd_write_timestamp(cmd, vk::PipelineStageFlags::COMPUTE_SHADER, pool, 1);
            }

            // Shader writes -> the host (buffers, after the fence) and the blit (image).
            let memory = [vk::MemoryBarrier::default()
                .src_access_mask(vk::AccessFlags::SHADER_WRITE)
                .dst_access_mask(vk::AccessFlags::HOST_READ)];
            let to_src = [layout_barrier(
                image.image,
                vk::ImageLayout::GENERAL,
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                vk::AccessFlags::SHADER_WRITE,
                vk::AccessFlags::TRANSFER_READ,
            )];
            let image_barriers: &[vk::ImageMemoryBarrier] = if target.is_some() { &to_src } else { &[] };
            image.layout.set(if target.is_some() {
                vk::ImageLayout::TRANSFER_SRC_OPTIMAL
            } else {
                vk::ImageLayout::GENERAL
            });
            d.cmd_pipeline_barrier(
                cmd,
                vk::PipelineStageFlags::COMPUTE_SHADER,
                vk::PipelineStageFlags::HOST | vk::PipelineStageFlags::TRANSFER,
                vk::DependencyFlags::empty(),
                &memory,
                &[],
                image_barriers,
            );

            if let Some((sc, index)) = &target {
                let dst = sc.images[*index as usize];
                let to_dst = [layout_barrier(
                    dst,
                    vk::ImageLayout::UNDEFINED,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::AccessFlags::empty(),
                    vk::AccessFlags::TRANSFER_WRITE,
                )];
                // TRANSFER: the stage the acquire semaphore is waited at.
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &to_dst,
                );
                let [w, h] = sc.extent();
                let layers = vk::ImageSubresourceLayers::default()
                    .aspect_mask(vk::ImageAspectFlags::COLOR)
                    .mip_level(0)
                    .base_array_layer(0)
                    .layer_count(1);
                let corner = |x: u32, y: u32| vk::Offset3D { x: x as i32, y: y as i32, z: 1 };
                let region = [vk::ImageBlit::default()
                    .src_subresource(layers)
                    .src_offsets([vk::Offset3D::default(), corner(extent[0], extent[1])])
                    .dst_subresource(layers)
                    .dst_offsets([vk::Offset3D::default(), corner(w, h)])];
                d.cmd_blit_image(
                    cmd,
                    image.image,
                    vk::ImageLayout::TRANSFER_SRC_OPTIMAL,
                    dst,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    &region,
                    vk::Filter::NEAREST,
                );
                let to_present = [layout_barrier(
                    dst,
                    vk::ImageLayout::TRANSFER_DST_OPTIMAL,
                    vk::ImageLayout::PRESENT_SRC_KHR,
                    vk::AccessFlags::TRANSFER_WRITE,
                    vk::AccessFlags::empty(),
                )];
                d.cmd_pipeline_barrier(
                    cmd,
                    vk::PipelineStageFlags::TRANSFER,
                    vk::PipelineStageFlags::BOTTOM_OF_PIPE,
                    vk::DependencyFlags::empty(),
                    &[],
                    &[],
                    &to_present,
                );
            }
            d.end_command_buffer(cmd).map_err(GpuError::vk("vkEndCommandBuffer"))?;
        }

        let queue = self.inner.queue.lock().unwrap_or_else(|p| p.into_inner());
        let cmds = [cmd];
        let wait = [self.acquired];
        let wait_stages = [vk::PipelineStageFlags::TRANSFER];
        let signal = target.as_ref().map(|(sc, i)| [sc.rendered[*i as usize]]);
        let mut submit = vk::SubmitInfo::default().command_buffers(&cmds);
        if let Some(signal) = &signal {
            submit = submit.wait_semaphores(&wait).wait_dst_stage_mask(&wait_stages).signal_semaphores(signal);
        }
        unsafe { d.queue_submit(*queue, &[submit], self.fence) }.map_err(GpuError::vk("vkQueueSubmit"))?;
        self.pending = true;
        self.timed = self.queries.is_some();

        let Some((sc, index)) = target else { return Ok(FrameStatus::Done) };
        let signal = signal.expect("set with target");
        let swapchains = [sc.handle];
        let indices = [index];
        let present =
            vk::PresentInfoKHR::default().wait_semaphores(&signal).swapchains(&swapchains).image_indices(&indices);
        match unsafe { sc.loader.queue_present(*queue, &present) } {
            Ok(false) => Ok(FrameStatus::Done),
            Ok(true) | Err(vk::Result::SUBOPTIMAL_KHR) => Ok(FrameStatus::Suboptimal),
            Err(vk::Result::ERROR_OUT_OF_DATE_KHR) => Ok(FrameStatus::Suboptimal),
            Err(e) => Err(GpuError::vk("vkQueuePresentKHR")(e)),
        }
    }
}

impl FrameLoop {
    /// Waits for the frame in flight at teardown, after `wait` timed out:
    /// nothing the frame uses may be destroyed while it runs (Mesa 25's
    /// lavapipe ran on into freed memory). A frame still running after
    /// TEARDOWN_WAIT is left running, and with it everything of the device
    /// (`Inner::leave_running`).
    pub fn finish(&mut self) {
        if std::mem::take(&mut self.pending) {
            self.inner.wait_or_leave_running(&[self.fence]);
        }
    }
}

impl Drop for FrameLoop {
    fn drop(&mut self) {
        self.finish();
        if self.inner.left_running() {
            return;
        }
        let d = &self.inner.device;
        unsafe {
            if let Some(pool) = self.queries {
                d.destroy_query_pool(pool, None);
            }
            d.destroy_semaphore(self.acquired, None);
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.pool, None);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gpu::{
        compile_kernel, Buffer, DataImage, DeviceSelector, Division, GpuOptions, ImageBinding, ImageFormat, Resource,
    };
    use crate::layout::{BindingLayout, FieldLayout, StructLayout};

    /// out[i] = 3 i + sample for i < 64, and the pixel (i, 0) of the image.
    const SRC: &str = r#"
#version 450
layout(local_size_x = 64) in;
struct Params { uint sample_index; uint pad0; uint pad1; uint pad2; };
struct Item { uint value; uint pad0; uint pad1; uint pad2; };
layout(std430, binding = 0) readonly buffer ParamsBuf { Params params; };
layout(std430, binding = 1) buffer Out { Item items[]; };
layout(binding = 2, rgba8) writeonly uniform image2D picture;
void main() {
    uint i = gl_GlobalInvocationID.x;
    items[i].value = 3u * i + params.sample_index;
    imageStore(picture, ivec2(int(i), 0), vec4(1.0, 0.0, 0.0, 1.0));
}
"#;

    /// `struct NAME { uint first; uint pad0; uint pad1; uint pad2; }`
    fn four_uints(name: &'static str, first: &'static str) -> StructLayout {
        let f = |name, offset| FieldLayout { name, offset, size: 4 };
        StructLayout { name, size: 16, fields: vec![f(first, 0), f("pad0", 4), f("pad1", 8), f("pad2", 12)] }
    }

    /// Rule: exact values, and not one validation message (synchronization
    /// validation included) over two frames without a swapchain.
    #[test]
    fn frames_dispatch_with_persistent_buffers_and_an_image() {
        let dir = std::env::temp_dir().join(format!("raycast-frames-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let src = dir.join("frames.comp");
        std::fs::write(&src, SRC).unwrap();
        let spv = compile_kernel(&src, Division::AsGiven).unwrap_or_else(|e| panic!("{e}"));
        let _ = std::fs::remove_dir_all(&dir);

        let opts = GpuOptions {
            device: Some(DeviceSelector::Name("llvmpipe".into())),
            validation: true,
            ..Default::default()
        };
        let ctx = GpuContext::new(&opts).unwrap_or_else(|e| panic!("{e}"));
        let bindings = [
            BindingLayout::single(0, four_uints("Params", "sample_index")),
            BindingLayout::array(1, four_uints("Item", "value")).writable(),
        ];
        let images = [ImageBinding { binding: 2, writable: true, format: ImageFormat::Rgba8 }];
        let kernel = Kernel::with_images(&ctx, "frames", &spv, &bindings, &images).unwrap_or_else(|e| panic!("{e}"));
        let params = Buffer::new(&ctx, 16, false, "params").unwrap();
        let out = Buffer::new(&ctx, 64 * 16, true, "out").unwrap();
        let image = StorageImage::new(&ctx, 64, 1).unwrap();

        // Every binding once, each of the right kind.
        let e =
            DescriptorSet::new(&kernel, &[(0, Resource::Buffer(&params)), (1, Resource::Buffer(&out))]).err().unwrap();
        assert!(e.to_string().contains("given bindings [0, 1], the kernel declares [0, 1, 2]"), "{e}");
        let e = DescriptorSet::new(
            &kernel,
            &[(0, Resource::Buffer(&params)), (1, Resource::Image(&image)), (2, Resource::Buffer(&out))],
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("is a storage buffer, not an image"), "{e}");
        // A data image where the kernel wants a picture.
        let data = DataImage::new(&ctx, &[7u8; 64], "a test data image").unwrap_or_else(|e| panic!("{e}"));
        let e = DescriptorSet::new(
            &kernel,
            &[(0, Resource::Buffer(&params)), (1, Resource::Buffer(&out)), (2, Resource::Data(&data))],
        )
        .err()
        .unwrap();
        assert!(e.to_string().contains("binding 2 is a picture (rgba8), not a data image"), "{e}");
        let e = DataImage::new(&ctx, &[7u8; 40], "a ragged data image").err().unwrap();
        assert!(e.to_string().contains("a ragged data image: 40 bytes are not whole 16-byte texels"), "{e}");
        // One-shot runs refuse kernels with pictures (they take data images only).
        let e =
            ctx.run(&kernel, &[(0, &[0u8; 16][..]), (2, &[0u8; 16][..])], (1, 64 * 16), 0, [1, 1, 1]).err().unwrap();
        assert!(e.to_string().contains("binding 2 is a picture"), "{e}");

        let set = DescriptorSet::new(
            &kernel,
            &[(0, Resource::Buffer(&params)), (1, Resource::Buffer(&out)), (2, Resource::Image(&image))],
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let mut frames = FrameLoop::new(&ctx).unwrap();
        for sample in 0..2u32 {
            frames.wait().unwrap();
            params.write(0, bytemuck::bytes_of(&[sample, 0, 0, 0]));
            assert_eq!(
                frames.submit(&kernel, &set, [1, 1, 1], &image, [image.width(), image.height()], None).unwrap(),
                FrameStatus::Done
            );
            frames.wait().unwrap();
            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&out.read(0, 64 * 16));
            for i in 0..64u32 {
                assert_eq!(words[4 * i as usize], 3 * i + sample, "item {i} of sample {sample}");
            }
        }
        drop(frames);
        drop(set);
        let messages = ctx.take_validation_messages();
        assert!(messages.is_empty(), "validation:\n{}", messages.join("\n"));
    }
}
