//! Where the time of one frame went, in terms every backend can fill: a
//! device's upload, dispatch and readback, the CPU build's rows.

use std::time::Duration;

/// Where the time of one frame went. A device fills every phase; the CPU
/// build only `dispatch` (its rows on every thread), `on_device` false.
#[derive(Clone, Copy, Debug, Default)]
pub struct Timings {
    /// Whether the frame ran on a device: its buffers uploaded, its kernel
    /// built and its pixels read back, each a phase of its own.
    pub on_device: bool,
    /// The frame's buffers written where the device reads them.
    pub upload: Duration,
    /// The kernel's work: on a device its recording, submission and the
    /// wait for it; on the CPU build every row on every thread.
    pub dispatch: Duration,
    /// The pixels copied back to the host.
    pub readback: Duration,
    /// Kernels checked and built for this frame (none when built before).
    pub compile: Duration,
    /// The device's own times of its phases, summed over the bands; None
    /// where its queue has no timestamps, and on the CPU build.
    pub device: Option<DevicePhases>,
    /// The dispatches' bands of rows: how many, and the rows of each but
    /// the last (one band of every row on the CPU build).
    pub bands: u32,
    pub band_rows: u32,
    /// The most bytes one band's pixel records may take: the device's
    /// largest storage buffer (why there are several bands).
    pub band_bytes: u64,
}

impl Timings {
    /// The frame's wall time as a picture's: upload, dispatch and readback,
    /// without the kernel's build.
    pub fn frame(&self) -> Duration {
        self.upload + self.dispatch + self.readback
    }

    /// The phases for people, after the scene's load: "upload 1.0 ms,
    /// compile …" on a device, "render 12.0 ms" on the CPU build.
    pub fn phases_text(&self, ms: impl Fn(Duration) -> String) -> String {
        if self.on_device {
            format!(
                "upload {}, compile {}, dispatch {}, readback {}",
                ms(self.upload),
                ms(self.compile),
                ms(self.dispatch),
                ms(self.readback)
            )
        } else {
            format!("render {}", ms(self.dispatch))
        }
    }
}

/// The device's times of one run's phases (`RunTimings::device`), from
/// timestamps written before and after each: what the device spent, not
/// counting recording, submission or the host's waits.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct DevicePhases {
    /// Clearing the cleared buffers and the output, and copying the data
    /// images from their upload buffers (the inputs' bytes themselves are
    /// written by the host into memory the device reads in place).
    pub clear: Duration,
    /// The dispatches: every submission's, summed (from the end of the
    /// clears in the first).
    pub dispatch: Duration,
    /// Copying the output into memory the host reads, where the run does
    /// (zero where the kernel writes that memory itself).
    pub readback: Duration,
}

impl std::ops::AddAssign for DevicePhases {
    fn add_assign(&mut self, o: DevicePhases) {
        self.clear += o.clear;
        self.dispatch += o.dispatch;
        self.readback += o.readback;
    }
}
