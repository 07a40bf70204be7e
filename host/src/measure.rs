//! What a frame costs in memory: the process's peak resident set and the
//! bytes a frame puts on the device (`bench`, the memory tests).

use crate::frame::FrameData;
use crate::layout::{Frame, PixelOut, SampleSum};

/// The process's peak resident set so far (VmHWM of /proc/self/status), in
/// bytes; None where there is no /proc.
pub fn peak_host_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: u64 = line.trim_start_matches("VmHWM:").trim().trim_end_matches("kB").trim().parse().ok()?;
    Some(kb * 1024)
}

/// Starts a new peak: VmHWM drops to the current resident set (Linux 4.0+,
/// `echo 5 > /proc/self/clear_refs`). False where that is not possible;
/// the peak is then the whole process's so far.
pub fn reset_peak_host() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Bytes a GPU frame of `data` puts on the device: the frame block, every
/// scene buffer (`FrameData::scene_buffers`: primitives, materials, lights,
/// textures, texels, and whatever else the frame binds), the samples'
/// running sums (render.comp's, cleared by the device) and the pixel buffer
/// read back. With `uniform` (render_uniform.comp), the arrays it reads as
/// uniform blocks count at their declared size, as they are uploaded
/// (`layout::uniform_image_bytes`). The driver's rounding of each
/// allocation is not counted, nor the kernel itself. A picture drawn in
/// bands (`GpuRenderer::band_rows`) holds the running sums and pixels of
/// one band of `band_rows` rows at a time.
pub fn device_bytes(data: &FrameData, uniform: bool, band_rows: u32) -> u64 {
    let scene: u64 = data
        .scene_buffers()
        .iter()
        .map(|&(binding, _, bytes)| if uniform { crate::layout::uniform_image_bytes(binding, bytes.len()) } else { bytes.len() } as u64)
        .sum();
    let per_pixel = std::mem::size_of::<PixelOut>() + std::mem::size_of::<SampleSum>();
    let pixels = u64::from(data.frame.width) * u64::from(data.frame.height.min(band_rows)) * per_pixel as u64;
    std::mem::size_of::<Frame>() as u64 + scene + pixels
}
