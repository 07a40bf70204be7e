//! Instance, validation messenger, device choice, and `GpuContext::run`:
//! upload, dispatch, wait, readback.

use std::ffi::{c_char, c_void, CStr};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

use ash::vk;

use super::environment;
use super::float_controls;
use super::image::layout_barrier;
use super::present::Surface;
use super::shader_object;
use super::specialize;
use super::{fma_probe, Division, GpuError, ImageFormat, Kernel, LESS_DATA};
use crate::layout::IMAGE_WIDTH;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";
/// Instance API version requested; nothing newer is used.
const API_VERSION: u32 = vk::API_VERSION_1_1;
/// Storage buffers cannot be empty; zero-length inputs get this many bytes.
const MIN_BUFFER: u64 = 16;

/// How long one submission of a run's passes aims to take (`run_passes`):
/// long enough that a GPU's thousands of short passes go in few
/// submissions, short enough that a pass on a slow device is told as it
/// finishes and the timeout bounds a pass or so, not a whole picture's
/// samples (4096 of them at most: 37 minutes at recursive-spheres depth 10
/// on lavapipe). A pass is split between submissions by rows of work
/// groups (vkCmdDispatchBase), so one sample of a large picture is told as
/// it goes too.
const CHUNK_AIM: Duration = Duration::from_millis(250);
/// The first submission of a run: this part of its first pass's rows of
/// work groups (the time it takes sizes the next) where the pass has more
/// than SPLIT_GROUPS work groups; else the whole pass. A split costs: on
/// lavapipe recursiveSpheres4's dispatch at 512x384 (3,072 groups) took
/// 80.75 ms split in eighths against 75.75 whole (medians of 12 rounds in
/// turn, `ci/benchmarks.sh builds`), where pictures of the course's size
/// gain nothing from it (a progress line shows after a second).
const FIRST_CHUNK_PARTS: u64 = 8;
/// Passes of more work groups than this are split from the first: the
/// course's 512x384 (3,072 groups of 8x8) is not, 1024x768 (12,288) is;
/// nor is a smaller one unless its caller expects it to be slow
/// (`run_passes_read`'s `slow`).
const SPLIT_GROUPS: u64 = 4096;
/// How many times the work of the submission before the next may take on,
/// where the one before was quick: its rows may have been cheap ones (the
/// sky above a scene).
const CHUNK_GROWTH: u64 = 8;

/// Who touches a buffer's memory (`Inner::create_buffer`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Place {
    /// The host writes it, the device reads it.
    Upload,
    /// The device writes it, the host reads it.
    Readback,
    /// Only the device.
    Device,
}

/// Which device `GpuContext::new` opens.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum DeviceSelector {
    /// Position in `list_devices()` (the loader's enumeration order).
    Index(usize),
    /// Case-insensitive substring of the device name; the first match wins.
    Name(String),
}

impl std::fmt::Display for DeviceSelector {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            DeviceSelector::Index(i) => write!(f, "index {i}"),
            DeviceSelector::Name(n) => write!(f, "name {n:?}"),
        }
    }
}

impl std::str::FromStr for DeviceSelector {
    type Err = String;

    /// `--device`'s words: an index from `raycast devices`, else part of a
    /// device's name; an empty one (an unset variable in a script) would
    /// match every name, so it is refused.
    fn from_str(s: &str) -> Result<DeviceSelector, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err("empty: give an index from `raycast devices` or part of a device's name".into());
        }
        Ok(s.parse::<usize>().map_or_else(|_| DeviceSelector::Name(s.to_string()), DeviceSelector::Index))
    }
}

/// Options of `GpuContext::new`.
#[derive(Clone, Debug)]
pub struct GpuOptions {
    /// `None`: discrete GPU > integrated > virtual > other > CPU.
    pub device: Option<DeviceSelector>,
    /// Enable VK_LAYER_KHRONOS_validation and capture its messages.
    pub validation: bool,
    /// How long `run` waits for a dispatch.
    pub timeout: Duration,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions { device: None, validation: false, timeout: Duration::from_secs(600) }
    }
}

/// A Vulkan device as `list_devices` reports it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct DeviceInfo {
    pub index: usize,
    pub name: String,
    /// "discrete GPU", "integrated GPU", "virtual GPU", "cpu" or "other".
    pub kind: String,
    pub api_version: String,
    pub driver: String,
    /// Which driver, where the device says (VK_KHR_driver_properties): the
    /// window system's veto of `GpuContext::with_surface` reads it.
    pub driver_id: Option<vk::DriverId>,
    /// How the kernels' arithmetic is made the CPU build's on this device
    /// (float_controls.rs, `GpuContext::division`), for people.
    pub arithmetic: String,
    /// Whether its kernels correct division and square root (every device
    /// but a CPU one, unless RAYCAST_INEXACT_DIVISION says); how, the open
    /// device's `GpuContext::division` says.
    pub corrects_division: bool,
    /// Whether its kernels are shader objects (VK_EXT_shader_object) when
    /// validation is off (shader_object.rs `chosen`).
    pub shader_objects: bool,
    /// Whether they are with validation too: when the installed validation
    /// layer knows shader objects (shader_object.rs `validated`).
    pub shader_objects_validated: bool,
    /// The installed Khronos validation layer's version, if there is one.
    pub validation_layer: Option<String>,
    /// Whether its pipelines are built from SPIR-V specialised ahead of the
    /// driver, the result kept (specialize.rs `chosen`).
    pub specialises_ahead: bool,
}

impl DeviceInfo {
    /// A device of type CPU (lavapipe): `--backend auto` renders with the
    /// CPU build instead.
    pub fn runs_on_cpu(&self) -> bool {
        self.kind == "cpu"
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (cpu, Vulkan 1.3.230)": the
    /// `device:` lines' words for it.
    pub fn summary(&self) -> String {
        format!("{} ({}, Vulkan {})", self.name, self.kind, self.api_version)
    }
}

/// Wall-clock times of the phases of one `GpuContext::run`.
#[derive(Clone, Copy, Debug, Default)]
pub struct RunTimings {
    /// Buffer creation and host writes, descriptor set.
    pub upload: Duration,
    /// Recording, submit and fence wait.
    pub dispatch: Duration,
    /// Copying the output to host memory.
    pub readback: Duration,
}

/// Lists the Vulkan devices in enumeration order (the `Index` of a selector).
pub fn list_devices() -> Result<Vec<DeviceInfo>, GpuError> {
    Ok(list_devices_with_default()?.0)
}

/// `list_devices`, and the position in it of the device opened without a
/// selector.
pub fn list_devices_with_default() -> Result<(Vec<DeviceInfo>, usize), GpuError> {
    let inst = InstanceParts::new(false)?;
    let devices = inst.physical_devices()?;
    let chosen = default_device(&devices);
    Ok((devices.into_iter().map(|d| d.info).collect(), chosen))
}

/// The device opened without a selector: the first of the best kind
/// (discrete, integrated, virtual GPU, other, CPU) with a compute queue (in
/// a window: one that can present), else the first.
fn default_device(devices: &[Physical]) -> usize {
    // min_by_key keeps the first of equal ranks: enumeration order within a kind.
    devices
        .iter()
        .enumerate()
        .filter(|(_, d)| d.compute_family.is_some())
        .min_by_key(|(_, d)| d.rank)
        .map_or(0, |(i, _)| i)
}

/// The window system's veto of a device (`GpuContext::with_surface`): Some(why) it cannot present.
type Veto<'a> = dyn Fn(&DeviceInfo) -> Option<String> + 'a;

/// An open Vulkan device with one compute queue. Kernels made from it keep it alive.
pub struct GpuContext {
    pub(crate) inner: Arc<Inner>,
}

/// Validation messages, shared with the messenger callback.
type Sink = Arc<Mutex<Vec<String>>>;

/// Loader, instance and (with validation) the debug messenger; destroyed in
/// reverse order on drop.
pub(crate) struct InstanceParts {
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub(crate) instance: ash::Instance,
    /// The callback's user data points into this; it outlives the instance.
    messages: Sink,
    /// The installed Khronos validation layer's spec version, enabled or
    /// not (None: not installed): whether shader objects may be used under
    /// it (shader_object::validated).
    validation_layer: Option<u32>,
    pub(crate) entry: ash::Entry,
}

/// A physical device and what we know of it.
struct Physical {
    handle: vk::PhysicalDevice,
    info: DeviceInfo,
    rank: u32,
    compute_family: Option<u32>,
    extensions: Vec<String>,
    float_modes: float_controls::Modes,
    inexact_division: bool,
}

/// Everything behind a `GpuContext`; dropped when the context and all its kernels are gone.
pub(crate) struct Inner {
    /// Resources of runs that timed out, freed after waiting for the device at drop.
    abandoned: Mutex<Vec<RunResources>>,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    info: DeviceInfo,
    pub(crate) limits: vk::PhysicalDeviceLimits,
    max_allocation: u64,
    pub(crate) memory: vk::PhysicalDeviceMemoryProperties,
    pub(crate) timeout: Duration,
    /// The float-controls execution modes every kernel gets (float_controls.rs).
    pub(crate) float_modes: float_controls::Modes,
    /// Kernels for this device correct its division (`division`).
    pub(crate) inexact_division: bool,
    /// `division`, once decided (its probe runs on the first call).
    division: OnceLock<Division>,
    /// Kernels are shader objects on this device (shader_object.rs); None: pipelines.
    pub(crate) shader_objects: Option<shader_object::ShaderObjects>,
    /// Pipelines are built from SPIR-V specialised ahead (specialize.rs).
    pub(crate) specialise_ahead: bool,
    pub(crate) physical: vk::PhysicalDevice,
    /// The window surface of `GpuContext::with_surface`; destroyed after the
    /// device, before the instance (field order).
    pub(crate) surface: Option<Surface>,
    /// Destroyed last, by `drop`, unless work was left running.
    pub(crate) parts: std::mem::ManuallyDrop<InstanceParts>,
    /// Work that timed out was still running when the context went
    /// (`may_destroy`): nothing of it is destroyed.
    left_running: std::sync::atomic::AtomicBool,
}

/// How long a context's teardown waits for work that timed out before it
/// leaves it running (`Inner::may_destroy`).
const TEARDOWN_WAIT: Duration = Duration::from_secs(5);

/// `d` in nanoseconds, as Vulkan's waits take it (u64::MAX: beyond ~584 years).
pub(crate) fn nanos(d: Duration) -> u64 {
    u64::try_from(d.as_nanos()).unwrap_or(u64::MAX)
}

/// Set when a context left timed-out work running: the process should end
/// without the drivers' own clean-up at exit (`device_left_running`).
static LEFT_RUNNING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether a device was left running work that outlived its timeout (a
/// kernel that never ends on a GPU; Mesa 25's lavapipe, which has no loop
/// budget): the process then ends at once after its message
/// (`cli::main`), since a driver's clean-up at exit (Mesa joins its worker
/// threads) would wait for that work for ever.
pub fn device_left_running() -> bool {
    LEFT_RUNNING.load(std::sync::atomic::Ordering::Relaxed)
}

fn cstrs(names: &[&CStr]) -> Vec<*const c_char> {
    names.iter().map(|n| n.as_ptr()).collect()
}

fn ext_names(props: &[vk::ExtensionProperties]) -> Vec<String> {
    props.iter().filter_map(|p| p.extension_name_as_c_str().ok().map(|s| s.to_string_lossy().into_owned())).collect()
}

fn version_string(v: u32) -> String {
    format!("{}.{}.{}", vk::api_version_major(v), vk::api_version_minor(v), vk::api_version_patch(v))
}

/// Receives validation messages (WARNING and ERROR only, by the messenger's filter).
unsafe extern "system" fn on_message(
    severity: vk::DebugUtilsMessageSeverityFlagsEXT,
    _types: vk::DebugUtilsMessageTypeFlagsEXT,
    data: *const vk::DebugUtilsMessengerCallbackDataEXT<'_>,
    user: *mut c_void,
) -> vk::Bool32 {
    if data.is_null() || user.is_null() {
        return vk::FALSE;
    }
    // Unwinding out of an extern "system" fn aborts; keep any panic inside.
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `user` is the `Mutex` of the instance's `Sink`, alive until
        // after vkDestroyInstance; `data` is valid for this call.
        let sink = unsafe { &*(user as *const Mutex<Vec<String>>) };
        let data = unsafe { &*data };
        let text = |s: Option<&CStr>| s.map(|s| s.to_string_lossy().into_owned());
        let id = text(unsafe { data.message_id_name_as_c_str() }).unwrap_or_else(|| "-".into());
        let message = text(unsafe { data.message_as_c_str() }).unwrap_or_default();
        if super::own_driver_choice(&message) {
            return;
        }
        let level = if severity.contains(vk::DebugUtilsMessageSeverityFlagsEXT::ERROR) { "ERROR" } else { "WARNING" };
        let line = format!("{level} [{id}] {message}");
        sink.lock().unwrap_or_else(|p| p.into_inner()).push(line);
    });
    vk::FALSE
}

impl InstanceParts {
    pub(crate) fn new(validation: bool) -> Result<InstanceParts, GpuError> {
        // SAFETY: loading libvulkan runs its initialisers; that is what the loader is for.
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::LoaderMissing { detail: e.to_string() })?;
        Self::with_entry(entry, validation, &[])
    }

    /// [`InstanceParts::new`] with the instance extensions in `extra` enabled as well.
    pub(crate) fn new_with(validation: bool, extra: &[String]) -> Result<InstanceParts, GpuError> {
        let entry = unsafe { ash::Entry::load() }.map_err(|e| GpuError::LoaderMissing { detail: e.to_string() })?;
        Self::with_entry(entry, validation, extra)
    }

    fn with_entry(entry: ash::Entry, validation: bool, extra: &[String]) -> Result<InstanceParts, GpuError> {
        let loader_version = unsafe { entry.try_enumerate_instance_version() }
            .map_err(GpuError::vk("vkEnumerateInstanceVersion"))?
            .unwrap_or(vk::API_VERSION_1_0);
        if loader_version < API_VERSION {
            return Err(GpuError::LoaderTooOld { version: version_string(loader_version) });
        }
        let available = ext_names(
            &unsafe { entry.enumerate_instance_extension_properties(None) }
                .map_err(GpuError::vk("vkEnumerateInstanceExtensionProperties"))?,
        );
        let has = |list: &[String], name: &CStr| list.iter().any(|e| e.as_bytes() == name.to_bytes());

        let mut extensions: Vec<&CStr> = Vec::new();
        let extra: Vec<std::ffi::CString> =
            extra.iter().map(|e| std::ffi::CString::new(e.as_str()).unwrap_or_default()).collect();
        for e in &extra {
            if !has(&available, e) {
                return Err(GpuError::Presentation {
                    what: format!(
                        "the Vulkan instance extension {} is not available; install a Vulkan driver with \
                         window-system support (e.g. Debian's mesa-vulkan-drivers)",
                        e.to_string_lossy()
                    ),
                });
            }
            extensions.push(e);
        }
        let mut layers: Vec<&CStr> = Vec::new();
        let mut flags = vk::InstanceCreateFlags::empty();
        if has(&available, ash::khr::portability_enumeration::NAME) {
            extensions.push(ash::khr::portability_enumeration::NAME);
            flags |= vk::InstanceCreateFlags::ENUMERATE_PORTABILITY_KHR;
        }
        let mut sync_validation = false;
        let installed = unsafe { entry.enumerate_instance_layer_properties() };
        let validation_layer = installed
            .as_deref()
            .unwrap_or_default()
            .iter()
            .find(|l| l.layer_name_as_c_str() == Ok(VALIDATION_LAYER))
            .map(|l| l.spec_version);
        if validation {
            installed.map_err(GpuError::vk("vkEnumerateInstanceLayerProperties"))?;
            if validation_layer.is_none() {
                return Err(GpuError::ValidationUnavailable {
                    what: "VK_LAYER_KHRONOS_validation is not installed (Debian package vulkan-validationlayers)"
                        .into(),
                });
            }
            layers.push(VALIDATION_LAYER);
            let from_layer = ext_names(
                &unsafe { entry.enumerate_instance_extension_properties(Some(VALIDATION_LAYER)) }
                    .map_err(GpuError::vk("vkEnumerateInstanceExtensionProperties"))?,
            );
            if !has(&available, ash::ext::debug_utils::NAME) && !has(&from_layer, ash::ext::debug_utils::NAME) {
                return Err(GpuError::ValidationUnavailable {
                    what: "the instance extension VK_EXT_debug_utils is not available to report its messages; \
                           update the Vulkan loader and vulkan-validationlayers"
                        .into(),
                });
            }
            extensions.push(ash::ext::debug_utils::NAME);
            // Synchronization validation catches missing barriers; it is off by default.
            if has(&from_layer, ash::ext::validation_features::NAME) {
                extensions.push(ash::ext::validation_features::NAME);
                sync_validation = true;
            }
        }

        let messages: Sink = Arc::new(Mutex::new(Vec::new()));
        let mut messenger_info = vk::DebugUtilsMessengerCreateInfoEXT::default()
            .message_severity(
                vk::DebugUtilsMessageSeverityFlagsEXT::WARNING | vk::DebugUtilsMessageSeverityFlagsEXT::ERROR,
            )
            .message_type(
                vk::DebugUtilsMessageTypeFlagsEXT::GENERAL
                    | vk::DebugUtilsMessageTypeFlagsEXT::VALIDATION
                    | vk::DebugUtilsMessageTypeFlagsEXT::PERFORMANCE,
            )
            .pfn_user_callback(Some(on_message))
            .user_data(Arc::as_ptr(&messages) as *mut c_void);
        let enabled_features = [vk::ValidationFeatureEnableEXT::SYNCHRONIZATION_VALIDATION];
        let mut features = vk::ValidationFeaturesEXT::default().enabled_validation_features(&enabled_features);

        let app = vk::ApplicationInfo::default()
            .application_name(c"raycast")
            .application_version(vk::make_api_version(0, 0, 1, 0))
            .engine_name(c"raycast")
            .api_version(API_VERSION);
        let layer_ptrs = cstrs(&layers);
        let ext_ptrs = cstrs(&extensions);
        let mut create_info = vk::InstanceCreateInfo::default()
            .flags(flags)
            .application_info(&app)
            .enabled_layer_names(&layer_ptrs)
            .enabled_extension_names(&ext_ptrs);
        if validation {
            // Chained so that vkCreateInstance and vkDestroyInstance are covered too.
            create_info = create_info.push_next(&mut messenger_info);
            if sync_validation {
                create_info = create_info.push_next(&mut features);
            }
        }
        let instance = match unsafe { entry.create_instance(&create_info, None) } {
            Ok(i) => i,
            Err(vk::Result::ERROR_INCOMPATIBLE_DRIVER) => {
                return Err(GpuError::no_device(
                    "vkCreateInstance found no compatible driver (ERROR_INCOMPATIBLE_DRIVER)",
                ))
            }
            Err(vk::Result::ERROR_LAYER_NOT_PRESENT) if validation => {
                return Err(GpuError::ValidationUnavailable {
                    what: "VK_LAYER_KHRONOS_validation is not installed (Debian package vulkan-validationlayers)"
                        .into(),
                })
            }
            Err(e) => return Err(GpuError::vk("vkCreateInstance")(e)),
        };
        let mut parts = InstanceParts { debug: None, instance, messages, validation_layer, entry };
        if validation {
            let loader = ash::ext::debug_utils::Instance::new(&parts.entry, &parts.instance);
            let messenger = unsafe { loader.create_debug_utils_messenger(&messenger_info, None) }
                .map_err(GpuError::vk("vkCreateDebugUtilsMessengerEXT"))?;
            parts.debug = Some((loader, messenger));
        }
        Ok(parts)
    }

    /// Every physical device with its `DeviceInfo`, in enumeration order.
    fn physical_devices(&self) -> Result<Vec<Physical>, GpuError> {
        let handles = usable_devices(unsafe { self.instance.enumerate_physical_devices() })?;
        let validation_layer = self.validation_layer;
        let mut out = Vec::with_capacity(handles.len());
        for (index, handle) in handles.into_iter().enumerate() {
            let props = unsafe { self.instance.get_physical_device_properties(handle) };
            let extensions = ext_names(
                &unsafe { self.instance.enumerate_device_extension_properties(handle) }
                    .map_err(GpuError::vk("vkEnumerateDeviceExtensionProperties"))?,
            );
            let (driver, driver_id) = if extensions
                .iter()
                .any(|e| e.as_bytes() == ash::khr::driver_properties::NAME.to_bytes())
            {
                let mut driver = vk::PhysicalDeviceDriverProperties::default();
                let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut driver);
                unsafe { self.instance.get_physical_device_properties2(handle, &mut props2) };
                let name = driver.driver_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                let info = driver.driver_info_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
                (format!("{name} {info}").trim().to_string(), Some(driver.driver_id))
            } else {
                (format!("driver version {:#x}", props.driver_version), None)
            };
            let (kind, rank) = match props.device_type {
                vk::PhysicalDeviceType::DISCRETE_GPU => ("discrete GPU", 0),
                vk::PhysicalDeviceType::INTEGRATED_GPU => ("integrated GPU", 1),
                vk::PhysicalDeviceType::VIRTUAL_GPU => ("virtual GPU", 2),
                vk::PhysicalDeviceType::CPU => ("cpu", 4),
                _ => ("other", 3),
            };
            let families = unsafe { self.instance.get_physical_device_queue_family_properties(handle) };
            let compute_family = families
                .iter()
                .position(|f| f.queue_count > 0 && f.queue_flags.contains(vk::QueueFlags::COMPUTE))
                .map(|i| i as u32);
            let name = props.device_name_as_c_str().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
            // IEEE NaN, infinities and subnormals in every kernel where the
            // device can promise them (float_controls.rs).
            let mut float_modes = float_controls::Modes::default();
            if props.api_version >= vk::API_VERSION_1_1
                && extensions.iter().any(|e| e == "VK_KHR_shader_float_controls")
            {
                let mut controls = vk::PhysicalDeviceFloatControlsProperties::default();
                let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut controls);
                unsafe { self.instance.get_physical_device_properties2(handle, &mut props2) };
                float_modes.preserve_nan = controls.shader_signed_zero_inf_nan_preserve_float32 == vk::TRUE;
                float_modes.preserve_denorms = controls.shader_denorm_preserve_float32 == vk::TRUE;
            }
            // A CPU device (lavapipe) divides and takes square roots as IEEE
            // does; a GPU's are approximations that the kernels compiled with
            // CORRECT_DIVISION correct (raycast.glsl div_rn).
            // RAYCAST_INEXACT_DIVISION=0 or 1 overrides, to measure the
            // correction's cost.
            let inexact_division = environment::switch("RAYCAST_INEXACT_DIVISION")
                .unwrap_or(props.device_type != vk::PhysicalDeviceType::CPU);
            let yes_no = |b: bool, yes: &str, no: &str| if b { yes.to_string() } else { no.to_string() };
            let arithmetic = [
                yes_no(
                    inexact_division,
                    "division and square root corrected to IEEE's",
                    "division and square root as the device gives them",
                ),
                yes_no(float_modes.preserve_nan, "NaN and infinities preserved", "NaN and infinities not promised"),
                yes_no(float_modes.preserve_denorms, "subnormals preserved", "subnormals not promised"),
            ]
            .join(", ");
            let shader_objects = shader_object::chosen(
                shader_object::supported(&self.instance, handle, &extensions),
                props.device_type == vk::PhysicalDeviceType::CPU,
            );
            let shader_objects_validated = shader_objects && shader_object::validated(validation_layer);
            out.push(Physical {
                handle,
                info: DeviceInfo {
                    index,
                    name,
                    kind: kind.to_string(),
                    api_version: version_string(props.api_version),
                    driver,
                    driver_id,
                    arithmetic,
                    corrects_division: inexact_division,
                    shader_objects,
                    shader_objects_validated,
                    validation_layer: validation_layer.map(version_string),
                    specialises_ahead: specialize::chosen(props.device_type == vk::PhysicalDeviceType::CPU),
                },
                rank,
                compute_family,
                extensions,
                float_modes,
                inexact_division,
            });
        }
        Ok(out)
    }
}

/// The result of vkEnumeratePhysicalDevices, with "none" as `GpuError::NoDevice`.
pub(crate) fn usable_devices(
    result: Result<Vec<vk::PhysicalDevice>, vk::Result>,
) -> Result<Vec<vk::PhysicalDevice>, GpuError> {
    match result {
        Ok(h) if h.is_empty() => Err(GpuError::no_device("the Vulkan loader reports zero devices")),
        Ok(h) => Ok(h),
        // The loader's answer when every driver loaded but none found hardware.
        Err(vk::Result::ERROR_INITIALIZATION_FAILED) => {
            Err(GpuError::no_device("vkEnumeratePhysicalDevices found no usable device (ERROR_INITIALIZATION_FAILED)"))
        }
        Err(e) => Err(GpuError::vk("vkEnumeratePhysicalDevices")(e)),
    }
}

impl Drop for InstanceParts {
    fn drop(&mut self) {
        unsafe {
            if let Some((loader, messenger)) = self.debug.take() {
                loader.destroy_debug_utils_messenger(messenger, None);
            }
            self.instance.destroy_instance(None);
        }
    }
}

/// The residuals RAYCAST_FMA_RESIDUALS forces past the fma probe: 1 fma's,
/// 0 Dekker's (`GpuContext::division`); None when it is unset or another value.
pub fn forced_residuals() -> Option<Division> {
    environment::switch("RAYCAST_FMA_RESIDUALS")
        .map(|fma| if fma { Division::CorrectedFma } else { Division::Corrected })
}

impl GpuContext {
    /// Opens the selected (or best) device with one compute queue.
    pub fn new(opts: &GpuOptions) -> Result<GpuContext, GpuError> {
        let parts = InstanceParts::new(opts.validation)?;
        Self::open(opts, parts, None)
    }

    /// Opens a device that can also present to a window: creates the instance
    /// with `instance_extensions` (the window system's, e.g. from
    /// glfwGetRequiredInstanceExtensions), lets `create_surface` make the
    /// window's surface on it, and opens the selected (or best) device whose
    /// compute queue can present to that surface, with VK_KHR_swapchain.
    /// `refuse` is the window system's veto, asked of each device before its
    /// driver is (some drivers crash when asked about a surface they cannot
    /// serve): Some(why) and the device cannot present; an error names why
    /// when it is the one selected.
    pub fn with_surface(
        opts: &GpuOptions,
        instance_extensions: &[String],
        create_surface: impl FnOnce(vk::Instance) -> Result<vk::SurfaceKHR, String>,
        refuse: impl Fn(&DeviceInfo) -> Option<String>,
    ) -> Result<GpuContext, GpuError> {
        let parts = InstanceParts::new_with(opts.validation, instance_extensions)?;
        let handle = create_surface(parts.instance.handle())
            .map_err(|e| GpuError::Presentation { what: format!("cannot create the window's Vulkan surface: {e}") })?;
        let surface = Surface { loader: ash::khr::surface::Instance::new(&parts.entry, &parts.instance), handle };
        // On an error below `surface` is dropped before `parts`: surface, then instance.
        Self::open(opts, parts, Some((surface, &refuse)))
    }

    fn open(opts: &GpuOptions, parts: InstanceParts, window: Option<(Surface, &Veto)>) -> Result<GpuContext, GpuError> {
        let mut devices = parts.physical_devices()?;
        let mut refused: Vec<Option<String>> = vec![None; devices.len()];
        let surface = window.as_ref().map(|(surface, _)| surface);
        if let Some((surface, refuse)) = &window {
            // Only a compute family that can present counts, on a device with VK_KHR_swapchain.
            for (d, refusal) in devices.iter_mut().zip(&mut refused) {
                *refusal = refuse(&d.info);
                if refusal.is_some() {
                    d.compute_family = None;
                    continue;
                }
                let swapchain = d.extensions.iter().any(|e| e.as_bytes() == ash::khr::swapchain::NAME.to_bytes());
                let families = unsafe { parts.instance.get_physical_device_queue_family_properties(d.handle) };
                d.compute_family = families
                    .iter()
                    .enumerate()
                    .position(|(i, f)| {
                        swapchain
                            && f.queue_count > 0
                            && f.queue_flags.contains(vk::QueueFlags::COMPUTE)
                            && unsafe {
                                surface.loader.get_physical_device_surface_support(d.handle, i as u32, surface.handle)
                            }
                            .unwrap_or(false)
                    })
                    .map(|i| i as u32);
            }
        }
        let chosen = match &opts.device {
            Some(DeviceSelector::Index(i)) => devices.iter().position(|d| d.info.index == *i),
            Some(DeviceSelector::Name(n)) => {
                let n = n.to_lowercase();
                devices.iter().position(|d| d.info.name.to_lowercase().contains(&n))
            }
            None => Some(default_device(&devices)),
        };
        let Some(chosen) = chosen else {
            return Err(GpuError::DeviceNotFound {
                selector: opts.device.as_ref().map(|s| s.to_string()).unwrap_or_default(),
                available: devices.into_iter().map(|d| d.info).collect(),
            });
        };
        let physical = devices.swap_remove(chosen);
        let Some(queue_family) = physical.compute_family else {
            if let Some(why) = refused.swap_remove(chosen) {
                return Err(GpuError::Presentation {
                    what: format!("the Vulkan device {} cannot present to this window: {why}", physical.info.name),
                });
            }
            if surface.is_some() {
                return Err(GpuError::Presentation {
                    what: format!(
                        "the Vulkan device {} has no compute queue that can present to the window \
                         (or no VK_KHR_swapchain); select another device",
                        physical.info.name
                    ),
                });
            }
            return Err(GpuError::NoComputeQueue { device: physical.info.name });
        };

        let instance = &parts.instance;
        let props = unsafe { instance.get_physical_device_properties(physical.handle) };
        let mut maintenance3 = vk::PhysicalDeviceMaintenance3Properties::default();
        let max_allocation = if props.api_version >= vk::API_VERSION_1_1 {
            let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut maintenance3);
            unsafe { instance.get_physical_device_properties2(physical.handle, &mut props2) };
            maintenance3.max_memory_allocation_size
        } else {
            u64::MAX
        };
        let memory = unsafe { instance.get_physical_device_memory_properties(physical.handle) };

        // VK_KHR_portability_subset must be enabled where the device offers it.
        let mut device_exts: Vec<&CStr> = Vec::new();
        if physical.extensions.iter().any(|e| e == "VK_KHR_portability_subset") {
            device_exts.push(c"VK_KHR_portability_subset");
        }
        if surface.is_some() {
            device_exts.push(ash::khr::swapchain::NAME);
        }
        if physical.float_modes != float_controls::Modes::default() {
            device_exts.push(ash::khr::shader_float_controls::NAME);
        }
        // Kernels as shader objects with their binaries kept, where offered (shader_object.rs).
        let shader_objects =
            if opts.validation { physical.info.shader_objects_validated } else { physical.info.shader_objects };
        if shader_objects {
            device_exts.extend(shader_object::DEVICE_EXTENSIONS);
        }
        let ext_ptrs = cstrs(&device_exts);
        let priorities = [1.0f32];
        let queue_info =
            [vk::DeviceQueueCreateInfo::default().queue_family_index(queue_family).queue_priorities(&priorities)];
        let mut shader_object_features = vk::PhysicalDeviceShaderObjectFeaturesEXT::default().shader_object(true);
        let mut device_info =
            vk::DeviceCreateInfo::default().queue_create_infos(&queue_info).enabled_extension_names(&ext_ptrs);
        if shader_objects {
            device_info = device_info.push_next(&mut shader_object_features);
        }
        let device = unsafe { instance.create_device(physical.handle, &device_info, None) }
            .map_err(GpuError::vk("vkCreateDevice"))?;
        let shader_objects =
            shader_objects.then(|| shader_object::ShaderObjects::new(instance, physical.handle, &device));
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let specialise_ahead = physical.info.specialises_ahead;

        Ok(GpuContext {
            inner: Arc::new(Inner {
                abandoned: Mutex::new(Vec::new()),
                device,
                queue: Mutex::new(queue),
                queue_family,
                info: physical.info,
                limits: props.limits,
                max_allocation,
                memory,
                timeout: opts.timeout,
                float_modes: physical.float_modes,
                inexact_division: physical.inexact_division,
                division: OnceLock::new(),
                shader_objects,
                specialise_ahead,
                physical: physical.handle,
                surface: window.map(|(surface, _)| surface),
                parts: std::mem::ManuallyDrop::new(parts),
                left_running: std::sync::atomic::AtomicBool::new(false),
            }),
        })
    }

    /// How many storage images one kernel may bind
    /// (maxPerStageDescriptorStorageImages, and the set's own limit).
    pub fn storage_image_limit(&self) -> u32 {
        let l = &self.inner.limits;
        l.max_per_stage_descriptor_storage_images.min(l.max_descriptor_set_storage_images)
    }

    /// How kernels for this device compile division and square root
    /// (glslang_args.rs): as given on a CPU device, corrected on every other
    /// (unless RAYCAST_INEXACT_DIVISION says), and there with residuals by
    /// fma() where the device's fma was seen to round once (fma_probe.rs,
    /// run on the first call; a probe that cannot run leaves Dekker's
    /// residuals, exact on any device, and says so on stderr).
    /// RAYCAST_FMA_RESIDUALS=0 or 1 overrides the probe, to measure the
    /// difference or to show what an unfused fma does to the pictures.
    pub fn division(&self) -> Division {
        if !self.inner.inexact_division {
            return Division::AsGiven;
        }
        *self.inner.division.get_or_init(|| match forced_residuals() {
            Some(division) => division,
            None => match fma_probe::fma_rounds_once(self) {
                Ok(true) => Division::CorrectedFma,
                Ok(false) => Division::Corrected,
                Err(e) => {
                    eprintln!("raycast: the fma probe could not run on {} ({e}); the division correction takes Dekker's residuals, exact but slower", self.inner.info.name);
                    Division::Corrected
                }
            },
        })
    }

    pub fn info(&self) -> &DeviceInfo {
        &self.inner.info
    }

    /// Validation-layer messages captured since the last call (empty when validation is off).
    pub fn take_validation_messages(&self) -> Vec<String> {
        std::mem::take(&mut *self.inner.parts.messages.lock().unwrap_or_else(|p| p.into_inner()))
    }

    /// The message list itself, to inspect what arrives while the device and instance are destroyed.
    #[cfg(test)]
    pub(crate) fn message_sink(&self) -> Arc<Mutex<Vec<String>>> {
        self.inner.parts.messages.clone()
    }

    /// The largest storage buffer (one binding) the device can address.
    pub fn max_storage_buffer_range(&self) -> u64 {
        self.inner.limits.max_storage_buffer_range as u64
    }

    /// The largest storage buffer the device can both address in one
    /// binding and allocate: the lesser of maxStorageBufferRange and
    /// maxMemoryAllocationSize.
    pub fn max_storage_bytes(&self) -> u64 {
        self.max_storage_buffer_range().min(self.inner.max_allocation)
    }

    /// Fails when a storage buffer of `bytes` exceeds maxStorageBufferRange
    /// or maxMemoryAllocationSize (`what` names it in the error).
    pub fn check_storage_size(&self, bytes: u64, what: impl Fn() -> String) -> Result<(), GpuError> {
        self.inner.check_storage_size(bytes, what)
    }

    /// The most work groups one dispatch may have, per dimension.
    pub fn max_compute_work_group_count(&self) -> [u32; 3] {
        self.inner.limits.max_compute_work_group_count
    }

    /// Upload each input to a storage buffer at its binding, create the output
    /// storage buffer (`out_bytes` long, every u32 word pre-filled with
    /// `fill`), dispatch `groups`, wait (with the timeout), read the output back.
    ///
    /// Every binding of the kernel must be given exactly once.
    pub fn run(
        &self,
        kernel: &Kernel,
        inputs: &[(u32, &[u8])],
        output: (u32, usize),
        fill: u32,
        groups: [u32; 3],
    ) -> Result<(Vec<u8>, RunTimings), GpuError> {
        self.run_passes(kernel, &RunBuffers { inputs, cleared: &[], output, fill }, groups, 1)
    }

    /// `run` with `passes` dispatches of `groups`, each seeing the writes
    /// of the one before (a kernel that keeps its own state in its buffers,
    /// like render.comp's one sample per pass), and with buffers the device
    /// clears (`RunBuffers::cleared`). The passes go in submissions of
    /// about `CHUNK_AIM` each (the first pass alone), so the timeout bounds
    /// one submission, not the whole run.
    pub fn run_passes(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
        groups: [u32; 3],
        passes: u32,
    ) -> Result<(Vec<u8>, RunTimings), GpuError> {
        self.run_passes_read(kernel, buffers, groups, passes, false, <[u8]>::to_vec, |_| {})
    }

    /// `run_passes`, the output given to `read` where the device left it
    /// (mapped), instead of copied out first: a caller that keeps it in a
    /// shape of its own copies it once (a 512x384 picture's pixel records
    /// are 6 MiB; two more copies took 10 ms of lavapipe's whole command).
    /// `done` is told the passes finished after each submission (a
    /// fraction where a pass is split: rows of its work groups apart).
    /// `slow`: the caller expects a pass to take long (seconds on this
    /// device), so it is split from the first whatever its size.
    #[allow(clippy::too_many_arguments)]
    pub fn run_passes_read<R>(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
        groups: [u32; 3],
        passes: u32,
        slow: bool,
        read: impl FnOnce(&[u8]) -> R,
        mut done: impl FnMut(f64),
    ) -> Result<(R, RunTimings), GpuError> {
        let inner = &*self.inner;
        if !Arc::ptr_eq(&kernel.inner, &self.inner) {
            return Err(GpuError::BadRun {
                kernel: kernel.name().to_string(),
                message: "the kernel was created on another GpuContext".into(),
            });
        }
        inner.check_run(kernel, buffers, groups)?;
        inner.refuse_if_still_running()?;

        let start = Instant::now();
        let (res, set) = inner.prepare_run(kernel, buffers)?;
        let upload = start.elapsed();

        // Clear, fill the data images, bind, dispatch, make the writes visible to the host, submit, wait.
        let start = Instant::now();
        // The work in units of one row of work groups of one pass; the
        // first submission the first pass, or an eighth of it where large or slow.
        let rows = u64::from(groups[1].max(1));
        let total = u64::from(passes) * rows;
        let split = slow || groups.iter().map(|&g| u64::from(g)).product::<u64>() > SPLIT_GROUPS;
        let first = if split { rows.div_ceil(FIRST_CHUNK_PARTS) } else { rows };
        let (mut res, mut finished, mut chunk) = (res, 0u64, first);
        while finished < total {
            let units = finished..(finished + chunk).min(total);
            let began = Instant::now();
            res = inner.submit_once(res, |d, cmd, res| unsafe {
                record_run(d, cmd, res, kernel, set, groups, units.clone())
            })?;
            let (n, took) = (units.end - units.start, began.elapsed().as_nanos().max(1));
            finished = units.end;
            done(finished as f64 / rows as f64);
            // The next submission about CHUNK_AIM long, at most CHUNK_GROWTH
            // times this one; whole passes where a pass is not split.
            let fit = u64::try_from(CHUNK_AIM.as_nanos() * u128::from(n) / took).unwrap_or(u64::MAX);
            chunk = fit.clamp(1, n.saturating_mul(CHUNK_GROWTH));
            if !split {
                chunk = (chunk / rows).max(1) * rows;
            }
        }
        let dispatch = start.elapsed();

        let start = Instant::now();
        let d = &inner.device;
        let memory = res.output;
        let ptr = unsafe { d.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
            .map_err(GpuError::vk("vkMapMemory"))?;
        // SAFETY: the mapping covers at least the output's bytes; the fence and barrier made the writes visible.
        let out = read(unsafe { std::slice::from_raw_parts(ptr as *const u8, buffers.output.1) });
        unsafe { d.unmap_memory(memory) };
        let readback = start.elapsed();
        drop(res);
        Ok((out, RunTimings { upload, dispatch, readback }))
    }
}

/// What a run binds: every binding of its kernel exactly once.
pub struct RunBuffers<'a> {
    /// Bindings uploaded from the host: (binding, bytes).
    pub inputs: &'a [(u32, &'a [u8])],
    /// Storage buffers the device clears to zero before the first pass,
    /// which the host neither writes nor reads (device-local where the
    /// device has such memory): (binding, bytes).
    pub cleared: &'a [(u32, usize)],
    /// The buffer read back: (binding, bytes); every u32 word of it is
    /// `fill` until the kernel writes it (on the device, before the first pass).
    pub output: (u32, usize),
    pub fill: u32,
}

impl RunBuffers<'_> {
    /// Every binding with its length: the inputs, the cleared buffers, the output.
    fn lengths(&self) -> impl Iterator<Item = (u32, usize)> + '_ {
        self.inputs.iter().map(|(b, d)| (*b, d.len())).chain(self.cleared.iter().copied()).chain([self.output])
    }
}

/// A storage buffer's size for `len` bytes: not empty, whole words.
pub(crate) fn buffer_size(len: usize) -> u64 {
    (len as u64).max(MIN_BUFFER).next_multiple_of(4)
}

impl Inner {
    /// Checks a run against the kernel and the device limits before anything is allocated.
    fn check_run(&self, kernel: &Kernel, buffers: &RunBuffers, groups: [u32; 3]) -> Result<(), GpuError> {
        let bad = |message: String| GpuError::BadRun { kernel: kernel.name().to_string(), message };
        if let Some(i) = kernel.images().iter().find(|i| i.writable || i.format != ImageFormat::Rgba32Uint) {
            return Err(bad(format!(
                "run() binds storage buffers and read-only rgba32ui data images; binding {} is a picture: \
                 it needs a DescriptorSet and a FrameLoop",
                i.binding
            )));
        }
        if let Some((given, wanted)) = kernel.binding_mismatch(buffers.lengths().map(|(b, _)| b)) {
            return Err(bad(format!(
                "run() was given bindings {given:?} (inputs, cleared and output), the kernel declares {wanted:?}; \
                 pass each binding exactly once"
            )));
        }
        let limit = self.limits.max_compute_work_group_count;
        if groups.iter().zip(limit).any(|(g, l)| *g > l) {
            return Err(GpuError::TooManyGroups { groups, limit });
        }
        let out_binding = buffers.output.0;
        if let Some(&(binding, _)) =
            buffers.cleared.iter().chain([&buffers.output]).find(|(b, _)| kernel.binds_image(*b))
        {
            let what = if binding == out_binding { "the output" } else { "cleared" };
            return Err(bad(format!("binding {binding} is a read-only image; it cannot be {what}")));
        }
        for (binding, len) in buffers.lengths() {
            if kernel.binds_image(binding) {
                self.check_data_image(kernel.name(), &kernel.binding_label(binding), len)?;
                continue;
            }
            self.check_storage_size(buffer_size(len), || kernel.binding_label(binding))?;
            let uniform_range = u64::from(self.limits.max_uniform_buffer_range);
            if kernel.descriptor_type(binding) == vk::DescriptorType::UNIFORM_BUFFER && buffer_size(len) > uniform_range
            {
                return Err(GpuError::TooLarge {
                    what: kernel.binding_label(binding),
                    bytes: buffer_size(len),
                    limit: uniform_range,
                    limit_name: "maxUniformBufferRange",
                    advice: LESS_DATA,
                });
            }
        }
        Ok(())
    }

    /// The buffers and data images of a checked run, the inputs written,
    /// and a descriptor set binding them.
    fn prepare_run(
        &self,
        kernel: &Kernel,
        buffers: &RunBuffers,
    ) -> Result<(RunResources, vk::DescriptorSet), GpuError> {
        let mut res = RunResources::new(self.device.clone());
        // Inputs: one host-visible buffer per binding, written in place.
        for &(binding, data) in buffers.inputs {
            let (buffer, memory) =
                self.create_buffer(&mut res, buffer_size(data.len()), Place::Upload, &kernel.binding_label(binding))?;
            let ptr = unsafe { self.device.map_memory(memory, 0, vk::WHOLE_SIZE, vk::MemoryMapFlags::empty()) }
                .map_err(GpuError::vk("vkMapMemory"))?;
            // SAFETY: the mapping covers the whole allocation, at least `data.len()` bytes.
            unsafe {
                std::ptr::copy_nonoverlapping(data.as_ptr(), ptr as *mut u8, data.len());
                self.device.unmap_memory(memory);
            }
            res.bindings.push((binding, buffer));
            if kernel.binds_image(binding) {
                // A device image, copied from this buffer when the command buffer starts.
                let texels = (data.len() / 16) as u32;
                self.create_data_image(&mut res, binding, buffer, texels, &kernel.binding_label(binding))?;
            }
        }
        // Cleared buffers and the output: filled by the device, before the first pass.
        for &(binding, len) in buffers.cleared {
            let (buffer, _) =
                self.create_buffer(&mut res, buffer_size(len), Place::Device, &kernel.binding_label(binding))?;
            res.bindings.push((binding, buffer));
            res.fills.push((buffer, 0));
        }
        let (out_binding, out_len) = buffers.output;
        let (buffer, memory) =
            self.create_buffer(&mut res, buffer_size(out_len), Place::Readback, &kernel.binding_label(out_binding))?;
        res.bindings.push((out_binding, buffer));
        res.fills.push((buffer, buffers.fill));
        res.output = memory;
        let set = self.run_descriptor_set(&mut res, kernel)?;
        Ok((res, set))
    }

    /// A descriptor set (from a pool in `res`) with `res`'s buffers and data images at their bindings.
    fn run_descriptor_set(&self, res: &mut RunResources, kernel: &Kernel) -> Result<vk::DescriptorSet, GpuError> {
        let images = res.images.len() as u32;
        let uniform = res
            .bindings
            .iter()
            .filter(|(b, _)| kernel.descriptor_type(*b) == vk::DescriptorType::UNIFORM_BUFFER)
            .count() as u32;
        let sizes: Vec<vk::DescriptorPoolSize> = [
            (vk::DescriptorType::STORAGE_BUFFER, res.bindings.len() as u32 - uniform - images),
            (vk::DescriptorType::UNIFORM_BUFFER, uniform),
            (vk::DescriptorType::STORAGE_IMAGE, images),
        ]
        .into_iter()
        .filter(|(_, n)| *n > 0)
        .map(|(ty, n)| vk::DescriptorPoolSize::default().ty(ty).descriptor_count(n))
        .collect();
        let pool_info = vk::DescriptorPoolCreateInfo::default().max_sets(1).pool_sizes(&sizes);
        res.descriptor_pool = unsafe { self.device.create_descriptor_pool(&pool_info, None) }
            .map_err(GpuError::vk("vkCreateDescriptorPool"))?;
        let set_layouts = [kernel.set_layout];
        let alloc =
            vk::DescriptorSetAllocateInfo::default().descriptor_pool(res.descriptor_pool).set_layouts(&set_layouts);
        let set = unsafe { self.device.allocate_descriptor_sets(&alloc) }
            .map_err(GpuError::vk("vkAllocateDescriptorSets"))?[0];
        let buffer_infos: Vec<[vk::DescriptorBufferInfo; 1]> = res
            .bindings
            .iter()
            .map(|(_, b)| [vk::DescriptorBufferInfo::default().buffer(*b).offset(0).range(vk::WHOLE_SIZE)])
            .collect();
        let image_infos: Vec<[vk::DescriptorImageInfo; 1]> = res
            .images
            .iter()
            .map(|i| [vk::DescriptorImageInfo::default().image_view(i.view).image_layout(vk::ImageLayout::GENERAL)])
            .collect();
        let writes: Vec<vk::WriteDescriptorSet> = res
            .bindings
            .iter()
            .zip(&buffer_infos)
            .filter(|((binding, _), _)| !kernel.binds_image(*binding))
            .map(|((binding, _), info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(*binding)
                    .descriptor_type(kernel.descriptor_type(*binding))
                    .buffer_info(info)
            })
            .chain(res.images.iter().zip(&image_infos).map(|(i, info)| {
                vk::WriteDescriptorSet::default()
                    .dst_set(set)
                    .dst_binding(i.binding)
                    .descriptor_type(vk::DescriptorType::STORAGE_IMAGE)
                    .image_info(info)
            }))
            .collect();
        unsafe { self.device.update_descriptor_sets(&writes, &[]) };
        Ok(set)
    }
}

/// Records a run: the device's fills (`RunResources::fills`) and the data
/// images' copies, then `passes` dispatches of `groups`, each seeing the
/// writes of the one before, then a barrier that makes the writes visible
/// to the host.
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state; `res` and
/// `set` were made for `kernel` (`Inner::prepare_run`).
unsafe fn record_run(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    res: &RunResources,
    kernel: &Kernel,
    set: vk::DescriptorSet,
    groups: [u32; 3],
    units: std::ops::Range<u64>,
) {
    let rows = u64::from(groups[1].max(1));
    // SAFETY: the caller's; every handle lives as long as the run.
    unsafe {
        if units.start == 0 {
            record_run_start(d, cmd, res);
        }
        kernel.bind(cmd);
        d.cmd_bind_descriptor_sets(cmd, vk::PipelineBindPoint::COMPUTE, kernel.pipeline_layout, 0, &[set], &[]);
        // Unit u: row u % rows of work groups of pass u / rows; each pass's
        // rows of the range in one dispatch.
        let mut u = units.start;
        while u < units.end {
            let (pass, row) = (u / rows, u % rows);
            let end = units.end.min((pass + 1) * rows);
            if row == 0 && pass > 0 {
                // The pass before's writes (in this submission or an earlier
                // one on the queue), visible to this one's reads and writes.
                let access = vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE;
                shader_writes_barrier(d, cmd, vk::PipelineStageFlags::COMPUTE_SHADER, access);
            }
            // Rows of one pass write pixels of their own: no barrier between them.
            d.cmd_dispatch_base(cmd, 0, row as u32, 0, groups[0], (end - u) as u32, groups[2]);
            u = end;
        }
        shader_writes_barrier(d, cmd, vk::PipelineStageFlags::HOST, vk::AccessFlags::HOST_READ);
    }
}

/// Records what a run does before its first pass: the buffers filled,
/// the data images uploaded.
///
/// # Safety
/// As `record_run`.
unsafe fn record_run_start(d: &ash::Device, cmd: vk::CommandBuffer, res: &RunResources) {
    // SAFETY: the caller's.
    unsafe {
        for &(buffer, value) in &res.fills {
            d.cmd_fill_buffer(cmd, buffer, 0, vk::WHOLE_SIZE, value);
        }
        let filled = [vk::MemoryBarrier::default()
            .src_access_mask(vk::AccessFlags::TRANSFER_WRITE)
            .dst_access_mask(vk::AccessFlags::SHADER_READ | vk::AccessFlags::SHADER_WRITE)];
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::TRANSFER,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            vk::DependencyFlags::empty(),
            &filled,
            &[],
            &[],
        );
        for image in &res.images {
            record_image_upload(d, cmd, image.source, image.image, image.texels);
        }
    }
}

/// Records a barrier that makes the compute shader's writes visible to
/// `dst_access` at `dst_stage` (all memory; no image layout changes).
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state.
unsafe fn shader_writes_barrier(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    dst_stage: vk::PipelineStageFlags,
    dst_access: vk::AccessFlags,
) {
    let barrier =
        [vk::MemoryBarrier::default().src_access_mask(vk::AccessFlags::SHADER_WRITE).dst_access_mask(dst_access)];
    // SAFETY: the caller's.
    unsafe {
        d.cmd_pipeline_barrier(
            cmd,
            vk::PipelineStageFlags::COMPUTE_SHADER,
            dst_stage,
            vk::DependencyFlags::empty(),
            &barrier,
            &[],
            &[],
        )
    };
}

impl Inner {
    /// A data image of `len` bytes (a run's rgba32ui input, a
    /// `DataImage`): whole texels, one row of up to IMAGE_WIDTH or whole
    /// rows of IMAGE_WIDTH (layout.h; the shaders address texel t at
    /// (t % IMAGE_WIDTH, t / IMAGE_WIDTH)), within maxImageDimension2D, a
    /// format the device can store. `kernel` and `what` name it in errors.
    pub(crate) fn check_data_image(&self, kernel: &str, what: &str, len: usize) -> Result<(), GpuError> {
        let bad =
            |message: String| GpuError::BadRun { kernel: kernel.to_string(), message: format!("{what}: {message}") };
        let max = u64::from(self.limits.max_image_dimension2_d);
        if len == 0 || !len.is_multiple_of(16) {
            return Err(bad(format!("{len} bytes are not whole 16-byte texels")));
        }
        let texels = (len / 16) as u64;
        let width = u64::from(IMAGE_WIDTH);
        if texels > width && !texels.is_multiple_of(width) {
            return Err(bad(format!("{texels} texels are more than one row and not whole rows of {width}")));
        }
        let [w, rows] = data_image_size(texels);
        if w > max || rows > max {
            return Err(GpuError::TooLarge {
                what: format!("{what} ({rows} rows of {w} texels)"),
                bytes: w.max(rows),
                limit: max,
                limit_name: "maxImageDimension2D (texels)",
                advice: LESS_DATA,
            });
        }
        let features = unsafe { self.parts.instance.get_physical_device_format_properties(self.physical, DATA_FORMAT) }
            .optimal_tiling_features;
        let needed = vk::FormatFeatureFlags::STORAGE_IMAGE | vk::FormatFeatureFlags::TRANSFER_DST;
        if !features.contains(needed) {
            return Err(bad(format!(
                "the device cannot use {DATA_FORMAT:?} as a storage image and copy target ({features:?})"
            )));
        }
        Ok(())
    }

    /// A device-local rgba32ui image of `texels` (`data_image_size`) for
    /// `binding`, filled from `source` when the run's command buffer starts
    /// (`record_image_upload`); `what` names it in errors.
    fn create_data_image(
        &self,
        res: &mut RunResources,
        binding: u32,
        source: vk::Buffer,
        texels: u32,
        what: &str,
    ) -> Result<(), GpuError> {
        let (image, memory, view) = super::image::create_image(
            self,
            DATA_FORMAT,
            data_image_size(u64::from(texels)).map(|n| n as u32),
            vk::ImageUsageFlags::STORAGE | vk::ImageUsageFlags::TRANSFER_DST,
            format!("{what} (a data image of {texels} texels)"),
        )?;
        res.images.push(RunImage { binding, source, texels, image, view, memory });
        Ok(())
    }

    /// Fails when a storage buffer of `bytes` exceeds maxStorageBufferRange or maxMemoryAllocationSize.
    pub(crate) fn check_storage_size(&self, bytes: u64, what: impl Fn() -> String) -> Result<(), GpuError> {
        let range = self.limits.max_storage_buffer_range as u64;
        if bytes > range {
            return Err(GpuError::TooLarge {
                what: what(),
                bytes,
                limit: range,
                limit_name: "maxStorageBufferRange",
                advice: LESS_DATA,
            });
        }
        if bytes > self.max_allocation {
            return Err(GpuError::TooLarge {
                what: what(),
                bytes,
                limit: self.max_allocation,
                limit_name: "maxMemoryAllocationSize",
                advice: LESS_DATA,
            });
        }
        Ok(())
    }

    /// One storage buffer as `create_buffer` makes it, owned by the caller
    /// (destroy and free it); `size` is checked against the device limits.
    pub(crate) fn create_owned_buffer(
        &self,
        size: u64,
        readback: bool,
        what: &str,
    ) -> Result<(vk::Buffer, vk::DeviceMemory), GpuError> {
        self.check_storage_size(size, || what.to_string())?;
        let mut res = RunResources::new(self.device.clone());
        let made = self.create_buffer(&mut res, size, if readback { Place::Readback } else { Place::Upload }, what)?;
        // Hand it over: `res` must not destroy it.
        res.buffers.clear();
        Ok(made)
    }

    /// Records commands with `record` into a command buffer of its own
    /// (in `res`, with what they use), submits it and waits for it (the
    /// context's timeout). On a timeout the device may still use `res`: it
    /// is kept until the context is dropped. Else it comes back.
    pub(crate) fn submit_once(
        &self,
        mut res: RunResources,
        record: impl FnOnce(&ash::Device, vk::CommandBuffer, &RunResources),
    ) -> Result<RunResources, GpuError> {
        let d = &self.device;
        // A submission before with `res` has finished (its fence waited on):
        // its pool and fence go (destroying a null handle does nothing).
        unsafe {
            d.destroy_fence(std::mem::take(&mut res.fence), None);
            d.destroy_command_pool(std::mem::take(&mut res.command_pool), None);
        }
        let cmd;
        (res.command_pool, cmd) = self.command_buffer(vk::CommandPoolCreateFlags::TRANSIENT)?;
        let begin = vk::CommandBufferBeginInfo::default().flags(vk::CommandBufferUsageFlags::ONE_TIME_SUBMIT);
        unsafe { d.begin_command_buffer(cmd, &begin) }.map_err(GpuError::vk("vkBeginCommandBuffer"))?;
        record(d, cmd, &res);
        unsafe { d.end_command_buffer(cmd) }.map_err(GpuError::vk("vkEndCommandBuffer"))?;
        res.fence =
            unsafe { d.create_fence(&vk::FenceCreateInfo::default(), None) }.map_err(GpuError::vk("vkCreateFence"))?;
        let queue = self.queue.lock().unwrap_or_else(|p| p.into_inner());
        let cmds = [cmd];
        let submit = [vk::SubmitInfo::default().command_buffers(&cmds)];
        unsafe { d.queue_submit(*queue, &submit, res.fence) }.map_err(GpuError::vk("vkQueueSubmit"))?;
        let timeout_ns = nanos(self.timeout);
        match unsafe { d.wait_for_fences(&[res.fence], true, timeout_ns) } {
            Ok(()) => Ok(res),
            Err(vk::Result::TIMEOUT) => {
                self.abandoned.lock().unwrap_or_else(|p| p.into_inner()).push(res);
                Err(GpuError::Timeout { after: self.timeout })
            }
            Err(e) => Err(GpuError::vk("vkWaitForFences")(e)),
        }
    }

    /// A command pool of the queue's family (`flags`) and one primary
    /// command buffer from it; the caller destroys the pool. On an error
    /// nothing is left behind.
    pub(crate) fn command_buffer(
        &self,
        flags: vk::CommandPoolCreateFlags,
    ) -> Result<(vk::CommandPool, vk::CommandBuffer), GpuError> {
        let d = &self.device;
        let info = vk::CommandPoolCreateInfo::default().flags(flags).queue_family_index(self.queue_family);
        let pool = unsafe { d.create_command_pool(&info, None) }.map_err(GpuError::vk("vkCreateCommandPool"))?;
        let alloc = vk::CommandBufferAllocateInfo::default()
            .command_pool(pool)
            .level(vk::CommandBufferLevel::PRIMARY)
            .command_buffer_count(1);
        match unsafe { d.allocate_command_buffers(&alloc) } {
            Ok(cmds) => Ok((pool, cmds[0])),
            Err(e) => {
                unsafe { d.destroy_command_pool(pool, None) };
                Err(GpuError::vk("vkAllocateCommandBuffers")(e))
            }
        }
    }

    /// A storage buffer in memory for `place`: host-visible and
    /// host-coherent for `Place::Upload` and `Place::Readback`, any for
    /// `Place::Device`. Memory types are tried best first (device-local;
    /// host-cached for readback), falling back to the next when an
    /// allocation fails.
    fn create_buffer(
        &self,
        res: &mut RunResources,
        size: u64,
        place: Place,
        what: &str,
    ) -> Result<(vk::Buffer, vk::DeviceMemory), GpuError> {
        let d = &self.device;
        let info = vk::BufferCreateInfo::default()
            .size(size)
            .usage(
                vk::BufferUsageFlags::STORAGE_BUFFER
                    | vk::BufferUsageFlags::UNIFORM_BUFFER
                    | vk::BufferUsageFlags::TRANSFER_SRC
                    | vk::BufferUsageFlags::TRANSFER_DST,
            )
            .sharing_mode(vk::SharingMode::EXCLUSIVE);
        let buffer = unsafe { d.create_buffer(&info, None) }.map_err(GpuError::vk("vkCreateBuffer"))?;
        res.buffers.push((buffer, vk::DeviceMemory::null()));
        let req = unsafe { d.get_buffer_memory_requirements(buffer) };

        let needed = match place {
            Place::Device => vk::MemoryPropertyFlags::empty(),
            Place::Upload | Place::Readback => {
                vk::MemoryPropertyFlags::HOST_VISIBLE | vk::MemoryPropertyFlags::HOST_COHERENT
            }
        };
        let types = &self.memory.memory_types[..self.memory.memory_type_count as usize];
        let mut candidates: Vec<(u32, u32)> = types
            .iter()
            .enumerate()
            .filter(|(i, t)| {
                req.memory_type_bits & (1 << i) != 0
                    && t.property_flags.contains(needed)
                    && self.memory.memory_heaps[t.heap_index as usize].size >= req.size
            })
            .map(|(i, t)| {
                let f = t.property_flags;
                let local = f.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL) as u32;
                let cached = f.contains(vk::MemoryPropertyFlags::HOST_CACHED) as u32;
                let score = if place == Place::Readback { cached * 2 + local } else { local * 2 };
                (i as u32, score)
            })
            .collect();
        candidates.sort_by_key(|(_, score)| std::cmp::Reverse(*score)); // stable: type order within a score
        let mut last = vk::Result::ERROR_OUT_OF_DEVICE_MEMORY;
        for (type_index, _) in &candidates {
            let alloc = vk::MemoryAllocateInfo::default().allocation_size(req.size).memory_type_index(*type_index);
            match unsafe { d.allocate_memory(&alloc, None) } {
                Ok(memory) => {
                    res.buffers.last_mut().expect("pushed above").1 = memory;
                    unsafe { d.bind_buffer_memory(buffer, memory, 0) }.map_err(GpuError::vk("vkBindBufferMemory"))?;
                    return Ok((buffer, memory));
                }
                Err(e @ (vk::Result::ERROR_OUT_OF_DEVICE_MEMORY | vk::Result::ERROR_OUT_OF_HOST_MEMORY)) => last = e,
                Err(e) => return Err(GpuError::vk("vkAllocateMemory")(e)),
            }
        }
        let kind = if place == Place::Device { "" } else { "host-visible, host-coherent " };
        let detail = if candidates.is_empty() {
            format!("no {kind}memory type is large enough")
        } else {
            format!("vkAllocateMemory failed with {last:?} for every {kind}memory type")
        };
        Err(GpuError::OutOfMemory { what: what.to_string(), bytes: req.size, detail })
    }
}

impl Inner {
    /// Whether the device's objects may be destroyed: no run that timed out
    /// is still executing (waited for up to TEARDOWN_WAIT). Else, and from
    /// then on, nothing is destroyed (the work would run on into freed
    /// memory, or the wait would last for ever): see `device_left_running`.
    pub(crate) fn may_destroy(&self) -> bool {
        let abandoned = self.abandoned.lock().unwrap_or_else(|p| p.into_inner());
        if !abandoned.is_empty() && !self.left_running() {
            self.wait_or_leave_running(&abandoned.iter().map(|r| r.fence).collect::<Vec<_>>());
        }
        !self.left_running()
    }

    /// Waits up to TEARDOWN_WAIT for `fences` (work that outlived the
    /// timeout, at teardown); work still running then is left running.
    pub(crate) fn wait_or_leave_running(&self, fences: &[vk::Fence]) {
        if unsafe { self.device.wait_for_fences(fences, true, nanos(TEARDOWN_WAIT)) }.is_err() {
            self.leave_running();
        }
    }

    /// GpuError::StillRunning where a run before timed out and may still
    /// be running: a run or a kernel's build would wait behind it.
    pub(crate) fn refuse_if_still_running(&self) -> Result<(), GpuError> {
        if self.abandoned.lock().unwrap_or_else(|p| p.into_inner()).is_empty() {
            Ok(())
        } else {
            Err(GpuError::StillRunning)
        }
    }

    /// Work that timed out is left running: nothing of this device is destroyed.
    pub(crate) fn leave_running(&self) {
        self.left_running.store(true, std::sync::atomic::Ordering::Relaxed);
        LEFT_RUNNING.store(true, std::sync::atomic::Ordering::Relaxed);
    }

    pub(crate) fn left_running(&self) -> bool {
        self.left_running.load(std::sync::atomic::Ordering::Relaxed)
    }
}

impl Drop for Inner {
    fn drop(&mut self) {
        // A timed-out dispatch may still run; its buffers can only go once it is done.
        let may_destroy = self.may_destroy();
        let abandoned = std::mem::take(&mut *self.abandoned.lock().unwrap_or_else(|p| p.into_inner()));
        if !may_destroy {
            // Nothing destroyed: the device, its instance and the window surface stay to the process's end.
            std::mem::forget(abandoned);
            std::mem::forget(self.surface.take());
            return;
        }
        unsafe {
            drop(abandoned);
            self.device.destroy_device(None);
        }
        drop(self.surface.take());
        // SAFETY: `parts` is not used after this (the device, the last user of the instance, is gone).
        unsafe { std::mem::ManuallyDrop::drop(&mut self.parts) };
    }
}

/// The format of a run's data images (`ImageFormat::Rgba32Uint`).
pub(crate) const DATA_FORMAT: vk::Format = vk::Format::R32G32B32A32_UINT;

/// The width and rows of a data image of `texels` (`Inner::check_data_image`).
pub(crate) fn data_image_size(texels: u64) -> [u64; 2] {
    let width = u64::from(IMAGE_WIDTH);
    if texels <= width {
        [texels, 1]
    } else {
        [width, texels.div_ceil(width)]
    }
}

/// A run's read-only data image, filled from its input buffer `source`.
struct RunImage {
    binding: u32,
    source: vk::Buffer,
    texels: u32,
    image: vk::Image,
    view: vk::ImageView,
    memory: vk::DeviceMemory,
}

/// Records the copy of `image`'s input buffer into it, between the layout
/// changes it needs: UNDEFINED -> TRANSFER_DST_OPTIMAL -> GENERAL, read by
/// the compute shader.
///
/// # Safety
/// `cmd` is a command buffer of `d` in the recording state.
pub(crate) unsafe fn record_image_upload(
    d: &ash::Device,
    cmd: vk::CommandBuffer,
    source: vk::Buffer,
    image: vk::Image,
    texels: u32,
) {
    let [width, height] = data_image_size(u64::from(texels)).map(|n| n as u32);
    let barrier = |old, new, src, dst| [layout_barrier(image, old, new, src, dst)];
    let region = [vk::BufferImageCopy::default()
        .image_subresource(
            vk::ImageSubresourceLayers::default().aspect_mask(vk::ImageAspectFlags::COLOR).layer_count(1),
        )
        .image_extent(vk::Extent3D { width, height, depth: 1 })];
    let to_copy = barrier(
        vk::ImageLayout::UNDEFINED,
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::AccessFlags::empty(),
        vk::AccessFlags::TRANSFER_WRITE,
    );
    let to_read = barrier(
        vk::ImageLayout::TRANSFER_DST_OPTIMAL,
        vk::ImageLayout::GENERAL,
        vk::AccessFlags::TRANSFER_WRITE,
        vk::AccessFlags::SHADER_READ,
    );
    let (top, transfer, compute) =
        (vk::PipelineStageFlags::TOP_OF_PIPE, vk::PipelineStageFlags::TRANSFER, vk::PipelineStageFlags::COMPUTE_SHADER);
    // SAFETY: the caller's; the buffer (filled and unmapped before recording) and the image live as long as the run.
    unsafe {
        d.cmd_pipeline_barrier(cmd, top, transfer, vk::DependencyFlags::empty(), &[], &[], &to_copy);
        d.cmd_copy_buffer_to_image(cmd, source, image, vk::ImageLayout::TRANSFER_DST_OPTIMAL, &region);
        d.cmd_pipeline_barrier(cmd, transfer, compute, vk::DependencyFlags::empty(), &[], &[], &to_read);
    }
}

/// The Vulkan objects of one run, destroyed on drop (also on every error path).
pub(crate) struct RunResources {
    device: ash::Device,
    buffers: Vec<(vk::Buffer, vk::DeviceMemory)>,
    bindings: Vec<(u32, vk::Buffer)>,
    /// Buffers the device fills before the first pass, and each one's word.
    fills: Vec<(vk::Buffer, u32)>,
    /// The memory of the buffer read back.
    output: vk::DeviceMemory,
    images: Vec<RunImage>,
    descriptor_pool: vk::DescriptorPool,
    command_pool: vk::CommandPool,
    fence: vk::Fence,
}

impl RunResources {
    pub(crate) fn new(device: ash::Device) -> Self {
        RunResources {
            device,
            buffers: Vec::new(),
            bindings: Vec::new(),
            fills: Vec::new(),
            output: vk::DeviceMemory::null(),
            images: Vec::new(),
            descriptor_pool: vk::DescriptorPool::null(),
            command_pool: vk::CommandPool::null(),
            fence: vk::Fence::null(),
        }
    }
}

impl Drop for RunResources {
    fn drop(&mut self) {
        let d = &self.device;
        // Destroying a null handle is a no-op in Vulkan.
        unsafe {
            d.destroy_fence(self.fence, None);
            d.destroy_command_pool(self.command_pool, None);
            d.destroy_descriptor_pool(self.descriptor_pool, None);
            for image in self.images.drain(..) {
                super::image::destroy_image(d, (image.image, image.memory, image.view));
            }
            for (buffer, memory) in self.buffers.drain(..) {
                d.destroy_buffer(buffer, None);
                d.free_memory(memory, None);
            }
        }
    }
}

#[cfg(test)]
pub(crate) fn load_entry_from(path: &str) -> Result<InstanceParts, GpuError> {
    let entry =
        unsafe { ash::Entry::load_from(path) }.map_err(|e| GpuError::LoaderMissing { detail: e.to_string() })?;
    InstanceParts::with_entry(entry, false, &[])
}
