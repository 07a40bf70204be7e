//! Rendering a [`FrameData`] on a Vulkan device with the render kernel, and
//! the picture that comes back.

use crate::error::Error;
use crate::frame::FrameData;
use crate::gpu::{Buffer, GpuContext, GpuError, GpuOptions, Kernel, RunBuffers};
use crate::layout::{self, PixelOut};
use crate::preview::layout::PreviewFrame;
use std::ops::Range;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub use crate::gpu::kernel_spirv;

/// The embedded kernel `stem` for `ctx`'s device, compiled as its
/// `division` says (`STEM`, `STEM_gpu` or `STEM_gpu_fma`).
pub fn kernel_spirv_for(ctx: &GpuContext, stem: &str) -> Option<&'static [u8]> {
    kernel_spirv(&format!("{stem}{}", ctx.division().suffix()))
}

/// Every pixel's output: colour (or AOV), t, hit id and normal.
#[derive(Clone, Debug, PartialEq)]
pub struct Picture {
    pub width: u32,
    pub height: u32,
    /// Row-major, row 0 at the top.
    pub pixels: Vec<PixelOut>,
}

/// An empty vector with room for `n` items, or an error naming `what` and
/// the bytes when the memory cannot be had (an absurd picture size), where
/// `Vec::with_capacity` would abort the process.
pub(crate) fn try_with_capacity<T>(n: usize, what: &str) -> Result<Vec<T>, String> {
    let mut v = Vec::new();
    v.try_reserve_exact(n).map_err(|_| {
        let bytes = (n as u128 * std::mem::size_of::<T>() as u128).min(u128::from(u64::MAX)) as u64;
        format!("cannot allocate {} for {what}; render a smaller image", crate::units::fmt_bytes(bytes))
    })?;
    Ok(v)
}

/// `n` copies of `value` (`try_with_capacity`'s error where the memory cannot be had).
pub(crate) fn try_filled<T: Clone>(n: usize, value: T, what: &str) -> Result<Vec<T>, String> {
    let mut v = try_with_capacity(n, what)?;
    v.resize(n, value);
    Ok(v)
}

impl Picture {
    /// 8-bit RGB, row 0 at the top; an error when its memory cannot be had.
    pub fn rgb8(&self) -> Result<Vec<u8>, Error> {
        let what = format!("the {}x{} picture's RGB bytes", self.width, self.height);
        let mut out = try_filled(self.pixels.len() * 3, 0u8, &what)?;
        for (rgb, p) in out.chunks_exact_mut(3).zip(&self.pixels) {
            rgb.copy_from_slice(&p.rgba.to_le_bytes()[..3]);
        }
        Ok(out)
    }

    /// The walk passes of a render in an AOV other than colour
    /// (PixelOut.normal's w: the camera ray's, or with AOV_COST_ALL all the
    /// pixel's rays'), for people, after `what`: their mean, median, 90th
    /// and 99th percentiles and the most, with its pixel.
    pub fn passes_text(&self, what: &str) -> String {
        let Some((most_at, most)) = self.most_passes() else {
            return "cost: no pixels".to_string();
        };
        let mut passes: Vec<u32> = self.pixels.iter().map(|p| p.normal[3] as u32).collect();
        let mean = passes.iter().map(|&n| f64::from(n)).sum::<f64>() / passes.len() as f64;
        passes.sort_unstable();
        let at = |q: usize| passes[(passes.len() - 1) * q / 100];
        let (x, y) = (most_at % self.width as usize, most_at / self.width as usize);
        format!(
            "cost: {what} {mean:.2} passes on average: median {}, 90% at most {}, 99% at most {}, most {most} (pixel ({x}, {y}))",
            at(50),
            at(90),
            at(99)
        )
    }

    /// The most walk passes of any pixel (as `passes_text` reads them) and
    /// the first pixel with them, by index; None without pixels.
    pub fn most_passes(&self) -> Option<(usize, u32)> {
        let passes = self.pixels.iter().map(|p| p.normal[3] as u32).enumerate();
        passes.max_by_key(|&(i, n)| (n, std::cmp::Reverse(i)))
    }

    /// Every ray the frame traced (camera, shadow and mirror): the sum of the pixels' counts.
    pub fn rays(&self) -> u64 {
        self.pixels.iter().map(|p| u64::from(p.rays)).sum()
    }
}

/// How far a frame's render is, told as it goes (`render`'s progress line).
#[derive(Clone, Debug, PartialEq)]
pub struct Progress {
    /// Done, from 0 to 1.
    pub fraction: f64,
    /// What is done, in the backend's steps: "sample 3 of 16", "row 120 of 384".
    pub detail: String,
}

/// Told the progress of a render, from whichever thread does the work.
pub type Told<'a> = &'a (dyn Fn(Progress) + Sync);

/// Renders frames: the one interface of the Vulkan device
/// ([`GpuRenderer`]) and of the CPU build of the same GLSL
/// ([`crate::cpu::CpuRenderer`]). `render`, `check`, `bench` and
/// `conformance` draw through it; what is only a device's (its kernel, its
/// validation layer) they ask of [`GpuRenderer`] itself.
pub trait Renderer {
    /// The backend as status lines name it: the device, or the CPU build with its threads.
    fn describe(&self) -> String;

    /// One frame of `data`, telling its progress as it goes, with where the
    /// time went (the CPU build's frame is all `dispatch`).
    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, GpuTimings), Error>;
}

impl Renderer for GpuRenderer {
    fn describe(&self) -> String {
        self.context.info().summary()
    }

    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, GpuTimings), Error> {
        Ok(self.render_told(data, told)?)
    }
}

/// Draws a picture a sample at a time into running sums it keeps: the
/// preview's way (shaders/preview_main.glsl), where [`Renderer`] draws a
/// whole frame at once. The preview kernel on a device (preview/renderer.rs
/// `PreviewRenderer`) and the CPU build ([`crate::cpu::CpuProgressive`])
/// implement it; the preview window asks whichever draws for each sample,
/// its time and its pixels.
pub trait Progressive {
    /// The backend as status lines name it: the device, or the CPU build with its threads.
    fn describe(&self) -> String;

    /// Adds sample `preview.sample_index` (its jitter in `preview`) of
    /// `frame`'s rows `preview.row_offset` to `row_end`, drawn with `data`'s
    /// scene, into the running sums: those rows' pixels become the average
    /// of the samples so far. `frame` is at most the picture's size. May
    /// return before the sample is drawn: `wait` waits for it.
    fn add_sample(
        &mut self,
        data: &FrameData,
        frame: &layout::Frame,
        preview: &PreviewFrame,
        row_end: u32,
    ) -> Result<(), Error>;

    /// Waits for the sample in flight; the time it took, where known.
    fn wait(&mut self) -> Result<Option<Duration>, Error>;

    /// Copies the bytes `bytes` of the frame's pixels (`PixelOut`s,
    /// frame.width a row) to the same place in `to`.
    fn copy_pixels(&mut self, bytes: Range<usize>, to: &Buffer) -> Result<(), Error>;

    /// How many pixels of the last sample the device cut short (Mesa's loop
    /// budget per invocation: sampling.glsl loop_budget_ok); they are wrong.
    fn cut_short(&mut self) -> Result<u32, Error>;
}

/// Where the time of one frame went (on a device: its upload, dispatch and readback).
#[derive(Clone, Copy, Debug, Default)]
pub struct GpuTimings {
    pub upload: Duration,
    pub dispatch: Duration,
    pub readback: Duration,
    /// The device's own times of its phases, summed over the bands
    /// (`RunTimings::device`); None where its queue has no timestamps.
    pub device: Option<crate::gpu::DevicePhases>,
    /// The dispatches' bands of rows (`GpuRenderer::band_rows`): how many, and the rows of each but the last.
    pub bands: u32,
    pub band_rows: u32,
}

/// The render kernel with the scene's arrays in data images
/// (shaders/render_uniform.comp), by its name.
pub const UNIFORM_KERNEL: &str = "render_uniform";

/// An error of the uniform kernel's choice or build.
fn uniform_error(message: String) -> GpuError {
    GpuError::BadRun { kernel: UNIFORM_KERNEL.into(), message }
}

/// Where render's scene arrays live: the choice between render.comp and
/// render_uniform.comp.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
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
    #[value(alias = "images")]
    Uniform,
}

/// Whether `data`'s arrays fit the uniform kernels' images, and the device
/// binds as many storage images as a uniform kernel declares (`images`: its
/// data images and any picture); else what does not.
pub fn fits_uniform(ctx: &GpuContext, data: &FrameData, images: usize) -> Result<(), Error> {
    let limit = ctx.storage_image_limit();
    if (limit as usize) < images {
        return Err(Error::Failed(format!(
            "{} binds at most {limit} storage images a kernel (maxPerStageDescriptorStorageImages), the uniform kernel {images}",
            ctx.info().name
        )));
    }
    let sizes: Vec<(u32, &str, usize)> =
        data.scene_buffers().iter().map(|&(b, what, bytes)| (b, what, bytes.len())).collect();
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

/// What a kernel built for a scene keeps of the shaders' code: one bool per
/// feature's specialization constant (shaders/layout.h SPEC_*, but for the
/// walk's form), false for what the scene and its frame flags can never
/// reach; and the walk's form (SPEC_LEVELS_IN_REGISTERS, SPEC_REGISTER_LEVELS).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Specialization {
    /// By constant_id; the walk's form's two are unused here.
    keeps: [bool; SPEC_COUNT],
    /// The walk's levels kept in registers, so many, or None: in arrays.
    register_levels: Option<u32>,
}

const SPEC_COUNT: usize = layout::SPEC_COUNT as usize;

/// Whether constant `id` turns a feature's code on or off: every one but the walk's form's two.
#[cfg(test)]
const fn is_feature(id: u32) -> bool {
    id != layout::SPEC_LEVELS_IN_REGISTERS && id != layout::SPEC_REGISTER_LEVELS
}

impl Specialization {
    /// Everything kept, the levels in arrays: the shaders' defaults, what the CPU build runs.
    pub const ALL: Specialization = Specialization { keeps: [true; SPEC_COUNT], register_levels: None };

    /// What rendering `data` with `frame` can reach.
    pub fn of(data: &FrameData, frame: &layout::Frame) -> Specialization {
        SceneFeatures::of(data).specialization(frame)
    }

    /// Whether the CPU build's lean copy (raycast_cpu_lean.cpp) computes
    /// the frame: it leaves out what host/cpu/shared.hpp turns off under
    /// RAYCAST_CPU_LEAN (this list), so it runs only where the frame's
    /// specialization leaves all of that out too; `check` compares its
    /// bits with the device's.
    pub fn cpu_lean(&self) -> bool {
        [
            layout::SPEC_AOVS,
            layout::SPEC_TORI,
            layout::SPEC_MESHES,
            layout::SPEC_COURSE_SAMPLING,
            layout::SPEC_AREA_LIGHTS,
            layout::SPEC_REFRACTION,
        ]
        .iter()
        .all(|&id| !self.keeps[id as usize])
    }

    /// The constants' values for `Kernel::specialized`, by constant_id.
    pub fn constants(&self) -> [u32; SPEC_COUNT] {
        let mut values = [0u32; SPEC_COUNT];
        for (value, &keep) in values.iter_mut().zip(&self.keeps) {
            *value = u32::from(keep);
        }
        values[layout::SPEC_LEVELS_IN_REGISTERS as usize] = u32::from(self.register_levels.is_some());
        values[layout::SPEC_REGISTER_LEVELS as usize] = self.register_levels.unwrap_or(1);
        values
    }

    /// What the kernel keeps and what it leaves out, for people:
    /// "keeps spheres, instances, …; leaves out cubes, …".
    pub fn describe(&self) -> String {
        let names = |on: bool| -> Vec<&str> {
            SPEC_NAMES.iter().filter(|(id, _)| self.keeps[*id as usize] == on).map(|(_, name)| *name).collect()
        };
        let (kept, out) = (names(true), names(false));
        let list = |v: &[&str]| if v.is_empty() { "nothing".to_string() } else { v.join(", ") };
        let levels = match self.register_levels {
            Some(1) => "; the walk's one level in registers".to_string(),
            Some(n) => format!("; the walk's {n} levels in registers"),
            None => String::new(),
        };
        format!("keeps {}; leaves out {}{levels}", list(&kept), list(&out))
    }
}

/// The specialization constants by name, for `Specialization::describe`.
const SPEC_NAMES: &[(u32, &str)] = &[
    (layout::SPEC_CUBES, "cubes"),
    (layout::SPEC_CONES, "cones"),
    (layout::SPEC_CYLINDERS, "cylinders"),
    (layout::SPEC_SPHERES, "spheres"),
    (layout::SPEC_INSTANCES, "instances"),
    (layout::SPEC_POSITIONED_LIGHTS, "point and spot lights"),
    (layout::SPEC_SPOT_LIGHTS, "spot falloff"),
    (layout::SPEC_TEXTURES, "textures"),
    (layout::SPEC_BILINEAR, "bilinear filtering"),
    (layout::SPEC_SPECULAR, "specular"),
    (layout::SPEC_SHADOWS, "shadows"),
    (layout::SPEC_REFLECTIONS, "mirrors"),
    (layout::SPEC_INNER_NODES, "inner hierarchy nodes"),
    (layout::SPEC_SEVERAL_PRIMITIVE_LEAVES, "leaves of several primitives"),
    (layout::SPEC_HIERARCHY, "the hierarchy walk"),
    (layout::SPEC_FLAT_LIST, "the flat primitive list"),
    (layout::SPEC_BOX_RECORDS, "instance boxes"),
    (layout::SPEC_SPHERE_RECORDS, "instance spheres"),
    (layout::SPEC_AOVS, "the normal, depth, id and cost AOVs"),
    (layout::SPEC_TORI, "tori"),
    (layout::SPEC_MESHES, "meshes"),
    (layout::SPEC_REFRACTION, "refraction"),
    (layout::SPEC_AREA_LIGHTS, "area lights"),
    (layout::SPEC_DOF, "depth of field"),
    (layout::SPEC_COURSE_SAMPLING, "the course's adaptive supersampling"),
];

/// What a scene has that the kernels may leave out when it is missing
/// (`Specialization`), apart from the frame's flags. Each test is the
/// shader's own condition over every primitive, light or material, or
/// looser, so a constant is only turned off where the shader never takes
/// that path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SceneFeatures {
    cubes: bool,
    cones: bool,
    cylinders: bool,
    tori: bool,
    /// raycast.glsl intersect_shape's last case: any other shape.
    spheres: bool,
    instances: bool,
    positioned_lights: bool,
    spot_lights: bool,
    area_lights: bool,
    textured: bool,
    specular: bool,
    /// A material with a reflective channel other than 0.
    reflective: bool,
    /// A hierarchy node with children: the walk's inner-node step.
    inner_nodes: bool,
    /// A leaf with more than one primitive: the walk's loop over them
    /// (without a hierarchy the walk tests one primitive a pass).
    several_primitive_leaves: bool,
    /// A hierarchy to walk (frame.node_count > 0); without one the walk
    /// tests the primitives in order.
    hierarchy: bool,
    /// Instance records holding a box, and holding a sphere
    /// (RECORD_SPHERE): the walk's two tests of an instance's bound.
    box_records: bool,
    sphere_records: bool,
    /// The levels the walk enters (FrameData::levels).
    levels: u32,
    /// A mesh primitive (SHAPE_MESH).
    meshes: bool,
}

impl SceneFeatures {
    pub fn of(data: &FrameData) -> SceneFeatures {
        let shape = |s: u32| data.primitives.iter().any(|p| p.shape == s);
        let (cube, cone, cylinder) = (layout::SHAPE_CUBE, layout::SHAPE_CONE, layout::SHAPE_CYLINDER);
        let torus = layout::SHAPE_TORUS;
        SceneFeatures {
            cubes: shape(cube),
            cones: shape(cone),
            cylinders: shape(cylinder),
            tori: shape(torus),
            meshes: shape(layout::SHAPE_MESH),
            spheres: data
                .primitives
                .iter()
                .any(|p| ![cube, cone, cylinder, torus, layout::SHAPE_MESH].contains(&p.shape)),
            instances: !data.instances.is_empty(),
            positioned_lights: data.lights.iter().any(|l| l.kind != layout::LIGHT_DIRECTIONAL),
            spot_lights: data.lights.iter().any(|l| l.kind == layout::LIGHT_SPOT),
            area_lights: data.lights.iter().any(|l| l.kind == layout::LIGHT_AREA),
            textured: data.materials.iter().any(|m| m.texture >= 0),
            specular: data.materials.iter().any(|m| m.shininess > 0.0),
            reflective: data.materials.iter().any(|m| m.reflective[..3].iter().any(|&r| r != 0.0)),
            inner_nodes: data.nodes.iter().any(|n| n.count == 0),
            // Every leaf counts its primitives (the walk reads `count`
            // instead where no instance makes them differ).
            several_primitive_leaves: data.nodes.iter().any(|n| n.count > 0 && n.primitives > 1),
            hierarchy: !data.nodes.is_empty(),
            box_records: record_kind(data, 0),
            sphere_records: record_kind(data, layout::RECORD_SPHERE),
            levels: data.levels,
        }
    }

    /// The kernel for this scene drawn with `frame`'s flags and coefficients.
    pub fn specialization(&self, frame: &layout::Frame) -> Specialization {
        let flag = |f: u32| frame.flags & f != 0;
        let textures = self.textured && flag(layout::FLAG_TEXTURES);
        let mut on = [false; SPEC_COUNT];
        for (id, value) in [
            (layout::SPEC_CUBES, self.cubes),
            (layout::SPEC_CONES, self.cones),
            (layout::SPEC_CYLINDERS, self.cylinders),
            (layout::SPEC_SPHERES, self.spheres),
            (layout::SPEC_INSTANCES, self.instances),
            (layout::SPEC_POSITIONED_LIGHTS, self.positioned_lights),
            (layout::SPEC_SPOT_LIGHTS, self.spot_lights),
            (layout::SPEC_TEXTURES, textures),
            (layout::SPEC_BILINEAR, textures && frame.texture_filter != layout::FILTER_NEAREST),
            (layout::SPEC_SPECULAR, self.specular),
            (layout::SPEC_SHADOWS, flag(layout::FLAG_SHADOWS)),
            // radiance: a mirror weight k_s O_r with a channel other than 0
            // (kept, too, where the product underflows to 0).
            (layout::SPEC_REFLECTIONS, flag(layout::FLAG_REFLECTIONS) && self.reflective && frame.k[2] != 0.0),
            (layout::SPEC_INNER_NODES, self.inner_nodes),
            (layout::SPEC_SEVERAL_PRIMITIVE_LEAVES, self.several_primitive_leaves),
            (layout::SPEC_HIERARCHY, self.hierarchy),
            (layout::SPEC_FLAT_LIST, !self.hierarchy),
            (layout::SPEC_BOX_RECORDS, self.box_records),
            (layout::SPEC_SPHERE_RECORDS, self.sphere_records),
            (layout::SPEC_AOVS, frame.aov != layout::AOV_COLOR),
            (layout::SPEC_TORI, self.tori),
            (layout::SPEC_MESHES, self.meshes),
            (layout::SPEC_COURSE_SAMPLING, flag(layout::FLAG_COURSE_SAMPLING)),
            // frame.rs sets FLAG_REFRACTION only where a material transmits.
            (layout::SPEC_REFRACTION, flag(layout::FLAG_REFRACTION)),
            (layout::SPEC_AREA_LIGHTS, self.area_lights),
            (layout::SPEC_DOF, flag(layout::FLAG_DOF)),
        ] {
            on[id as usize] = value;
        }
        // The walk's levels in registers, as many as the scene has (layout.h;
        // frame.rs refuses a scene nested MAX_LEVELS deep or more, and a
        // count below the scene's would drop its deeper levels).
        debug_assert!((1..=layout::MAX_LEVELS).contains(&self.levels), "{} levels", self.levels);
        let register_levels = Some(self.levels.max(1));
        Specialization { keeps: on, register_levels }
    }
}

/// Whether a leaf holds an instance record whose RECORD_SPHERE bit is
/// `bit` (layout.h, BvhNode: the records follow the leaf's primitives
/// from the next multiple of 4).
fn record_kind(data: &FrameData, bit: u32) -> bool {
    data.nodes.iter().filter(|n| n.count > n.primitives).any(|n| {
        let records = (n.first + n.primitives).next_multiple_of(4);
        (0..n.count - n.primitives)
            .any(|r| data.leaf_items[(records + 4 * r + 3) as usize].item & layout::RECORD_SPHERE == bit)
    })
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

/// What to do about pixels cut short, for the commands that render
/// `data`: the settings of its frame that spend the loop budget (mirror
/// bounces where its kernel keeps mirrors), then another device.
pub fn render_advice(data: &FrameData) -> String {
    let f = &data.frame;
    let mirrors = Specialization::of(data, f).constants().get(layout::SPEC_REFLECTIONS as usize) == Some(&1);
    let mut ways: Vec<String> = Vec::new();
    if f.flags & layout::FLAG_NO_BVH != 0 {
        ways.push("drop --no-bvh".into());
    }
    if f.flags & layout::FLAG_SHADOWS != 0 && f.light_count > 1 {
        ways.push(format!(
            "render with --no-shadows (each hit sends a shadow ray to each of {} lights)",
            f.light_count
        ));
    }
    if mirrors && f.max_depth > 1 {
        ways.push(format!("use a smaller --depth than {}", f.max_depth));
    }
    ways.push("use another Vulkan device".into());
    let last = ways.pop().unwrap_or_default();
    let ways = if ways.is_empty() { last } else { format!("{}, or {last}", ways.join(", ")) };
    format!("`raycast render` finishes such pixels with the CPU build (the same code; on lavapipe the same bits); here, {ways}")
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

/// An error when the kernel marked pixels whose loops the device ended
/// early (raycast.glsl loop_budget_ok): such a picture is wrong.
pub fn refuse_cut_short(pixels: &[PixelOut], width: u32, device: &str, advice: String) -> Result<(), GpuError> {
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
        let (spirv, uniform) = crate::gpu::compile_kernel_pair(dir, "render", context.division())?;
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
    ) -> Result<(&'static str, &[u8], Vec<crate::layout::BindingLayout>, Vec<crate::gpu::ImageBinding>), GpuError> {
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
    pub fn kernel_statistics(&self, data: &FrameData) -> Result<Option<Vec<crate::gpu::Executable>>, GpuError> {
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
    /// (`refuse_cut_short`).
    pub fn render(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        self.render_told(data, &|_| {})
    }

    /// `render`, `told` its progress (`render_marked_told`).
    pub fn render_told(&self, data: &FrameData, told: Told) -> Result<(Picture, GpuTimings), GpuError> {
        let (picture, t) = self.render_marked_told(data, told)?;
        refuse_cut_short(&picture.pixels, picture.width, &self.context.info().name, render_advice(data))?;
        Ok((picture, t))
    }

    /// The frame as the device computed it, pixels it cut short still
    /// marked (RAYS_CUT_SHORT in `rays`): for `finish_cut_short`.
    pub fn render_marked(&self, data: &FrameData) -> Result<(Picture, GpuTimings), GpuError> {
        self.render_marked_told(data, &|_| {})
    }

    /// `render_marked`, `told` after each submission of samples: the
    /// samples of each band done, over every band's.
    pub fn render_marked_told(&self, data: &FrameData, told: Told) -> Result<(Picture, GpuTimings), GpuError> {
        let f = &data.frame;
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
        let mut timings = GpuTimings::default();
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
        Ok((Picture { width: f.width, height: f.height, pixels }, timings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{Aov, RenderSettings};

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

    /// The advice for pixels cut short names what spends the loop budget in
    /// this frame: --no-bvh where given, shadows where several lights cast
    /// them, mirror bounces where the scene has a mirror, then another device.
    #[test]
    fn cut_short_advice_names_what_spends_the_budget() {
        let lights = r#"<lightdata><id v="0"/><position x="0" y="4" z="0"/></lightdata>
          <lightdata><id v="1"/><position x="4" y="4" z="0"/></lightdata>"#;
        let scene = |reflective: &str| {
            format!(
                r#"<scenefile>{lights}<object type="tree" name="root"><transblock><object type="primitive" name="cube">
                <reflective r="{reflective}" g="0" b="0"/></object></transblock></object></scenefile>"#
            )
        };
        let all = render_advice(&data(&scene("0.5"), &RenderSettings::default()));
        assert!(
            all.ends_with(
                "here, render with --no-shadows (each hit sends a shadow ray to each of 2 lights), use a smaller \
                 --depth than 4, or use another Vulkan device"
            ),
            "{all}"
        );
        assert!(!all.contains("--no-bvh"), "{all}");
        let no_bvh = RenderSettings { bvh: false, shadows: false, ..RenderSettings::default() };
        let a = render_advice(&data(&scene("0"), &no_bvh));
        assert!(a.ends_with("here, drop --no-bvh, or use another Vulkan device"), "{a}");
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

    /// The features' constants that are on, by SPEC_* name.
    fn on(s: Specialization) -> Vec<u32> {
        (0..SPEC_COUNT as u32).filter(|&id| is_feature(id) && s.constants()[id as usize] == 1).collect()
    }

    /// A constant is on exactly when the scene and the flags can reach its
    /// code: shapes, instances, light kinds, textures, filters, specular,
    /// shadows, mirrors, inner hierarchy nodes, leaves of several
    /// primitives, and the hierarchy or the flat list, each turned off where
    /// absent.
    #[test]
    fn specialization_keeps_what_the_scene_can_reach() {
        let plain = r#"<scenefile><globaldata><specularcoeff v="0.5"/></globaldata>
          <lightdata><id v="0"/><type v="directional"/><direction x="0" y="-1" z="0"/></lightdata>
          <object type="tree" name="root"><transblock><object type="primitive" name="cube">
            <reflective r="0" g="0.5" b="0"/></object></transblock></object></scenefile>"#;
        let d = data(plain, &RenderSettings::default());
        assert_eq!(
            on(Specialization::of(&d, &d.frame)),
            [layout::SPEC_CUBES, layout::SPEC_SHADOWS, layout::SPEC_REFLECTIONS, layout::SPEC_FLAT_LIST]
        );
        let flat = RenderSettings { shadows: false, reflections: false, ..RenderSettings::default() };
        let d = data(plain, &flat);
        assert_eq!(on(Specialization::of(&d, &d.frame)), [layout::SPEC_CUBES, layout::SPEC_FLAT_LIST]);

        let rich = r#"<scenefile><globaldata><specularcoeff v="0"/></globaldata>
          <lightdata><id v="0"/><type v="spot"/><direction x="0" y="-1" z="0"/><angle v="30"/><penumbra v="5"/></lightdata>
          <object type="tree" name="m"><transblock><object type="primitive" name="cone">
            <reflective r="1" g="1" b="1"/><shininess v="20"/></object></transblock></object>
          <object type="tree" name="root">
            <transblock><object type="primitive" name="sphere"/></transblock>
            <transblock><object type="primitive" name="cylinder"/></transblock>
            <transblock><translate x="2" y="0" z="0"/><object type="master" name="m"/></transblock>
            <transblock><translate x="4" y="0" z="0"/><object type="master" name="m"/></transblock></object></scenefile>"#;
        let d = data(rich, &RenderSettings::default());
        let s = on(Specialization::of(&d, &d.frame));
        // k_s = 0: no mirror weight, so no reflections; no texture.
        let expect = [
            layout::SPEC_CONES,
            layout::SPEC_CYLINDERS,
            layout::SPEC_SPHERES,
            layout::SPEC_INSTANCES,
            layout::SPEC_POSITIONED_LIGHTS,
            layout::SPEC_SPOT_LIGHTS,
            layout::SPEC_SPECULAR,
            layout::SPEC_SHADOWS,
            layout::SPEC_SEVERAL_PRIMITIVE_LEAVES,
            layout::SPEC_HIERARCHY,
            layout::SPEC_SPHERE_RECORDS,
        ];
        assert_eq!(s, expect);
        assert_ne!(Specialization::of(&d, &d.frame), Specialization::ALL);
        assert_eq!(
            Specialization::of(&d, &d.frame).describe(),
            "keeps cones, cylinders, spheres, instances, point and spot lights, spot falloff, specular, shadows, \
             leaves of several primitives, the hierarchy walk, instance spheres; leaves out cubes, textures, bilinear filtering, \
             mirrors, inner hierarchy nodes, the flat primitive list, instance boxes, the normal, depth, id and cost AOVs, tori, meshes, \
             refraction, area lights, depth of field, the course's adaptive supersampling; the walk's 2 levels in registers"
        );
        // The CPU build's lean copy draws it; never everything.
        assert!(Specialization::of(&d, &d.frame).cpu_lean());
        assert!(!Specialization::ALL.cpu_lean());
        // An AOV other than colour keeps its code, and the CPU build's whole copy draws it.
        for aov in [Aov::Normal, Aov::Depth, Aov::Id, Aov::Cost, Aov::CostAll] {
            let d = data(rich, &RenderSettings { aov, ..RenderSettings::default() });
            assert!(on(Specialization::of(&d, &d.frame)).contains(&layout::SPEC_AOVS), "{aov:?}");
            assert!(!Specialization::of(&d, &d.frame).cpu_lean(), "{aov:?}");
        }
        // Each group of `rich` fits one leaf; twenty cubes in a row do not.
        let d = data(&crate::scene::row_of_cubes_xml(20), &RenderSettings::default());
        assert!(d.nodes.iter().any(|n| n.count == 0), "twenty primitives make inner nodes");
        assert!(on(Specialization::of(&d, &d.frame)).contains(&layout::SPEC_INNER_NODES));
        // One sphere and its child instances in each group's one leaf: neither.
        let options = crate::gen::GenOptions { texture: None };
        let spheres = crate::gen::generate(crate::gen::Family::RecursiveSpheres, 3, &options).unwrap();
        let d = data(&spheres, &RenderSettings::default());
        let s = on(Specialization::of(&d, &d.frame));
        assert!(!s.contains(&layout::SPEC_INNER_NODES) && !s.contains(&layout::SPEC_SEVERAL_PRIMITIVE_LEAVES), "{s:?}");
        // Their instances are bounded by spheres; a long thin one by its box.
        assert!(s.contains(&layout::SPEC_SPHERE_RECORDS) && !s.contains(&layout::SPEC_BOX_RECORDS), "{s:?}");
        let plank = r#"<scenefile><object type="tree" name="m"><transblock><object type="primitive" name="cube"/></transblock></object>
          <object type="tree" name="root"><transblock><scale x="10" y="0.1" z="0.1"/><object type="master" name="m"/></transblock></object></scenefile>"#;
        let d = data(plank, &RenderSettings::default());
        let s = on(Specialization::of(&d, &d.frame));
        assert!(s.contains(&layout::SPEC_BOX_RECORDS) && !s.contains(&layout::SPEC_SPHERE_RECORDS), "{s:?}");
        assert!(Specialization::ALL.describe().ends_with("leaves out nothing"));
        // Every feature's constant has its name, once.
        let mut ids: Vec<u32> = SPEC_NAMES.iter().map(|(id, _)| *id).collect();
        ids.sort();
        assert_eq!(ids, (0..SPEC_COUNT as u32).filter(|&id| is_feature(id)).collect::<Vec<_>>());
    }

    /// FLAG_REFRACTION and SPEC_REFRACTION: on only where a material lets
    /// light through (k_t O_t has a channel other than 0) and refraction is
    /// not turned off; a transparent colour with k_t = 0, or k_t with no
    /// transparent colour, keeps the opaque kernel.
    #[test]
    fn refraction_is_kept_only_where_a_material_transmits() {
        let scene = |kt: &str, transparent: &str| {
            format!(
                r#"<scenefile><globaldata><transparentcoeff v="{kt}"/></globaldata><object type="tree" name="root">
                  <transblock><object type="primitive" name="sphere"><transparent r="{transparent}" g="0" b="0"/><ior v="1.5"/></object></transblock>
                  </object></scenefile>"#
            )
        };
        for (kt, transparent, settings, want) in [
            ("0.5", "0.8", RenderSettings::default(), true),
            ("0.5", "0.8", RenderSettings { refraction: false, ..RenderSettings::default() }, false),
            ("0", "0.8", RenderSettings::default(), false),
            ("0.5", "0", RenderSettings::default(), false),
        ] {
            let d = data(&scene(kt, transparent), &settings);
            assert_eq!(d.frame.flags & layout::FLAG_REFRACTION != 0, want, "k_t {kt}, O_t {transparent}, {settings:?}");
            let s = on(Specialization::of(&d, &d.frame));
            assert_eq!(s.contains(&layout::SPEC_REFRACTION), want, "k_t {kt}, O_t {transparent}: {s:?}");
        }
    }

    /// A kernel specialised for a scene keeps the walk's levels in
    /// registers, as many as the scene nests (layout.h); `ALL`, in arrays.
    #[test]
    fn specialization_chooses_the_walks_form_by_the_levels() {
        let levels = |depth: u32| {
            let options = crate::gen::GenOptions { texture: None };
            let xml = crate::gen::generate(crate::gen::Family::RecursiveSpheres, depth, &options).unwrap();
            let d = data(&xml, &RenderSettings::default());
            let c = Specialization::of(&d, &d.frame).constants();
            (d.levels, c[layout::SPEC_LEVELS_IN_REGISTERS as usize], c[layout::SPEC_REGISTER_LEVELS as usize])
        };
        // Depth N: the root and N - 1 masters nested.
        assert_eq!(levels(1), (1, 1, 1));
        assert_eq!(levels(4), (4, 1, 4));
        assert_eq!(levels(10), (10, 1, 10));
        let d = data(&crate::scene::row_of_cubes_xml(20), &RenderSettings::default());
        assert_eq!(d.levels, 1);
        assert!(Specialization::of(&d, &d.frame).describe().ends_with("; the walk's one level in registers"));
        assert_eq!(Specialization::ALL.constants()[layout::SPEC_LEVELS_IN_REGISTERS as usize], 0);
    }
}
