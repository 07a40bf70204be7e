//! The CPU build drawing the preview's samples: a [`Progressive`].

use super::CpuRenderer;
use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, AccumPixel, PixelOut, PreviewFrame};
use crate::render::Progressive;
use std::ops::Range;
use std::time::{Duration, Instant};

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
}

impl Progressive for CpuProgressive {
    fn describe(&self) -> String {
        self.cpu.summary()
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

    fn pixel_bytes(&mut self, bytes: Range<usize>) -> Result<&[u8], Error> {
        Ok(&bytemuck::cast_slice(&self.pixels)[bytes])
    }

    /// Never: the CPU build runs every loop to its end.
    fn cut_short(&mut self) -> Result<u32, Error> {
        Ok(0)
    }

    fn threads(&self) -> Option<usize> {
        Some(self.cpu.threads)
    }

    fn resize(&mut self, [w, h]: [u32; 2]) -> Result<(), Error> {
        let count = w as usize * h as usize;
        self.accum = vec![AccumPixel::default(); count];
        self.pixels = vec![PixelOut::default(); count];
        Ok(())
    }
}
