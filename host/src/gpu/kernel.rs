//! `Kernel`: a checked compute pipeline (or, where the device offers them
//! and validation is off, a shader object: shader_object.rs) and its
//! descriptor set layout, reusable across runs. On a device that runs on
//! the CPU a pipeline is built from SPIR-V specialised ahead
//! (specialize.rs).

use std::sync::Arc;

use ash::vk;

use super::device::Inner;
use super::{float_controls, reflect, specialize, GpuContext, GpuError, ImageBinding, ShaderSource, Specialised};
use crate::layout::BindingLayout;
use crate::render::{Executable, Statistic, StatisticValue};

/// A compute pipeline (entry point `main`) whose storage buffers match the host's layouts.
pub struct Kernel {
    /// Unique in the process: what a kept run (`Inner::kept`) belongs to.
    pub(crate) id: u64,
    /// Null where the kernel is a shader object (`shader`).
    pub(crate) pipeline: vk::Pipeline,
    /// The shader object, on a device with shader objects; else null.
    shader: vk::ShaderEXT,
    /// Where the shader object came from (None: a pipeline).
    source: Option<ShaderSource>,
    /// How a pipeline's specialization constants were applied ahead (None:
    /// by the driver as usual, or a shader object).
    specialised: Option<Specialised>,
    pub(crate) pipeline_layout: vk::PipelineLayout,
    pub(crate) set_layout: vk::DescriptorSetLayout,
    name: String,
    bindings: Vec<BindingLayout>,
    images: Vec<ImageBinding>,
    workgroup_size: [u32; 3],
    /// The specialization constants it was built with (constant_id i = constants[i]).
    constants: Vec<u32>,
    /// Keeps the device alive while the kernel exists.
    pub(crate) inner: Arc<Inner>,
}

/// What a kernel is built from (`Kernel::specialized`'s arguments), as
/// its private builders pass it on.
#[derive(Clone, Copy)]
struct Source<'a> {
    name: &'a str,
    spirv: &'a [u8],
    expected: &'a [BindingLayout],
    images: &'a [ImageBinding],
    constants: &'a [u32],
}

impl Kernel {
    /// Validates `spirv` with naga, checks its bindings and struct layouts
    /// against `expected` (`reflect::check_layouts`), then builds the pipeline.
    pub fn new(ctx: &GpuContext, name: &str, spirv: &[u8], expected: &[BindingLayout]) -> Result<Kernel, GpuError> {
        Kernel::with_images(ctx, name, spirv, expected, &[])
    }

    /// [`Kernel::new`] for a kernel that also binds storage images (`images`,
    /// checked the same way); run it with a `DescriptorSet` and a `FrameLoop`.
    pub fn with_images(
        ctx: &GpuContext,
        name: &str,
        spirv: &[u8],
        expected: &[BindingLayout],
        images: &[ImageBinding],
    ) -> Result<Kernel, GpuError> {
        Kernel::specialized(ctx, name, spirv, expected, images, &[])
    }

    /// The checks of [`Kernel::with_images`] alone (naga's validation, the
    /// bindings and struct layouts against `expected` and `images`), for
    /// SPIR-V whose pipelines are built later.
    pub fn check(
        name: &str,
        spirv: &[u8],
        expected: &[BindingLayout],
        images: &[ImageBinding],
    ) -> Result<(), GpuError> {
        reflect::reflect(name, spirv, expected, images).map(|_| ())
    }

    /// [`Kernel::with_images`] with the shader's specialization constants
    /// 0 .. constants.len() set to `constants` (32-bit each: a bool is 0 or
    /// 1); the others keep their defaults.
    ///
    /// For the embedded kernels, naga's checks run beside the driver's
    /// build, on another thread: the kernel is returned only when they pass
    /// (a mismatch is still an error before anything runs), and the build
    /// no longer waits for them (5 ms of lavapipe's 45 ms kernel for
    /// recursiveSpheres4). Any other SPIR-V (`--shaders`, the preview's
    /// reload, a shader-test kernel) is checked first and given to the
    /// driver only when it passes: bindings that clash with the pipeline
    /// layout are undefined behaviour there, and lavapipe 22.3 crashed on
    /// them (a shader edit moving BINDING_PRIMITIVES onto the frame's
    /// binding ended `render --shaders` on SIGSEGV).
    pub fn specialized(
        ctx: &GpuContext,
        name: &str,
        spirv: &[u8],
        expected: &[BindingLayout],
        images: &[ImageBinding],
        constants: &[u32],
    ) -> Result<Kernel, GpuError> {
        Kernel::specialized_as(ctx, Source { name, spirv, expected, images, constants }, false)
    }

    /// [`Kernel::specialized`] built as a pipeline (never a shader object,
    /// never specialised ahead) that keeps the driver's statistics of its
    /// code, for [`Kernel::statistics`]; None where the device reports none
    /// (no VK_KHR_pipeline_executable_properties: lavapipe in Mesa 22.3).
    pub fn for_statistics(
        ctx: &GpuContext,
        name: &str,
        spirv: &[u8],
        expected: &[BindingLayout],
        images: &[ImageBinding],
        constants: &[u32],
    ) -> Result<Option<Kernel>, GpuError> {
        if ctx.inner.executables.is_none() {
            return Ok(None);
        }
        Kernel::specialized_as(ctx, Source { name, spirv, expected, images, constants }, true).map(Some)
    }

    /// `specialized`; `capture`: as `for_statistics` builds it.
    fn specialized_as(ctx: &GpuContext, source: Source, capture: bool) -> Result<Kernel, GpuError> {
        let Source { name, spirv, expected, images, .. } = source;
        let check = || reflect::reflect(name, spirv, expected, images);
        let build = || Kernel::build(ctx, source, capture);
        // The checks' error first; a kernel built from SPIR-V that failed them is destroyed as it drops.
        let finish = |reflection: Result<reflect::Reflection, GpuError>, built: Result<Kernel, GpuError>| {
            let reflection = reflection?;
            let mut kernel = built?;
            kernel.workgroup_size = reflection.workgroup_size;
            Ok(kernel)
        };
        if !super::EMBEDDED_KERNELS.iter().any(|(_, embedded)| *embedded == spirv) {
            let reflection = check()?;
            return finish(Ok(reflection), build());
        }
        std::thread::scope(|s| match std::thread::Builder::new().spawn_scoped(s, check) {
            Ok(checking) => {
                let built = build();
                finish(checking.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic)), built)
            }
            // No thread to be had (a process at its limit): the checks first, as before.
            Err(_) => {
                let reflection = check()?;
                finish(Ok(reflection), build())
            }
        })
    }

    /// The pipeline (or shader object) of `specialized`, before naga's
    /// checks have said whether it may be used; `capture`: a pipeline
    /// that keeps its statistics (`for_statistics`).
    fn build(ctx: &GpuContext, source: Source, capture: bool) -> Result<Kernel, GpuError> {
        let Source { name, spirv, expected, images, constants } = source;
        // Mesa 25's lavapipe makes a shader object only once its queue is
        // idle: behind a run that timed out, that is never.
        ctx.inner.refuse_if_still_running()?;
        let invalid = |message: String| GpuError::InvalidSpirv { kernel: name.to_string(), message };
        let mut words = ash::util::read_spv(&mut std::io::Cursor::new(spirv)).map_err(|e| invalid(e.to_string()))?;
        words = float_controls::add_modes(&words, ctx.inner.float_modes).map_err(invalid)?;

        let d = &ctx.inner.device;
        static NEXT_ID: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        let mut kernel = Kernel {
            id: NEXT_ID.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            pipeline: vk::Pipeline::null(),
            shader: vk::ShaderEXT::null(),
            source: None,
            specialised: None,
            pipeline_layout: vk::PipelineLayout::null(),
            set_layout: vk::DescriptorSetLayout::null(),
            name: name.to_string(),
            bindings: expected.to_vec(),
            images: images.to_vec(),
            workgroup_size: [0; 3], // naga's answer, set by `specialized`
            constants: constants.to_vec(),
            inner: ctx.inner.clone(),
        };
        // From here on, dropping `kernel` destroys whatever was created.
        let layout_bindings: Vec<vk::DescriptorSetLayoutBinding> = expected
            .iter()
            .map(|b| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(b.binding)
                    .descriptor_type(buffer_descriptor_type(b))
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            })
            .chain(images.iter().map(|i| {
                vk::DescriptorSetLayoutBinding::default()
                    .binding(i.binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .descriptor_count(1)
                    .stage_flags(vk::ShaderStageFlags::COMPUTE)
            }))
            .collect();
        let info = vk::DescriptorSetLayoutCreateInfo::default().bindings(&layout_bindings);
        kernel.set_layout = unsafe { d.create_descriptor_set_layout(&info, None) }
            .map_err(GpuError::vk("vkCreateDescriptorSetLayout"))?;
        let set_layouts = [kernel.set_layout];
        let info = vk::PipelineLayoutCreateInfo::default().set_layouts(&set_layouts);
        kernel.pipeline_layout =
            unsafe { d.create_pipeline_layout(&info, None) }.map_err(GpuError::vk("vkCreatePipelineLayout"))?;

        // constant_id i is constants[i], a 32-bit word.
        let entries: Vec<vk::SpecializationMapEntry> = (0..constants.len() as u32)
            .map(|id| vk::SpecializationMapEntry { constant_id: id, offset: id * 4, size: 4 })
            .collect();
        let specialization =
            vk::SpecializationInfo::default().map_entries(&entries).data(bytemuck::cast_slice(constants));

        if let Some(objects) = ctx.inner.shader_objects.as_ref().filter(|_| !capture) {
            let bindings: Vec<(u32, i32)> =
                layout_bindings.iter().map(|b| (b.binding, b.descriptor_type.as_raw())).collect();
            let (shader, source) = objects.create(name, &words, constants, &specialization, &set_layouts, &bindings)?;
            kernel.shader = shader;
            kernel.source = Some(source);
            return Ok(kernel);
        }
        // The pipeline of `code` (SPIR-V words) with `specialization`; where the constants are in the
        // SPIR-V already (specialised ahead) the driver finds none of them and ignores it.
        let build = |code: &[u32]| {
            let info = vk::ShaderModuleCreateInfo::default().code(code);
            let module =
                unsafe { d.create_shader_module(&info, None) }.map_err(GpuError::vk("vkCreateShaderModule"))?;
            let stage = vk::PipelineShaderStageCreateInfo::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .module(module)
                .name(c"main")
                .specialization_info(&specialization);
            // DISPATCH_BASE: a run splits a pass by rows of work groups (dispatch.rs record_run).
            let capture = if capture {
                vk::PipelineCreateFlags::CAPTURE_STATISTICS_KHR
            } else {
                vk::PipelineCreateFlags::empty()
            };
            let info = [vk::ComputePipelineCreateInfo::default()
                .flags(vk::PipelineCreateFlags::DISPATCH_BASE | capture)
                .stage(stage)
                .layout(kernel.pipeline_layout)];
            let result = unsafe { d.create_compute_pipelines(vk::PipelineCache::null(), &info, None) };
            unsafe { d.destroy_shader_module(module, None) };
            result.map(|p| p[0]).map_err(|(_, e)| GpuError::vk("vkCreateComputePipelines")(e))
        };
        let ahead = if ctx.inner.specialise_ahead && !constants.is_empty() && !capture {
            Some(specialize::specialise(name, &words, constants))
        } else {
            None
        };
        kernel.pipeline = match ahead {
            None => build(&words)?,
            Some((None, how)) => {
                kernel.specialised = Some(how);
                build(&words)?
            }
            Some((Some(specialised), how)) => match build(&specialised) {
                Ok(pipeline) => {
                    kernel.specialised = Some(how);
                    pipeline
                }
                // A driver that refuses the specialised module gets the kernel as built, its constants to
                // apply; what was kept is removed, so the next run makes it again.
                Err(e) => {
                    specialize::forget(name, &words, constants);
                    kernel.specialised =
                        Some(Specialised::ByTheDriver(format!("it refused the specialised SPIR-V: {e}")));
                    build(&words)?
                }
            },
        };
        Ok(kernel)
    }

    pub fn name(&self) -> &str {
        &self.name
    }

    /// The driver's statistics of each executable of the kernel's
    /// pipeline (registers, shared memory, occupancy: whatever the driver
    /// names), for a kernel built by `for_statistics`; empty for any other.
    pub fn statistics(&self) -> Result<Vec<Executable>, GpuError> {
        let Some(ext) = &self.inner.executables else { return Ok(Vec::new()) };
        if self.pipeline == vk::Pipeline::null() {
            return Ok(Vec::new());
        }
        let text = |c: Result<&std::ffi::CStr, _>| c.map(|c| c.to_string_lossy().into_owned()).unwrap_or_default();
        let info = vk::PipelineInfoKHR::default().pipeline(self.pipeline);
        let properties = unsafe { ext.get_pipeline_executable_properties(&info) }
            .map_err(GpuError::vk("vkGetPipelineExecutablePropertiesKHR"))?;
        let mut out = Vec::new();
        for (index, p) in properties.iter().enumerate() {
            let info = vk::PipelineExecutableInfoKHR::default().pipeline(self.pipeline).executable_index(index as u32);
            let statistics = unsafe { ext.get_pipeline_executable_statistics(&info) }
                .map_err(GpuError::vk("vkGetPipelineExecutableStatisticsKHR"))?
                .iter()
                .map(|s| Statistic {
                    name: text(s.name_as_c_str()),
                    description: text(s.description_as_c_str()),
                    // SAFETY: `format` says which member of the union the driver wrote.
                    value: unsafe {
                        match s.format {
                            vk::PipelineExecutableStatisticFormatKHR::BOOL32 => StatisticValue::Bool(s.value.b32 != 0),
                            vk::PipelineExecutableStatisticFormatKHR::INT64 => StatisticValue::Int(s.value.i64),
                            vk::PipelineExecutableStatisticFormatKHR::UINT64 => StatisticValue::Uint(s.value.u64),
                            _ => StatisticValue::Float(s.value.f64),
                        }
                    },
                })
                .collect();
            out.push(Executable {
                name: text(p.name_as_c_str()),
                description: text(p.description_as_c_str()),
                subgroup_size: p.subgroup_size,
                statistics,
            });
        }
        Ok(out)
    }

    /// How it was built, where that is worth saying (`render`'s kernel line,
    /// `bench`): a shader object compiled or from a kept binary, or a
    /// pipeline specialised ahead (or why not); None for a pipeline built
    /// as everywhere.
    pub fn how_built(&self) -> Option<String> {
        let object = |how: &str| Some(format!("a shader object, {how}"));
        match (self.source, &self.specialised) {
            (Some(ShaderSource::Compiled { kept: true }), _) => object("compiled; its binary kept for the next run"),
            (Some(ShaderSource::Compiled { kept: false }), _) => {
                object("compiled; its binary could not be kept: no cache folder, or not writable")
            }
            (Some(ShaderSource::Cached), _) => object("from the binary a run before kept"),
            (None, Some(specialised)) => Some(specialised.describe()),
            (None, None) => None,
        }
    }

    /// Records binding the kernel (its pipeline or shader object) for dispatch.
    pub(crate) fn bind(&self, cmd: vk::CommandBuffer) {
        let d = &self.inner.device;
        match &self.inner.shader_objects {
            Some(objects) if self.shader != vk::ShaderEXT::null() => unsafe {
                objects.ext.cmd_bind_shaders(cmd, &[vk::ShaderStageFlags::COMPUTE], &[self.shader])
            },
            _ => unsafe { d.cmd_bind_pipeline(cmd, vk::PipelineBindPoint::COMPUTE, self.pipeline) },
        }
    }

    /// None when `given` names each of the kernel's bindings (buffers and
    /// images) exactly once; else the given and the declared binding
    /// numbers, each sorted, for the caller's message.
    pub fn binding_mismatch(&self, given: impl IntoIterator<Item = u32>) -> Option<(Vec<u32>, Vec<u32>)> {
        let mut given: Vec<u32> = given.into_iter().collect();
        given.sort_unstable();
        let mut wanted: Vec<u32> =
            self.bindings.iter().map(|b| b.binding).chain(self.images.iter().map(|i| i.binding)).collect();
        wanted.sort_unstable();
        (given != wanted).then_some((given, wanted))
    }

    /// The specialization constants it was built with (`specialized`).
    pub fn constants(&self) -> &[u32] {
        &self.constants
    }

    /// The `local_size` of the shader's `main`.
    pub fn workgroup_size(&self) -> [u32; 3] {
        self.workgroup_size
    }

    /// The bindings the kernel was checked against (all of descriptor set 0).
    pub fn bindings(&self) -> &[BindingLayout] {
        &self.bindings
    }

    /// The storage images the kernel was checked against (set 0).
    pub fn images(&self) -> &[ImageBinding] {
        &self.images
    }

    /// `kernel render: binding 4 (PixelOut[])`, for messages.
    pub(crate) fn binding_label(&self, binding: u32) -> String {
        let shape = self.bindings.iter().find(|b| b.binding == binding).map(|b| reflect::shape_label(&b.shape));
        format!("kernel {}: binding {binding} ({})", self.name, shape.as_deref().unwrap_or("?"))
    }

    /// Whether `binding` is one of the kernel's storage images.
    pub(crate) fn binds_image(&self, binding: u32) -> bool {
        self.images.iter().any(|i| i.binding == binding)
    }

    /// The descriptor type of buffer binding `binding` (storage unless the kernel declares a uniform block there).
    pub(crate) fn descriptor_type(&self, binding: u32) -> vk::DescriptorType {
        self.bindings
            .iter()
            .find(|b| b.binding == binding)
            .map_or(vk::DescriptorType::STORAGE_BUFFER, buffer_descriptor_type)
    }
}

/// A uniform block's binding is a uniform buffer; every other buffer a storage buffer.
fn buffer_descriptor_type(b: &BindingLayout) -> vk::DescriptorType {
    if b.shape.is_uniform() {
        vk::DescriptorType::UNIFORM_BUFFER
    } else {
        vk::DescriptorType::STORAGE_BUFFER
    }
}

impl Drop for Kernel {
    fn drop(&mut self) {
        let d = &self.inner.device;
        // A timed-out dispatch may still use the pipeline.
        if !self.inner.may_destroy() {
            return;
        }
        // Its kept run's memory goes with it (its descriptor set has this kernel's layout).
        self.inner.forget_kept(self.id);
        // Null handles (a failed `new`) are no-ops.
        unsafe {
            if let Some(objects) = &self.inner.shader_objects {
                objects.ext.destroy_shader(self.shader, None);
            }
            d.destroy_pipeline(self.pipeline, None);
            d.destroy_pipeline_layout(self.pipeline_layout, None);
            d.destroy_descriptor_set_layout(self.set_layout, None);
        }
    }
}
