//! The preview window and its loop: input, camera, reloads, title, picking,
//! screenshots. Frames come from `PreviewRenderer`; this file decides what
//! to draw (camera, size, output mode, sample) and when.

use std::path::Path;
use std::time::{Duration, Instant};

use glam::DVec3;
use glfw::{Action, Key, MouseButton, WindowEvent};

use crate::cpu::{CpuProgressive, CpuRenderer};
use crate::error::Error;
use crate::frame::{self, Aov, FrameData};
use crate::gpu::{DeviceInfo, FrameStatus, GpuError};
use crate::image_io;
use crate::layout::{self, Frame, NO_HIT};
use crate::render::Picture;
use crate::scene::{scene_bounds, Bounds, Scene};

use super::pacing::{
    band_rows, forced_band_rows, frame_budget_ms, frames_at, jitter, motion_scale, rate, PixelCost, COST_MIN_PIXELS,
    MOTION_HOLD, MOVING_DEG_PER_FRAME,
};
use super::reload::{Reload, ShaderFolder, Watcher, KERNEL_FILE};
use super::renderer::PreviewRenderer;
use crate::layout::PreviewFrame;
use crate::scene::CameraControl;

const MAX_SAMPLES: u32 = 1024;
/// A press and release of the left button closer than this (pixels) is a click, not a drag.
const CLICK_SLOP: f64 = 3.0;
/// Orbit degrees per pixel of drag.
const ORBIT_DEG_PER_PIXEL: f64 = 0.3;
const TITLE_INTERVAL: Duration = Duration::from_millis(250);

const HELP: &str = "\
preview controls:
  left drag       orbit about the focus        left click    print what the pixel sees
  right/mid drag  pan                          wheel         dolly toward / away from the focus
  W A S D         fly forward, left, back, right (Shift: faster)
  Q E             fly down, up
  R               back to the scene's camera   F             frame the whole scene
  C               print the camera as a <cameradata> block
  1 to 6          show colour, normal, depth, object id, walk cost (camera ray, all rays)
  H M T           toggle shadows, mirror reflections, textures
  G               toggle refraction (transparent materials opaque)
  B               switch who draws: the device or the CPU build (the same pixels)
  K               recompile the shaders now, as an edit does (the device draws after)
  F1              this help                    Esc           quit";

/// Mouse state between events.
#[derive(Default)]
struct Mouse {
    cursor: (f64, f64),
    /// Where the left button went down, while it is down.
    left_from: Option<(f64, f64)>,
    /// The left button moved past the click slop: it orbits.
    orbiting: bool,
    panning: bool,
}

/// Frame-time and ray-rate averages for the title.
#[derive(Default)]
struct Stats {
    frame_ms: f64,
    device_ms: Option<f64>,
    last_submit: Option<Instant>,
}

impl Stats {
    fn average(old: f64, new: f64) -> f64 {
        if old == 0.0 {
            new
        } else {
            old * 0.8 + new * 0.2
        }
    }
}

/// Everything the loop keeps.
pub(super) struct Preview {
    pub(super) scene: Scene,
    pub(super) data: FrameData,
    pub(super) bounds: Option<Bounds>,
    pub(super) camera: CameraControl,
    /// The Vulkan device's name.
    pub(super) device: String,
    /// Whether that device runs on the CPU (lavapipe): the frame budget.
    pub(super) device_on_cpu: bool,
    /// A shader was reloaded: the device's kernel is no longer the code the
    /// CPU build was built from (so an edit hands the drawing to the device,
    /// and B back to the CPU build says so).
    pub(super) shader_edited: bool,
    /// The picture stays at the size asked for (screenshots): the window is not resizable.
    pub(super) fixed_size: bool,
    /// What the window shows (Frame.aov, keys 1 to 6).
    pub(super) aov: Aov,
    pub(super) shadows: bool,
    pub(super) reflections: bool,
    /// Refraction (G): FLAG_REFRACTION where the scene's frame has it.
    pub(super) refraction: bool,
    pub(super) textures: bool,
    /// Whether the scene's textures were loaded (not with --no-textures): T can turn them on.
    pub(super) textures_loaded: bool,
    /// The sample the next frame draws; 0 restarts the accumulation.
    pub(super) sample: u32,
    /// Scripted runs (--moving N): the first N frames turn the camera.
    pub(super) moving_frames: u32,
    /// Scripted runs (--click X,Y): the pixel clicked after the last frame.
    pub(super) click: Option<(u32, u32)>,
    /// Scripted runs (--keys): keys pressed just before frame N (from 1).
    pub(super) keys: Vec<(u32, Key)>,
    /// The shader folder the watcher follows (None: reload is off): K
    /// recompiles it at once.
    pub(super) shaders: Option<ShaderFolder>,
    /// K was pressed: recompile before the next frame.
    pub(super) recompile: bool,
    /// Frames submitted so far.
    pub(super) rendered: u32,
    /// The size of the frame submitted last.
    pub(super) frame_sizes: (u32, u32),
    /// Submit-to-submit times of the --moving frames, and their sizes.
    pub(super) moving_times: Vec<(Duration, [u32; 2])>,
    /// Submit-to-submit times of the frames after them (scripted runs: each a whole sample), and their sizes.
    pub(super) rest_times: Vec<(Duration, [u32; 2])>,
    /// The first row of the sample's next band (0: the sample starts).
    pub(super) band_next: u32,
    /// When the camera last moved (`moved`).
    pub(super) last_move: Option<Instant>,
    /// Device (or frame) milliseconds per pixel of the last frames.
    pub(super) pixel_cost: PixelCost,
    /// Pixels of the frame in flight, for `pixel_cost`.
    pub(super) pixels_in_flight: u64,
    /// Pixels of the last frame the device cut short (wrong; lavapipe's loop budget).
    pub(super) cut_short: u32,
    pub(super) error: Option<String>,
    mouse: Mouse,
    stats: Stats,
    pub(super) renderer: PreviewRenderer,
}

impl Preview {
    pub(super) fn new(
        scene: Scene,
        data: FrameData,
        device: &DeviceInfo,
        fixed_size: bool,
        renderer: PreviewRenderer,
    ) -> Preview {
        let bounds = scene_bounds(&scene);
        let camera = CameraControl::new(&scene.camera, bounds);
        Preview {
            scene,
            data,
            bounds,
            camera,
            device: device.name.clone(),
            device_on_cpu: device.runs_on_cpu(),
            shader_edited: false,
            fixed_size,
            aov: Aov::Color,
            shadows: true,
            reflections: true,
            refraction: true,
            textures: true,
            textures_loaded: true,
            sample: 0,
            moving_frames: 0,
            click: None,
            keys: Vec::new(),
            shaders: None,
            recompile: false,
            rendered: 0,
            frame_sizes: (0, 0),
            moving_times: Vec::new(),
            rest_times: Vec::new(),
            band_next: 0,
            last_move: None,
            pixel_cost: PixelCost::default(),
            pixels_in_flight: 0,
            cut_short: 0,
            error: None,
            mouse: Mouse::default(),
            stats: Stats::default(),
            renderer,
        }
    }

    /// The loop: until Esc, the window closes, or `frames` samples are drawn
    /// (then the picture goes to `screenshot`).
    pub(super) fn run(
        &mut self,
        glfw: &mut glfw::Glfw,
        window: &mut glfw::PWindow,
        events: &glfw::GlfwReceiver<(f64, WindowEvent)>,
        watcher: &Watcher,
        frames: Option<u32>,
        screenshot: Option<&Path>,
    ) -> Result<(), Error> {
        let mut last_title = Instant::now() - TITLE_INTERVAL;
        let mut last_tick = Instant::now();
        let mut recreate = false;
        loop {
            // Input.
            let idle = frames.is_none() && self.sample >= MAX_SAMPLES;
            let (fw, fh) = window.get_framebuffer_size();
            let minimised = fw <= 0 || fh <= 0 || window.is_iconified();
            if idle || minimised {
                glfw.wait_events_timeout(0.05);
                // The pause is not a frame time.
                self.stats.last_submit = None;
            } else {
                glfw.poll_events();
            }
            for (_, event) in glfw::flush_messages(events) {
                match event {
                    WindowEvent::FramebufferSize(..) => recreate = true,
                    other => self.on_event(other, window)?,
                }
            }
            if window.should_close() {
                return Ok(());
            }
            let now = Instant::now();
            let dt = (now - last_tick).as_secs_f64().min(0.1);
            last_tick = now;
            self.fly(window, dt);

            // Reloads, done by the watcher thread.
            while let Some(reload) = watcher.try_recv() {
                self.on_reload(reload)?;
            }

            if last_title.elapsed() >= TITLE_INTERVAL {
                window.set_title(&self.title());
                last_title = Instant::now();
            }
            if minimised {
                continue;
            }
            if recreate || self.renderer.swapchain().extent() != [fw as u32, fh as u32] {
                recreate = false;
                self.renderer.resize_window([fw as u32, fh as u32])?;
                if !self.fixed_size && self.renderer.size() != [fw as u32, fh as u32] {
                    self.renderer.resize([fw as u32, fh as u32])?;
                    // New buffers: the sample in progress, and its band, start over.
                    self.restart();
                }
            }
            if idle {
                continue;
            }

            // One sample.
            let waited = Instant::now();
            let device = self.renderer.wait()?;
            if let Some(t) = device {
                self.stats.device_ms = Some(Stats::average(self.stats.device_ms.unwrap_or(0.0), t.as_secs_f64() * 1e3));
            }
            // Small frames (steering, bands) carry a fixed cost per frame that would
            // inflate the cost per pixel: only frames of COST_MIN_PIXELS or more count.
            if self.pixels_in_flight >= COST_MIN_PIXELS {
                // The frame's own time: the device's, or else since its submission.
                let ms = device
                    .map(|t| t.as_secs_f64() * 1e3)
                    .or_else(|| self.stats.last_submit.map(|s| (waited.max(s) - s).as_secs_f64() * 1e3));
                if let Some(ms) = ms {
                    self.pixel_cost.push(ms / self.pixels_in_flight as f64);
                }
            }
            let cut = self.renderer.cut_short()?;
            if cut > 0 && self.cut_short == 0 {
                errln!(
                    "raycast: preview: the picture is WRONG: the device cut {cut} pixels short. Mesa's lavapipe gives each \
                     shader invocation 65535 loop iterations in all and these pixels need more; \
                     reflections off (M) or another Vulkan device avoid it"
                );
            }
            self.cut_short = cut;
            let steering = frames.is_some() && self.rendered < self.moving_frames;
            if steering {
                self.camera.orbit(MOVING_DEG_PER_FRAME, 0.0);
                self.moved();
            }
            // --keys: those pressed before this frame (the first is frame 1).
            let pressed: Vec<Key> = self.keys.iter().filter(|(n, _)| *n == self.rendered + 1).map(|k| k.1).collect();
            for key in pressed {
                self.on_key(key, glfw::Modifiers::empty(), window);
            }
            // K, from the window or --keys: the kernel this frame draws with.
            if std::mem::take(&mut self.recompile) {
                self.recompile_shaders()?;
            }
            let scale = self.motion_scale(frames.is_some() && !steering);
            if scale > 1.0 || self.renderer.frame_size() != self.renderer.size() {
                // Moving, or the first frame at rest after moving: no samples to add to.
                self.sample = 0;
                self.band_next = 0;
            }
            let frame = self.frame(scale);
            // At full size on a slow device, a sample is drawn a band of rows per frame (each
            // within the frame budget) and shown once whole, so input is never kept waiting
            // for a long frame. Scripted runs and fast devices draw it whole.
            let rows = if scale > 1.0 || frames.is_some() {
                frame.height
            } else {
                forced_band_rows().unwrap_or_else(|| {
                    band_rows(self.pixel_cost.estimate(), frame.width, frame.height, self.frame_budget_ms())
                })
            };
            let band = [self.band_next, (self.band_next + rows).min(frame.height)];
            let whole = band[1] == frame.height;
            self.pixels_in_flight = u64::from(frame.width) * u64::from(band[1] - band[0]);
            let [jx, jy] = jitter(self.sample);
            let preview = PreviewFrame {
                jitter: [jx, jy, 0.0, 0.0],
                sample_index: self.sample,
                row_offset: band[0],
                pad0: 0,
                pad1: 0,
            };
            match self.renderer.render(&self.data, &frame, &preview, band[1], whole)? {
                FrameStatus::OutOfDate => {
                    recreate = true;
                    continue;
                }
                FrameStatus::Suboptimal => recreate = true,
                FrameStatus::Done => {}
            }
            let now = Instant::now();
            if let Some(prev) = self.stats.last_submit.replace(now) {
                self.stats.frame_ms = Stats::average(self.stats.frame_ms, (now - prev).as_secs_f64() * 1e3);
                if frames.is_some() {
                    // Scripted: the frame before this one, a --moving frame or one at rest: its time is now known.
                    let timed = (now - prev, [self.frame_sizes.0, self.frame_sizes.1]);
                    if self.rendered <= self.moving_frames {
                        self.moving_times.push(timed);
                    } else {
                        self.rest_times.push(timed);
                    }
                }
            }
            self.frame_sizes = (frame.width, frame.height);
            self.rendered += 1;
            if whole {
                self.sample += 1;
                self.band_next = 0;
            } else {
                self.band_next = band[1];
                continue;
            }

            if let Some(n) = frames {
                if self.rendered >= n {
                    self.renderer.wait()?;
                    self.report_rates();
                    if let Some((j, i)) = self.click {
                        self.pick_pixel(j, i)?;
                    }
                    if let Some(path) = screenshot {
                        self.save(path)?;
                    }
                    return Ok(());
                }
            }
        }
    }

    /// The Frame of this camera, size, mode and flags. The rest (scene
    /// counts, coefficients) is `frame::build`'s, so the scene's own camera
    /// gives its `raycast render` Frame bit for bit.
    fn frame(&self, scale: f64) -> Frame {
        let [w, h] = self.renderer.size();
        let side = |n: u32| ((f64::from(n) / scale).ceil() as u32).clamp(1, n);
        self.frame_at([side(w), side(h)])
    }

    /// `frame`'s Frame at a size of w x h pixels.
    fn frame_at(&self, [w, h]: [u32; 2]) -> Frame {
        let mut f = self.data.frame;
        f.width = w;
        f.height = h;
        frame::set_camera(&mut f, &self.camera.camera);
        let eye = self.camera.camera.pos;
        f.aov = self.aov.code();
        // As frame::build's for the scene's camera: the depth AOV's range from this one.
        f.aov_scale = frame::aov_scale(frame::depth_range(self.bounds, eye), self.aov.default_cost_max());
        f.flags = (if self.shadows { layout::FLAG_SHADOWS } else { 0 })
            | (if self.reflections { layout::FLAG_REFLECTIONS } else { 0 })
            | (if self.textures { layout::FLAG_TEXTURES } else { 0 })
            | (if self.refraction { self.data.frame.flags & layout::FLAG_REFRACTION } else { 0 });
        f
    }

    fn title(&self) -> String {
        let [w, h] = self.renderer.frame_size();
        let rays = self.pixels_in_flight as f64;
        let ms = self.stats.device_ms.unwrap_or(self.stats.frame_ms);
        let rate = if ms > 0.0 { rays / (ms * 1e-3) / 1e6 } else { 0.0 };
        let on = |b: bool| if b { "on" } else { "off" };
        let name = self.scene.path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
        let mut t = format!(
            "raycast preview | {name} | {} | {:.1} ms/frame, {rate:.2} Mrays/s | {} samples | {} | \
             shadows {}, reflections {}, textures {}",
            self.aov.name(),
            self.stats.frame_ms,
            self.sample,
            self.drawn_by(),
            on(self.shadows),
            on(self.reflections),
            on(self.textures)
        );
        if [w, h] != self.renderer.size() {
            t.push_str(&format!(" | {w}x{h} while moving"));
        } else if self.band_next > 0 {
            t.push_str(&format!(" | sample {}: row {} of {h}", self.sample + 1, self.band_next));
        }
        if self.cut_short > 0 {
            t.push_str(&format!(" | WRONG: {} pixels cut short by the device's loop budget", self.cut_short));
        }
        if let Some(e) = &self.error {
            t.push_str(" | ERROR: ");
            t.push_str(e);
        }
        t
    }

    /// B: the device draws the samples from now on if the CPU build did,
    /// else the CPU build (the same pixels; on lavapipe the faster); the
    /// samples start over. A failure keeps who drew and shows in the title.
    fn switch_drawing(&mut self) {
        let switched = if let Some(why) = self.renderer.device_cannot_draw() {
            Err(Error::Failed(why.to_string()))
        } else if self.renderer.cpu_threads().is_some() {
            self.renderer.draw_on_device().map_err(Error::from)
        } else {
            let size = self.renderer.size();
            CpuRenderer::new()
                .and_then(|cpu| Ok(self.renderer.draw_on_cpu(Box::new(CpuProgressive::new(cpu, size)))?))
        };
        match switched {
            Ok(()) if self.shader_edited && self.renderer.cpu_threads().is_some() => errln!(
                "raycast: preview: {} draws: the code raycast was built with, not the edited shader",
                self.drawn_by()
            ),
            Ok(()) => errln!("raycast: preview: {} draws", self.drawn_by()),
            Err(e) => {
                errln!("raycast: preview: error: cannot switch who draws: {e}");
                self.error = Some(format!("cannot switch who draws: {e}"));
            }
        }
        self.restart();
    }

    /// Who draws the samples, for the title.
    fn drawn_by(&self) -> String {
        match self.renderer.cpu_threads() {
            Some(n) => format!("CPU build ({n} threads)"),
            None => self.device.clone(),
        }
    }

    fn restart(&mut self) {
        self.sample = 0;
        self.band_next = 0;
    }

    /// Scripted runs: with `--moving N`, the frame rate of those frames
    /// (the first left out: it renders at full size, before any cost is
    /// known); then that of the frames at rest (the last one's time is not
    /// known: nothing follows it), each a whole sample at the picture's size.
    fn report_rates(&self) {
        if self.moving_frames > 0 {
            let times: Vec<(Duration, [u32; 2])> = self.moving_times.iter().skip(1).copied().collect();
            if times.is_empty() {
                outln!("moving: too few frames to time (--moving 2 or more, with --frames more than that)");
            } else {
                outln!(
                    "moving: {} (the picture {}x{}): {}",
                    frames_at(&times),
                    self.renderer.size()[0],
                    self.renderer.size()[1],
                    rate(&times)
                );
            }
        }
        if !self.rest_times.is_empty() {
            outln!("at rest: {}: {}", frames_at(&self.rest_times), rate(&self.rest_times));
        }
    }

    /// The camera moved: start over, at a lower resolution for a moment
    /// (`motion_scale`).
    fn moved(&mut self) {
        self.restart();
        self.last_move = Some(Instant::now());
    }

    /// The divisor of the picture's width and height for the next frame:
    /// 1 at rest and in scripted runs (but for --moving); while the camera moves (and for
    /// MOTION_HOLD after), the smallest that keeps a frame within
    /// the frame budget at the cost per pixel measured so far, at most 8
    /// (`motion_scale`). A slow device (lavapipe) stays interactive while
    /// you steer; the picture sharpens once you stop.
    fn motion_scale(&self, at_rest: bool) -> f64 {
        let moving = self.last_move.is_some_and(|t| t.elapsed() < MOTION_HOLD);
        if at_rest || !moving {
            return 1.0;
        }
        let [w, h] = self.renderer.size();
        motion_scale(self.pixel_cost.estimate(), u64::from(w) * u64::from(h), self.frame_budget_ms())
    }

    /// MOTION_FRAME_MS of whoever draws now: the CPU build, or the device.
    fn frame_budget_ms(&self) -> f64 {
        frame_budget_ms(self.renderer.cpu_threads().is_some() || self.device_on_cpu)
    }

    fn on_event(&mut self, event: WindowEvent, window: &mut glfw::PWindow) -> Result<(), Error> {
        match event {
            WindowEvent::Close => window.set_should_close(true),
            WindowEvent::Key(key, _, Action::Press, mods) => self.on_key(key, mods, window),
            WindowEvent::MouseButton(button, action, _) => {
                let at = self.mouse.cursor;
                match (button, action) {
                    (MouseButton::Button1, Action::Press) => {
                        self.mouse.left_from = Some(at);
                        self.mouse.orbiting = false;
                    }
                    (MouseButton::Button1, Action::Release) => {
                        let clicked = self.mouse.left_from.take().is_some() && !self.mouse.orbiting;
                        self.mouse.orbiting = false;
                        if clicked {
                            self.pick(at, window)?;
                        }
                    }
                    (MouseButton::Button2 | MouseButton::Button3, Action::Press) => self.mouse.panning = true,
                    (MouseButton::Button2 | MouseButton::Button3, Action::Release) => self.mouse.panning = false,
                    _ => {}
                }
            }
            WindowEvent::CursorPos(x, y) => {
                let (dx, dy) = (x - self.mouse.cursor.0, y - self.mouse.cursor.1);
                self.mouse.cursor = (x, y);
                if let Some(from) = self.mouse.left_from {
                    if !self.mouse.orbiting && ((x - from.0).powi(2) + (y - from.1).powi(2)).sqrt() > CLICK_SLOP {
                        self.mouse.orbiting = true;
                        // The drag so far counts.
                        self.camera.orbit(-(x - from.0) * ORBIT_DEG_PER_PIXEL, (y - from.1) * ORBIT_DEG_PER_PIXEL);
                        self.moved();
                    } else if self.mouse.orbiting {
                        self.camera.orbit(-dx * ORBIT_DEG_PER_PIXEL, dy * ORBIT_DEG_PER_PIXEL);
                        self.moved();
                    }
                } else if self.mouse.panning && (dx != 0.0 || dy != 0.0) {
                    let (_, wh) = window.get_size();
                    self.camera.pan(dx, dy, f64::from(wh.max(1)));
                    self.moved();
                }
            }
            WindowEvent::Scroll(_, y) if y != 0.0 => {
                self.camera.dolly(y);
                self.moved();
            }
            _ => {}
        }
        Ok(())
    }

    fn on_key(&mut self, key: Key, _mods: glfw::Modifiers, window: &mut glfw::PWindow) {
        let aov = match key {
            Key::Num1 | Key::Kp1 => Some(Aov::Color),
            Key::Num2 | Key::Kp2 => Some(Aov::Normal),
            Key::Num3 | Key::Kp3 => Some(Aov::Depth),
            Key::Num4 | Key::Kp4 => Some(Aov::Id),
            Key::Num5 | Key::Kp5 => Some(Aov::Cost),
            Key::Num6 | Key::Kp6 => Some(Aov::CostAll),
            _ => None,
        };
        if let Some(a) = aov {
            self.aov = a;
            self.restart();
            return;
        }
        match key {
            Key::Escape => window.set_should_close(true),
            Key::R => {
                self.camera.reset();
                self.restart();
            }
            Key::F => {
                if let Some(b) = self.bounds {
                    let [w, h] = self.renderer.size();
                    self.camera.frame(&b, f64::from(w) / f64::from(h));
                    self.restart();
                }
            }
            Key::C => outln!("{}", self.camera.cameradata_block()),
            Key::H => {
                self.shadows = !self.shadows;
                self.restart();
            }
            Key::M => {
                self.reflections = !self.reflections;
                self.restart();
            }
            Key::G => {
                self.refraction = !self.refraction;
                self.restart();
            }
            Key::T if !self.textures_loaded => {
                errln!("raycast: preview: no textures were loaded (--no-textures): start without it to turn them on");
            }
            Key::T => {
                self.textures = !self.textures;
                self.restart();
            }
            Key::B => self.switch_drawing(),
            Key::K => self.recompile = true,
            Key::F1 => outln!("{HELP}"),
            _ => {}
        }
    }

    /// WASD / QE while held, at a speed relative to the scene's size.
    fn fly(&mut self, window: &glfw::PWindow, dt: f64) {
        let held = |k: Key| if window.get_key(k) == Action::Press { 1.0 } else { 0.0 };
        let forward = held(Key::W) - held(Key::S);
        let right = held(Key::D) - held(Key::A);
        let up = held(Key::E) - held(Key::Q);
        if forward == 0.0 && right == 0.0 && up == 0.0 {
            return;
        }
        let fast = if window.get_key(Key::LeftShift) == Action::Press { 4.0 } else { 1.0 };
        let size = self.bounds.map_or(2.0, |b| b.radius().max(1e-3));
        let step = size * 0.5 * fast * dt;
        self.camera.fly(forward * step, right * step, up * step);
        self.moved();
    }

    fn on_reload(&mut self, reload: Reload) -> Result<(), Error> {
        match reload {
            Reload::Scene(loaded) => {
                let (scene, data) = *loaded;
                crate::source::print_warnings(&scene);
                crate::source::print_notes(&data);
                // An array beyond a storage buffer of the drawing device:
                // the last good scene stays, as after a parse error.
                if let Err(e @ GpuError::TooLarge { .. }) = self.renderer.set_scene(&data) {
                    self.reload_failed(&format!(
                        "raycast: preview: error: {} cannot draw the reloaded {}: {e}",
                        self.device,
                        scene.path.display()
                    ));
                    return Ok(());
                }
                let new_camera = scene.camera != self.scene.camera;
                self.bounds = scene_bounds(&scene);
                if new_camera {
                    self.camera = CameraControl::new(&scene.camera, self.bounds);
                }
                errln!(
                    "raycast: preview: reloaded {} ({} primitives, {} lights)",
                    scene.path.display(),
                    data.primitives.len(),
                    data.lights.len()
                );
                self.scene = scene;
                self.data = data;
                self.error = None;
                self.restart();
            }
            Reload::Kernel(kernels) => match self.renderer.set_kernels(kernels, &self.data)? {
                Ok(()) => {
                    errln!("raycast: preview: reloaded the kernel ({KERNEL_FILE})");
                    self.shader_edited = true;
                    if let Some(why) = self.renderer.device_cannot_draw() {
                        errln!(
                            "raycast: preview: the reloaded kernel cannot draw this scene on {}: {why}; the CPU build \
                             goes on drawing the code raycast was built with",
                            self.device
                        );
                    } else if self.renderer.cpu_threads().is_some() {
                        self.renderer.draw_on_device()?;
                        errln!(
                            "raycast: preview: {} draws from now on: the CPU build is the code raycast was built with \
                             and cannot follow a shader edit (B switches back to it)",
                            self.device
                        );
                    }
                    self.error = None;
                    self.restart();
                }
                Err(why) => self.reload_failed(&format!(
                    "raycast: preview: error: the reloaded kernel ({KERNEL_FILE}) does not build on the device: {why}"
                )),
            },
            Reload::Failed(message) => self.reload_failed(&message),
        }
        Ok(())
    }

    /// K: the watched shader folder compiled now and taken as an edit is
    /// (`on_reload`: the device draws from then on), whether or not a file
    /// changed: after an edit the watcher has not seen, or to hand the
    /// drawing to the device's kernel of the folder's code.
    fn recompile_shaders(&mut self) -> Result<(), Error> {
        let Some(folder) = self.shaders.clone() else {
            errln!("raycast: preview: K: no shader folder to recompile (the source tree's shaders/ is not here; use --shaders DIR)");
            return Ok(());
        };
        errln!("raycast: preview: recompiling the shaders of {}", folder.dir.display());
        self.on_reload(folder.compile())
    }

    /// A reload that did not take: says why, keeps the last good picture
    /// and shows the first error line in the title.
    fn reload_failed(&mut self, message: &str) {
        errln!("{message}");
        errln!("raycast: preview: keeping the last good picture");
        let first = message.lines().find(|l| l.contains("ERROR") || l.contains("error")).or(message.lines().next());
        let first = first.unwrap_or_default().trim();
        self.error = Some(first.strip_prefix("ERROR: ").unwrap_or(first).to_string());
    }

    /// Prints what the pixel under the cursor sees (the ray through its centre).
    fn pick(&mut self, cursor: (f64, f64), window: &glfw::PWindow) -> Result<(), Error> {
        let (ww, wh) = window.get_size();
        let [w, h] = self.renderer.frame_size();
        if ww <= 0 || wh <= 0 || self.sample == 0 {
            return Ok(());
        }
        let j = (cursor.0 / f64::from(ww) * f64::from(w)).floor();
        let i = (cursor.1 / f64::from(wh) * f64::from(h)).floor();
        if j < 0.0 || i < 0.0 || j >= f64::from(w) || i >= f64::from(h) {
            return Ok(());
        }
        self.pick_pixel(j as u32, i as u32)
    }

    /// Prints what pixel (j, i) of the picture sees, and in the colour view
    /// its sample 0's rays as `raycast trace` follows them (the CPU build,
    /// which gives the device's bits).
    fn pick_pixel(&mut self, j: u32, i: u32) -> Result<(), Error> {
        let [w, h] = self.renderer.frame_size();
        if j >= w || i >= h {
            errln!("raycast: preview: pixel ({j}, {i}) is outside the {w}x{h} picture");
            return Ok(());
        }
        let p = self.renderer.pixel(j, i)?;
        // The cost AOVs' passes (PixelOut.normal's w), hit or miss.
        match self.aov {
            Aov::Cost => outln!("pixel ({j}, {i}): its camera ray's walk took {} passes", p.normal[3]),
            Aov::CostAll => outln!("pixel ({j}, {i}): its rays' walks took {} passes in all", p.normal[3]),
            Aov::Lanes => {
                // Its record holds the split, not the hit (layout.h AOV_LANES).
                let [camera, shadow, mirror, all] = p.normal;
                outln!(
                    "pixel ({j}, {i}): its rays' walks took {all} passes in all: camera {camera}, shadow {shadow}, \
                     mirror and refracted {mirror}; they fetched {} bytes of hierarchy, {} of primitives",
                    p.t,
                    p.id
                );
                return Ok(());
            }
            _ => {}
        }
        if p.id == NO_HIT {
            outln!("pixel ({j}, {i}): nothing (the ray misses every primitive)");
            return Ok(());
        }
        let Some(prim) = self.scene.primitive(u64::from(p.id)) else {
            outln!("pixel ({j}, {i}): primitive {} (not in the scene on the host: reloading?)", p.id);
            return Ok(());
        };
        // The ray through the pixel centre, as camera_ray in raycast.glsl (in f64, for the report).
        let world_from_film = frame::world_from_film(&self.camera.camera, w, h);
        let x = ((f64::from(j) + 0.5) / f64::from(w)) * 2.0 - 1.0;
        let y = 1.0 - ((f64::from(i) + 0.5) / f64::from(h)) * 2.0;
        let dir = world_from_film.transform_vector3(DVec3::new(x, y, -1.0));
        let hit = self.camera.camera.pos + dir * f64::from(p.t);
        let m = &self.scene.materials[prim.material as usize];
        let v3 = |v: DVec3| format!("({:.4}, {:.4}, {:.4})", v.x, v.y, v.z);
        outln!("pixel ({j}, {i}): primitive {} ({}) at {}", p.id, prim.shape.name(), prim.loc);
        outln!(
            "  t {} (ray direction not unit; distance {:.4}), position {}, normal {}",
            p.t,
            f64::from(p.t) * dir.length(),
            v3(hit),
            v3(DVec3::new(f64::from(p.normal[0]), f64::from(p.normal[1]), f64::from(p.normal[2])))
        );
        outln!("  material: {}", m.describe());
        self.print_trace(j, i)
    }

    /// The colour view's trace of pixel (j, i) (its sample 0, the centre ray).
    fn print_trace(&self, j: u32, i: u32) -> Result<(), Error> {
        if self.aov != Aov::Color {
            return Ok(());
        }
        let frame = self.frame_at(self.renderer.frame_size());
        let steps = crate::cpu::CpuRenderer::new()?.trace(&self.data, &frame, j, i, 0)?;
        if self.sample > 1 {
            // The window shows the mean of its samples; the trace follows the centre one.
            outln!("  its rays (`raycast trace`), sample 0 (the pixel centre) of the {} averaged here:", self.sample);
        } else {
            outln!("  its rays (`raycast trace`):");
        }
        for line in crate::trace::describe(&self.scene, &steps) {
            outln!("    {line}");
        }
        Ok(())
    }

    /// Writes the last frame's picture (the quantised bytes the kernel wrote) as RGB PNG.
    fn save(&mut self, path: &Path) -> Result<(), Error> {
        let [width, height] = self.renderer.frame_size();
        let pixels = self.renderer.pixels()?;
        crate::render::refuse_cut_short(
            &pixels,
            width,
            &self.device,
            "Turn mirror reflections off (M, or --no-reflections), or use another Vulkan device".into(),
        )?;
        let picture = Picture { width, height, pixels };
        image_io::write_png(path, &picture.rgb8()?)?;
        let n = self.sample;
        outln!("wrote {} ({width}x{height}, {n} sample{} per pixel)", path.display(), if n == 1 { "" } else { "s" });
        Ok(())
    }
}
