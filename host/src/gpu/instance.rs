//! The Vulkan instance: the loader, the instance with its layers and
//! extensions, the validation messenger that captures the layer's
//! messages, and a window's surface (an object of the instance).

use std::ffi::{c_char, c_void, CStr};
use std::sync::{Arc, Mutex};

use ash::vk;

use super::GpuError;

const VALIDATION_LAYER: &CStr = c"VK_LAYER_KHRONOS_validation";
/// Instance API version requested; nothing newer is used.
const API_VERSION: u32 = vk::API_VERSION_1_1;

/// Validation messages, shared with the messenger callback.
pub(crate) type Sink = Arc<Mutex<Vec<String>>>;

/// Loader, instance and (with validation) the debug messenger; destroyed in
/// reverse order on drop.
pub(crate) struct InstanceParts {
    debug: Option<(ash::ext::debug_utils::Instance, vk::DebugUtilsMessengerEXT)>,
    pub(crate) instance: ash::Instance,
    /// The callback's user data points into this; it outlives the instance.
    pub(crate) messages: Sink,
    /// The installed Khronos validation layer's spec version, enabled or
    /// not (None: not installed): whether shader objects may be used under
    /// it (shader_object::validated).
    pub(crate) validation_layer: Option<u32>,
    pub(crate) entry: ash::Entry,
}

pub(crate) fn cstrs(names: &[&CStr]) -> Vec<*const c_char> {
    names.iter().map(|n| n.as_ptr()).collect()
}

pub(crate) fn ext_names(props: &[vk::ExtensionProperties]) -> Vec<String> {
    props.iter().filter_map(|p| p.extension_name_as_c_str().ok().map(|s| s.to_string_lossy().into_owned())).collect()
}

pub(crate) fn version_string(v: u32) -> String {
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

/// A window surface and the loader that destroys it (before the instance).
pub(crate) struct Surface {
    pub(crate) loader: ash::khr::surface::Instance,
    pub(crate) handle: vk::SurfaceKHR,
}

impl Drop for Surface {
    fn drop(&mut self) {
        unsafe { self.loader.destroy_surface(self.handle, None) };
    }
}

#[cfg(test)]
pub(crate) fn load_entry_from(path: &str) -> Result<InstanceParts, GpuError> {
    let entry =
        unsafe { ash::Entry::load_from(path) }.map_err(|e| GpuError::LoaderMissing { detail: e.to_string() })?;
    InstanceParts::with_entry(entry, false, &[])
}
