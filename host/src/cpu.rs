//! The CPU backend: the C++ build of the shared GLSL (host/cpu), called
//! through its C ABI (`ffi`), rows handed out to every core; a
//! [`Renderer`] and, for the preview, a [`Progressive`]
//! (`CpuProgressive`). It knows no Vulkan: the same code, run natively.

mod ffi;
mod machine;
mod progressive;
#[cfg(test)]
mod tests;

pub use ffi::check_layouts;
pub use machine::{host_cpu, host_threads};
pub use progressive::CpuProgressive;

use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, AccumPixel, PixelOut, PreviewFrame};
use crate::render::{BackendInfo, Picture, Progress, Renderer, Timings, Told, Walk};
use ffi::{buffer_pointers, raycast_cpu_course_samples, raycast_cpu_trace_sample, row_loops_for};
use std::sync::atomic::{AtomicU32, Ordering};
use std::sync::Mutex;

/// Rows a thread takes at a time: small enough to balance uneven rows.
const ROWS_PER_JOB: u32 = 4;

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

/// The steps of sample `sample` of pixel (x, y) into `steps`, grown until
/// they fit (layout.h TraceStep); how many there are.
fn trace_into(buffers: &ffi::SendPtrs, x: u32, y: u32, sample: u32, steps: &mut Vec<layout::TraceStep>) -> usize {
    loop {
        let capacity = u32::try_from(steps.len()).expect("a trace's steps fit u32");
        // SAFETY: as in `run`; `steps` holds `capacity` TraceSteps (layout checked).
        let n =
            unsafe { raycast_cpu_trace_sample(buffers.as_ptr(), x, y, sample, steps.as_mut_ptr().cast(), capacity) };
        if n <= capacity {
            return n as usize;
        }
        steps.resize(n as usize, layout::TraceStep::default());
    }
}

/// Renders on the CPU with the shared GLSL built as C++.
pub struct CpuRenderer {
    pub threads: usize,
    /// Why it was chosen, as the `device:` line adds it after the threads
    /// ("; --backend auto: …"), or empty.
    why: String,
}

impl CpuRenderer {
    /// Uses every core; checks the C++ struct layouts first.
    pub fn new() -> Result<CpuRenderer, Error> {
        check_layouts()?;
        Ok(CpuRenderer { threads: host_threads(), why: String::new() })
    }

    /// The same, chosen for the reason `why` ("--backend auto: …"; empty:
    /// none to give), which its `device:` line gives.
    pub fn chosen_because(self, why: &str) -> CpuRenderer {
        let why = if why.is_empty() { String::new() } else { format!("; {why}") };
        CpuRenderer { why, ..self }
    }

    /// "CPU build of the shared GLSL (2 threads; --backend auto: …)": the
    /// `device:` lines' words for it.
    pub fn summary(&self) -> String {
        format!("CPU build of the shared GLSL ({} threads{})", self.threads, self.why)
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

    /// Rows `rows` of the frame (each below its height), in that order, `told`
    /// how many of them are done as they end: a device's picture finished
    /// where the device could not (`render::finish_cut_short`).
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
        let n = trace_into(&buffers, x, y, sample, &mut steps);
        steps.truncate(n);
        Ok(steps)
    }

    /// Every walk of `frame`, pixel by pixel (row by row) and sample by
    /// sample, as the kernels step a vector's lanes through them: each a
    /// `Walk` of its turn of the tracing loop and its slot in the turn
    /// (trace.glsl: the level's ray, then the light loop's shadow rays,
    /// one slot a light's point, needed or not), with the `passes` `trace`
    /// records (with `frame.aov` AOV_LANES, a mesh's steps count as the
    /// lanes AOV counts them). What `lanes::in_step` steps lanes through.
    /// None under the course's sampling, whose samples a pixel takes
    /// depend on the ones before (`bench --lanes` leaves it out).
    pub fn walks(&self, data: &FrameData, frame: &layout::Frame) -> Option<Vec<Vec<Vec<Walk>>>> {
        if frame.flags & layout::FLAG_COURSE_SAMPLING != 0 {
            return None;
        }
        let (width, height, spp) = (frame.width, frame.height, frame.spp.max(1));
        let mut buffers = buffer_pointers(data);
        buffers.buffers[layout::BINDING_FRAME as usize] = (frame as *const layout::Frame).cast();
        let mut out: Vec<Vec<Vec<Walk>>> = vec![Vec::new(); width as usize * height as usize];
        let rows_each = height.div_ceil(self.threads.max(1) as u32).max(1);
        std::thread::scope(|scope| {
            for (part, pixels) in out.chunks_mut((rows_each * width) as usize).enumerate() {
                let buffers = &buffers;
                scope.spawn(move || {
                    let mut steps = vec![layout::TraceStep::default(); 256];
                    for (k, pixel) in pixels.iter_mut().enumerate() {
                        let at = part * (rows_each * width) as usize + k;
                        let (x, y) = ((at % width as usize) as u32, (at / width as usize) as u32);
                        for sample in 0..spp {
                            let n = trace_into(buffers, x, y, sample, &mut steps);
                            pixel.push(Walk::of_steps(&steps[..n]));
                        }
                    }
                });
            }
        });
        Some(out)
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

impl Renderer for CpuRenderer {
    fn info(&self) -> BackendInfo {
        BackendInfo {
            summary: self.summary(),
            name: "the CPU build".to_string(),
            label: format!("CPU build, {} threads", self.threads),
            kernels_clause: String::new(),
            cpu_build: true,
            device_on_cpu: false,
            threads: Some(self.threads),
        }
    }

    fn render_frame(&self, data: &FrameData, told: Told) -> Result<(Picture, Timings), Error> {
        let start = std::time::Instant::now();
        let picture = self.render_told(data, told)?;
        let timings =
            Timings { dispatch: start.elapsed(), bands: 1, band_rows: data.frame.height, ..Timings::default() };
        Ok((picture, timings))
    }

    fn render_rows(&self, data: &FrameData, rows: &[u32], told: Told) -> Result<Vec<Vec<PixelOut>>, Error> {
        Ok(self.render_rows_told(data, rows, told))
    }
}
