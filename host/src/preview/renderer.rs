//! The preview kernel on a device: its buffers and display image, a
//! swapchain, and one frame at a time. Everything Vulkan is the gpu part's;
//! this only says which buffer goes to which binding of preview.comp, and,
//! when the CPU build or another device (`apart`) draws the samples, hands
//! their pixels to the kernel that shows them. Whichever draws, it draws
//! through `render::Progressive`, which this renderer implements too.

use std::ops::Range;
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::error::Error;
use crate::frame::FrameData;
use crate::gpu::{
    Buffer, DataImage, DescriptorSet, FrameLoop, FrameStatus, GpuContext, GpuError, Kernel, PresentMode, Resource,
    StorageImage, Swapchain,
};
use crate::layout::{
    self, preview_bindings, preview_images, preview_uniform_bindings, preview_uniform_images, AccumPixel, Frame,
    PixelOut, PreviewFrame, PreviewStatus, BINDING_ACCUM, BINDING_DISPLAY, BINDING_PREVIEW, BINDING_STATUS,
    SPEC_HOST_PIXELS,
};
use crate::render::{Progressive, SceneFeatures, Specialization};

// The preview kernel's own constant follows the render kernel's (preview.h,
// SPEC_COUNT): `build` pushes its value after theirs.
const _: () = assert!(SPEC_HOST_PIXELS == layout::SPEC_COUNT);

/// The preview kernel's SPIR-V with the scene in storage buffers
/// (preview.comp) and, where there is one, with its arrays in data images
/// (preview_uniform.comp), used for scenes that fit them. Checked
/// when made; the renderer builds the one a scene needs, specialised for it
/// and the frame's flags (`Specialization`).
pub struct PreviewKernels {
    storage: Vec<u8>,
    uniform: Option<Vec<u8>>,
}

impl PreviewKernels {
    /// Checked SPIR-V (naga: the bindings and struct layouts against the host's).
    pub fn new(storage: &[u8], uniform: Option<&[u8]>) -> Result<PreviewKernels, GpuError> {
        Kernel::check("preview", storage, &preview_bindings(), &preview_images())?;
        if let Some(u) = uniform {
            Kernel::check("preview_uniform", u, &preview_uniform_bindings(), &preview_uniform_images())?;
        }
        Ok(PreviewKernels { storage: storage.to_vec(), uniform: uniform.map(<[u8]>::to_vec) })
    }

    /// The embedded kernels (shaders/preview*.comp, compiled at build time)
    /// for `ctx`'s device (`gpu::kernel_spirv_for`).
    pub fn embedded(ctx: &GpuContext) -> Result<PreviewKernels, GpuError> {
        let storage = crate::gpu::kernel_spirv_for(ctx, "preview").expect("build.rs embeds shaders/preview.comp");
        PreviewKernels::new(storage, crate::gpu::kernel_spirv_for(ctx, "preview_uniform"))
    }

    /// The uniform kernel (data images) when `uniform` (the scene's arrays
    /// are laid out for it: `SceneBuffers`) and there is one, else the
    /// storage one, built for `key` (with HOST_PIXELS, it only shows the
    /// pixels the host drew).
    fn build(&self, ctx: &GpuContext, key: KernelKey) -> Result<Kernel, GpuError> {
        let KernelKey { uniform, spec, host_pixels } = key;
        let mut constants = spec.constants().to_vec();
        constants.push(u32::from(host_pixels));
        match &self.uniform {
            Some(u) if uniform => Kernel::specialized(
                ctx,
                "preview_uniform",
                u,
                &preview_uniform_bindings(),
                &preview_uniform_images(),
                &constants,
            ),
            _ => Kernel::specialized(ctx, "preview", &self.storage, &preview_bindings(), &preview_images(), &constants),
        }
    }
}

/// The scene's arrays (FrameData::scene_buffers) on the device, by
/// binding: each array once, as a data image where preview_uniform.comp
/// draws the scene and reads it as one, else as a buffer. Where the CPU
/// build draws and an array is beyond one storage buffer of the device,
/// every array is bound empty instead (the kernel only shows the CPU
/// build's pixels), and the device cannot draw this scene.
struct SceneBuffers {
    buffers: Vec<(u32, Buffer)>,
    /// When preview_uniform.comp draws the scene: the arrays it reads from
    /// storage images (`layout::UNIFORM_KERNEL_IMAGES`), by binding.
    images: Vec<(u32, DataImage)>,
    /// preview_uniform.comp draws the scene: there is one, the scene fits
    /// its blocks, and the arrays it reads as uniform blocks are padded to
    /// their declared size.
    uniform: bool,
    /// What the kernel for it needs (with the frame's flags).
    features: SceneFeatures,
    /// Why the arrays are bound empty: the array beyond a storage buffer of
    /// the device, and its size (`check_storage_arrays`).
    left_off: Option<String>,
}

/// What a device does with the scene: what its arrays on it are for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    /// Its kernel draws: an array beyond one storage buffer is the error.
    Draws,
    /// The CPU build draws, and the device may later (B, an edit): such an
    /// array leaves them all off it (`left_off`).
    MayDraw,
    /// Another device draws (`apart`); this one only shows the pixels, and
    /// the arrays stay off it.
    ShowsOnly,
}

impl Role {
    /// The role of a device that another one apart from it draws for
    /// (`apart`: the window's device), and where the CPU build draws.
    fn of(apart: bool, cpu_draws: bool) -> Role {
        match (apart, cpu_draws) {
            (true, _) => Role::ShowsOnly,
            (false, true) => Role::MayDraw,
            (false, false) => Role::Draws,
        }
    }
}

impl SceneBuffers {
    /// `data`'s arrays, as `role` wants them: for the uniform kernel when
    /// `has_uniform` (the kernels include one) and the scene fits it, else
    /// for preview.comp; or bound empty (`left_off`).
    fn new(ctx: &GpuContext, data: &FrameData, has_uniform: bool, role: Role) -> Result<SceneBuffers, GpuError> {
        let uniform = has_uniform && crate::gpu::fits_uniform(ctx, data, preview_uniform_images().len()).is_ok();
        let features = SceneFeatures::of(data);
        let advice = match role {
            Role::Draws => crate::gpu::PREVIEW_DEVICE_STORAGE_ADVICE,
            Role::MayDraw | Role::ShowsOnly => crate::gpu::PREVIEW_CPU_STORAGE_ADVICE,
        };
        let checked = match role {
            Role::ShowsOnly => Err("another device draws the scene".to_string()),
            Role::Draws | Role::MayDraw => match crate::gpu::check_storage_arrays(ctx, data, uniform, advice) {
                Err(e @ GpuError::TooLarge { .. }) if role == Role::MayDraw => Err(e.to_string()),
                other => Ok(other?),
            },
        };
        if let Err(left_off) = checked {
            let mut buffers = Vec::new();
            for &(binding, what, _) in &data.scene_buffers() {
                buffers.push((binding, Buffer::new(ctx, 0, false, what)?));
            }
            return Ok(SceneBuffers {
                buffers,
                images: Vec::new(),
                uniform: false,
                features,
                left_off: Some(left_off),
            });
        }
        let mut images = Vec::new();
        let mut buffers = Vec::new();
        for &(binding, what, bytes) in &data.scene_buffers() {
            if !uniform {
                buffers.push((binding, Buffer::with_data(ctx, bytes, what)?));
                continue;
            }
            let bytes = crate::layout::padded_for_uniform(binding, bytes);
            if layout::UNIFORM_KERNEL_IMAGES.contains(&binding) {
                images.push((binding, DataImage::new(ctx, &bytes, what)?));
            } else {
                buffers.push((binding, Buffer::with_data(ctx, &bytes, what)?));
            }
        }
        Ok(SceneBuffers { buffers, images, uniform, features, left_off: None })
    }
}

/// What a preview kernel is built for: the scene's arrays as data images
/// (preview_uniform.comp) or buffers, the scene and frame's
/// specialization, and whether the host draws the pixels (HOST_PIXELS).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct KernelKey {
    uniform: bool,
    spec: Specialization,
    host_pixels: bool,
}

/// How many kernels the renderer keeps beside the one it draws with: a
/// view (keys 1 to 6) or flag (H, M, T) switched back finds its kernel
/// built (each build takes 50 ms or more on lavapipe, seconds cold).
const SPARE_KERNELS: usize = 3;

/// The kernel drawn with, by its key, and up to SPARE_KERNELS built
/// before for other keys, the latest first.
struct Built<K, T> {
    current: Option<(K, T)>,
    spare: Vec<(K, T)>,
}

impl<K: Copy + PartialEq, T> Built<K, T> {
    /// `current` alone (new shaders: what was built from the old ones goes).
    fn only(current: Option<(K, T)>) -> Built<K, T> {
        Built { current, spare: Vec::new() }
    }

    fn current_key(&self) -> Option<K> {
        self.current.as_ref().map(|(k, _)| *k)
    }

    fn current(&self) -> Option<&T> {
        self.current.as_ref().map(|(_, t)| t)
    }

    /// Makes `key`'s the current one: already current, a spare, or else
    /// `build`'s (on an error the current one stays).
    fn select<E>(&mut self, key: K, build: impl FnOnce() -> Result<T, E>) -> Result<(), E> {
        if self.current_key() == Some(key) {
            return Ok(());
        }
        let found = self.spare.iter().position(|(k, _)| *k == key).map(|i| self.spare.remove(i).1);
        let t = match found {
            Some(t) => t,
            None => build()?,
        };
        if let Some(old) = self.current.replace((key, t)) {
            self.spare.insert(0, old);
            self.spare.truncate(SPARE_KERNELS);
        }
        Ok(())
    }
}

/// Per-pixel buffers and the display image of one picture size.
struct PictureBuffers {
    size: [u32; 2],
    pixels: Buffer,
    accum: Buffer,
    display: StorageImage,
}

/// The pixel buffer's name in messages: too large a window says where larger pictures go.
const WHOLE_WINDOW_PIXELS: &str =
    "the preview's pixel buffer (every pixel of the window; `raycast render` draws larger pictures in bands)";

impl PictureBuffers {
    fn new(ctx: &GpuContext, size: [u32; 2]) -> Result<PictureBuffers, GpuError> {
        let count = size[0] as usize * size[1] as usize;
        Ok(PictureBuffers {
            size,
            // One buffer each for the whole window (`raycast render` draws larger pictures in bands).
            pixels: Buffer::new(ctx, count * std::mem::size_of::<PixelOut>(), true, WHOLE_WINDOW_PIXELS)?,
            accum: Buffer::new(
                ctx,
                count * std::mem::size_of::<AccumPixel>(),
                false,
                "the preview's accumulation buffer",
            )?,
            display: StorageImage::new(ctx, size[0], size[1])?,
        })
    }
}

/// The preview kernel with everything it binds.
pub struct PreviewRenderer {
    // Field order is drop order: the set before what it binds, all before the context.
    set: Option<DescriptorSet>,
    frames: FrameLoop,
    frame: Buffer,
    preview: Buffer,
    status: Buffer,
    /// The last frame's size (render).
    frame_size: [u32; 2],
    scene: SceneBuffers,
    picture: PictureBuffers,
    /// None: a renderer apart from the window (`apart`), whose pixels another one shows.
    swapchain: Option<Swapchain>,
    /// The kernel the scene and the last frame's flags needed, and its
    /// key, built when they change; beside it the last few it replaced.
    kernel: Built<KernelKey, Kernel>,
    kernels: PreviewKernels,
    /// The CPU build draws the samples (None: the kernel does).
    host: Option<Box<dyn Progressive>>,
    /// The device that draws the samples where it is not the window's (one
    /// that cannot present to it, or --window-device): the same kernel
    /// there, without a window; each band's pixels come back through the
    /// host and this renderer's kernel, built with HOST_PIXELS, shows them.
    /// The CPU build draws instead while `host` is Some.
    apart: Option<Box<PreviewRenderer>>,
    /// The time the CPU build or the device apart took for the sample in
    /// flight (and its pixels' way here), until `wait` reports it.
    drawn_in: Option<Duration>,
    context: Arc<GpuContext>,
}

/// Whichever draws the samples for the window's device: the CPU build, else
/// the device apart; None: the window's device's own kernel.
fn drawer<'a>(
    host: &'a mut Option<Box<dyn Progressive>>,
    apart: &'a mut Option<Box<PreviewRenderer>>,
) -> Option<&'a mut dyn Progressive> {
    match (host, apart) {
        (Some(cpu), _) => Some(&mut **cpu),
        (None, Some(device)) => Some(&mut **device),
        (None, None) => None,
    }
}

impl PreviewRenderer {
    /// Buffers for `data` and a `size` picture, a swapchain for a window of
    /// `window` pixels; with `cpu`, the CPU build draws the samples; with
    /// `apart`, another device (its context and kernels) draws them unless
    /// the CPU build does.
    #[allow(clippy::too_many_arguments)]
    pub fn new(
        context: Arc<GpuContext>,
        kernels: PreviewKernels,
        data: &FrameData,
        size: [u32; 2],
        window: [u32; 2],
        mode: PresentMode,
        cpu: Option<Box<dyn Progressive>>,
        apart: Option<(Arc<GpuContext>, PreviewKernels)>,
    ) -> Result<PreviewRenderer, GpuError> {
        let apart = match apart {
            Some((ctx, kernels)) => {
                let role = Role::of(false, cpu.is_some());
                Some(Box::new(PreviewRenderer::without_window(ctx, kernels, data, size, role)?))
            }
            None => None,
        };
        // The window's device shows the pixels of whoever else draws them.
        let role = Role::of(apart.is_some(), cpu.is_some());
        let mut r = PreviewRenderer::without_window(context, kernels, data, size, role)?;
        r.swapchain = Some(Swapchain::new(&r.context, window, mode)?);
        r.host = cpu;
        r.apart = apart;
        Ok(r)
    }

    /// Buffers for `data` (as `role` wants them) and a `size` picture, and no window.
    fn without_window(
        context: Arc<GpuContext>,
        kernels: PreviewKernels,
        data: &FrameData,
        size: [u32; 2],
        role: Role,
    ) -> Result<PreviewRenderer, GpuError> {
        let ctx = &*context;
        Ok(PreviewRenderer {
            set: None,
            frames: FrameLoop::new(ctx)?,
            frame: Buffer::new(ctx, std::mem::size_of::<Frame>(), false, "the frame")?,
            preview: Buffer::new(ctx, std::mem::size_of::<PreviewFrame>(), false, "the preview frame")?,
            status: Buffer::new(ctx, std::mem::size_of::<PreviewStatus>(), true, "the status word")?,
            frame_size: size,
            scene: SceneBuffers::new(ctx, data, kernels.uniform.is_some(), role)?,
            picture: PictureBuffers::new(ctx, size)?,
            swapchain: None,
            kernel: Built::only(None),
            kernels,
            host: None,
            apart: None,
            drawn_in: None,
            context: context.clone(),
        })
    }

    pub fn swapchain(&self) -> &Swapchain {
        self.swapchain.as_ref().expect("PreviewRenderer::new makes the window's swapchain")
    }

    /// Whether this device only shows pixels others draw (HOST_PIXELS).
    fn shows_only(&self) -> bool {
        self.role() != Role::Draws
    }

    /// What this device does with the scene now (the window's; the device
    /// apart's is `apart_role`).
    fn role(&self) -> Role {
        Role::of(self.apart.is_some(), self.host.is_some())
    }

    /// What the device apart does with the scene now: draws it, unless the CPU build does.
    fn apart_role(&self) -> Role {
        Role::of(false, self.host.is_some())
    }

    /// The picture's width and height.
    pub fn size(&self) -> [u32; 2] {
        self.picture.size
    }

    /// The kernel for the scene drawn with `frame`, built when the scene
    /// or the frame's flags want another one, and the descriptor set.
    fn prepare(&mut self, frame: &Frame) -> Result<(), GpuError> {
        // A kernel that shows the host's pixels is the same for every frame
        // (HOST_PIXELS leaves the rest out): switching a view or a flag
        // does not build another.
        let shows_only = self.shows_only();
        let spec = if shows_only { Specialization::ALL } else { self.scene.features.specialization(frame) };
        let key = KernelKey { uniform: self.scene.uniform, spec, host_pixels: shows_only };
        if self.kernel.current_key() != Some(key) {
            self.frames.wait()?;
            self.set = None;
            let (kernels, context) = (&self.kernels, &self.context);
            self.kernel.select(key, || kernels.build(context, key))?;
        }
        if self.set.is_none() {
            self.bind()?;
        }
        Ok(())
    }

    fn bind(&mut self) -> Result<(), GpuError> {
        self.set = None;
        let p = &self.picture;
        let s = &self.scene;
        let kernel = self.kernel.current().expect("prepare builds the kernel first");
        let mut resources = vec![(layout::BINDING_FRAME, Resource::Buffer(&self.frame))];
        resources.extend(s.buffers.iter().map(|(binding, buffer)| (*binding, Resource::Buffer(buffer))));
        resources.extend(s.images.iter().map(|(binding, image)| (*binding, Resource::Data(image))));
        resources.extend([
            (layout::BINDING_PIXELS, Resource::Buffer(&p.pixels)),
            (BINDING_PREVIEW, Resource::Buffer(&self.preview)),
            (BINDING_ACCUM, Resource::Buffer(&p.accum)),
            (BINDING_DISPLAY, Resource::Image(&p.display)),
            (BINDING_STATUS, Resource::Buffer(&self.status)),
        ]);
        self.set = Some(DescriptorSet::new(kernel, &resources)?);
        Ok(())
    }

    /// Replaces the kernels (a reloaded shader) for `data`, the scene on
    /// the device. The kernel the last frame used is built from them at
    /// once: when the driver refuses it (a shader that glslang and naga
    /// accept can still fail vkCreateComputePipelines), the old kernels stay
    /// and the inner error says why. When the new kernels add or drop
    /// preview_uniform.comp, the scene's arrays are laid out again for the
    /// kernel that now draws it.
    /// With a device apart, they are its kernels (compiled for it): this
    /// device only shows the pixels.
    pub fn set_kernels(&mut self, kernels: PreviewKernels, data: &FrameData) -> Result<Result<(), Error>, GpuError> {
        let apart_role = self.apart_role();
        match &mut self.apart {
            Some(apart) => apart.replace_kernels(kernels, data, apart_role),
            None => {
                let role = self.role();
                self.replace_kernels(kernels, data, role)
            }
        }
    }

    fn replace_kernels(
        &mut self,
        kernels: PreviewKernels,
        data: &FrameData,
        role: Role,
    ) -> Result<Result<(), Error>, GpuError> {
        self.frames.wait()?;
        let relayout = kernels.uniform.is_some() != self.kernels.uniform.is_some();
        let scene = if relayout {
            Some(SceneBuffers::new(&self.context, data, kernels.uniform.is_some(), role)?)
        } else {
            None
        };
        let uniform = scene.as_ref().map_or(self.scene.uniform, |s| s.uniform);
        let built = match self.kernel.current_key() {
            Some(key) => {
                let key = KernelKey { uniform, ..key };
                match kernels.build(&self.context, key) {
                    Ok(kernel) => Some((key, kernel)),
                    Err(e) => return Ok(Err(Error::Gpu(e))),
                }
            }
            None => None,
        };
        self.set = None;
        self.kernel = Built::only(built);
        self.kernels = kernels;
        if let Some(scene) = scene {
            self.scene = scene;
        }
        Ok(Ok(()))
    }

    /// Replaces the scene's buffers (a reloaded scene), on the device apart
    /// too; where it cannot take them, the old scene stays on both.
    pub fn set_scene(&mut self, data: &FrameData) -> Result<(), GpuError> {
        let role = self.apart_role();
        if let Some(apart) = &mut self.apart {
            apart.replace_scene(data, role)?;
        }
        let role = self.role();
        self.replace_scene(data, role)
    }

    fn replace_scene(&mut self, data: &FrameData, role: Role) -> Result<(), GpuError> {
        let scene = SceneBuffers::new(&self.context, data, self.kernels.uniform.is_some(), role)?;
        self.frames.wait()?;
        self.set = None;
        self.scene = scene;
        Ok(())
    }

    /// A new picture size: new per-pixel buffers and display image.
    pub fn resize(&mut self, size: [u32; 2]) -> Result<(), Error> {
        if size == self.picture.size {
            return Ok(());
        }
        if let Some(apart) = &mut self.apart {
            apart.resize(size)?;
        }
        self.frames.wait()?;
        self.set = None;
        self.picture = PictureBuffers::new(&self.context, size)?;
        self.frame_size = size;
        if let Some(host) = &mut self.host {
            host.resize(size)?;
        }
        Ok(())
    }

    /// A new window size: a new swapchain.
    pub fn resize_window(&mut self, window: [u32; 2]) -> Result<(), GpuError> {
        self.frames.wait()?;
        match &mut self.swapchain {
            Some(swapchain) => swapchain.recreate(window),
            None => Ok(()),
        }
    }

    /// The CPU build's threads when it draws the samples.
    pub fn cpu_threads(&self) -> Option<usize> {
        self.host.as_ref().and_then(|h| h.threads())
    }

    /// Why the device cannot draw the scene (an array beyond one of its
    /// storage buffers, found while the CPU build draws): `draw_on_device`
    /// may not be called then.
    pub fn device_cannot_draw(&self) -> Option<&str> {
        match &self.apart {
            Some(apart) => apart.scene.left_off.as_deref(),
            None => self.scene.left_off.as_deref(),
        }
    }

    /// From now on the kernel draws the samples, not the CPU build (which
    /// cannot follow an edited shader). The running sums stay with the CPU
    /// build: start the samples over.
    pub fn draw_on_device(&mut self) -> Result<(), GpuError> {
        assert!(self.device_cannot_draw().is_none(), "the scene's arrays are on the drawing device");
        self.frames.wait()?;
        self.host = None;
        Ok(())
    }

    /// From now on `cpu` (the CPU build, drawing pictures of `size`)
    /// draws the samples and the kernel only shows them; they start over.
    pub fn draw_on_cpu(&mut self, cpu: Box<dyn Progressive>) -> Result<(), GpuError> {
        self.frames.wait()?;
        self.host = Some(cpu);
        Ok(())
    }

    /// Draws one sample, or the band of its rows from `preview.row_offset`
    /// to `row_end`, of `data`'s scene: writes `frame` (at most the
    /// picture's size: a smaller frame fills the top-left of the buffers and
    /// is scaled up to the window) and `preview`, dispatches, and with
    /// `present` shows the display image (so present only once a sample's
    /// last band is drawn). Returns at once when the kernel draws the
    /// sample; the CPU build draws it before the dispatch.
    pub fn render(
        &mut self,
        data: &FrameData,
        frame: &Frame,
        preview: &PreviewFrame,
        row_end: u32,
        present: bool,
    ) -> Result<FrameStatus, Error> {
        let [w, h] = self.picture.size;
        assert!(
            frame.width >= 1 && frame.height >= 1 && frame.width <= w && frame.height <= h,
            "the frame fits the picture"
        );
        assert!(preview.row_offset < row_end && row_end <= frame.height, "the band is inside the frame");
        self.frames.wait()?;
        if let Some(drawer) = drawer(&mut self.host, &mut self.apart) {
            let start = Instant::now();
            drawer.add_sample(data, frame, preview, row_end)?;
            // Its dispatch where it has timestamps: a kernel built for this
            // frame is no part of what the steering's cost per pixel measures.
            let drawn = drawer.wait()?;
            let copy = Instant::now();
            let size = std::mem::size_of::<PixelOut>();
            let band = preview.row_offset as usize * frame.width as usize * size
                ..row_end as usize * frame.width as usize * size;
            self.picture.pixels.write(band.start, drawer.pixel_bytes(band.clone())?);
            self.drawn_in = Some(drawn.map_or_else(|| start.elapsed(), |d| d + copy.elapsed()));
        }
        self.prepare(frame)?;
        self.frame_size = [frame.width, frame.height];
        self.status.write(0, bytemuck::bytes_of(&PreviewStatus::default()));
        self.frame.write(0, bytemuck::bytes_of(frame));
        self.preview.write(0, bytemuck::bytes_of(preview));
        let kernel = self.kernel.current().expect("prepared");
        let wg = kernel.workgroup_size();
        let groups = [frame.width.div_ceil(wg[0]), (row_end - preview.row_offset).div_ceil(wg[1]), 1];
        let set = self.set.as_ref().expect("bound");
        let swapchain = self.swapchain.as_mut().filter(|_| present);
        Ok(self.frames.submit(kernel, set, groups, &self.picture.display, self.frame_size, swapchain)?)
    }

    /// Waits for the frame in flight; its dispatch time when the device has
    /// timestamps, plus the CPU build's or the device apart's time (its
    /// dispatch and the pixels' way back) when it drew the sample.
    pub fn wait(&mut self) -> Result<Option<Duration>, GpuError> {
        let device = self.frames.wait()?;
        match self.drawn_in.take() {
            Some(cpu) => Ok(Some(cpu + device.unwrap_or_default())),
            None => Ok(device),
        }
    }

    /// How many pixels of the last frame the device cut short (Mesa's loop
    /// budget per invocation; raycast.glsl loop_budget_ok): they are wrong.
    pub fn cut_short(&mut self) -> Result<u32, Error> {
        if let Some(drawer) = drawer(&mut self.host, &mut self.apart) {
            return drawer.cut_short();
        }
        self.frames.wait()?;
        let status: PreviewStatus =
            bytemuck::pod_read_unaligned(&self.status.read(0, std::mem::size_of::<PreviewStatus>()));
        Ok(status.cut_short)
    }

    /// The last frame's width and height (the picture's, or less while the camera moves).
    pub fn frame_size(&self) -> [u32; 2] {
        self.frame_size
    }

    /// Every pixel of the last frame, row by row: the first sample's hit, the average colour.
    pub fn pixels(&mut self) -> Result<Vec<PixelOut>, GpuError> {
        self.frames.wait()?;
        let count = self.frame_size[0] as usize * self.frame_size[1] as usize;
        Ok(bytemuck::pod_collect_to_vec(&self.picture.pixels.read(0, count * std::mem::size_of::<PixelOut>())))
    }

    /// Pixel (column j, row i) of the last frame.
    pub fn pixel(&mut self, j: u32, i: u32) -> Result<PixelOut, GpuError> {
        self.frames.wait()?;
        let size = std::mem::size_of::<PixelOut>();
        let index = i as usize * self.frame_size[0] as usize + j as usize;
        Ok(bytemuck::pod_read_unaligned(&self.picture.pixels.read(index * size, size)))
    }
}

/// The device apart draws the window's samples through this (`drawer`):
/// its kernel, without a window.
impl Progressive for PreviewRenderer {
    fn describe(&self) -> String {
        self.context.info().summary()
    }

    fn add_sample(
        &mut self,
        data: &FrameData,
        frame: &Frame,
        preview: &PreviewFrame,
        row_end: u32,
    ) -> Result<(), Error> {
        self.render(data, frame, preview, row_end, false).map(|_| ())
    }

    fn wait(&mut self) -> Result<Option<Duration>, Error> {
        Ok(PreviewRenderer::wait(self)?)
    }

    fn pixel_bytes(&mut self, bytes: Range<usize>) -> Result<&[u8], Error> {
        self.frames.wait()?;
        Ok(self.picture.pixels.bytes(bytes.start, bytes.len()))
    }

    fn cut_short(&mut self) -> Result<u32, Error> {
        PreviewRenderer::cut_short(self)
    }

    fn resize(&mut self, size: [u32; 2]) -> Result<(), Error> {
        PreviewRenderer::resize(self, size)
    }
}

impl Drop for PreviewRenderer {
    fn drop(&mut self) {
        // Nothing may be destroyed while the last frame runs, even one that
        // outlived the timeout (the error that ends the preview).
        if self.frames.wait().is_err() {
            self.frames.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A key switched back finds its kernel without a build; beyond
    /// SPARE_KERNELS others, the oldest is built again; a failed build
    /// leaves the current one.
    #[test]
    fn kernels_built_before_are_kept() {
        let mut built: Built<u32, String> = Built::only(None);
        let mut builds = Vec::new();
        let mut select = |b: &mut Built<u32, String>, key: u32| {
            b.select(key, || -> Result<String, ()> {
                builds.push(key);
                Ok(format!("kernel {key}"))
            })
            .unwrap();
            assert_eq!(b.current(), Some(&format!("kernel {key}")));
        };
        for key in [1, 2, 1, 2, 2, 3, 4, 5, 1] {
            select(&mut built, key);
        }
        // 1 and 2 once each, then 3, 4, 5; 5 pushed 1, the oldest, out of the three spares.
        assert_eq!(builds, [1, 2, 3, 4, 5, 1]);
        assert_eq!(built.select(9, || Err("refused")), Err("refused"));
        assert_eq!(built.current_key(), Some(1));
    }
}
