//! Dispatch: a run's buffers bound and its passes recorded, submitted in
//! chunks and waited for (`Inner::run_passes_read`); command buffers,
//! one-off submissions and their fences; timeouts, and work left running
//! past them (`device_left_running`).

use std::time::{Duration, Instant};

use ash::vk;

use super::device::Inner;
use super::image::record_image_upload;
use super::memory::{
    buffer_size, create_buffer, create_image, data_image_size, KeptRun, Place, RunImage, RunResources, DATA_FORMAT,
};
use super::{GpuError, ImageFormat, Kernel, LESS_DATA};
use crate::render::DevicePhases;

/// How long one submission of a run's passes aims to take (`run_passes`):
/// long enough that a GPU's thousands of short passes go in few
/// submissions, short enough that a pass on a slow device is told as it
/// finishes and the timeout bounds a pass or so, not a whole picture's
/// samples (4096 of them at most: 37 minutes at recursive-spheres depth 10
/// on lavapipe). A pass is split between submissions by rows of work
/// groups (vkCmdDispatchBase), so one sample of a large picture is told as
/// it goes too.
const CHUNK_AIM: Duration = Duration::from_millis(250);
/// The first submission of a run: this part of its first pass's rows of
/// work groups (the time it takes sizes the next) where the pass has more
/// than SPLIT_GROUPS work groups; else the whole pass. A split costs: on
/// lavapipe recursiveSpheres4's dispatch at 512x384 (3,072 groups) took
/// 80.75 ms split in eighths against 75.75 whole (medians of 12 rounds in
/// turn, `ci/benchmarks.sh builds`), where pictures of the course's size
/// gain nothing from it (a progress line shows after a second).
const FIRST_CHUNK_PARTS: u64 = 8;
/// Passes of more work groups than this are split from the first: the
/// course's 512x384 (3,072 groups of 8x8) is not, 1024x768 (12,288) is;
/// nor is a smaller one unless its caller expects it to be slow
/// (`run_passes_read`'s `slow`).
const SPLIT_GROUPS: u64 = 4096;
/// How many times the work of the submission before the next may take on,
/// where the one before was quick: its rows may have been cheap ones (the
/// sky above a scene).
const CHUNK_GROWTH: u64 = 8;

/// Wall-clock times of the phases of one `GpuContext::run`.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunTimings {
    /// Buffer creation and host writes, descriptor set.
    pub upload: Duration,
    /// Recording, submit and fence wait.
    pub dispatch: Duration,
    /// Copying the output to host memory.
    pub readback: Duration,
    /// The device's own times of the run's phases, by its timestamps;
    /// None where the queue has none.
    pub device: Option<DevicePhases>,
}

/// Timestamps of a run's submission (`record_run`): the clears' start and
/// end (first submission only), the dispatches' start and end, the output
/// copy's start and end (last submission, where the output is copied).
const RUN_QUERIES: u32 = 6;

/// What a run binds: every binding of its kernel exactly once.
pub struct RunBuffers<'a> {
    /// Bindings uploaded from the host: (binding, bytes).
    pub inputs: &'a [(u32, &'a [u8])],
    /// Storage buffers the device clears to zero before the first pass,
    /// which the host neither writes nor reads (device-local where the
    /// device has such memory): (binding, bytes).
    pub cleared: &'a [(u32, usize)],
    /// The buffer read back: (binding, bytes); every u32 word of it is
    /// `fill` until the kernel writes it (on the device, before the first pass).
    pub output: (u32, usize),
    pub fill: u32,
}

impl RunBuffers<'_> {
    /// Every binding with its length: the inputs, the cleared buffers, the output.
    fn lengths(&self) -> impl Iterator<Item = (u32, usize)> + '_ {
        self.inputs.iter().map(|(b, d)| (*b, d.len())).chain(self.cleared.iter().copied()).chain([self.output])
    }
}

/// The most bytes of bindings a kept run holds (`KeptRun`): a 4K frame's
/// pixel records and samples' sums (64 bytes a pixel: 133 MB at 1080p,
/// 531 MB at 3840x2160; on a discrete GPU the records' host copy besides)
/// and a small scene's. A larger run's resources go at its end as
/// before: on lavapipe the device's memory is the host's, and `check` or
/// a large `render` would otherwise hold them beside the CPU build's
/// picture or the PNG being written.
const KEPT_BYTES_MAX: usize = 512 << 20;

/// What a run's resources are kept by (`KeptRun`).
pub(crate) struct KeptKey {
    kernel: u64,
    lengths: Vec<(u32, usize)>,
    inputs: Vec<u64>,
}

/// A 64-bit hash of an input's bytes (FxHash's step, eight bytes at a
/// time): whether a kept run's input changed. Not for adversaries: two
/// different inputs of the same length with the same hash would keep the
/// old bytes.
fn input_hash(bytes: &[u8]) -> u64 {
    const K: u64 = 0x517c_c1b7_2722_0a95;
    let step = |h: u64, w: u64| (h.rotate_left(5) ^ w).wrapping_mul(K);
    let mut words = bytes.chunks_exact(8);
    let mut h = bytes.len() as u64;
    for w in &mut words {
        h = step(h, u64::from_le_bytes(w.try_into().unwrap_or([0; 8])));
    }
    let mut tail = [0u8; 8];
    tail[..words.remainder().len()].copy_from_slice(words.remainder());
    step(h, u64::from_le_bytes(tail))
}

/// How long a context's teardown waits for work that timed out before it
/// leaves it running (`Inner::may_destroy`).
const TEARDOWN_WAIT: Duration = Duration::from_secs(5);

/// `d` in nanoseconds, as Vulkan's waits take it (u64::MAX: beyond ~584 years).
pub(crate) fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// Set when a context left timed-out work running: the process should end
/// without the drivers' own clean-up at exit (`device_left_running`).
static LEFT_RUNNING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a device was left running work that outlived its timeout (a
/// kernel that never ends on a GPU; Mesa 25's lavapipe, which has no loop
/// budget): the process then ends at once after its message
/// (`cli::main`), since a driver's clean-up at exit (Mesa joins its worker
/// threads) would wait for that work for ever.
pub fn device_left_running() -> bool {
    LEFT_RUNNING.load(std::sync::atomic::Ordering::Relaxed)
}

impl Inner {
    /// The work of `GpuContext::run_passes_read` (which says what it
    /// takes), its kernel made on this device: the run checked, its buffers
    /// made and bound, its passes submitted in chunks of about `CHUNK_AIM`,
    /// and the output handed to `read` where the device left it.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn run_passes_read<R>(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
        groups: [u32; 3],
        passes: u32,
        slow: bool,
        read: impl FnOnce(&[u8]) -> R,
        mut done: impl FnMut(f64),
    ) -> Result<(R, RunTimings), GpuError> {
        self.check_run(kernel, buffers, groups)?;
        self.refuse_if_still_running()?;

        let start = Instant::now();
        let (mut res, set, key) = self.prepare_run(kernel, buffers)?;
        let stamps = self.timestamp_ticks()?;
        if stamps.is_some() && res.queries == vk::QueryPool::null() {
            let info = vk::QueryPoolCreateInfo::default().query_type(vk::QueryType::TIMESTAMP).query_count(RUN_QUERIES);
            res.queries =
                unsafe { self.device.create_query_pool(&info, None) }.map_err(GpuError::vk("vkCreateQueryPool"))?;
        }
        let upload = start.elapsed();
        let mut phases = DevicePhases::default();

        // Clear, fill the data images, bind, dispatch, make the writes visible to the host, submit, wait.
        let start = Instant::now();
        // The work in units of one row of work groups of one pass; the
        // first submission the first pass, or an eighth of it where large or slow.
        let rows = u64::from(groups[1].max(1));
        let total = u64::from(passes) * rows;
        let split = slow || groups.iter().map(|&g| u64::from(g)).product::<u64>() > SPLIT_GROUPS;
        let first = if split { rows.div_ceil(FIRST_CHUNK_PARTS) } else { rows };
        let (mut res, mut finished, mut chunk) = (res, 0u64, first);
        while finished < total {
            let units = finished..(finished + chunk).min(total);
            let began = Instant::now();
            let last = units.end == total;
            res = self.submit_once(res, |d, cmd, res| unsafe {
                record_run(d, cmd, res, kernel, set, groups, units.clone(), last)
            })?;
            if let Some(tick) = &stamps {
                // Only the queries this submission wrote: the others are not available.
                let read = |first: u32| {
                    let mut t = [0u64; 2];
                    let flags = vk::QueryResultFlags::TYPE_64;
                    unsafe { self.device.get_query_pool_results(res.queries, first, &mut t, flags) }
                        .map(|()| t)
                        .map_err(GpuError::vk("vkGetQueryPoolResults"))
                };
                let [start, end] = read(2)?;
                if units.start == 0 {
                    let [clear, cleared] = read(0)?;
                    phases.clear += tick(clear, cleared);
                    phases.dispatch += tick(cleared, end);
                } else {
                    phases.dispatch += tick(start, end);
                }
                if last && res.output_copy.is_some() {
                    let [copy, copied] = read(4)?;
                    phases.readback += tick(copy, copied);
                }
            }
            let (n, took) = (units.end - units.start, began.elapsed().as_nanos().max(1));
            finished = units.end;
            done(finished as f64 / rows as f64);
            // The next submission about CHUNK_AIM long, at most CHUNK_GROWTH
            // times this one; whole passes where a pass is not split.
            let fit = u64::try_from(CHUNK_AIM.as_nanos() * u128::from(n) / took).unwrap_or(u64::MAX);
            chunk = fit.clamp(1, n.saturating_mul(CHUNK_GROWTH));
            if !split {
                chunk = (chunk / rows).max(1) * rows;
            }
        }
        let dispatch = start.elapsed();

        let start = Instant::now();
        let d = &self.device;
        let memory = res.output;
        let ptr = unsafe { d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
            .map_err(GpuError::vk("vkMapMemory"))?;
        // SAFETY: the mapping covers at least the output's bytes; the fence and barrier made the writes visible.
        let out = read(unsafe { std::slice::from_raw_parts(ptr as *const u8, buffers.output.1) });
        unsafe { d.unmap_memory(memory) };
        let readback = start.elapsed();
        // Kept for the next run; its data images hold their inputs now.
        for image in &mut res.images {
            image.upload = false;
        }
        let KeptKey { kernel, lengths, inputs } = key;
        if lengths.iter().map(|&(_, bytes)| bytes).sum::<usize>() <= KEPT_BYTES_MAX {
            *self.kept.lock().unwrap_or_else(|p| p.into_inner()) = Some(KeptRun { kernel, lengths, inputs, res, set });
        }
        Ok((out, RunTimings { upload, dispatch, readback, device: stamps.map(|_| phases) }))
    }

    /// Where the queue writes timestamps: how to turn two of them into
    /// the time between (ticks masked to the valid bits, times the period).
    #[allow(clippy::type_complexity)]
    fn timestamp_ticks(&self) -> Result<Option<impl Fn(u64, u64) -> Duration>, GpuError> {
        let families = unsafe { self.parts.instance.get_physical_device_queue_family_properties(self.physical) };
        let bits = families.get(self.queue_family as usize).map_or(0, |q| q.timestamp_valid_bits);
        let period = f64::from(self.limits.timestamp_period);
        if bits == 0 || period <= 0.0 {
            return Ok(None);
        }
        let mask = if bits >= 64 { u64::MAX } else { (1u64 << bits) - 1 };
        Ok(Some(move |a: u64, b: u64| Duration::from_secs_f64((b.wrapping_sub(a) & mask) as f64 * period * 1e-9)))
    }

    /// Checks a run against the kernel and the device limits before anything is allocated.
    fn check_run(&self, kernel: &Kernel, buffers: &RunBuffers, groups: [u32; 3]) -> Result<(), GpuError> {
        let bad = |message: String| GpuError::BadRun { kernel: kernel.name().to_string(), message };
        if let Some(i) = kernel.images().iter().find(|i| i.writable || i.format != ImageFormat::Rgba32Uint) {
            return Err(bad(format!(
                "run() binds storage buffers and read-only rgba32ui data images; binding {} is a picture: \
                 it needs a DescriptorSet and a FrameLoop",
                i.binding
            )));
        }
        if let Some((given, wanted)) = kernel.binding_mismatch(buffers.lengths().map(|(b, _)| b)) {
            return Err(bad(format!(
                "run() was given bindings {given:?} (inputs, cleared and output), the kernel declares {wanted:?}; \
                 pass each binding exactly once"
            )));
        }
        let limit = self.limits.max_compute_work_group_count;
        if groups.iter().zip(limit).any(|(g, l)| *g > l) {
            return Err(GpuError::TooManyGroups { groups, limit });
        }
        let out_binding = buffers.output.0;
        if let Some(&(binding, _)) =
            buffers.cleared.iter().chain([&buffers.output]).find(|(b, _)| kernel.binds_image(*b))
        {
            let what = if binding == out_binding { "the output" } else { "cleared" };
            return Err(bad(format!("binding {binding} is a read-only image; it cannot be {what}")));
        }
        for (binding, len) in buffers.lengths() {
            if kernel.binds_image(binding) {
                self.check_data_image(kernel.name(), &kernel.binding_label(binding), len)?;
                continue;
            }
            self.check_storage_size(buffer_size(len), || kernel.binding_label(binding))?;
            let uniform_range = u64::from(self.limits.max_uniform_buffer_range);
            if kernel.descriptor_type(binding) == vk::DescriptorType::UNIFORM_BUFFER && buffer_size(len) > uniform_range
            {
                return Err(GpuError::TooLarge {
                    what: kernel.binding_label(binding),
                    bytes: buffer_size(len),
                    limit: uniform_range,
                    limit_name: "maxUniformBufferRange",
                    advice: LESS_DATA,
                });
            }
        }
        Ok(())
    }

    /// The buffers and data images of a checked run, the inputs written,
    /// and a descriptor set binding them.
    fn prepare_run(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
    ) -> Result<(RunResources, vk::DescriptorSet, KeptKey), GpuError> {
        let key = KeptKey {
            kernel: kernel.id,
            lengths: buffers.lengths().collect(),
            inputs: buffers.inputs.iter().map(|(_, data)| input_hash(data)).collect(),
        };
        // The last run's resources where they fit this one; else they go
        // before this run's are made.
        let kept = self.kept.lock().unwrap_or_else(|p| p.into_inner()).take();
        if let Some(kept) = kept.filter(|k| k.kernel == key.kernel && k.lengths == key.lengths) {
            self.kept_taken.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            let KeptRun { inputs, mut res, set, .. } = kept;
            // The output's word before the kernel writes it: this run's.
            let output = res.bindings.iter().find(|(b, _)| *b == buffers.output.0).map(|&(_, buffer)| buffer);
            for fill in res.fills.iter_mut().filter(|(b, _)| Some(*b) == output) {
                fill.1 = buffers.fill;
            }
            for ((&(binding, data), new), old) in buffers.inputs.iter().zip(&key.inputs).zip(&inputs) {
                if new == old {
                    continue;
                }
                let buffer = res.bindings.iter().find(|(b, _)| *b == binding).map(|&(_, buffer)| buffer);
                let memory = res.buffers.iter().find(|(b, _)| Some(*b) == buffer).map(|&(_, memory)| memory);
                let Some(memory) = memory else {
                    return Err(GpuError::BadRun {
                        kernel: kernel.name().to_string(),
                        message: format!("a kept run has no buffer at binding {binding}"),
                    });
                };
                self.write_input(memory, data)?;
                for image in res.images.iter_mut().filter(|i| i.binding == binding) {
                    image.upload = true;
                }
            }
            return Ok((res, set, key));
        }
        let mut res = RunResources::new(self.device.clone());
        // Inputs: one host-visible buffer per binding, written in place.
        for &(binding, data) in buffers.inputs {
            let (buffer, memory) = create_buffer(
                &self.device,
                &self.memory,
                &mut res,
                buffer_size(data.len()),
                Place::Upload,
                &kernel.binding_label(binding),
            )?;
            self.write_input(memory, data)?;
            res.bindings.push((binding, buffer));
            if kernel.binds_image(binding) {
                // A device image, copied from this buffer when the command buffer starts.
                let texels = (data.len() / 16) as u32;
                self.create_data_image(&mut res, binding, buffer, texels, &kernel.binding_label(binding))?;
            }
        }
        // Cleared buffers and the output: filled by the device, before the first pass.
        for &(binding, len) in buffers.cleared {
            let (buffer, _) = create_buffer(
                &self.device,
                &self.memory,
                &mut res,
                buffer_size(len),
                Place::Device,
                &kernel.binding_label(binding),
            )?;
            res.bindings.push((binding, buffer));
            res.fills.push((buffer, 0));
        }
        let (out_binding, out_len) = buffers.output;
        let place = if self.output_copy { Place::Device } else { Place::Readback };
        let what = kernel.binding_label(out_binding);
        let size = buffer_size(out_len);
        let (buffer, mut memory) = create_buffer(&self.device, &self.memory, &mut res, size, place, &what)?;
        res.bindings.push((out_binding, buffer));
        res.fills.push((buffer, buffers.fill));
        if self.output_copy {
            // The host reads a copy, made after the last pass.
            let copy = format!("{what}, its copy for the host");
            let host;
            (host, memory) = create_buffer(&self.device, &self.memory, &mut res, size, Place::Readback, &copy)?;
            res.output_copy = Some((buffer, host, size));
        }
        res.output = memory;
        let set = self.run_descriptor_set(&mut res, kernel)?;
        Ok((res, set, key))
    }

    /// `data` written at the start of the host-visible `memory`.
    fn write_input(&self, memory: vk::DeviceMemory, data: &[u8]) -> Result<(), GpuError> {
        let ptr = unsafe { self.device.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
            .map_err(GpuError::vk("vkMapMemory"))?;
        // SAFETY: the mapping covers the whole allocation, at least `data.len()` bytes.
        unsafe {
            std::ptr::copy_nonoverlapping(data.as_ptr(), ptr as *mut u8, data.len());
            self.device.unmap_memory(memory);
        }
        Ok(())
    }

    /// Drops the kept run (`KeptRun`) where it is kernel `kernel`'s.
    pub(crate) fn forget_kept(&self, kernel: u64) {
        let mut kept = self.kept.lock().unwrap_or_else(|p| p.into_inner());
        if kept.as_ref().is_some_and(|k| k.kernel == kernel) {
            drop(kept.take());
        }
    }

    /// A descriptor set (from a pool in `res`) with `res`'s buffers and data images at their bindings.
    fn run_descriptor_set(&self, res: &mut RunResources, kernel: &Kernel) -> Result<vk::DescriptorSet, GpuError> {
        let images = res.images.len() as u32;
        let uniform = res
            .bindings
            .iter()
            .filter(|(b, _)| kernel.descriptor_type(*b) == vk::DescriptorType::UNIFORM_BUFFER)
            .count() as u32;
        let sizes: Vec<vk::DescriptorPoolSize> = [
            (vk::DescriptorType::STORAGE_BUFFER, res.bindings.len() as u32 - uniform - images),
            (vk::DescriptorType::UNIFORM_BUFFER, uniform),
            (vk::DescriptorType::STORAGE_IMAGE, images),
        ]
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .map(|(ty, n)| vk::DescriptorPoolSize::default().ty(ty).descriptor_count(n))
        .collect();
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        res.descriptor_pool = unsafe { self.device.create_descriptor_pool(&pool_info, None) }
            .map_err(GpuError::vk("vkCreateDescriptorPool"))?;
        let set_layouts = [kernel.set_layout];
        let alloc =
            vk::DescriptorSetAllocateInfo::default().descriptor_pool(res.descriptor_pool).set_layouts(&set_layouts);
        let set = unsafe { self.device.allocate_descriptor_sets(&alloc) }
            .map_err(GpuError::vk("vkAllocateDescriptorSets"))?[0];
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = res
            .bindings
            .iter()
            .map(|(_, b)| [vk::DescriptorBufferInfo::default().buffer(*b).offset(0).range(vk::WHOLE_SIZE)])
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = res
            .images
            .iter()
            .map(|i| [vk::DescriptorImageInfo::default().image_view(i.view).image_layout(vk::ImageLayout::GENERAL)])
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = res
            .bindings
            .iter()
            .zip(&buffer_infos)
            .filter(|((binding, _), _)| !kernel.binds_image(*binding))
            .map(|((binding, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(*binding)
                    .descriptor_type(kernel.descriptor_type(*binding))
                    .buffer_info(info)
            })
            .chain(res.images.iter().zip(&image_infos).map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i.binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(info)
            }))
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
        Ok(set)
    }

    /// A device-local rgba32ui image of `texels` (`data_image_size`) for
    /// `binding`, filled from `source` when the run's command buffer starts
    /// (`record_image_upload`); `what` names it in errors.
    fn create_data_image(
        &self,
        res: &mut RunResources,
        binding: u32,
        source: vk::Buffer,
        texels: u32,
        what: &str,
    ) -> Result<(), GpuError> {
        let (image, memory, view) = create_image(
            &self.device,
            &self.memory,
            DATA_FORMAT,
            data_image_size(u64::from(texels)).map(|n| n as u32),
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
            format!("{what} (a data image of {texels} texels)"),
        )?;
        res.images.push(RunImage { upload: true, binding, source, texels, image, view, memory });
        Ok(())
    }

    /// Records commands with `record` into a command buffer of its own
    /// (in `res`, with what they use), submits it and waits for it (the
    /// context's timeout). On a timeout the device may still use `res`: it
    /// is kept until the context is dropped. Else it comes back.
    pub(crate) fn submit_once(
        &self,
        mut res: RunResources,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer, &RunResources),
    ) -> Result<RunResources, GpuError> {
        let d = &self.device;
        // A submission before with `res` has finished (its fence waited on):
        // its pool and fence go (destroying a null handle does nothing).
        unsafe {
            d.destroy_fence(std::mem::take(&mut res.fence), None);
            d.destroy_command_pool(std::mem::take(&mut res.command_pool), None);
        }
        let cmd;
        (res.command_pool, cmd) = self.command_buffer(vk::CommandPoolCreateFlags::TRANSIENT)?;
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(cmd, &begin) }.map_err(GpuError::vk("vkBeginCommandBuffer"))?;
        record(d, cmd, &res);
        unsafe { d.end_command_buffer(cmd) }.map_err(GpuError::vk("vkEndCommandBuffer"))?;
        res.fence =
            unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(GpuError::vk("vkCreateFence"))?;
        let queue = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        unsafe { d.queue_submit(*queue, &submit, res.fence) }.map_err(GpuError::vk("vkQueueSubmit"))?;
        let timeout_ns = nanos(self.timeout);
        match unsafe { d.wait_for_fences(&[res.fence], true, timeout_ns) } {
            Ok(()) => Ok(res),
            Err(vk::Result::TIMEOUT) => {
                self.abandoned.lock().unwrap_or_else(|p| p.into_inner()).push(res);
                Err(GpuError::Timeout { after: self.timeout })
            }
            Err(e) => Err(GpuError::vk("vkWaitForFences")(e)),
        }
    }

    /// A command pool of the queue's family (`flags`) and one primary
    /// command buffer from it; the caller destroys the pool. On an error
    /// nothing is left behind.
    pub(crate) fn command_buffer(
        &self,
        flags: vk::CommandPoolCreateFlags,
    ) -> Result<(vk::CommandPool, vk::CommandBuffer), GpuError> {
        let d = &self.device;
        let info = vk::CommandPoolCreateInfo::default().flags(flags).queue_family_index(self.queue_family);
        let pool = unsafe { d.create_command_pool(&info, None) }.map_err(GpuError::vk("vkCreateCommandPool"))?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        match unsafe { d.allocate_command_buffers(&alloc) } {
            Ok(cmds) => Ok((pool, cmds[0])),
            Err(e) => {
                unsafe { d.destroy_command_pool(pool, None) };
                Err(GpuError::vk("vkAllocateCommandBuffers")(e))
            }
        }
    }
}

/// Records a run: the device's fills (`RunResources::fills`) and the data
/// images' copies, then `passes` dispatches of `groups`, each seeing the
/// writes of the one before, then a barrier that makes the writes visible
/// to the host; in the `last` submission, where the output is device-local,
/// its copy to the host's buffer first (`RunResources::output_copy`).
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state; `res` and
/// `set` were made for `kernel` (`Inner::prepare_run`).
#[allow(clippy::too_many_arguments)]
unsafe fn record_run(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    res: &RunResources,
    kernel: &Kernel,
    set: vk::DescriptorSet,
    groups: [u32; 3],
    units: std::ops::Range<u64>,
    last: bool,
) {
    let rows = u64::from(groups[1].max(1));
    let stamp = |stage, query| {
        if res.queries != vk::QueryPool::null() {
            // SAFETY: the caller's; the pool has RUN_QUERIES queries.
            unsafe { d.cmd_write_timestamp(cmd, stage, res.queries, query) };
        }
    };
    // SAFETY: the caller's; every handle lives as long as the run.
    unsafe {
        if res.queries != vk::QueryPool::null() {
            d.cmd_reset_query_pool(cmd, res.queries, 0, RUN_QUERIES);
        }
        if units.start == 0 {
            stamp(vk::PipelineStageFlags::TOP_OF_PIPE, 0);
            record_run_start(d, cmd, res);
            stamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 1);
        }
        kernel.bind(cmd);
        d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, kernel.pipeline_layout, 0, &[set], &[]);
        // The first submission's dispatches are timed from the clears' end (query 1).
        stamp(vk::PipelineStageFlags::TOP_OF_PIPE, 2);
        // Unit u: row u % rows of work groups of pass u / rows; each pass's
        // rows of the range in one dispatch.
        let mut u = units.start;
        while u < units.end {
            let (pass, row) = (u / rows, u % rows);
            let end = units.end.min((pass + 1) * rows);
            if row == 0 && pass > 0 {
                // The pass before's writes (in this submission or an earlier
                // one on the queue), visible to this one's reads and writes.
                let access = vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE;
                shader_writes_barrier(d, cmd, vk::PipelineStageFlags::COMPUTE_SHADER, access);
            }
            // Rows of one pass write pixels of their own: no barrier between them.
            d.cmd_dispatch_base(cmd, 0, row as u32, 0, groups[0], (end - u) as u32, groups[2]);
            u = end;
        }
        stamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 3);
        if let (true, Some((output, host, size))) = (last, res.output_copy) {
            shader_writes_barrier(d, cmd, vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_READ);
            stamp(vk::PipelineStageFlags::TOP_OF_PIPE, 4);
            d.cmd_copy_buffer(cmd, output, host, &[vk::BufferCopy { src_offset: 0, dst_offset: 0, size }]);
            stamp(vk::PipelineStageFlags::BOTTOM_OF_PIPE, 5);
            let transfer = (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE);
            memory_barrier(d, cmd, transfer, (vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ));
            return;
        }
        shader_writes_barrier(d, cmd, vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ);
    }
}

/// Records what a run does before its first pass: the buffers filled,
/// the data images uploaded.
///
/// # Safety
/// As `record_run`.
unsafe fn record_run_start(d: &ash::Device, cmd: vk::CommandBuffer, res: &RunResources) {
    // SAFETY: the caller's.
    unsafe {
        for &(buffer, value) in &res.fills {
            d.cmd_fill_buffer(cmd, buffer, 0, vk::WHOLE_SIZE, value);
        }
        let shader = vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE;
        let transfer = (vk::PipelineStageFlags::TRANSFER, vk::AccessFlags::TRANSFER_WRITE);
        memory_barrier(d, cmd, transfer, (vk::PipelineStageFlags::COMPUTE_SHADER, shader));
        for image in res.images.iter().filter(|i| i.upload) {
            record_image_upload(d, cmd, image.source, image.image, image.texels);
        }
    }
}

/// Records a barrier that makes the compute shader's writes visible to
/// `dst_access` at `dst_stage` (all memory; no image layout changes).
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state.
unsafe fn shader_writes_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    dst_stage: vk::PipelineStageFlags,
    dst_access: vk::AccessFlags,
) {
    let src = (vk::PipelineStageFlags::COMPUTE_SHADER, vk::AccessFlags::SHADER_WRITE);
    // SAFETY: the caller's.
    unsafe { memory_barrier(d, cmd, src, (dst_stage, dst_access)) };
}

/// Records a barrier on all memory: `src`'s accesses at its stage made
/// visible to `dst`'s (each a stage and its accesses).
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state.
unsafe fn memory_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    src: (vk::PipelineStageFlags, vk::AccessFlags),
    dst: (vk::PipelineStageFlags, vk::AccessFlags),
) {
    let barrier = [vk::MemoryBarrier::default().src_access_mask(src.1).dst_access_mask(dst.1)];
    // SAFETY: the caller's.
    unsafe { d.cmd_pipeline_barrier(cmd, src.0, dst.0, vk::DependencyFlags::empty(), &barrier, &[], &[]) };
}

impl Inner {
    /// Whether the device's objects may be destroyed: no run that timed out
    /// is still executing (waited for up to TEARDOWN_WAIT). Else, and from
    /// then on, nothing is destroyed (the work would run on into freed
    /// memory, or the wait would last for ever): see `device_left_running`.
    pub(crate) fn may_destroy(&self) -> bool {
        let abandoned = self.abandoned.lock().unwrap_or_else(|p| p.into_inner());
        if !abandoned.is_empty() && !self.left_running() {
            self.wait_or_leave_running(&abandoned.iter().map(|r| r.fence).collect::<Vec<_>>());
        }
        !self.left_running()
    }

    /// Waits up to TEARDOWN_WAIT for `fences` (work that outlived the
    /// timeout, at teardown); work still running then is left running.
    pub(crate) fn wait_or_leave_running(&self, fences: &[vk::Fence]) {
        if unsafe { self.device.wait_for_fences(fences, true, nanos(TEARDOWN_WAIT)) }.is_err() {
            self.leave_running();
        }
    }

    /// GpuError::StillRunning where a run before timed out and may still
    /// be running: a run or a kernel's build would wait behind it.
    pub(crate) fn refuse_if_still_running(&self) -> Result<(), GpuError> {
        if self.abandoned.lock().unwrap_or_else(|p| p.into_inner()).is_empty() {
            Ok(())
        } else {
            Err(GpuError::StillRunning)
        }
    }

    /// Work that timed out is left running: nothing of this device is destroyed.
    pub(crate) fn leave_running(&self) {
        self.left_running.store(true, std::sync::atomic::Ordering::Relaxed);
        LEFT_RUNNING.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    pub(crate) fn left_running(&self) -> bool {
        self.left_running.load(std::sync::atomic::Ordering::Relaxed)
    }
}
