//! The C ABI of the C++ build (host/cpu/raycast_cpu.h): its row loops in
//! each copy (the whole one, the lean one, the lean one with AVX2), the
//! buffers it reads by binding number, and the check of its struct layouts
//! against the host's.

use crate::error::Error;
use crate::frame::FrameData;
use crate::layout::{self, AccumPixel};
use crate::render::Specialization;
use std::ffi::{c_void, CString};

/// raycast_cpu_render_rows and its lean copy's (raycast_cpu.h).
pub(super) type RenderRows =
    unsafe extern "C" fn(buffers: *const *const c_void, row_begin: u32, row_end: u32, out: *mut c_void);
/// raycast_cpu_preview_rows and its lean copy's (raycast_cpu.h).
pub(super) type PreviewRows = unsafe extern "C" fn(
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
pub(super) enum BuildCopy {
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
    pub(super) fn for_frame(data: &FrameData, frame: &layout::Frame) -> BuildCopy {
        match (Specialization::of(data, frame).cpu_lean(), has_avx2()) {
            (false, _) => BuildCopy::Whole,
            (true, false) => BuildCopy::Lean,
            (true, true) => BuildCopy::LeanAvx2,
        }
    }

    pub(super) fn row_loops(self) -> (RenderRows, PreviewRows) {
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
pub(super) fn has_avx2() -> bool {
    #[cfg(target_arch = "x86_64")]
    return std::is_x86_feature_detected!("avx2");
    #[cfg(not(target_arch = "x86_64"))]
    return false;
}

/// The row loops of the copy that draws `frame` of `data` (BuildCopy::for_frame).
pub(super) fn row_loops_for(data: &FrameData, frame: &layout::Frame) -> (RenderRows, PreviewRows) {
    BuildCopy::for_frame(data, frame).row_loops()
}

extern "C" {
    pub(super) fn raycast_cpu_course_samples(buffers: *const *const c_void, x: u32, y: u32, out: *mut f32) -> u32;
    fn raycast_cpu_field_offset(ty: *const std::ffi::c_char, member: *const std::ffi::c_char) -> i64;
    fn raycast_cpu_record_columns(buffers: *const *const c_void, out: *mut u32, capacity: u64) -> u64;
    pub(super) fn raycast_cpu_trace_sample(
        buffers: *const *const c_void,
        x: u32,
        y: u32,
        sample: u32,
        out: *mut c_void,
        capacity: u32,
    ) -> u32;
}

/// Where raycast_cpu.h takes the record columns: past the kernel's bindings.
pub(super) const RECORD_COLUMNS: usize = layout::BINDING_COUNT as usize;

/// The kernel's buffers by binding number, and the record columns made
/// for them, as raycast_cpu.h takes them.
pub(super) fn buffer_pointers(data: &FrameData) -> SendPtrs {
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
pub(super) struct SendPtrs {
    pub(super) buffers: [*const c_void; RECORD_COLUMNS + 1],
    _columns: Vec<u32>,
}
// SAFETY: the pointers are only read, and the data they point to outlives
// the scoped threads (it is borrowed from `data` for the whole render).
unsafe impl Sync for SendPtrs {}

impl SendPtrs {
    /// The array for the C ABI (a method, so that a closure captures the
    /// whole `SendPtrs`, which is Sync, not its array).
    pub(super) fn as_ptr(&self) -> *const *const c_void {
        self.buffers.as_ptr()
    }
}
