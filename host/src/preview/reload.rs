//! Live reload: a thread polls the scene file, the textures it uses and the
//! shader sources every 250 ms and, when one changed, does the slow part off
//! the render thread —
//! parse and flatten the scene and pack its buffers, or compile
//! preview.comp with glslang and build the checked kernel (naga reflection,
//! pipeline) — and sends the result (or the error) to the render loop.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, SystemTime};

use crate::frame::{self, FrameData, RenderSettings};
use crate::scene::{self, FlattenLimits, ParseOptions, Scene};

use super::renderer::PreviewKernels;

pub(crate) const POLL: Duration = Duration::from_millis(250);
/// The kernel that is recompiled, in the shader folder, by stem and file;
/// its uniform variant (preview_uniform.comp) too when the folder has it.
const KERNEL_STEM: &str = "preview";
pub const KERNEL_FILE: &str = "preview.comp";

/// What the watcher sends.
pub enum Reload {
    /// The scene file changed and loads.
    Scene(Box<(Scene, FrameData)>),
    /// A shader source changed; these are the new kernels, checked and built.
    Kernel(PreviewKernels),
    /// A reload failed; the message says where and why.
    Failed(String),
}

/// What to watch and how to load it.
pub struct WatchConfig {
    pub scene: Option<PathBuf>,
    /// The image files the scene's textures come from (Scene::texture_files):
    /// a change reloads the scene; each reload follows its own.
    pub textures: Vec<PathBuf>,
    pub parse: ParseOptions,
    pub limits: FlattenLimits,
    pub settings: RenderSettings,
    /// The shader folder to follow; None: no shader reload.
    pub shaders: Option<ShaderFolder>,
}

/// A folder with preview.comp and what it includes, and how its kernels
/// are compiled for the device (`GpuContext::division`): what the watcher
/// follows and K recompiles.
#[derive(Clone, Debug)]
pub struct ShaderFolder {
    pub dir: PathBuf,
    pub division: crate::gpu::Division,
}

/// The watcher thread; stopped and joined on drop.
pub struct Watcher {
    rx: Receiver<Reload>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Watcher {
    pub fn spawn(config: WatchConfig) -> Watcher {
        let (tx, rx) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::Builder::new()
            .name("raycast-reload".into())
            .spawn(move || watch(config, tx, flag))
            .expect("spawn the reload thread");
        Watcher { rx, stop, thread: Some(thread) }
    }

    /// The next result, if one is ready.
    pub fn try_recv(&self) -> Option<Reload> {
        self.rx.try_recv().ok()
    }
}

impl Drop for Watcher {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// Modification time and length: what "changed" means.
pub(crate) type Stamp = Option<(SystemTime, u64)>;

fn stamp(path: &Path) -> Stamp {
    let m = std::fs::metadata(path).ok()?;
    Some((m.modified().ok()?, m.len()))
}

/// Every shader source in `dir`: *.comp, *.glsl, *.h.
pub(crate) fn shader_stamps(dir: &Path) -> BTreeMap<PathBuf, Stamp> {
    let Ok(entries) = std::fs::read_dir(dir) else { return BTreeMap::new() };
    entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| matches!(p.extension().and_then(|e| e.to_str()), Some("comp" | "glsl" | "h")))
        .map(|p| {
            let s = stamp(&p);
            (p, s)
        })
        .collect()
}

/// Each file's stamp.
pub(crate) fn stamps<'a>(files: impl IntoIterator<Item = &'a PathBuf>) -> BTreeMap<PathBuf, Stamp> {
    files.into_iter().map(|f| (f.clone(), stamp(f))).collect()
}

fn watch(config: WatchConfig, tx: Sender<Reload>, stop: Arc<AtomicBool>) {
    let mut scene_stamp = config.scene.as_deref().map(stamp);
    let mut texture_stamps = stamps(&config.textures);
    let mut shader_stamp = config.shaders.as_ref().map(|f| shader_stamps(&f.dir));
    while !stop.load(Ordering::Relaxed) {
        std::thread::sleep(POLL);
        if let Some(path) = &config.scene {
            let now = Some(stamp(path));
            let textures_now = stamps(texture_stamps.keys());
            if now != scene_stamp || textures_now != texture_stamps {
                scene_stamp = now;
                texture_stamps = textures_now;
                let msg = match scene::load(path, &config.parse, &config.limits) {
                    Ok(scene) => match frame::build(&scene, &config.settings) {
                        Ok(data) => {
                            // The textures this scene uses, from now on.
                            texture_stamps = stamps(&scene.texture_files());
                            Reload::Scene(Box::new((scene, data)))
                        }
                        Err(e) => Reload::Failed(e.to_string()),
                    },
                    Err(e) => Reload::Failed(e.to_string()),
                };
                if tx.send(msg).is_err() {
                    return;
                }
            }
        }
        if let Some(folder) = &config.shaders {
            let now = Some(shader_stamps(&folder.dir));
            if now != shader_stamp {
                shader_stamp = now;
                if tx.send(folder.compile()).is_err() {
                    return;
                }
            }
        }
    }
}

impl ShaderFolder {
    /// `dir/preview.comp` and, when there is one, `dir/preview_uniform.comp`
    /// compiled as every runtime kernel is (`gpu::compile_kernel_pair`:
    /// glslang with `dir` on the include path and `division`'s macros, then
    /// spirv-opt), checked (PreviewKernels::new; the renderer builds their
    /// pipelines).
    pub fn compile(&self) -> Reload {
        let (storage, uniform) = match crate::gpu::compile_kernel_pair(&self.dir, KERNEL_STEM, self.division) {
            Ok(pair) => pair,
            Err(e) => return Reload::Failed(e),
        };
        match PreviewKernels::new(&storage, uniform.as_deref()) {
            Ok(k) => Reload::Kernel(k),
            Err(e) => Reload::Failed(format!("{}: {e}", self.dir.join(KERNEL_FILE).display())),
        }
    }
}
