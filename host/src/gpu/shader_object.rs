//! Kernels as shader objects (VK_EXT_shader_object) with their binaries
//! kept on disk, where the device offers them.
//!
//! A compute pipeline is built from SPIR-V on every run: lavapipe turns
//! the SPIR-V into NIR and optimises it each time (50-75 ms for the render
//! kernel; only LLVM's machine code is in Mesa's own cache). A shader
//! object's binary (`vkGetShaderBinaryDataEXT`) holds what that step made,
//! and a shader object made from it takes 3-4 ms (Mesa 25.0's lavapipe:
//! BENCHMARKS.md, "A newer lavapipe"). So where the extension is there, a
//! kernel is a shader object, made from the binary a run before kept in
//! the cache folder when there is one for exactly this kernel on exactly
//! this driver, else from SPIR-V, whose binary is then written there.
//!
//! Only on a device that runs on the CPU unless RAYCAST_SHADER_OBJECTS=1
//! (`chosen`), and with validation only where the validation layer knows
//! the extension (`validated`): Debian 12's layers (1.3.239) predate it and
//! crash on its dispatches, so there validated runs are pipelines; Debian
//! 13's (1.4.309) validate it. With RAYCAST_SHADER_OBJECTS=0 kernels are
//! pipelines as everywhere else.
//!
//! A cache file (cache.rs) holds the whole key it was made for (the
//! driver's binary UUID and version, the kernel's name, SPIR-V,
//! specialization constants and bindings) and a checksum of its binary; a
//! binary the driver refuses is made again. The folder keeps the newest
//! `CACHE.keep` of them.

use std::path::PathBuf;

use ash::vk;

use super::cache;
use super::error::GpuError;

/// Shader binaries in the cache folder: `.bin` files, the newest 64 kept.
const CACHE: cache::Kind = cache::Kind { extension: "bin", keep: 64 };
/// Part of every key: 3 since the shaders are made with DISPATCH_BASE.
const MAGIC: &[u8] = b"raycast shader binary 3\n";

/// The extension's functions and what identifies the driver's binaries.
pub(crate) struct ShaderObjects {
    pub(crate) ext: ash::ext::shader_object::Device,
    /// shaderBinaryUUID and shaderBinaryVersion.
    driver_key: Vec<u8>,
    /// None: nothing is kept (no cache folder could be named).
    dir: Option<PathBuf>,
}

/// Whether a kernel's shader object came from the cache or was compiled.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ShaderSource {
    /// From SPIR-V (no binary for it in the cache, or none usable), its
    /// binary then written to the cache (`kept`) or not (no folder, or it
    /// could not be written).
    Compiled { kept: bool },
    /// From the binary in the cache.
    Cached,
}

/// Whether a device's kernels are shader objects when validation is off:
/// where it offers them (`offered`) and runs on the CPU (lavapipe, which
/// builds a pipeline from SPIR-V on every run; a GPU's driver keeps its own
/// cache of pipelines, and this path has not been run on a GPU), unless
/// RAYCAST_SHADER_OBJECTS says otherwise: 0 never, 1 wherever offered.
pub(crate) fn chosen(offered: bool, cpu: bool) -> bool {
    offered && super::environment::switch("RAYCAST_SHADER_OBJECTS").unwrap_or(cpu)
}

/// The first Khronos validation layer taken to validate shader objects:
/// 1.3.268 (the SDK of November 2023, which added most of its checks:
/// KhronosGroup/Vulkan-Samples#843). 1.3.239 (Debian 12) crashes on their
/// dispatches; 1.4.309 (Debian 13) validates render, check, shader-test and
/// the preview with them without a message.
pub(crate) const FIRST_VALIDATION_LAYER: u32 = vk::make_api_version(0, 1, 3, 268);

/// Whether kernels may be shader objects under validation, with this
/// validation layer installed (its spec version; None: none installed).
pub(crate) fn validated(layer: Option<u32>) -> bool {
    layer.is_some_and(|v| v >= FIRST_VALIDATION_LAYER)
}

/// The device extensions a device is created with for shader objects:
/// VK_EXT_shader_object and, as raycast asks for Vulkan 1.1, what it
/// requires that only later versions have in core: VK_KHR_dynamic_rendering
/// (1.3) and its own requirements VK_KHR_depth_stencil_resolve and
/// VK_KHR_create_renderpass2 (1.2). Without them device creation breaks
/// the extension's rules (VUID-vkCreateDevice-ppEnabledExtensionNames-01387,
/// which Debian 13's validation layers report).
pub(crate) const DEVICE_EXTENSIONS: [&std::ffi::CStr; 4] = [
    ash::ext::shader_object::NAME,
    ash::khr::dynamic_rendering::NAME,
    ash::khr::depth_stencil_resolve::NAME,
    ash::khr::create_renderpass2::NAME,
];

/// The device's shader-object feature, if it has the extensions
/// ([`DEVICE_EXTENSIONS`]) and the feature (`extensions`: the device's).
pub(crate) fn supported(instance: &ash::Instance, physical: vk::PhysicalDevice, extensions: &[String]) -> bool {
    let offered = |name: &std::ffi::CStr| extensions.iter().any(|e| e.as_bytes() == name.to_bytes());
    if !DEVICE_EXTENSIONS.iter().all(|name| offered(name)) {
        return false;
    }
    let mut features = vk::PhysicalDeviceShaderObjectFeaturesEXT::default();
    let mut features2 = vk::PhysicalDeviceFeatures2::default().push_next(&mut features);
    unsafe { instance.get_physical_device_features2(physical, &mut features2) };
    features.shader_object == vk::TRUE
}

impl ShaderObjects {
    pub(crate) fn new(instance: &ash::Instance, physical: vk::PhysicalDevice, device: &ash::Device) -> ShaderObjects {
        let mut props = vk::PhysicalDeviceShaderObjectPropertiesEXT::default();
        let mut props2 = vk::PhysicalDeviceProperties2::default().push_next(&mut props);
        unsafe { instance.get_physical_device_properties2(physical, &mut props2) };
        let mut driver_key = props.shader_binary_uuid.to_vec();
        driver_key.extend_from_slice(&props.shader_binary_version.to_le_bytes());
        ShaderObjects {
            ext: ash::ext::shader_object::Device::new(instance, device),
            driver_key,
            dir: cache::cache_dir(),
        }
    }

    /// The compute shader object of `spirv` (words) with `constants` (as
    /// `specialization` gives them to the driver) and `set_layouts`, from the cache when it holds this very kernel's
    /// binary, else compiled and its binary kept. `bindings` (binding,
    /// descriptor type) are part of the key.
    pub(crate) fn create(
        &self,
        name: &str,
        spirv: &[u32],
        constants: &[u32],
        specialization: &vk::SpecializationInfo<'_>,
        set_layouts: &[vk::DescriptorSetLayout],
        bindings: &[(u32, i32)],
    ) -> Result<(vk::ShaderEXT, ShaderSource), GpuError> {
        let bindings: Vec<u8> =
            bindings.iter().flat_map(|(b, t)| [b.to_le_bytes(), t.to_le_bytes()]).flatten().collect();
        let key = cache::key(&[
            MAGIC,
            &self.driver_key,
            name.as_bytes(),
            bytemuck::cast_slice(constants),
            bytemuck::cast_slice(spirv),
            &bindings,
        ]);
        let file = self.dir.as_ref().map(|d| cache::file_for(d, CACHE, name, &key));
        let make = |code_type: vk::ShaderCodeTypeEXT, code: &[u8]| {
            // DISPATCH_BASE: a run splits a pass by rows of work groups (dispatch.rs record_run).
            let info = [vk::ShaderCreateInfoEXT::default()
                .flags(vk::ShaderCreateFlagsEXT::DISPATCH_BASE)
                .stage(vk::ShaderStageFlags::COMPUTE)
                .code_type(code_type)
                .code(code)
                .name(c"main")
                .set_layouts(set_layouts)
                .specialization_info(specialization)];
            unsafe { self.ext.create_shaders(&info, None) }.map(|s| s[0])
        };
        if let Some(binary) = file.as_deref().and_then(|f| cache::read(f, &key)) {
            // A binary the driver refuses (another build of it) is made again below.
            if let Ok(shader) = make(vk::ShaderCodeTypeEXT::BINARY, &binary) {
                return Ok((shader, ShaderSource::Cached));
            }
        }
        let shader = make(vk::ShaderCodeTypeEXT::SPIRV, bytemuck::cast_slice(spirv))
            .map_err(|(_, e)| GpuError::vk("vkCreateShadersEXT")(e))?;
        let mut kept = false;
        if let (Some(file), Ok(binary)) = (&file, unsafe { self.ext.get_shader_binary_data(shader) }) {
            // A cache that cannot be written is only slower.
            kept = cache::write(file, CACHE, &key, &binary).is_ok();
        }
        Ok((shader, ShaderSource::Compiled { kept }))
    }
}
