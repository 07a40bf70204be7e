//! The display's veto of a device: whether a window on this X display can
//! take a device's pictures, asked before the device's driver is.

use std::ffi::CStr;

use ash::vk;

use crate::gpu::DeviceInfo;

/// The X extensions one of which NVIDIA's Vulkan driver presents through:
/// its own X driver's GLX (NV-GLX) or DRI3 (XWayland, PRIME offload).
pub(super) const NVIDIA_PRESENTS_THROUGH: [&CStr; 2] = [c"NV-GLX", c"DRI3"];

/// Why the window cannot take `device`'s pictures, asked before its driver
/// is (`GpuContext::with_surface`'s veto). NVIDIA's Vulkan driver crashes
/// when asked to present to an X display that has neither of
/// NVIDIA_PRESENTS_THROUGH (a call through a null pointer in
/// libnvidia-eglcore while the device is opened for the window; driver
/// 580.159.04 on an H100 under Xvfb, with and without GLX, 2026-11-27): such
/// a display is refused for it. RAYCAST_PRESENT_CHECK=1 applies the rule to
/// every device (how the suite tests it on lavapipe), 0 to none.
pub(crate) fn window_refuses(device: &DeviceInfo) -> Option<String> {
    let forced = crate::gpu::switch("RAYCAST_PRESENT_CHECK");
    let nvidia = device.driver_id == Some(vk::DriverId::NVIDIA_PROPRIETARY);
    if !forced.unwrap_or(nvidia) {
        return None;
    }
    let why = if forced == Some(true) {
        "which RAYCAST_PRESENT_CHECK=1 asks of every device"
    } else {
        "one of which NVIDIA's Vulkan driver presents through (it crashes when asked to present without them; \
         RAYCAST_PRESENT_CHECK=0 tries anyway)"
    };
    let display = std::env::var("DISPLAY").unwrap_or_default();
    refusal(super::x11::display_extensions(None, &NVIDIA_PRESENTS_THROUGH), &display, why)
}

/// The refusal of `window_refuses` where the display answered that it has
/// none of NVIDIA_PRESENTS_THROUGH (`answers`, in that order); nothing where
/// it has one or could not be asked.
pub(super) fn refusal(answers: Result<Vec<bool>, String>, display: &str, why: &str) -> Option<String> {
    if !answers.is_ok_and(|has| has.len() == NVIDIA_PRESENTS_THROUGH.len() && has.iter().all(|h| !h)) {
        return None;
    }
    Some(format!("the X display {display} has neither NV-GLX (NVIDIA's X driver) nor DRI3, {why}"))
}

/// What to do where no device can present (`window_refuses`): one that can
/// shows the pixels of one that cannot.
pub(super) const REFUSED_ADVICE: &str =
    "install a Vulkan device that can present to this display (Debian's mesa-vulkan-drivers: \
                              lavapipe) and the preview shows through it what this one draws (--window-device), run \
                              the preview on a desktop whose X server runs on the GPU, or render headless with \
                              `raycast render`";

#[cfg(test)]
mod tests {
    use super::refusal;

    /// NVIDIA's driver is refused only a display that says it has neither
    /// NV-GLX nor DRI3; one that has either, or cannot be asked, is tried.
    #[test]
    fn a_display_is_refused_only_without_both_ways_to_present() {
        // Answers for NVIDIA_PRESENTS_THROUGH: NV-GLX, DRI3.
        let m = refusal(Ok(vec![false, false]), ":7", "why").expect("neither NV-GLX nor DRI3: refused");
        assert!(m.starts_with("the X display :7 has neither NV-GLX") && m.ends_with("nor DRI3, why"), "{m}");
        assert_eq!(refusal(Ok(vec![false, true]), ":7", "why"), None, "DRI3 (XWayland, PRIME)");
        assert_eq!(refusal(Ok(vec![true, false]), ":7", "why"), None, "NVIDIA's X driver");
        assert_eq!(refusal(Err("no libX11".to_string()), ":7", "why"), None, "cannot ask: tried");
    }
}
