//! Rendering a [`FrameData`] on a Vulkan device with the render kernel, and
//! the picture that comes back.

use crate::cpu::CpuRenderer;
use crate::frame::FrameData;
use crate::gpu::{GpuContext, GpuError, GpuOptions, Kernel};
use crate::layout::{self, PixelOut};
use std::sync::{Mutex, OnceLock};
use std::time::{Duration, Instant};

/// The render kernel's SPIR-V, compiled from shaders/render.comp at build time.
pub fn render_spirv() -> &'static [u8] {
    kernel_spirv("render").expect("build.rs embeds shaders/render.comp")
}

include!(concat!(env!("OUT_DIR"), "/kernels.rs"));

/// A kernel of shaders/*.comp by file stem, as embedded at build time.
pub fn kernel_spirv(stem: &str) -> Option<&'static [u8]> {
    EMBEDDED_KERNELS.iter().find(|(name, _)| *name == stem).map(|(_, spv)| *spv)
}

/// Every pixel's output: colour (or AOV), t, hit id and normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<PixelOut>,
}

impl Picture {
    /// 8-bit RGB, row 0 at the top.
    pub fn rgb8(&self) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| {
                let [r, g, b, _] = p.rgba.to_le_bytes();
                [r, g, b]
            })
            .collect()
    }

    /// Every ray the frame traced (camera, shadow and mirror): the sum of the pixels' counts.
    pub fn rays(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.rays)).sum()
    }
}

/// Where the time of one GPU render went.
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuTimings {
    pub upload: Duration,
    pub dispatch: Duration,
    pub readback: Duration,
}

/// The render kernel with the scene's small arrays in uniform buffers
/// (shaders/render_uniform.comp), by its name.
pub const UNIFORM_KERNEL: &str = "render_uniform";

/// Where render's scene arrays live: the choice between render.comp and
/// render_uniform.comp.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum SceneBuffers {
    /// Uniform buffers when the scene fits them, storage buffers otherwise.
    #[default]
    Auto,
    /// Storage buffers (render.comp): any size.
    Storage,
    /// Uniform buffers (render_uniform.comp): an error when the scene does not fit.
    Uniform,
}

/// Whether `data`'s arrays fit render_uniform.comp's uniform blocks; else
/// what does not.
pub fn fits_uniform(data: &FrameData) -> Result<(), String> {
    let counts = [
        ("primitives", data.primitives.len(), layout::UNIFORM_PRIMITIVES),
        ("materials", data.materials.len(), layout::UNIFORM_MATERIALS),
        ("lights", data.lights.len(), layout::UNIFORM_LIGHTS),
        ("hierarchy nodes", data.nodes.len(), layout::UNIFORM_NODES),
        ("instances", data.instances.len(), layout::UNIFORM_INSTANCES),
    ];
    match counts.iter().find(|(_, n, max)| *n > *max as usize) {
        None => Ok(()),
        Some((what, n, max)) => Err(format!("the scene has {n} {what}; uniform buffers hold at most {max}")),
    }
}

/// A Vulkan device with the render kernels, each built and checked on
/// first use (so a command compiles only the one its scene needs).
pub struct GpuRenderer {
    // Field order is drop order: the kernels go before their device.
    /// render.comp's SPIR-V and kernel.
    storage: (Vec<u8>, OnceLock<Kernel>),
    /// render_uniform.comp's; None when there is none (a --shaders folder
    /// without it).
    uniform: Option<(Vec<u8>, OnceLock<Kernel>)>,
    context: GpuContext,
    /// Time to check the SPIR-V and build the pipelines so far.
    compile_time: Mutex<Duration>,
    choice: SceneBuffers,
}

/// Recomputes with the CPU build the pixels of `picture` (a render of
/// `data`) that the device cut short; returns how many. The CPU build runs
/// the same shader code: on lavapipe, the only device known to cut pixels
/// short, its pixels are the device's bit for bit (what `raycast check`
/// and CI compare), so the finished picture is the one the device would
/// have made without its limit.
pub fn finish_cut_short(picture: &mut Picture, data: &FrameData, cpu: &CpuRenderer) -> usize {
    let width = picture.width as usize;
    let rows: Vec<u32> = picture
        .pixels
        .chunks(width)
        .enumerate()
        .filter(|(_, row)| row.iter().any(PixelOut::is_cut_short))
        .map(|(i, _)| i as u32)
        .collect();
    let mut count = 0;
    for (row, cpu_row) in rows.iter().zip(cpu.render_rows(data, &rows)) {
        let device_row = &mut picture.pixels[*row as usize * width..][..width];
        for (d, c) in device_row.iter_mut().zip(cpu_row) {
            if d.is_cut_short() {
                *d = c;
                count += 1;
            }
        }
    }
    count
}

/// What to do about pixels cut short, for the commands that render a frame.
pub const RENDER_ADVICE: &str = "`raycast render` finishes such pixels with the CPU build (the same code; on lavapipe the same \
     bits); here, drop --no-bvh, use a smaller --depth, or another Vulkan device";

/// An error when the kernel marked pixels whose loops the device ended
/// early (raycast.glsl loop_budget_ok): such a picture is wrong.
pub fn refuse_cut_short(pixels: &[PixelOut], width: u32, device: &str, advice: &'static str) -> Result<(), GpuError> {
    let Some(first) = pixels.iter().position(PixelOut::is_cut_short) else { return Ok(()) };
    let first = first as u32;
    Err(GpuError::CutShort {
        device: device.to_string(),
        count: pixels.iter().filter(|p| p.is_cut_short()).count(),
        total: pixels.len(),
        first: (first % width, first / width),
        advice,
    })
}

impl GpuRenderer {
    /// The device of `options` with the embedded render kernels.
    pub fn new(options: &GpuOptions) -> Result<GpuRenderer, GpuError> {
        let uniform = kernel_spirv(UNIFORM_KERNEL).expect("build.rs embeds shaders/render_uniform.comp");
        GpuRenderer::with_spirv(options, render_spirv(), Some(uniform))
    }

    /// The device of `options` with render kernels of the caller's (for
    /// example compiled from `--shaders DIR`): render.comp's and, when
    /// there is one, render_uniform.comp's; checked like the embedded ones.
    pub fn with_spirv(options: &GpuOptions, spirv: &[u8], uniform: Option<&[u8]>) -> Result<GpuRenderer, GpuError> {
        Ok(GpuRenderer {
            storage: (spirv.to_vec(), OnceLock::new()),
            uniform: uniform.map(|u| (u.to_vec(), OnceLock::new())),
            context: GpuContext::new(options)?,
            compile_time: Mutex::new(Duration::ZERO),
            choice: SceneBuffers::Auto,
        })
    }

    /// The device of `options` with the kernels compiled from `dir`
    /// (`--shaders DIR`): its render.comp, and its render_uniform.comp
    /// when it has one.
    pub fn from_shaders(options: &GpuOptions, dir: &std::path::Path) -> Result<GpuRenderer, String> {
        let spirv = crate::gpu::compile_kernel(&dir.join("render.comp"))?;
        let uniform_src = dir.join("render_uniform.comp");
        let uniform = if uniform_src.is_file() { Some(crate::gpu::compile_kernel(&uniform_src)?) } else { None };
        GpuRenderer::with_spirv(options, &spirv, uniform.as_deref()).map_err(|e| e.to_string())
    }

    /// Where the scene's arrays go from now on (Auto unless told).
    pub fn with_scene_buffers(mut self, choice: SceneBuffers) -> GpuRenderer {
        self.choice = choice;
        self
    }

    /// Time spent checking SPIR-V and building pipelines so far.
    pub fn compile_time(&self) -> Duration {
        *self.compile_time.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The kernel for `data`, by the choice made (`with_scene_buffers`):
    /// render_uniform.comp when the scene fits it, else render.comp.
    pub fn kernel_for(&self, data: &FrameData) -> Result<&Kernel, GpuError> {
        let bad = |message: String| GpuError::BadRun { kernel: UNIFORM_KERNEL.into(), message };
        let fits = fits_uniform(data);
        let want_uniform = match self.choice {
            SceneBuffers::Storage => false,
            SceneBuffers::Auto => fits.is_ok() && self.uniform.is_some(),
            SceneBuffers::Uniform => {
                fits.map_err(|e| bad(format!("{e}: use --scene-buffers storage or auto")))?;
                true
            }
        };
        let (name, (spirv, cell), bindings) = if want_uniform {
            let Some(u) = &self.uniform else {
                return Err(bad("there is no render_uniform.comp (in the --shaders folder)".into()));
            };
            (UNIFORM_KERNEL, u, layout::render_uniform_bindings())
        } else {
            ("render", &self.storage, layout::render_bindings())
        };
        if let Some(k) = cell.get() {
            return Ok(k);
        }
        let start = Instant::now();
        let k = Kernel::new(&self.context, name, spirv, &bindings)?;
        *self.compile_time.lock().unwrap_or_else(|p| p.into_inner()) += start.elapsed();
        Ok(cell.get_or_init(|| k))
    }

    pub fn context(&self) -> &GpuContext {
        &self.context
    }

    /// The frame on the device; an error when the device cut pixels short
    /// (`refuse_cut_short`).
    pub fn render(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        let (picture, t) = self.render_marked(data)?;
        refuse_cut_short(&picture.pixels, picture.width, &self.context.info().name, RENDER_ADVICE)?;
        Ok((picture, t))
    }

    /// The frame as the device computed it, pixels it cut short still
    /// marked (RAYS_CUT_SHORT in `rays`): for `finish_cut_short`.
    pub fn render_marked(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        let f = &data.frame;
        let count = f.width as usize * f.height as usize;
        let groups = [f.width.div_ceil(layout::WORKGROUP_SIZE), f.height.div_ceil(layout::WORKGROUP_SIZE), 1];
        let kernel = self.kernel_for(data)?;
        // A uniform block's buffer holds its whole declared array (zeros past the scene's own).
        let uniform = kernel.name() == UNIFORM_KERNEL;
        let scene: Vec<(u32, std::borrow::Cow<[u8]>)> = data
            .scene_buffers()
            .into_iter()
            .map(|(binding, _, bytes)| (binding, if uniform { layout::padded_for_uniform(binding, bytes) } else { bytes.into() }))
            .collect();
        let mut inputs = vec![(layout::BINDING_FRAME, bytemuck::bytes_of(&data.frame))];
        inputs.extend(scene.iter().map(|(binding, bytes)| (*binding, bytes.as_ref())));
        // The samples' running sums start at zero: sample 0 is next.
        let sums = vec![0u8; count * std::mem::size_of::<layout::SampleSum>()];
        inputs.push((layout::BINDING_SAMPLE_SUMS, &sums));
        let (bytes, t) = self.context.run_passes(
            kernel,
            &inputs,
            (layout::BINDING_PIXELS, count * std::mem::size_of::<PixelOut>()),
            // Sentinel: a pixel the kernel never wrote reads as NaN t and id 0xffffffff.
            0xffff_ffff,
            groups,
            // One sample of every pixel per dispatch (render.comp).
            f.spp.max(1),
        )?;
        let pixels: Vec<PixelOut> = bytemuck::pod_collect_to_vec(&bytes);
        // Every pixel the kernel covers counts at least its camera ray, far
        // fewer than the sentinel.
        let unwritten = pixels.iter().filter(|p| p.rays == 0 || p.rays == 0xffff_ffff).count();
        if unwritten > 0 {
            return Err(GpuError::BadRun {
                kernel: "render".into(),
                message: format!("the kernel left {unwritten} of {count} pixels unwritten (the sentinel is still in place)"),
            });
        }
        let timings = GpuTimings { upload: t.upload, dispatch: t.dispatch, readback: t.readback };
        Ok((Picture { width: f.width, height: f.height, pixels }, timings))
    }
}
