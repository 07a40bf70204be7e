//! The process environment that Mesa's lavapipe and the Vulkan loader
//! read, set before any instance exists (`prepare_process`:
//! `spread_lavapipe_work`, `skip_drivers_without_devices`), and the
//! loader's notes on drivers left out as asked. Also raycast's own reading
//! of it: its on/off overrides (`switch`) and the temporary folder
//! (`temp_file`).

/// Sets the environment lavapipe and the loader read
/// (`spread_lavapipe_work`, then `skip_drivers_without_devices`). Call
/// first thing in the process: before any Vulkan instance exists, while no
/// other thread reads the environment.
pub fn prepare_process() {
    spread_lavapipe_work();
    skip_drivers_without_devices();
}

/// Mesa's lavapipe gives each of its threads (LP_NUM_THREADS, by default
/// one per core) one contiguous block of a dispatch's workgroups, so the
/// block that holds the costliest part of the picture decides when the
/// dispatch ends while the other threads wait. More threads than cores make
/// smaller blocks that the system interleaves: on 2 cores, 8 threads took
/// recursiveSpheres4's dispatch from 310 to 279 ms and the depth-10 scene's
/// from 2790 to 2350 ms, the same pixels (docs/platforms.md#lavapipe);
/// on 16 cores, 32 threads beat 16 and 8. Sets LP_NUM_THREADS to 4 a core (at most Mesa's 32)
/// unless it is set already; other drivers ignore it. Call first thing in
/// the process (`prepare_process`).
fn spread_lavapipe_work() {
    if std::env::var_os("LP_NUM_THREADS").is_none() {
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
        std::env::set_var("LP_NUM_THREADS", (4 * cores).min(32).to_string());
    }
}

/// Mesa's Vulkan drivers for GPUs that are reached through DRM device nodes
/// (/dev/dri), as VK_LOADER_DRIVERS_DISABLE globs of their manifests' file
/// names (e.g. /usr/share/vulkan/icd.d/intel_icd.x86_64.json).
pub const DRM_DRIVER_MANIFESTS: &str = "intel_icd*,intel_hasvk_icd*,radeon_icd*,nouveau_icd*,freedreno_icd*,\
panfrost_icd*,broadcom_icd*,virtio_icd*,asahi_icd*,powervr_mesa_icd*";

/// Whether this process set VK_LOADER_DRIVERS_DISABLE itself (`skip_drivers_without_devices`).
static DRIVERS_DISABLED_HERE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// The Vulkan loader loads every driver it finds at start-up, and Mesa's
/// hardware drivers are large: on a machine without DRM device nodes (no
/// /dev/dri: a container, a server without a GPU) they cannot find a
/// device, yet loading them took 13 ms of a 45 ms `raycast devices` here.
/// There, unless the user chose drivers (any of VK_DRIVER_FILES,
/// VK_ICD_FILENAMES, VK_ADD_DRIVER_FILES, VK_LOADER_DRIVERS_SELECT or
/// VK_LOADER_DRIVERS_DISABLE set), sets VK_LOADER_DRIVERS_DISABLE to
/// `DRM_DRIVER_MANIFESTS` (loaders from 1.3.234 read it, older ones ignore
/// it); lavapipe, NVIDIA's driver (/dev/nvidia*) and any other driver load
/// as before. Call first thing in the process (`prepare_process`).
fn skip_drivers_without_devices() {
    let has_drm_nodes = std::fs::read_dir("/dev/dri").is_ok_and(|mut d| d.next().is_some());
    if let Some(value) = drivers_to_disable(|var| std::env::var_os(var).is_some(), has_drm_nodes) {
        std::env::set_var("VK_LOADER_DRIVERS_DISABLE", value);
        DRIVERS_DISABLED_HERE.store(true, std::sync::atomic::Ordering::Relaxed);
    }
}

/// The environment variables that choose Vulkan drivers.
pub(crate) const DRIVER_CHOICE_VARS: [&str; 5] = [
    "VK_DRIVER_FILES",
    "VK_ICD_FILENAMES",
    "VK_ADD_DRIVER_FILES",
    "VK_LOADER_DRIVERS_SELECT",
    "VK_LOADER_DRIVERS_DISABLE",
];

/// `skip_drivers_without_devices`'s rule: the drivers to disable, given
/// which variables are set (`is_set`) and whether the machine has DRM
/// device nodes.
fn drivers_to_disable(is_set: impl Fn(&str) -> bool, has_drm_nodes: bool) -> Option<&'static str> {
    (!has_drm_nodes && !DRIVER_CHOICE_VARS.iter().any(|var| is_set(var))).then_some(DRM_DRIVER_MANIFESTS)
}

/// Whether VK_LOADER_DRIVERS_DISABLE is the user's, not `skip_drivers_without_devices`'s.
pub(crate) fn user_disabled_drivers() -> bool {
    !DRIVERS_DISABLED_HERE.load(std::sync::atomic::Ordering::Relaxed)
}

/// The loader's note that a driver was left out as VK_LOADER_DRIVERS_DISABLE
/// or VK_LOADER_DRIVERS_SELECT asked (the user's, or raycast's own:
/// `skip_drivers_without_devices`): what it was asked for, not a
/// problem to report.
pub(crate) fn own_driver_choice(message: &str) -> bool {
    message.starts_with("Driver ")
        && message.contains(" ignored because ")
        && message.contains("env var 'VK_LOADER_DRIVERS_")
}

/// An on/off override in the environment: Some(false) when `var` is "0",
/// Some(true) when it is "1", None when unset or anything else (the
/// default rule applies). RAYCAST_SHADER_OBJECTS, RAYCAST_SPECIALIZE,
/// RAYCAST_INEXACT_DIVISION and RAYCAST_FMA_RESIDUALS read this way.
pub(crate) fn switch(var: &str) -> Option<bool> {
    match std::env::var(var).as_deref() {
        Ok("0") => Some(false),
        Ok("1") => Some(true),
        _ => None,
    }
}

/// A path in the temporary folder for one call's file, unique to this
/// process and call (threads may work on files of the same name at once):
/// raycast-PID-N-NAME.
pub(crate) fn temp_file(name: &str) -> std::path::PathBuf {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    std::env::temp_dir().join(format!("raycast-{}-{call}-{name}", std::process::id()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hardware_drivers_are_skipped_only_without_drm_nodes_and_without_a_user_choice() {
        assert_eq!(drivers_to_disable(|_| false, false), Some(DRM_DRIVER_MANIFESTS));
        assert_eq!(drivers_to_disable(|_| false, true), None, "a machine with /dev/dri keeps every driver");
        for var in DRIVER_CHOICE_VARS {
            assert_eq!(drivers_to_disable(|v| v == var, false), None, "{var} set: the user's choice stands");
        }
        // lavapipe and NVIDIA's driver are never among them.
        for manifest in ["lvp_icd.x86_64.json", "nvidia_icd.json"] {
            let matched = DRM_DRIVER_MANIFESTS.split(',').any(|glob| manifest.starts_with(glob.trim_end_matches('*')));
            assert!(!matched, "{manifest} would be disabled");
        }
        assert!(
            DRM_DRIVER_MANIFESTS.split(',').all(|g| g.ends_with('*') && !g.contains(' ')),
            "{DRM_DRIVER_MANIFESTS}"
        );
    }

    /// The loader's notes on drivers left out as asked are not reported as
    /// validation messages (Vulkan loader 1.3.239's wording); its other warnings are.
    #[test]
    fn the_loaders_notes_on_chosen_drivers_are_not_validation_messages() {
        let own = own_driver_choice;
        assert!(own(
            "Driver \"intel_icd.x86_64.json\" ignored because it was disabled by env var 'VK_LOADER_DRIVERS_DISABLE'"
        ));
        assert!(own(
            "Driver \"radeon_icd.x86_64.json\" ignored because not selected by env var 'VK_LOADER_DRIVERS_SELECT'"
        ));
        assert!(!own("loader_scan_for_implicit_layers: Implicit layer VkLayer_X ignored because it was disabled by env var 'VK_LOADER_LAYERS_DISABLE'"));
        assert!(!own("Validation Error: [ VUID-vkCmdDispatch-None-02697 ] Driver state is invalid"));
    }
}
