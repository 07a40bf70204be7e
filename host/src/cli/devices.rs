//! `raycast devices`: the Vulkan devices and the CPU build.

use crate::error::Error;
use crate::gpu::{self, DeviceSelector, GpuOptions};

pub fn run() -> Result<(), Error> {
    // The CPU build renders without Vulkan: its line comes whatever the driver says.
    let cpu_line = || {
        let (threads, cpu) = (crate::cpu::host_threads(), crate::cpu::host_cpu());
        outln!("cpu: the CPU build (--backend cpu), {threads} threads on {cpu}");
    };
    let (list, default) = match gpu::list_devices_with_default() {
        Ok(found) => found,
        Err(e) => {
            cpu_line();
            return Err(e.into());
        }
    };
    for d in &list {
        outln!("{}: {} ({}, Vulkan {}, driver {})", d.index, d.name, d.kind, d.api_version, d.driver);
        outln!("   arithmetic: {}", d.arithmetic);
        if d.corrects_division {
            outln!("   {}", division_line(d.index));
        }
        if d.fast_by_default() {
            outln!(
                "   kernel: the fast one by default (FAST_MATH, not the CPU build's bits); --exact for the exact one"
            );
        }
        if d.shader_objects {
            let kept = match gpu::cache_dir() {
                Some(dir) => format!("their binaries kept in {}", dir.display()),
                None => "no cache folder to keep their binaries in (set RAYCAST_CACHE_DIR)".to_string(),
            };
            let validated = match (&d.validation_layer, d.shader_objects_validated) {
                (Some(layer), true) => format!("with validation too (the validation layer, {layer}, knows them)"),
                (Some(layer), false) => {
                    format!("pipelines with validation (the validation layer, {layer}, predates them)")
                }
                (None, _) => "no validation layer installed".to_string(),
            };
            outln!("   kernels: shader objects (VK_EXT_shader_object), {kept}; {validated}; pipelines with RAYCAST_SHADER_OBJECTS=0");
        }
        if d.specialises_ahead {
            let kept = match gpu::cache_dir() {
                Some(dir) => format!("the results kept in {}", dir.display()),
                None => "the results not kept: no cache folder (set RAYCAST_CACHE_DIR)".to_string(),
            };
            outln!("   pipelines: specialised ahead of the driver by spirv-opt, {kept}; by the driver with RAYCAST_SPECIALIZE=0");
        }
        if let Some(why) = crate::preview::window_refuses(d) {
            outln!(
                "   preview: cannot present to this display ({why}); `raycast preview` draws here and a device that \
                 can present shows the pixels (--window-device)"
            );
        }
    }
    if let Some(d) = list.get(default) {
        // As open_backend decides for --backend auto.
        let auto =
            if d.runs_on_cpu() { "the CPU build instead, as this device runs on the CPU" } else { "this device" };
        outln!("default: device {} (without --device); --backend auto renders with {auto}", d.index);
    }
    cpu_line();
    Ok(())
}

/// How device `index`'s kernels take the residuals of their division
/// correction, which the fma probe decides once the device is open
/// (`GpuContext::division`).
fn division_line(index: usize) -> String {
    let options = GpuOptions {
        device: Some(DeviceSelector::Index(index)),
        kernel: gpu::KernelChoice::Exact,
        ..Default::default()
    };
    let ctx = match gpu::GpuContext::new(&options) {
        Ok(ctx) => ctx,
        Err(e) => return format!("division correction: residuals not known, the device does not open ({e})"),
    };
    let why = |probe: &str| match gpu::forced_residuals() {
        Some(_) => "as RAYCAST_FMA_RESIDUALS says".to_string(),
        None => format!("the fma probe saw this device's fma() {probe}"),
    };
    match ctx.division() {
        gpu::Division::CorrectedFma => format!("division correction: residuals by fma() ({})", why("round once")),
        _ => format!("division correction: residuals by Dekker's exact product ({})", why("round more than once")),
    }
}
