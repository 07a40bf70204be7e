//! The render kernel on a Vulkan device as a [`Renderer`]: the kernel for
//! each scene chosen (the scene's arrays in storage buffers or in images and
//! uniform blocks), specialised and built on first use, run in bands of rows
//! where the picture does not fit one storage buffer, one sample of every
//! pixel a dispatch.

use super::{kernel_spirv, GpuContext, GpuError, GpuOptions, Kernel, RunBuffers};
use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, ImageBinding, PixelOut};
use crate::render::{
    refuse_cut_short, render_advice, try_with_capacity, BackendInfo, Executable, KernelInfo, Picture, Progress,
    Renderer, Specialization, Timings, Told,
};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The embedded kernel `stem` for `ctx`'s device, compiled as its
/// `division` says (`STEM`, `STEM_gpu` or `STEM_gpu_fma`).
pub fn kernel_spirv_for(ctx: &GpuContext, stem: &str) -> Option<&'static [u8]> {
    kernel_spirv(&format!("{stem}{}", ctx.division().suffix()))
}

/// (shaders/render_uniform.comp), by its name.
pub const UNIFORM_KERNEL: &str = "render_uniform";

/// An error of the uniform kernel's choice or build.
fn uniform_error(message: String) -> GpuError {
    GpuError::BadRun { kernel: UNIFORM_KERNEL.into(), message }
}

/// Where render's scene arrays live: the choice between render.comp and
/// render_uniform.comp.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SceneBuffers {
    /// Images and uniform blocks when the scene fits them, storage buffers otherwise.
    #[default]
    Auto,
    /// Storage buffers (render.comp): any size.
    Storage,
    /// Images and uniform blocks (render_uniform.comp): an error naming what
    /// does not fit when the scene does not (docs/scale.md#shaped-for-lavapipe).
    /// Also spelled `images`: the scene's arrays are storage images, only
    /// the frame is a uniform block.
    Uniform,
}

/// Whether `data`'s arrays fit the uniform kernels' images, and the device
/// binds as many storage images as a uniform kernel declares (`images`: its
/// data images and any picture); else what does not.
pub fn fits_uniform(ctx: &GpuContext, data: &FrameData, images: usize) -> Result<(), Error> {
    if let Some((field, value)) = data.frame.not_unfolded() {
        return Err(Error::Failed(format!(
            "the frame's {field} is {value}, too large for the uniform kernel's copy of the frame, which holds values below 2^32 - 64"
        )));
    }
    let limit = ctx.storage_image_limit();
    if (limit as usize) < images {
        return Err(Error::Failed(format!(
            "{} binds at most {limit} storage images a kernel (maxPerStageDescriptorStorageImages), the uniform kernel {images}",
            ctx.info().name
        )));
    }
    let sizes: Vec<(u32, &str, usize)> = data
        .scene_buffers()
        .iter()
        .map(|&(b, what, bytes)| (b, what, layout::uniform_image_bytes(b, bytes.len())))
        .collect();
    fits_images(&sizes)
}

/// What to do about a scene array too large for one storage buffer of the
/// device: about the textures' texels, and about any other array.
#[derive(Clone, Copy, Debug)]
pub struct StorageAdvice {
    pub texels: &'static str,
    pub other: &'static str,
}

/// In `render`, `check` and `bench`.
pub const RENDER_STORAGE_ADVICE: StorageAdvice = StorageAdvice {
    texels: "use smaller textures, render with --no-textures, or render with --backend cpu (the CPU build has no such \
             limit)",
    other: "render it with --backend cpu (the CPU build has no such limit) or on a device with larger storage buffers",
};
/// In the preview while the device draws the samples (it keeps the
/// textures there while they are off, T).
pub const PREVIEW_DEVICE_STORAGE_ADVICE: StorageAdvice = StorageAdvice {
    texels: "use smaller textures, or preview with --backend cpu (the CPU build draws the samples and the device only \
             shows them)",
    other: "preview it with --backend cpu (the CPU build draws the samples and the device only shows them) or on a \
            device with larger storage buffers",
};
/// In the preview while the CPU build draws the samples: it goes on, and
/// the device cannot take the drawing over (B).
pub const PREVIEW_CPU_STORAGE_ADVICE: StorageAdvice = StorageAdvice {
    texels: "the CPU build draws the samples; with smaller textures the device could draw them too (B)",
    other: "the CPU build draws the samples; a device with larger storage buffers could draw them too (B)",
};

/// Each of `data`'s arrays that a kernel binds as a storage buffer (every
/// one in the storage kernels; the textures and their texels in the uniform
/// ones, whose other arrays are images) within one storage buffer of the
/// device: an error naming the array and `advice`, where the run's own
/// check would name a binding and say to render a smaller image.
pub fn check_storage_arrays(
    ctx: &GpuContext,
    data: &FrameData,
    uniform: bool,
    advice: StorageAdvice,
) -> Result<(), GpuError> {
    for (binding, what, bytes) in data.scene_buffers() {
        if uniform && layout::UNIFORM_KERNEL_IMAGES.contains(&binding) {
            continue;
        }
        let advice = if binding == layout::BINDING_TEXELS { advice.texels } else { advice.other };
        ctx.check_storage_size(bytes.len() as u64, || format!("the storage buffer of {what}"))
            .map_err(|e| e.with_advice(advice))?;
    }
    Ok(())
}

/// `fits_uniform` on (binding, what, bytes) of each scene buffer.
fn fits_images(sizes: &[(u32, &str, usize)]) -> Result<(), Error> {
    let max = layout::UNIFORM_KERNEL_IMAGE_BYTES;
    match sizes.iter().find(|(binding, _, len)| layout::UNIFORM_KERNEL_IMAGES.contains(binding) && *len > max) {
        None => Ok(()),
        Some((_, what, len)) => Err(Error::Failed(format!(
            "{what} take {len} bytes; the uniform kernels' images hold at most {max} bytes ({} rows of {} texels) an array",
            layout::IMAGE_ROWS,
            layout::IMAGE_WIDTH
        ))),
    }
}

/// A render kernel built for a scene: whether it is render_uniform.comp,
/// the specialization, and the kernel.
type BuiltKernel = ((bool, Specialization), Arc<Kernel>);

/// A Vulkan device with the render kernels, each built and checked on
/// first use for the scenes that need it (so a command compiles only the
/// one its scene needs), specialised for the scene (`Specialization`).
pub struct GpuRenderer {
    // Field order is drop order: the kernels go before their device.
    /// Built so far: (uniform, specialization) and the kernel.
    kernels: Mutex<Vec<BuiltKernel>>,
    /// render.comp's SPIR-V.
    storage: Vec<u8>,
    /// render_uniform.comp's; None when there is none (a --shaders folder
    /// without it).
    uniform: Option<Vec<u8>>,
    context: GpuContext,
    /// Time to check the SPIR-V and build the pipelines so far.
    compile_time: Mutex<Duration>,
    choice: SceneBuffers,
    /// The most bytes of a band's buffers (`set_band_bytes`); None: as
    /// many as the device's storage buffers hold.
    band_bytes: Option<u64>,
}

/// A camera ray's tests past which a pass of a picture is expected to be
/// slow (`slow_pass`): on lavapipe (2 cores) a 512x384 sample takes about
/// 1.5 ms per test, so this is most of a second there.
const SLOW_RAY_TESTS: u64 = 500;

/// Whether one sample of the picture is expected to take long enough
/// (seconds on lavapipe) that its first pass goes to the device in parts,
/// telling its progress, even where the picture is small: a camera ray's
/// tests, guessed as the primitives it tests (every one of them with
/// --no-bvh, else about the hierarchy's depth) times its rays (one, and a
/// shadow ray to each light), pass SLOW_RAY_TESTS. recursiveSpheres4
/// `--no-bvh` (187 spheres, 3 lights: 748) takes 1.1 s at 512x384 on
/// lavapipe, recursive-spheres depth 6 `--no-bvh` (4,687: 18,748) about
/// 50 s; with the hierarchy neither is slow (12 and 16). A part costs a
/// submission: 5 ms of recursiveSpheres4's 76 in eighths.
pub fn slow_pass(data: &FrameData) -> bool {
    let f = &data.frame;
    let tested = if f.flags & layout::FLAG_NO_BVH != 0 {
        data.expanded
    } else {
        u64::from(64 - data.expanded.max(1).leading_zeros())
    };
    let rays = 1 + if f.flags & layout::FLAG_SHADOWS != 0 { u64::from(f.light_count) } else { 0 };
    tested.saturating_mul(rays) > SLOW_RAY_TESTS
}

impl GpuRenderer {
    /// The device of `options` with the embedded render kernels (compiled
    /// as the device's `division` says).
    pub fn new(options: &GpuOptions) -> Result<GpuRenderer, GpuError> {
        let context = GpuContext::new(options)?;
        let storage = kernel_spirv_for(&context, "render").expect("build.rs embeds shaders/render.comp");
        let uniform = kernel_spirv_for(&context, UNIFORM_KERNEL).expect("build.rs embeds shaders/render_uniform.comp");
        Ok(GpuRenderer::with_context(context, storage, Some(uniform)))
    }

    /// `context` with render kernels: render.comp's SPIR-V and, when there
    /// is one, render_uniform.comp's; checked like the embedded ones when
    /// their pipelines are built.
    fn with_context(context: GpuContext, spirv: &[u8], uniform: Option<&[u8]>) -> GpuRenderer {
        GpuRenderer {
            kernels: Mutex::new(Vec::new()),
            storage: spirv.to_vec(),
            uniform: uniform.map(<[u8]>::to_vec),
            context,
            compile_time: Mutex::new(Duration::ZERO),
            choice: SceneBuffers::Auto,
            band_bytes: None,
        }
    }

    /// The device of `options` with the kernels compiled from `dir`
    /// (`--shaders DIR`): its render.comp, and its render_uniform.comp
    /// when it has one.
    pub fn from_shaders(options: &GpuOptions, dir: &std::path::Path) -> Result<GpuRenderer, Error> {
        let context = GpuContext::new(options)?;
        let (spirv, uniform) = super::compile_kernel_pair(dir, "render", context.division())?;
        Ok(GpuRenderer::with_context(context, &spirv, uniform.as_deref()))
    }

    /// Where the scene's arrays go from now on (Auto unless told).
    pub fn set_scene_buffers(&mut self, choice: SceneBuffers) {
        self.choice = choice;
    }

    /// Bands of rows whose pixel and sums buffers take at most `bytes` each
    /// (but at least one tile high), where the device's limit would allow
    /// larger: to test the bands on small pictures. None: the device's limit.
    pub fn set_band_bytes(&mut self, bytes: Option<u64>) {
        self.band_bytes = bytes;
    }

    /// How many rows of `frame`'s picture one dispatch draws: as many
    /// as a storage buffer of the device holds in pixel records and running
    /// sums (or `set_band_bytes`), a whole number of tiles.
    pub fn band_rows(&self, frame: &layout::Frame) -> u32 {
        // The course's scheme's state is the largest record.
        let sums = if frame.flags & layout::FLAG_COURSE_SAMPLING != 0 {
            std::mem::size_of::<layout::CourseSum>()
        } else {
            std::mem::size_of::<layout::SampleSum>()
        };
        let per_row = u64::from(frame.width) * std::mem::size_of::<PixelOut>().max(sums) as u64;
        let limit = self.band_bytes.unwrap_or(u64::MAX).min(self.context.max_storage_bytes());
        let tiles = (limit / per_row.max(1) / u64::from(layout::WORKGROUP_SIZE)).max(1);
        u32::try_from(tiles * u64::from(layout::WORKGROUP_SIZE)).unwrap_or(u32::MAX)
    }

    /// Time spent checking SPIR-V and building pipelines so far.
    pub fn compile_time(&self) -> Duration {
        *self.compile_time.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The kernel for `data`, by the choice made (`set_scene_buffers`):
    /// render_uniform.comp when the scene fits it, else render.comp;
    /// specialised for the scene and its frame flags.
    pub fn kernel_for(&self, data: &FrameData) -> Result<Arc<Kernel>, GpuError> {
        self.kernel_chosen(data, self.wants_uniform(data)?)
    }

    /// The kernel for `data` once `wants_uniform` has chosen.
    fn kernel_chosen(&self, data: &FrameData, want_uniform: bool) -> Result<Arc<Kernel>, GpuError> {
        let key = (want_uniform, Specialization::of(data, &data.frame));
        let mut kernels = self.kernels.lock().unwrap_or_else(|p| p.into_inner());
        if let Some((_, k)) = kernels.iter().find(|(k, _)| *k == key) {
            return Ok(k.clone());
        }
        let (name, spirv, bindings, images) = self.kernel_source(want_uniform)?;
        let start = Instant::now();
        let k = Arc::new(Kernel::specialized(&self.context, name, spirv, &bindings, &images, &key.1.constants())?);
        *self.compile_time.lock().unwrap_or_else(|p| p.into_inner()) += start.elapsed();
        kernels.push((key, k.clone()));
        Ok(k)
    }

    /// What the kernel is built from: its name, SPIR-V, buffer bindings
    /// and images (render_uniform.comp's where `want_uniform`).
    #[allow(clippy::type_complexity)]
    fn kernel_source(
        &self,
        want_uniform: bool,
    ) -> Result<(&'static str, &[u8], Vec<crate::layout::BindingLayout>, Vec<ImageBinding>), GpuError> {
        if !want_uniform {
            return Ok(("render", &self.storage, layout::render_bindings(), Vec::new()));
        }
        let Some(u) = &self.uniform else {
            return Err(uniform_error("there is no render_uniform.comp (in the --shaders folder)".into()));
        };
        Ok((UNIFORM_KERNEL, u, layout::render_uniform_bindings(), layout::uniform_kernel_images()))
    }

    /// The driver's statistics of the kernel `kernel_for` chooses for
    /// `data` (registers, shared memory, occupancy: as the driver names
    /// them), from a pipeline built again to keep them
    /// (`Kernel::for_statistics`); None where the device reports none.
    pub fn kernel_statistics(&self, data: &FrameData) -> Result<Option<Vec<Executable>>, GpuError> {
        let want_uniform = self.wants_uniform(data)?;
        let (name, spirv, bindings, images) = self.kernel_source(want_uniform)?;
        let constants = Specialization::of(data, &data.frame).constants();
        let Some(kernel) = Kernel::for_statistics(&self.context, name, spirv, &bindings, &images, &constants)? else {
            return Ok(None);
        };
        kernel.statistics().map(Some)
    }

    /// Whether `data` is drawn by render_uniform.comp (the choice made,
    /// `set_scene_buffers`, and whether the scene fits it), known before
    /// the kernel is built.
    fn wants_uniform(&self, data: &FrameData) -> Result<bool, GpuError> {
        let fits = fits_uniform(&self.context, data, layout::UNIFORM_KERNEL_IMAGES.len());
        Ok(match self.choice {
            SceneBuffers::Storage => false,
            SceneBuffers::Auto => fits.is_ok() && self.uniform.is_some(),
            SceneBuffers::Uniform => {
                fits.map_err(|e| uniform_error(format!("{e}: use --scene-buffers storage or auto")))?;
                true
            }
        })
    }

    pub fn context(&self) -> &GpuContext {
        &self.context
    }

    /// The frame on the device; an error when the device cut pixels short
    /// (`Renderer::render_frame`, without progress).
    pub fn render(&self, data: &FrameData) -> Result<(Picture, Timings), Error> {
        self.render_frame(data, &|_| {})
    }

    /// `render_marked`, `told` after each submission of samples: the
    /// samples of each band done, over every band's.
    fn render_marked_told(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), GpuError> {
        let f = &data.frame;
        let compiled_before = self.compile_time();
        // An array beyond a storage buffer is refused before the kernel is built.
        let uniform = self.wants_uniform(data)?;
        check_storage_arrays(&self.context, data, uniform, RENDER_STORAGE_ADVICE)?;
        let kernel = self.kernel_chosen(data, uniform)?;
        let scene: Vec<(u32, std::borrow::Cow<[u8]>)> = data
            .scene_buffers()
            .into_iter()
            .map(|(binding, _, bytes)| {
                (binding, if uniform { layout::padded_for_uniform(binding, bytes) } else { bytes.into() })
            })
            .collect();
        let count = f.width as usize * f.height as usize;
        let what = format!("the {}x{} picture's pixels read back from the device", f.width, f.height);
        let mut pixels: Vec<PixelOut> =
            try_with_capacity(count, &what).map_err(|message| GpuError::BadRun { kernel: "render".into(), message })?;
        let mut timings = Timings { on_device: true, ..Timings::default() };
        // Bands of rows where the picture's pixels do not fit one storage buffer.
        let band_rows = self.band_rows(f);
        // Dispatches: one sample of every pixel each, as many as a pixel takes at most.
        let course = f.flags & layout::FLAG_COURSE_SAMPLING != 0;
        let spp = if course { layout::COURSE_MAX_SAMPLES } else { f.spp.max(1) };
        let bands = f.height.div_ceil(band_rows);
        for (band, row_offset) in (0..f.height).step_by(band_rows as usize).enumerate() {
            // `done`: the band's samples done, a fraction where one is partly drawn.
            let tell = |done: f64| {
                let of_bands = if bands > 1 { format!(", band {} of {bands}", band + 1) } else { String::new() };
                told(Progress {
                    fraction: (band as f64 * f64::from(spp) + done) / (f64::from(bands) * f64::from(spp)),
                    detail: format!("sample {} of {spp}{of_bands}", done.ceil()),
                });
            };
            let rows = band_rows.min(f.height - row_offset);
            let frame = layout::Frame { row_offset, ..*f };
            let count = f.width as usize * rows as usize;
            // The course's scheme keeps its state beside the sums; else one record, unused.
            let course_sums = std::mem::size_of::<layout::CourseSum>() * if course { count } else { 1 };
            let mut inputs = vec![(layout::BINDING_FRAME, bytemuck::bytes_of(&frame))];
            inputs.extend(scene.iter().map(|(binding, bytes)| (*binding, bytes.as_ref())));
            let buffers = RunBuffers {
                inputs: &inputs,
                // The samples' running sums start at zero: sample 0 is next.
                cleared: &[
                    (layout::BINDING_SAMPLE_SUMS, count * std::mem::size_of::<layout::SampleSum>()),
                    (layout::BINDING_COURSE_SUMS, course_sums),
                ],
                output: (layout::BINDING_PIXELS, count * std::mem::size_of::<PixelOut>()),
                // Sentinel: a pixel the kernel never wrote reads as NaN t and id 0xffffffff.
                fill: 0xffff_ffff,
            };
            let groups = [f.width.div_ceil(layout::WORKGROUP_SIZE), rows.div_ceil(layout::WORKGROUP_SIZE), 1];
            // One sample of every pixel per dispatch (render.comp).
            // The band's records copied once, from where the device left them.
            let before = pixels.len();
            let read = |bytes: &[u8]| {
                // Read as records wherever the bytes lie (a mapping's alignment is the driver's).
                pixels.extend(
                    bytes.chunks_exact(std::mem::size_of::<PixelOut>()).map(bytemuck::pod_read_unaligned::<PixelOut>),
                );
            };
            let ((), t) = self.context.run_passes_read(&kernel, &buffers, groups, spp, slow_pass(data), read, tell)?;
            // Every pixel the kernel covers counts at least its camera ray, far
            // fewer than the sentinel.
            let unwritten = pixels[before..].iter().filter(|p| p.rays == 0 || p.rays == 0xffff_ffff).count();
            if unwritten > 0 {
                return Err(GpuError::BadRun {
                    kernel: "render".into(),
                    message: format!(
                        "the kernel left {unwritten} of {count} pixels unwritten (rows {row_offset} to {}: the sentinel is still in place)",
                        row_offset + rows - 1
                    ),
                });
            }
            timings.upload += t.upload;
            timings.dispatch += t.dispatch;
            timings.readback += t.readback;
            timings.device = match (band, timings.device, t.device) {
                (0, _, d) => d,
                (_, Some(mut sum), Some(d)) => {
                    sum += d;
                    Some(sum)
                }
                _ => None,
            };
            timings.bands += 1;
        }
        timings.band_rows = band_rows.min(f.height);
        timings.band_bytes = self.context.max_storage_bytes();
        timings.compile = self.compile_time() - compiled_before;
        Ok((Picture { width: f.width, height: f.height, pixels }, timings))
    }
}

impl Renderer for GpuRenderer {
    fn info(&self) -> BackendInfo {
        let info = self.context.info();
        BackendInfo {
            summary: info.summary(),
            name: info.name.clone(),
            label: format!("{} ({})", info.name, info.kind),
            kernels_clause: self.context.division().kernels_clause(),
            cpu_build: false,
            device_on_cpu: info.runs_on_cpu(),
            threads: None,
        }
    }

    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), Error> {
        let (picture, t) = self.render_marked_told(data, told)?;
        refuse_cut_short(&picture.pixels, picture.width, &self.context.info().name, render_advice(data))?;
        Ok((picture, t))
    }

    fn render_marked(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), Error> {
        Ok(self.render_marked_told(data, told)?)
    }

    fn kernel(&self, data: &FrameData) -> Result<Option<KernelInfo>, Error> {
        let compiled_before = self.compile_time();
        let kernel = self.kernel_for(data)?;
        Ok(Some(KernelInfo {
            name: kernel.name().to_string(),
            arrays: if kernel.name() == UNIFORM_KERNEL { "uniform" } else { "storage" },
            // The device's division and square root corrected (raycast.glsl div_rn).
            division: self.context.division().describe().to_string(),
            // A shader object (compiled, or from the binary a run before
            // kept), or a pipeline specialised ahead.
            how_built: kernel.how_built(),
            specialization: Specialization::of(data, &data.frame).describe(),
            build_time: self.compile_time() - compiled_before,
        }))
    }

    fn kernel_statistics(&self, data: &FrameData) -> Result<Option<Vec<Executable>>, Error> {
        Ok(GpuRenderer::kernel_statistics(self, data)?)
    }

    fn device_bytes(&self, data: &FrameData) -> Result<Option<u64>, Error> {
        let uniform = self.wants_uniform(data)?;
        Ok(Some(crate::measure::device_bytes(data, uniform, self.band_rows(&data.frame))))
    }

    fn take_messages(&self) -> Vec<String> {
        self.context.take_validation_messages()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::RenderSettings;

    /// An array past the images' rows is refused by name; a texture (a
    /// storage buffer in every kernel) is not counted.
    #[test]
    fn arrays_past_the_images_do_not_fit() {
        let max = layout::UNIFORM_KERNEL_IMAGE_BYTES;
        assert!(fits_images(&[(layout::BINDING_PRIMITIVES, "the primitives", max)]).is_ok());
        let e = fits_images(&[(layout::BINDING_NODES, "the hierarchy nodes", max + 16)]).unwrap_err().to_string();
        assert_eq!(
            e,
            format!("the hierarchy nodes take {} bytes; the uniform kernels' images hold at most {max} bytes (4096 rows of 4096 texels) an array", max + 16)
        );
        assert!(fits_images(&[(layout::BINDING_TEXELS, "the texels", 2 * max)]).is_ok());
    }

    fn data(xml: &str, settings: &RenderSettings) -> FrameData {
        let scene = crate::scene::from_xml(xml, "t.xml");
        crate::frame::build(&scene, settings).unwrap()
    }

    /// A sample is expected to be slow where a camera ray's tests are many:
    /// --no-bvh over the recursive spheres' 187 at depth 4, not with the
    /// hierarchy at depth 10, nor --no-bvh without shadows over a handful.
    #[test]
    fn slow_passes_are_told_by_the_tests_a_ray_makes() {
        let spheres = |depth: u32, settings: &RenderSettings| {
            let options = crate::gen::GenOptions { texture: None };
            data(&crate::gen::generate(crate::gen::Family::RecursiveSpheres, depth, &options).unwrap(), settings)
        };
        let no_bvh = RenderSettings { bvh: false, ..RenderSettings::default() };
        assert!(slow_pass(&spheres(4, &no_bvh)));
        assert!(!slow_pass(&spheres(10, &RenderSettings::default())));
        let few = RenderSettings { shadows: false, ..no_bvh };
        assert!(!slow_pass(&spheres(2, &few)), "{}", spheres(2, &few).expanded);
    }
}
