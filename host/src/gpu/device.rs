//! The device: the physical devices and the one chosen (`DeviceSelector`,
//! the default's ranking, `list_devices`), what is known of each
//! (`DeviceInfo`), and the logical device with its compute queue
//! (`Inner`, what a `GpuContext` owns) and its limits.

use std::ffi::CStr;
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use ash::vk;

use super::environment;
use super::float_controls;
use super::instance::{cstrs, ext_names, version_string, InstanceParts, Surface};
use super::memory::{KeptRun, RunResources};
use super::shader_object;
use super::specialize;
use super::{Division, GpuError, LESS_DATA};

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
    /// The exact kernels or the fast ones (`GpuContext::division`).
    pub kernel: KernelChoice,
}

impl Default for GpuOptions {
    fn default() -> Self {
        GpuOptions { device: None, validation: false, timeout: Duration::from_secs(600), kernel: KernelChoice::Auto }
    }
}

/// Which kernels a device runs (`--kernel`; docs/exactness.md, "The fast
/// kernel").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum KernelChoice {
    /// The fast kernels on a discrete or integrated GPU, the exact ones on
    /// every other device (lavapipe and other CPU devices).
    #[default]
    Auto,
    /// The exact kernels: the CPU build's bits on every device.
    Exact,
    /// The fast kernels (FAST_MATH): the device's own division, square
    /// root and transcendentals; within a stated rule of the CPU build.
    Fast,
}

impl KernelChoice {
    /// Whether a device runs the fast kernels under this choice.
    pub fn fast_on(self, device: &DeviceInfo) -> bool {
        match self {
            KernelChoice::Auto => device.fast_by_default(),
            KernelChoice::Exact => false,
            KernelChoice::Fast => true,
        }
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

    /// A discrete or integrated GPU: `--kernel auto` runs the fast kernels here.
    pub fn fast_by_default(&self) -> bool {
        self.kind == "discrete GPU" || self.kind == "integrated GPU"
    }

    /// "llvmpipe (LLVM 15.0.6, 256 bits) (cpu, Vulkan 1.3.230)": the
    /// `device:` lines' words for it.
    pub fn summary(&self) -> String {
        format!("{} ({}, Vulkan {})", self.name, self.kind, self.api_version)
    }
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
pub(crate) type Veto<'a> = dyn Fn(&DeviceInfo) -> Option<String> + 'a;

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
    pub(crate) abandoned: Mutex<Vec<RunResources>>,
    /// The last run's buffers, images and descriptor set, kept for the
    /// next run of the same kernel with the same bindings (`KeptRun`).
    pub(crate) kept: Mutex<Option<KeptRun>>,
    /// How many runs took a kept run's resources (the tests read it).
    pub(crate) kept_taken: std::sync::atomic::AtomicU64,
    pub(crate) device: ash::Device,
    pub(crate) queue: Mutex<vk::Queue>,
    pub(crate) queue_family: u32,
    pub(crate) info: DeviceInfo,
    pub(crate) limits: vk::PhysicalDeviceLimits,
    pub(crate) max_allocation: u64,
    pub(crate) memory: vk::PhysicalDeviceMemoryProperties,
    pub(crate) timeout: Duration,
    /// The float-controls execution modes every kernel gets (float_controls.rs).
    pub(crate) float_modes: float_controls::Modes,
    /// Kernels for this device correct its division (`division`).
    pub(crate) inexact_division: bool,
    /// This device runs the fast kernels (`GpuOptions::kernel`, `division`).
    pub(crate) fast: bool,
    /// `division`, once decided (its probe runs on the first call).
    pub(crate) division: OnceLock<Division>,
    /// Kernels are shader objects on this device (shader_object.rs); None: pipelines.
    pub(crate) shader_objects: Option<shader_object::ShaderObjects>,
    /// Pipelines are built from SPIR-V specialised ahead (specialize.rs).
    pub(crate) specialise_ahead: bool,
    /// A run's output lives in device-local memory, and is copied to memory
    /// the host reads after the last pass (`dispatch::record_run`): where
    /// the device has device-local memory the host cannot map (a discrete
    /// GPU), so the kernel's writes stay on the device; RAYCAST_OUTPUT_COPY
    /// = 0 or 1 overrides (1 tests the copy on lavapipe).
    pub(crate) output_copy: bool,
    /// VK_KHR_pipeline_executable_properties, where the device offers it
    /// (`Kernel::statistics`); None: its driver reports no statistics.
    pub(crate) executables: Option<ash::khr::pipeline_executable_properties::Device>,
    pub(crate) physical: vk::PhysicalDevice,
    /// The window surface of `GpuContext::with_surface`; destroyed after the
    /// device, before the instance (field order).
    pub(crate) surface: Option<Surface>,
    /// Destroyed last, by `drop`, unless work was left running.
    pub(crate) parts: std::mem::ManuallyDrop<InstanceParts>,
    /// Work that timed out was still running when the context went
    /// (`may_destroy`): nothing of it is destroyed.
    pub(crate) left_running: std::sync::atomic::AtomicBool,
}

impl InstanceParts {
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

impl Inner {
    /// Opens the selected (or best) device of `parts` with one compute
    /// queue; with a window, one whose compute queue can present to its
    /// surface, unless the window system's veto refuses it
    /// (`GpuContext::with_surface`).
    pub(crate) fn open(
        opts: &GpuOptions,
        parts: InstanceParts,
        window: Option<(Surface, &Veto)>,
    ) -> Result<Inner, GpuError> {
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
        // Kernel statistics (`Kernel::statistics`), where the extension and its feature are offered.
        let executables = props.api_version >= vk::API_VERSION_1_1
            && physical
                .extensions
                .iter()
                .any(|e| e.as_bytes() == ash::khr::pipeline_executable_properties::NAME.to_bytes())
            && {
                let mut feature = vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default();
                let mut features = vk::PhysicalDeviceFeatures2::default().push_next(&mut feature);
                unsafe { instance.get_physical_device_features2(physical.handle, &mut features) };
                feature.pipeline_executable_info == vk::TRUE
            };
        if executables {
            device_exts.push(ash::khr::pipeline_executable_properties::NAME);
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
        let mut executable_features =
            vk::PhysicalDevicePipelineExecutablePropertiesFeaturesKHR::default().pipeline_executable_info(true);
        if executables {
            device_info = device_info.push_next(&mut executable_features);
        }
        let device = unsafe { instance.create_device(physical.handle, &device_info, None) }
            .map_err(GpuError::vk("vkCreateDevice"))?;
        let shader_objects =
            shader_objects.then(|| shader_object::ShaderObjects::new(instance, physical.handle, &device));
        let queue = unsafe { device.get_device_queue(queue_family, 0) };
        let specialise_ahead = physical.info.specialises_ahead;
        let fast = opts.kernel.fast_on(&physical.info);
        let executables = executables.then(|| ash::khr::pipeline_executable_properties::Device::new(instance, &device));
        let apart = memory.memory_types[..memory.memory_type_count as usize].iter().any(|t| {
            t.property_flags.contains(vk::MemoryPropertyFlags::DEVICE_LOCAL)
                && !t.property_flags.contains(vk::MemoryPropertyFlags::HOST_VISIBLE)
        });
        let output_copy = environment::switch("RAYCAST_OUTPUT_COPY").unwrap_or(apart);

        Ok(Inner {
            abandoned: Mutex::new(Vec::new()),
            kept: Mutex::new(None),
            kept_taken: std::sync::atomic::AtomicU64::new(0),
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
            fast,
            division: OnceLock::new(),
            shader_objects,
            specialise_ahead,
            output_copy,
            executables,
            physical: physical.handle,
            surface: window.map(|(surface, _)| surface),
            parts: std::mem::ManuallyDrop::new(parts),
            left_running: std::sync::atomic::AtomicBool::new(false),
        })
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
}

impl Drop for Inner {
    fn drop(&mut self) {
        // A timed-out dispatch may still run; its buffers can only go once it is done.
        let may_destroy = self.may_destroy();
        let abandoned = std::mem::take(&mut *self.abandoned.lock().unwrap_or_else(|p| p.into_inner()));
        if !may_destroy {
            // Nothing destroyed: the device, its instance and the window surface stay to the process's end.
            std::mem::forget(abandoned);
            std::mem::forget(self.kept.lock().unwrap_or_else(|p| p.into_inner()).take());
            std::mem::forget(self.surface.take());
            return;
        }
        let kept = self.kept.lock().unwrap_or_else(|p| p.into_inner()).take();
        unsafe {
            drop(abandoned);
            drop(kept);
            self.device.destroy_device(None);
        }
        drop(self.surface.take());
        // SAFETY: `parts` is not used after this (the device, the last user of the instance, is gone).
        unsafe { std::mem::ManuallyDrop::drop(&mut self.parts) };
    }
}
