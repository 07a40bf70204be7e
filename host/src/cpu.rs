//! The CPU backend: the C++ build of the shared GLSL (host/cpu), called
//! through its C ABI, rows handed out to every core.

use crate::error::Error;
use crate::frame::FrameData;
use crate::gpu::Buffer;
use crate::layout::{self, PixelOut};
use crate::preview::layout::{AccumPixel, PreviewFrame};
use crate::render::{GpuTimings, Picture, Progress, Progressive, Renderer, Specialization, Told};
use std::ffi::{c_void, CString};
use std::ops::Range;
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// raycast_cpu_render_rows and its lean copy's (raycast_cpu.h).
type RenderRows = unsafe extern "C" fn(buffers: *const *const c_void, row_begin: u32, row_end: u32, out: *mut c_void);
/// raycast_cpu_preview_rows and its lean copy's (raycast_cpu.h).
type PreviewRows = unsafe extern "C" fn(
    buffers: *const *const c_void,
    row_begin: u32,
    row_end: u32,
    sample_index: u32,
    jitter_x: f32,
    jitter_y: f32,
    accum: *mut c_void,
    pixels: *mut c_void,
);

/// The row loops of each copy of the C++ build, the whole one and the
/// lean one (raycast_cpu_lean.cpp): the same signatures, RenderRows' and
/// PreviewRows'.
macro_rules! row_loops {
    ($($render:ident, $preview:ident);*) => {
        extern "C" {
            $(
                fn $render(buffers: *const *const c_void, row_begin: u32, row_end: u32, out: *mut c_void);
                fn $preview(
                    buffers: *const *const c_void,
                    row_begin: u32,
                    row_end: u32,
                    sample_index: u32,
                    jitter_x: f32,
                    jitter_y: f32,
                    accum: *mut c_void,
                    pixels: *mut c_void,
                );
            )*
        }
    };
}
row_loops!(raycast_cpu_render_rows, raycast_cpu_preview_rows; raycast_cpu_render_rows_lean, raycast_cpu_preview_rows_lean);
#[cfg(target_arch = "x86_64")]
row_loops!(raycast_cpu_render_rows_lean_avx2, raycast_cpu_preview_rows_lean_avx2);

/// The copies of the C++ build (raycast_cpu.h): the same bits, each with
/// less code than the one before.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum BuildCopy {
    Whole,
    /// Without what Specialization::cpu_lean leaves out (raycast_cpu_lean.cpp).
    Lean,
    /// The lean copy compiled with AVX2 (raycast_cpu_lean_avx2.cpp), x86-64 only.
    LeanAvx2,
}

impl BuildCopy {
    /// The copy that draws `frame` of `data`: a lean one where the frame's
    /// specialization leaves out all it leaves out, with AVX2 where the
    /// CPU has it; else the whole one.
    fn for_frame(data: &FrameData, frame: &layout::Frame) -> BuildCopy {
        match (Specialization::of(data, frame).cpu_lean(), has_avx2()) {
            (false, _) => BuildCopy::Whole,
            (true, false) => BuildCopy::Lean,
            (true, true) => BuildCopy::LeanAvx2,
        }
    }

    fn row_loops(self) -> (RenderRows, PreviewRows) {
        match self {
            BuildCopy::Whole => (raycast_cpu_render_rows, raycast_cpu_preview_rows),
            BuildCopy::Lean => (raycast_cpu_render_rows_lean, raycast_cpu_preview_rows_lean),
            #[cfg(target_arch = "x86_64")]
            BuildCopy::LeanAvx2 => (raycast_cpu_render_rows_lean_avx2, raycast_cpu_preview_rows_lean_avx2),
            #[cfg(not(target_arch = "x86_64"))]
            BuildCopy::LeanAvx2 => unreachable!("has_avx2 is false off x86-64"),
        }
    }
}

/// Whether this CPU runs the lean copy's AVX2 build.
fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

/// The row loops of the copy that draws `frame` of `data` (BuildCopy::for_frame).
fn row_loops_for(data: &FrameData, frame: &layout::Frame) -> (RenderRows, PreviewRows) {
    BuildCopy::for_frame(data, frame).row_loops()
}

extern "C" {
    fn raycast_cpu_course_samples(buffers: *const *const c_void, x: u32, y: u32, out: *mut f32) -> u32;
    fn raycast_cpu_field_offset(ty: *const std::ffi::c_char, member: *const std::ffi::c_char) -> i64;
    fn raycast_cpu_record_columns(buffers: *const *const c_void, out: *mut u32, capacity: u64) -> u64;
    fn raycast_cpu_trace_sample(
        buffers: *const *const c_void,
        x: u32,
        y: u32,
        sample: u32,
        out: *mut c_void,
        capacity: u32,
    ) -> u32;
}

/// Where raycast_cpu.h takes the record columns: past the kernel's bindings.
const RECORD_COLUMNS: usize = layout::BINDING_COUNT as usize;

/// The kernel's buffers by binding number, and the record columns made
/// for them, as raycast_cpu.h takes them.
fn buffer_pointers(data: &FrameData) -> SendPtrs {
    let mut buffers = [std::ptr::null::<c_void>(); RECORD_COLUMNS + 1];
    buffers[layout::BINDING_FRAME as usize] = (&data.frame as *const layout::Frame).cast();
    for (binding, _, bytes) in data.scene_buffers() {
        buffers[binding as usize] = bytes.as_ptr().cast();
    }
    let mut columns = Vec::new();
    if !data.instances.is_empty() {
        // SAFETY: as in `CpuRenderer::run`; a null `out` only sizes them.
        let words = unsafe { raycast_cpu_record_columns(buffers.as_ptr(), std::ptr::null_mut(), 0) };
        columns = vec![0u32; usize::try_from(words).expect("the record columns fit the address space")];
        // SAFETY: `columns` holds `words` words.
        unsafe { raycast_cpu_record_columns(buffers.as_ptr(), columns.as_mut_ptr(), words) };
        if !columns.is_empty() {
            buffers[RECORD_COLUMNS] = columns.as_ptr().cast();
        }
    }
    SendPtrs { buffers, _columns: columns }
}

/// Rows a thread takes at a time: small enough to balance uneven rows.
const ROWS_PER_JOB: u32 = 4;

/// Checks the C++ layout of every struct in `shaders/layout.h` against the
/// Rust mirror (which the GPU side checks against naga's reflection).
pub fn check_layouts() -> Result<(), Error> {
    let structs = [
        layout::Frame::layout(),
        layout::Primitive::layout(),
        layout::Material::layout(),
        layout::Light::layout(),
        layout::Texture::layout(),
        layout::Texel::layout(),
        layout::BvhNode::layout(),
        layout::LeafItem::layout(),
        layout::Instance::layout(),
        layout::MeshTriangle::layout(),
        layout::MeshVertex::layout(),
        layout::PixelOut::layout(),
        layout::TraceStep::layout(),
        AccumPixel::layout(),
    ];
    let mut errors = Vec::new();
    for s in &structs {
        let name = CString::new(s.name).unwrap();
        // SAFETY: both pointers are valid NUL-terminated strings or null.
        let size = unsafe { raycast_cpu_field_offset(name.as_ptr(), std::ptr::null()) };
        if size != i64::from(s.size) {
            errors.push(format!("{}: size {size} in the C++ build, {} on the host", s.name, s.size));
        }
        for f in &s.fields {
            let member = CString::new(f.name).unwrap();
            let offset = unsafe { raycast_cpu_field_offset(name.as_ptr(), member.as_ptr()) };
            if offset != i64::from(f.offset) {
                errors
                    .push(format!("{}.{}: offset {offset} in the C++ build, {} on the host", s.name, f.name, f.offset));
            }
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(Error::Failed(format!(
            "the CPU build's structs differ from host/src/layout.rs:\n  {}",
            errors.join("\n  ")
        )))
    }
}

/// Buffer pointers shared by the render threads, which only read through
/// them, and the record columns, which the last one points into.
struct SendPtrs {
    buffers: [*const c_void; RECORD_COLUMNS + 1],
    _columns: Vec<u32>,
}
// SAFETY: the pointers are only read, and the data they point to outlives
// the scoped threads (it is borrowed from `data` for the whole render).
unsafe impl Sync for SendPtrs {}

impl SendPtrs {
    /// The array for the C ABI (a method, so that a closure captures the
    /// whole `SendPtrs`, which is Sync, not its array).
    fn as_ptr(&self) -> *const *const c_void {
        self.buffers.as_ptr()
    }
}

/// The machine's CPU, for the reports that compare machines (`raycast
/// devices`, `bench --json`, BENCHMARKS.md's machine block): its name as
/// /proc/cpuinfo gives it, with what tells two CPUs of one name apart (a
/// virtual machine's "AMD EPYC" has been CPUs with and without AVX-512 from
/// one day to the next, every time moving with it): family, model and
/// stepping, the widest vector instructions, and a core's L2 and the L3
/// cache (sysfs). "unknown CPU" without /proc/cpuinfo's model name.
pub fn host_cpu() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        info.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            (k.trim() == name).then(|| v.trim().to_string())
        })
    };
    let Some(name) = field("model name") else { return "unknown CPU".to_string() };
    let mut parts = Vec::new();
    if let (Some(f), Some(m), Some(s)) = (field("cpu family"), field("model"), field("stepping")) {
        parts.push(format!("family {f}, model {m}, stepping {s}"));
    }
    let flags = field("flags").unwrap_or_default();
    let has = |f: &str| flags.split_whitespace().any(|x| x == f);
    parts.push(
        if has("avx512f") {
            "AVX-512"
        } else if has("avx2") {
            "AVX2"
        } else {
            "no AVX2"
        }
        .to_string(),
    );
    let caches: Vec<String> = (0..8)
        .filter_map(|i| {
            let dir = format!("/sys/devices/system/cpu/cpu0/cache/index{i}");
            let read = |f: &str| std::fs::read_to_string(format!("{dir}/{f}")).ok().map(|t| t.trim().to_string());
            let level = read("level")?;
            (level == "2" || level == "3").then(|| format!("L{level} {}", read("size").unwrap_or_default()))
        })
        .collect();
    if !caches.is_empty() {
        parts.push(caches.join(", "));
    }
    format!("{name} ({})", parts.join("; "))
}

/// The threads the CPU build renders on: one a core.
pub fn host_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// What `run` tells as jobs end: `told` the rows done of `total`
/// ("row 120 of 384" and `suffix`), from whichever thread ends one.
fn rows_told<'a>(total: u32, suffix: &'a str, told: Told<'a>) -> impl Fn(u32) + Sync + 'a {
    let done = AtomicU32::new(0);
    move |n| {
        let done = done.fetch_add(n, Ordering::Relaxed) + n;
        let detail = format!("row {done} of {total}{suffix}");
        told(Progress { fraction: f64::from(done) / f64::from(total.max(1)), detail });
    }
}

/// Renders on the CPU with the shared GLSL built as C++.
pub struct CpuRenderer {
    pub threads: usize,
}

impl CpuRenderer {
    /// Uses every core; checks the C++ struct layouts first.
    pub fn new() -> Result<CpuRenderer, Error> {
        check_layouts()?;
        Ok(CpuRenderer { threads: host_threads() })
    }

    /// "CPU build of the shared GLSL (2 threads`why`)": the `device:` lines'
    /// words for it (`why`: "; --backend auto: …" or empty).
    pub fn summary(&self, why: &str) -> String {
        format!("CPU build of the shared GLSL ({} threads{why})", self.threads)
    }

    /// The frame on every core; an error when its pixels' memory cannot be had.
    pub fn render(&self, data: &FrameData) -> Result<Picture, Error> {
        self.render_told(data, &|_| {})
    }

    /// `render`, `told` the rows done (every sample of a row at once) as jobs finish.
    pub fn render_told(&self, data: &FrameData, told: Told) -> Result<Picture, Error> {
        let (width, height) = (data.frame.width, data.frame.height);
        let what = format!("the {width}x{height} picture's pixels ({} bytes each)", std::mem::size_of::<PixelOut>());
        let mut pixels = crate::render::try_filled(width as usize * height as usize, PixelOut::default(), &what)?;
        // Jobs: disjoint slices of ROWS_PER_JOB rows.
        let jobs = pixels.chunks_mut(width as usize * ROWS_PER_JOB as usize).enumerate().map(|(job, slice)| {
            let begin = job as u32 * ROWS_PER_JOB;
            (begin, (begin + ROWS_PER_JOB).min(height), slice)
        });
        let done = self.run(data, jobs, &rows_told(height, "", told));
        debug_assert_eq!(done, height);
        Ok(Picture { width, height, pixels })
    }

    /// Rows `rows` of the frame (each below its height), in that order: a
    /// device's picture finished where the device could not (`render`'s
    /// `finish_cut_short`).
    pub fn render_rows(&self, data: &FrameData, rows: &[u32]) -> Vec<Vec<PixelOut>> {
        self.render_rows_told(data, rows, &|_| {})
    }

    /// `render_rows`, `told` how many of them are done as they end.
    pub fn render_rows_told(&self, data: &FrameData, rows: &[u32], told: Told) -> Vec<Vec<PixelOut>> {
        let width = data.frame.width as usize;
        let mut out = vec![vec![PixelOut::default(); width]; rows.len()];
        assert!(rows.iter().all(|&r| r < data.frame.height), "rows inside the frame");
        let jobs = rows.iter().zip(out.iter_mut()).map(|(&row, pixels)| (row, row + 1, pixels.as_mut_slice()));
        let total = u32::try_from(rows.len()).unwrap_or(u32::MAX);
        self.run(data, jobs, &rows_told(total, " on the CPU build", told));
        out
    }

    /// The steps of sample `sample` of pixel (x, y) of `frame` (the scene's
    /// `data.frame`, or another camera's or size's, as the preview draws)
    /// as `render` takes it (layout.h TraceStep): each ray and what it met,
    /// each light's term, each level's colour, and the sample's colour last.
    pub fn trace(
        &self,
        data: &FrameData,
        frame: &layout::Frame,
        x: u32,
        y: u32,
        sample: u32,
    ) -> Result<Vec<layout::TraceStep>, Error> {
        if x >= frame.width || y >= frame.height {
            return Err(Error::Failed(format!(
                "pixel ({x}, {y}) is outside the {}x{} picture",
                frame.width, frame.height
            )));
        }
        let spp = if frame.flags & layout::FLAG_COURSE_SAMPLING != 0 {
            self.course_samples(data, frame, x, y)?.len() as u32
        } else {
            frame.spp.max(1)
        };
        if sample >= spp {
            return Err(Error::Failed(format!("sample {sample} is not one of the pixel's {spp} (0 to {})", spp - 1)));
        }
        let mut buffers = buffer_pointers(data);
        buffers.buffers[layout::BINDING_FRAME as usize] = (frame as *const layout::Frame).cast();
        let mut steps = vec![layout::TraceStep::default(); 64];
        loop {
            let capacity = u32::try_from(steps.len()).expect("a trace's steps fit u32");
            // SAFETY: as in `run`; `steps` holds `capacity` TraceSteps (layout checked).
            let n = unsafe {
                raycast_cpu_trace_sample(buffers.as_ptr(), x, y, sample, steps.as_mut_ptr().cast(), capacity)
            };
            if n <= capacity {
                steps.truncate(n as usize);
                return Ok(steps);
            }
            steps.resize(n as usize, layout::TraceStep::default());
        }
    }

    /// The samples the course's adaptive scheme takes at pixel (x, y) of
    /// `frame` (`--supersample course`), in the order it takes them.
    pub fn course_samples(
        &self,
        data: &FrameData,
        frame: &layout::Frame,
        x: u32,
        y: u32,
    ) -> Result<Vec<CourseSample>, Error> {
        if x >= frame.width || y >= frame.height {
            let (w, h) = (frame.width, frame.height);
            return Err(Error::Failed(format!("pixel ({x}, {y}) is outside the {w}x{h} picture")));
        }
        let mut buffers = buffer_pointers(data);
        buffers.buffers[layout::BINDING_FRAME as usize] = (frame as *const layout::Frame).cast();
        let mut out = vec![0f32; 6 * layout::COURSE_MAX_SAMPLES as usize];
        // SAFETY: as in `run`; `out` holds COURSE_MAX_SAMPLES records of 6 floats (raycast_cpu.h).
        let n = unsafe { raycast_cpu_course_samples(buffers.as_ptr(), x, y, out.as_mut_ptr()) };
        Ok(out
            .chunks_exact(6)
            .take(n as usize)
            .map(|r| CourseSample { offset: [r[0], r[1]], level: r[2] as u32, color: [r[3], r[4], r[5]] })
            .collect())
    }

    /// Runs the jobs (first row, end row, their pixels) on every thread,
    /// each taken by whichever thread is free, `finished` told each job's
    /// rows as it ends; returns the rows rendered.
    fn run<'a>(
        &self,
        data: &FrameData,
        jobs: impl Iterator<Item = (u32, u32, &'a mut [PixelOut])> + Send,
        finished: &(dyn Fn(u32) + Sync),
    ) -> u32 {
        let buffers = buffer_pointers(data);
        let width = data.frame.width as usize;
        let (render_rows, _) = row_loops_for(data, &data.frame);
        self.run_jobs(jobs, |(begin, end, slice)| {
            assert_eq!(slice.len(), (end - begin) as usize * width, "a job's pixels are its rows");
            // SAFETY: the buffers outlive the call and hold the structs of
            // layout.h (checked by check_layouts); `slice` holds exactly
            // (end - begin) rows (asserted); the C++ code reads only
            // primitive_count primitives and light_count lights, materials
            // indexed by primitives, textures indexed by materials and
            // texels inside each texture's range (frame::build guarantees
            // all three).
            unsafe { render_rows(buffers.as_ptr(), begin, end, slice.as_mut_ptr().cast()) };
            finished(end - begin);
            end - begin
        })
    }

    /// One sample of the preview (`preview` says which, and its rows from
    /// `preview.row_offset` to `row_end`) of `frame` (the preview's camera
    /// and size) drawn with `data`'s scene: preview_main.glsl's steps in the
    /// C++ build (raycast_cpu_preview_rows). `accum` and `pixels` hold the
    /// frame's pixels, row by row (frame.width a row); the band's are read
    /// and written.
    pub fn preview_rows(
        &self,
        data: &FrameData,
        frame: &layout::Frame,
        preview: &PreviewFrame,
        row_end: u32,
        accum: &mut [AccumPixel],
        pixels: &mut [PixelOut],
    ) {
        let width = frame.width as usize;
        let (begin, end) = (preview.row_offset, row_end);
        assert!(begin < end && end <= frame.height, "the band is inside the frame");
        assert!(
            accum.len() >= end as usize * width && pixels.len() >= end as usize * width,
            "the buffers hold the frame"
        );
        let mut buffers = buffer_pointers(data);
        buffers.buffers[layout::BINDING_FRAME as usize] = (frame as *const layout::Frame).cast();
        let band = begin as usize * width..end as usize * width;
        let rows = width * ROWS_PER_JOB as usize;
        let jobs =
            accum[band.clone()].chunks_mut(rows).zip(pixels[band].chunks_mut(rows)).enumerate().map(|(k, (a, p))| {
                let first = begin + k as u32 * ROWS_PER_JOB;
                (first, (first + ROWS_PER_JOB).min(end), a, p)
            });
        let (sample, [jx, jy, ..]) = (preview.sample_index, preview.jitter);
        let (_, preview_rows) = row_loops_for(data, frame);
        self.run_jobs(jobs, |(first, last, a, p)| {
            assert!(a.len() == p.len() && a.len() == (last - first) as usize * width, "a job's pixels are its rows");
            // SAFETY: as in `run`; `a` and `p` hold exactly the job's rows (asserted).
            unsafe {
                preview_rows(
                    buffers.as_ptr(),
                    first,
                    last,
                    sample,
                    jx,
                    jy,
                    a.as_mut_ptr().cast(),
                    p.as_mut_ptr().cast(),
                );
            }
            last - first
        });
    }

    /// Runs `work` on the jobs on every thread, each job taken by whichever
    /// thread is free; returns the sum of what `work` returned (the rows).
    fn run_jobs<J: Send>(&self, jobs: impl Iterator<Item = J> + Send, work: impl Fn(J) -> u32 + Sync) -> u32 {
        let jobs = Mutex::new(jobs);
        let done = AtomicU32::new(0);
        std::thread::scope(|scope| {
            for _ in 0..self.threads.max(1) {
                scope.spawn(|| loop {
                    let Some(job) = jobs.lock().unwrap().next() else { break };
                    done.fetch_add(work(job), Ordering::Relaxed);
                });
            }
        });
        done.load(Ordering::Relaxed)
    }
}

/// One sample the course's adaptive scheme took (`CpuRenderer::course_samples`).
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct CourseSample {
    /// From the pixel centre, in pixels.
    pub offset: [f32; 2],
    /// Its square's level: 0 the pixel's 4, 1 and 2 refined quadrants.
    pub level: u32,
    pub color: [f32; 3],
}

/// The CPU build drawing the preview's samples (`raycast preview --backend
/// cpu`): preview_main.glsl's steps in C++ (`CpuRenderer::preview_rows`),
/// with the picture's running sums and pixels it keeps, frame.width a row.
/// A device shows its pixels (the preview kernel built with HOST_PIXELS).
pub struct CpuProgressive {
    cpu: CpuRenderer,
    accum: Vec<AccumPixel>,
    pixels: Vec<PixelOut>,
    /// The time of the sample drawn last, until `wait` reports it.
    drawn_in: Option<Duration>,
}

impl CpuProgressive {
    /// Running sums for a picture of `w` x `h` pixels, drawn by `cpu`.
    pub fn new(cpu: CpuRenderer, [w, h]: [u32; 2]) -> CpuProgressive {
        let count = w as usize * h as usize;
        CpuProgressive {
            cpu,
            accum: vec![AccumPixel::default(); count],
            pixels: vec![PixelOut::default(); count],
            drawn_in: None,
        }
    }

    /// The same CPU build for a picture of another size; the samples start over.
    pub fn resized(self, size: [u32; 2]) -> CpuProgressive {
        CpuProgressive::new(self.cpu, size)
    }

    /// The threads that draw.
    pub fn threads(&self) -> usize {
        self.cpu.threads
    }
}

impl Progressive for CpuProgressive {
    fn describe(&self) -> String {
        Renderer::describe(&self.cpu)
    }

    /// Draws the sample before it returns.
    fn add_sample(
        &mut self,
        data: &FrameData,
        frame: &layout::Frame,
        preview: &PreviewFrame,
        row_end: u32,
    ) -> Result<(), Error> {
        let start = Instant::now();
        self.cpu.preview_rows(data, frame, preview, row_end, &mut self.accum, &mut self.pixels);
        self.drawn_in = Some(start.elapsed());
        Ok(())
    }

    fn wait(&mut self) -> Result<Option<Duration>, Error> {
        Ok(self.drawn_in.take())
    }

    fn copy_pixels(&mut self, bytes: Range<usize>, to: &Buffer) -> Result<(), Error> {
        let start = bytes.start;
        to.write(start, &bytemuck::cast_slice(&self.pixels)[bytes]);
        Ok(())
    }

    /// Never: the CPU build runs every loop to its end.
    fn cut_short(&mut self) -> Result<u32, Error> {
        Ok(0)
    }
}

impl Renderer for CpuRenderer {
    fn describe(&self) -> String {
        self.summary("")
    }

    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, GpuTimings), Error> {
        let start = std::time::Instant::now();
        let picture = self.render_told(data, told)?;
        let timings =
            GpuTimings { dispatch: start.elapsed(), bands: 1, band_rows: data.frame.height, ..GpuTimings::default() };
        Ok((picture, timings))
    }
}

/// Recomputes with the CPU build the pixels of `picture` (a render of
/// `data`) that the device cut short; returns how many. The CPU build runs
/// the same shader code: on lavapipe, the only device known to cut pixels
/// short, its pixels are the device's bit for bit (what `raycast check`
/// and CI compare), so the finished picture is the one the device would
/// have made without its limit.
pub fn finish_cut_short(picture: &mut Picture, data: &FrameData, cpu: &CpuRenderer, told: Told) -> usize {
    let width = picture.width as usize;
    let rows: Vec<u32> = picture
        .pixels
        .chunks(width)
        .enumerate()
        .filter(|(_, row)| row.iter().any(PixelOut::is_cut_short))
        .map(|(i, _)| i as u32)
        .collect();
    let mut count = 0;
    for (row, cpu_row) in rows.iter().zip(cpu.render_rows_told(data, &rows, told)) {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpp_layouts_match_the_host() {
        check_layouts().unwrap();
    }

    /// Every copy of the C++ build draws the same bits: the whole one (in
    /// the device's walk order), the lean one (in its own order, the record
    /// columns read four at a time) and, where the CPU has AVX2, the lean
    /// one's AVX2 build (eight at a time). Over instances bounded by spheres
    /// (recursive spheres) and by boxes (recursive cubes, cones), the ties
    /// scene, where the order the walk meets hits in matters most, and
    /// leaves of box and sphere records together (divergent lanes), with
    /// shadows and mirrors. Rule: every pixel's PixelOut, bit for bit.
    #[test]
    fn every_copy_draws_the_same_bits() {
        use crate::gen::{generate, Family, GenOptions};
        let stress = |name: &str| {
            let path = format!("{}/../tests/scenes/stress/{name}", env!("CARGO_MANIFEST_DIR"));
            let limits = crate::scene::FlattenLimits::default();
            crate::scene::load(path.as_ref(), &crate::scene::ParseOptions::default(), &limits).unwrap()
        };
        let untextured = GenOptions { texture: None };
        let generated =
            |family, depth| crate::scene::from_xml(generate(family, depth, &untextured).unwrap(), "gen.xml");
        let scenes = [
            ("recursive spheres 5", generated(Family::RecursiveSpheres, 5)),
            ("recursive cubes 4", generated(Family::RecursiveCubes, 4)),
            ("recursive cones 4", generated(Family::RecursiveCones, 4)),
            ("ties", stress("ties.xml")),
            // Box and sphere records in one leaf: records_meet's lanes and its scalar tests.
            ("divergent lanes", stress("divergent_lanes.xml")),
        ];
        let mut copies = vec![BuildCopy::Lean];
        if has_avx2() {
            copies.push(BuildCopy::LeanAvx2);
        } else {
            eprintln!("every_copy_draws_the_same_bits: no AVX2 on this CPU, its build not compared");
        }
        for (name, scene) in scenes {
            let settings = crate::frame::RenderSettings { width: 96, height: 72, ..Default::default() };
            let data = crate::frame::build(&scene, &settings).unwrap();
            assert!(Specialization::of(&data, &data.frame).cpu_lean(), "{name}: the lean copies draw it");
            let buffers = buffer_pointers(&data);
            let draw = |copy: BuildCopy| {
                let mut pixels = vec![PixelOut::default(); (data.frame.width * data.frame.height) as usize];
                // SAFETY: as in `CpuRenderer::run`; `pixels` holds every row.
                unsafe { (copy.row_loops().0)(buffers.as_ptr(), 0, data.frame.height, pixels.as_mut_ptr().cast()) };
                pixels
            };
            let whole = draw(BuildCopy::Whole);
            for &copy in &copies {
                let pixels = draw(copy);
                let differ: Vec<usize> = (0..whole.len())
                    .filter(|&k| bytemuck::bytes_of(&pixels[k]) != bytemuck::bytes_of(&whole[k]))
                    .collect();
                assert!(
                    differ.is_empty(),
                    "{name}: {copy:?} differs from the whole copy at {} of {} pixels; the first, pixel {}: {:?} against {:?}",
                    differ.len(),
                    whole.len(),
                    differ[0],
                    pixels[differ[0]],
                    whole[differ[0]]
                );
            }
        }
    }

    /// The camera between two facing mirrors (wide mirror cubes at z = -5
    /// and z = +5) with `second` as its second light: every camera ray
    /// bounces to the depth limit.
    fn mirrors(second: &str) -> crate::scene::Scene {
        let xml = format!(
            r#"<scenefile>
  <globaldata><ambientcoeff v="0.5"/><diffusecoeff v="0.5"/><specularcoeff v="0.5"/></globaldata>
  <cameradata><pos x="0" y="0" z="0"/><look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="30"/></cameradata>
  <lightdata><id v="0"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="2" z="0"/></lightdata>
  {second}
  <object type="tree" name="root">
    <transblock><translate x="0" y="0" z="-5"/><scale x="40" y="40" z="1"/>
      <object type="primitive" name="cube"><diffuse r="1" g="1" b="1"/><reflective r="1" g="1" b="1"/></object></transblock>
    <transblock><translate x="0" y="0" z="5"/><scale x="40" y="40" z="1"/>
      <object type="primitive" name="cube"><diffuse r="1" g="1" b="1"/><reflective r="1" g="1" b="1"/></object></transblock>
  </object>
</scenefile>"#
        );
        crate::scene::from_xml(xml, "mirrors.xml")
    }

    /// Two point lights between the mirrors light both faces: every pixel
    /// traces 1 camera ray + (depth + 1) shaded hits x 2 shadow rays +
    /// depth mirror rays. A directional light along the mirrors (n . l = 0,
    /// no specular) adds nothing anywhere, so it gets no shadow ray: one per
    /// hit. Rule: exact count in every pixel.
    #[test]
    fn pixels_count_camera_shadow_and_mirror_rays() {
        let renderer = CpuRenderer::new().unwrap();
        let depth = 4;
        let point = r#"<lightdata><id v="1"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="-2" z="0"/></lightdata>"#;
        let grazing = r#"<lightdata><id v="1"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="-1" z="0"/></lightdata>"#;
        for (second, shadows, reflections, want) in [
            (point, true, true, 1 + (depth + 1) * 2 + depth),
            (point, false, true, 1 + depth),
            (point, true, false, 1 + 2),
            (grazing, true, true, 1 + (depth + 1) + depth),
        ] {
            let settings = crate::frame::RenderSettings {
                width: 16,
                height: 12,
                shadows,
                reflections,
                max_depth: depth,
                ..Default::default()
            };
            let picture = renderer.render(&crate::frame::build(&mirrors(second), &settings).unwrap()).unwrap();
            let wrong: Vec<(usize, u32)> =
                picture.pixels.iter().enumerate().filter(|(_, p)| p.rays != want).map(|(i, p)| (i, p.rays)).collect();
            assert!(
                wrong.is_empty(),
                "shadows {shadows}, reflections {reflections}: {} of {} pixels do not count {want} rays; first (pixel, rays) {:?}, all {:?}",
                wrong.len(),
                picture.pixels.len(),
                wrong.first(),
                wrong
            );
        }
    }

    /// `trace` follows the render: for every pixel of the mirrors (every
    /// ray bouncing to the depth limit, two shadowed lights) and of the
    /// embedded default scene (shadows cast, a spot light) and of glass (a
    /// refracting sphere and cube, total internal reflection), at one sample a
    /// pixel its last step holds the pixel's 8-bit colour, its ray steps are
    /// the pixel's ray count and its camera ray's hit is the pixel's (id and
    /// t bits); at two, the samples' rays add up to the pixel's. Each light
    /// whose shadow ray decides is followed by that shadow ray. Rule: exact,
    /// every pixel.
    #[test]
    fn the_trace_of_every_pixel_is_its_render() {
        use crate::layout::{TRACE_CAMERA, TRACE_LIGHT, TRACE_LIGHT_SHADOW, TRACE_PIXEL, TRACE_SHADOW};
        let renderer = CpuRenderer::new().unwrap();
        let point = r#"<lightdata><id v="1"/><type v="point"/><color r="1" g="1" b="1"/><position x="0" y="-2" z="0"/></lightdata>"#;
        let default = crate::scene::from_xml(crate::source::DEFAULT_SCENE, "default.xml");
        let glass = crate::scene::from_xml(
            r#"<scenefile><globaldata><transparentcoeff v="0.9"/></globaldata>
              <cameradata><pos x="0" y="1" z="3"/><focus x="0" y="0" z="0"/></cameradata>
              <lightdata><type v="directional"/><direction x="-1" y="-2" z="-1"/></lightdata>
              <object type="tree" name="root">
                <transblock><translate x="0" y="-1" z="0"/><scale x="6" y="0.2" z="6"/><object type="primitive" name="cube"><diffuse r="0.8" g="0.5" b="0.2"/><reflective r="0.3" g="0.3" b="0.3"/></object></transblock>
                <transblock><translate x="-0.6" y="0" z="0"/><object type="primitive" name="sphere"><diffuse r="0.1" g="0.1" b="0.2"/><reflective r="0.2" g="0.2" b="0.2"/><transparent r="0.9" g="0.9" b="1"/><ior v="1.5"/></object></transblock>
                <transblock><translate x="0.6" y="0" z="0"/><rotate x="0" y="1" z="0" angle="30"/><object type="primitive" name="cube"><diffuse r="0" g="0.2" b="0"/><transparent r="0.8" g="1" b="0.8"/><ior v="2"/></object></transblock>
              </object></scenefile>"#,
            "glass.xml",
        );
        for (name, scene) in [("mirrors", mirrors(point)), ("default", default), ("glass", glass)] {
            for spp in [1, 2] {
                let settings = crate::frame::RenderSettings { width: 24, height: 18, spp, ..Default::default() };
                let data = crate::frame::build(&scene, &settings).unwrap();
                let picture = renderer.render(&data).unwrap();
                for (k, pixel) in picture.pixels.iter().enumerate() {
                    let (x, y) = (k as u32 % 24, k as u32 / 24);
                    let mut rays = 0;
                    for sample in 0..spp {
                        let steps = renderer.trace(&data, &data.frame, x, y, sample).unwrap();
                        rays += steps.iter().filter(|s| s.is_ray()).count() as u32;
                        for pair in steps.windows(2) {
                            if pair[0].kind == TRACE_LIGHT && pair[0].id == TRACE_LIGHT_SHADOW {
                                assert!(
                                    pair[1].kind == TRACE_SHADOW && pair[1].light == pair[0].light,
                                    "{name} ({x}, {y}): {steps:?}"
                                );
                            }
                        }
                        let last = steps.last().expect("a step");
                        assert_eq!(last.kind, TRACE_PIXEL, "{name} ({x}, {y})");
                        if spp == 1 {
                            assert_eq!(last.id, pixel.rgba, "{name} ({x}, {y}): the 8-bit colour");
                            let camera = &steps[0];
                            assert_eq!(camera.kind, TRACE_CAMERA, "{name} ({x}, {y})");
                            assert_eq!(camera.id, pixel.id, "{name} ({x}, {y})");
                            if camera.id != layout::NO_HIT {
                                assert_eq!(camera.value[3].to_bits(), pixel.t.to_bits(), "{name} ({x}, {y}): t");
                            }
                        }
                    }
                    assert_eq!(rays, pixel.rays, "{name} ({x}, {y}), {spp} samples: the rays");
                }
            }
        }
        let data = crate::frame::build(&mirrors(point), &Default::default()).unwrap();
        assert!(renderer
            .trace(&data, &data.frame, 512, 0, 0)
            .unwrap_err()
            .to_string()
            .contains("outside the 512x384 picture"));
        assert!(renderer
            .trace(&data, &data.frame, 0, 0, 1)
            .unwrap_err()
            .to_string()
            .contains("sample 1 is not one of the pixel's 1"));
    }

    /// Two spheres in front of the camera: A (id 0, radius 1) at the
    /// origin, 4 from the eye along the centre pixel's ray; B (id 1) higher
    /// up, 5 behind it.
    fn two_spheres() -> crate::scene::Scene {
        let xml = r#"<scenefile>
  <cameradata><pos x="0" y="0" z="5"/><look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="30"/></cameradata>
  <lightdata><id v="0"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="0" z="-1"/></lightdata>
  <object type="tree" name="root">
    <transblock><scale x="2" y="2" z="2"/><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/></object></transblock>
    <transblock><translate x="0" y="2" z="-5"/><scale x="2" y="2" z="2"/><object type="primitive" name="sphere"><diffuse r="0" g="1" b="0"/></object></transblock>
  </object>
</scenefile>"#;
        crate::scene::from_xml(xml, "two.xml")
    }

    /// raycast.glsl heat_color, quantised as pack_rgba8, as written here.
    fn heat(x: f32) -> [u8; 3] {
        let s = 4.0 * x.clamp(0.0, 1.0);
        [3.0f32, 2.0, 1.0].map(|c| ((1.5 - (s - c).abs()).clamp(0.0, 1.0) * 255.0).floor() as u8)
    }

    fn rgb(p: &crate::layout::PixelOut) -> [u8; 3] {
        let b = p.rgba.to_le_bytes();
        [b[0], b[1], b[2]]
    }

    /// The AOVs show the first hit (the CPU build runs the kernels' code;
    /// the check suite holds the device to it bit for bit). Rules, exact:
    /// misses black; the normal AOV of the centre pixel (normal +z) is
    /// floor(255 (n + 1) / 2); the depth AOV with --depth-range 3.75,4.75 of
    /// the centre pixel (distance 4) is floor(255 * 3 / 4), and with the
    /// default range A is lighter than B; the id AOV of every hit pixel is
    /// its id's colour as written here (the hash of raycast.glsl id_color),
    /// and both spheres appear.
    #[test]
    fn aovs_show_the_first_hit() {
        use crate::frame::{build, Aov, RenderSettings};
        let renderer = CpuRenderer::new().unwrap();
        let scene = two_spheres();
        let (w, h) = (33u32, 33u32);
        let at = |x: u32, y: u32| (y * w + x) as usize;
        let (centre, corner) = (at(16, 16), at(0, 32));
        let render = |aov: Aov, depth_range: Option<[f32; 2]>| {
            let settings = RenderSettings { width: w, height: h, aov, depth_range, ..RenderSettings::default() };
            settings.validate().unwrap();
            renderer.render(&build(&scene, &settings).unwrap()).unwrap()
        };
        // Where B shows: the pixels whose first hit is id 1.
        let ids = render(Aov::Id, None);
        let b_pixel = ids.pixels.iter().position(|p| p.id == 1).expect("sphere B is in the picture");
        assert_eq!(ids.pixels[centre].id, 0, "the centre pixel sees sphere A");

        let normal = render(Aov::Normal, None);
        assert_eq!(rgb(&normal.pixels[centre]), [127, 127, 255], "normal AOV, centre pixel");
        assert_eq!(rgb(&normal.pixels[corner]), [0, 0, 0], "normal AOV, a miss");

        let depth = render(Aov::Depth, Some([3.75, 4.75]));
        assert_eq!(rgb(&depth.pixels[centre]), [191, 191, 191], "depth AOV 3.75..4.75, distance 4: 1 - 1/4");
        assert_eq!(rgb(&depth.pixels[corner]), [0, 0, 0], "depth AOV, a miss");
        let auto = render(Aov::Depth, None);
        let (a, b) = (rgb(&auto.pixels[centre])[0], rgb(&auto.pixels[b_pixel])[0]);
        assert!(a > b && b > 0, "default depth range: A ({a}) lighter than B ({b}), B not black");

        let id_color = |id: u32| -> [u8; 3] {
            let mut hash = id.wrapping_add(1).wrapping_mul(2654435761);
            hash ^= hash >> 15;
            [0, 8, 16].map(|s| (((((hash >> s) & 255) as f32 / 255.0) * 0.75 + 0.25) * 255.0).floor() as u8)
        };
        let wrong: Vec<(usize, u32, [u8; 3])> = ids
            .pixels
            .iter()
            .enumerate()
            .filter(|(_, p)| rgb(p) != if p.id == crate::layout::NO_HIT { [0, 0, 0] } else { id_color(p.id) })
            .map(|(i, p)| (i, p.id, rgb(p)))
            .collect();
        assert!(
            wrong.is_empty(),
            "id AOV: {} of {} pixels not their id's colour; first (pixel, id, rgb) {:?}",
            wrong.len(),
            ids.pixels.len(),
            wrong.first()
        );
        assert_ne!(id_color(0), id_color(1), "the two spheres' colours");
    }

    /// The cost AOV: every pixel's colour is heat(passes / cost_max) for a
    /// whole number of passes (the scale of raycast.glsl heat_color, as
    /// written here), misses included, one for a ray that meets no box;
    /// without the hierarchy's boxes no
    /// pixel's walk is shorter and the picture's is longer; with
    /// --cost-max 1 every walk of a pass or more is dark red; PixelOut.normal's
    /// w holds the same counts. Rules, exact.
    #[test]
    fn cost_aov_counts_the_walk() {
        use crate::frame::{build, Aov, RenderSettings};
        let cubes: String = (0..20)
            .map(|i| {
                format!(
                    r#"<transblock><translate x="{}" y="0" z="0"/><object type="primitive" name="cube"/></transblock>"#,
                    i - 10
                )
            })
            .collect();
        let xml = format!(
            r#"<scenefile>
  <cameradata><pos x="0" y="2" z="12"/><look x="0" y="-0.2" z="-1"/><up x="0" y="1" z="0"/><heightangle v="60"/></cameradata>
  <object type="tree" name="root">{cubes}</object>
</scenefile>"#
        );
        let scene = crate::scene::from_xml(xml, "row.xml");
        let renderer = CpuRenderer::new().unwrap();
        let render = |bvh: bool, cost_max: Option<u32>| {
            let settings =
                RenderSettings { width: 48, height: 32, aov: Aov::Cost, bvh, cost_max, ..RenderSettings::default() };
            settings.validate().unwrap();
            renderer.render(&build(&scene, &settings).unwrap()).unwrap()
        };
        let max = 64u32;
        let passes = |picture: &crate::render::Picture| -> Vec<u32> {
            picture
                .pixels
                .iter()
                .enumerate()
                .map(|(i, p)| {
                    (0..=max)
                        .find(|&n| heat(n as f32 / max as f32) == rgb(p))
                        .unwrap_or_else(|| panic!("pixel {i}: {:?} is no whole number of passes on the scale", rgb(p)))
                })
                .collect()
        };
        let picture = render(true, None);
        let with = passes(&picture);
        let without = passes(&render(false, None));
        // The passes also come back as numbers (PixelOut.normal's w), the same as the colours say.
        let counted: Vec<u32> = picture.pixels.iter().map(|p| p.normal[3] as u32).collect();
        assert_eq!(counted, with, "normal.w against the colours");
        assert!(
            picture.passes_text("x").contains(&format!("most {}", with.iter().max().unwrap())),
            "{}",
            picture.passes_text("x")
        );
        assert!(with.iter().all(|&n| n >= 1), "every camera ray walks a pass or more");
        // The top-left pixel looks above the row: its walk pops the root,
        // meets neither child's box, and ends.
        assert_eq!(with[0], 1, "a ray that meets no box: the root's pass alone");
        let shorter: Vec<usize> = (0..with.len()).filter(|&i| without[i] < with[i]).collect();
        assert!(
            shorter.is_empty(),
            "{} pixels walk less without the boxes; first {:?}",
            shorter.len(),
            shorter.first()
        );
        let (a, b) = (with.iter().sum::<u32>(), without.iter().sum::<u32>());
        assert!(b > a, "without the boxes the walks are longer: {b} passes against {a}");
        let one = render(true, Some(1));
        assert!(one.pixels.iter().all(|p| rgb(p) == [127, 0, 0]), "--cost-max 1: every pixel dark red");
    }

    /// The cost of all a pixel's rays (AOV_COST_ALL): without shadows and
    /// mirrors it is the camera ray's alone, pixel for pixel; with shadows
    /// never less, and more where a shadow ray is traced; its colour is
    /// heat(total / 256) of the total in PixelOut.normal's w. Rules, exact.
    #[test]
    fn cost_all_sums_every_rays_walk() {
        use crate::frame::{build, Aov, RenderSettings};
        let renderer = CpuRenderer::new().unwrap();
        let scene = two_spheres();
        let render = |aov: Aov, shadows: bool| {
            let settings = RenderSettings { width: 33, height: 33, aov, shadows, ..RenderSettings::default() };
            renderer.render(&build(&scene, &settings).unwrap()).unwrap()
        };
        let w = |p: &crate::render::Picture| p.pixels.iter().map(|p| p.normal[3] as u32).collect::<Vec<u32>>();
        let camera = w(&render(Aov::Cost, true));
        assert_eq!(w(&render(Aov::CostAll, false)), camera, "no shadow rays, no mirrors: the camera ray's walk alone");
        let all = render(Aov::CostAll, true);
        let totals = w(&all);
        assert!(totals.iter().zip(&camera).all(|(t, c)| t >= c), "a pixel's rays walk no less than its camera ray");
        let more = totals.iter().zip(&camera).filter(|(t, c)| t > c).count();
        assert!(more > 0, "shadow rays walk too");
        for (i, p) in all.pixels.iter().enumerate() {
            assert_eq!(rgb(p), heat(totals[i] as f32 / 256.0), "pixel {i}: total {}", totals[i]);
        }
    }
}
