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
//! A cache file holds the whole key it was made for (the driver's binary
//! UUID and version, the kernel's name, SPIR-V, specialization constants
//! and bindings) and a checksum of its binary, and is used only when that
//! key is equal byte for byte and the checksum holds; a binary the driver
//! refuses is made again. The folder keeps the newest
//! `KEEP` files.

use std::path::{Path, PathBuf};

use ash::vk;

use super::error::GpuError;

/// Cache files kept (the newest by modification time).
const KEEP: usize = 64;
const MAGIC: &[u8] = b"raycast shader binary 1\n";

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

/// The folder for kept binaries: RAYCAST_CACHE_DIR, else
/// $XDG_CACHE_HOME/raycast, else ~/.cache/raycast.
pub fn cache_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RAYCAST_CACHE_DIR").filter(|d| !d.is_empty()) {
        return Some(PathBuf::from(d));
    }
    if let Some(d) = std::env::var_os("XDG_CACHE_HOME").filter(|d| !d.is_empty()) {
        return Some(Path::new(&d).join("raycast"));
    }
    std::env::var_os("HOME").filter(|d| !d.is_empty()).map(|h| Path::new(&h).join(".cache/raycast"))
}

/// Whether a device's kernels are shader objects when validation is off:
/// where it offers them (`offered`) and runs on the CPU (lavapipe, which
/// builds a pipeline from SPIR-V on every run; a GPU's driver keeps its own
/// cache of pipelines, and this path has not been run on a GPU), unless
/// RAYCAST_SHADER_OBJECTS says otherwise: 0 never, 1 wherever offered.
pub(crate) fn chosen(offered: bool, cpu: bool) -> bool {
    match std::env::var("RAYCAST_SHADER_OBJECTS").as_deref() {
        Ok("0") => false,
        Ok("1") => offered,
        _ => offered && cpu,
    }
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
        ShaderObjects { ext: ash::ext::shader_object::Device::new(instance, device), driver_key, dir: cache_dir() }
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
        let mut key = MAGIC.to_vec();
        key.extend_from_slice(&self.driver_key);
        for part in [name.as_bytes(), bytemuck::cast_slice(constants), bytemuck::cast_slice(spirv)] {
            key.extend_from_slice(&(part.len() as u64).to_le_bytes());
            key.extend_from_slice(part);
        }
        for (b, t) in bindings {
            key.extend_from_slice(&b.to_le_bytes());
            key.extend_from_slice(&t.to_le_bytes());
        }
        let file = self.dir.as_ref().map(|d| d.join(format!("{}-{:016x}.bin", name, fnv1a(&key))));
        let make = |code_type: vk::ShaderCodeTypeEXT, code: &[u8]| {
            let info = [vk::ShaderCreateInfoEXT::default()
                .stage(vk::ShaderStageFlags::COMPUTE)
                .code_type(code_type)
                .code(code)
                .name(c"main")
                .set_layouts(set_layouts)
                .specialization_info(specialization)];
            unsafe { self.ext.create_shaders(&info, None) }.map(|s| s[0])
        };
        if let Some(binary) = file.as_deref().and_then(|f| cached_binary(f, &key)) {
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
            kept = keep(file, &key, &binary).is_ok();
        }
        Ok((shader, ShaderSource::Compiled { kept }))
    }
}

/// The binary stored in `file` for exactly `key`, if any, and if its
/// checksum holds (a driver need not survive a damaged binary).
fn cached_binary(file: &Path, key: &[u8]) -> Option<Vec<u8>> {
    let bytes = std::fs::read(file).ok()?;
    let len = usize::try_from(u64::from_le_bytes(bytes.get(..8)?.try_into().ok()?)).ok()?;
    let key_end = 8usize.checked_add(len)?;
    if bytes.get(8..key_end)? != key {
        return None;
    }
    let sum = u64::from_le_bytes(bytes.get(key_end..key_end + 8)?.try_into().ok()?);
    let binary = &bytes[key_end + 8..];
    (fnv1a(binary) == sum).then(|| binary.to_vec())
}

/// Writes `key` and `binary` to `file` (through a temporary file renamed
/// over it, so a reader never sees half of one), then keeps the newest
/// KEEP files of the folder.
fn keep(file: &Path, key: &[u8], binary: &[u8]) -> std::io::Result<()> {
    let dir = file.parent().unwrap_or(Path::new("."));
    std::fs::create_dir_all(dir)?;
    let mut bytes = (key.len() as u64).to_le_bytes().to_vec();
    bytes.extend_from_slice(key);
    bytes.extend_from_slice(&fnv1a(binary).to_le_bytes());
    bytes.extend_from_slice(binary);
    let tmp = file.with_extension(format!("tmp{}", std::process::id()));
    std::fs::write(&tmp, &bytes)?;
    std::fs::rename(&tmp, file)?;
    let mut files: Vec<(std::time::SystemTime, PathBuf)> = std::fs::read_dir(dir)?
        .filter_map(|e| e.ok())
        .filter(|e| e.path().extension().is_some_and(|x| x == "bin"))
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    files.sort_by_key(|f| std::cmp::Reverse(f.0));
    for (_, old) in files.into_iter().skip(KEEP) {
        let _ = std::fs::remove_file(old);
    }
    Ok(())
}

/// 64-bit FNV-1a: the cache file's name (the file holds the whole key).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, b| (h ^ u64::from(*b)).wrapping_mul(0x0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_cache_file_answers_only_its_own_key() {
        let dir = std::env::temp_dir().join(format!("raycast-shader-cache-test-{}", std::process::id()));
        let file = dir.join("k.bin");
        keep(&file, b"key one", b"binary").unwrap();
        assert_eq!(cached_binary(&file, b"key one").as_deref(), Some(&b"binary"[..]));
        assert_eq!(cached_binary(&file, b"key two"), None);
        assert_eq!(cached_binary(&file, b"key on"), None);
        // Cut short: no binary, no panic.
        let bytes = std::fs::read(&file).unwrap();
        std::fs::write(&file, &bytes[..10]).unwrap();
        assert_eq!(cached_binary(&file, b"key one"), None);
        std::fs::write(&file, [0xffu8; 8]).unwrap();
        assert_eq!(cached_binary(&file, b"key one"), None);
        // A changed byte of the binary: its checksum fails.
        keep(&file, b"key one", b"binary").unwrap();
        let mut bytes = std::fs::read(&file).unwrap();
        *bytes.last_mut().unwrap() ^= 1;
        std::fs::write(&file, &bytes).unwrap();
        assert_eq!(cached_binary(&file, b"key one"), None);
        // The folder keeps the newest KEEP files.
        for i in 0..KEEP + 5 {
            keep(&dir.join(format!("{i}.bin")), b"k", b"b").unwrap();
        }
        let n = std::fs::read_dir(&dir).unwrap().count();
        assert_eq!(n, KEEP, "files kept");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn fnv1a_is_the_published_function() {
        // Published test vectors of 64-bit FNV-1a.
        assert_eq!(fnv1a(b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(b"foobar"), 0x8594_4171_f739_67e8);
    }
}
