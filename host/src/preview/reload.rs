//! Live reload: a thread follows the scene file, the textures it uses and
//! the shader sources (`watch::FileWatch`) and, when one changed, does the
//! slow part off the render thread —
//! parse and flatten the scene and pack its buffers, or compile
//! preview.comp with glslang and build the checked kernel (naga reflection,
//! pipeline) — and sends the result (or the error) to the render loop.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use crate::frame::{self, FrameData, RenderSettings};
use crate::scene::{self, FlattenLimits, ParseOptions, Scene};

use super::renderer::PreviewKernels;
use crate::watch::FileWatch;

/// The longest the watcher thread waits between looks at its stop flag.
const STOP_CHECK: Duration = Duration::from_millis(250);
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

fn watch(config: WatchConfig, tx: Sender<Reload>, stop: Arc<AtomicBool>) {
    let scene: Vec<PathBuf> = config.scene.iter().cloned().collect();
    let folders: Vec<PathBuf> = config.shaders.iter().map(|f| f.dir.clone()).collect();
    let mut files = FileWatch::new();
    files.follow(&[scene.clone(), config.textures.clone()].concat(), &folders);
    while !stop.load(Ordering::Relaxed) {
        // Short waits, so that a stop is seen soon.
        let changed = files.changes(STOP_CHECK);
        if changed.is_empty() {
            continue;
        }
        let in_folder = |p: &PathBuf| folders.iter().any(|dir| p.starts_with(dir));
        if let (Some(path), true) = (&config.scene, changed.iter().any(|p| !in_folder(p))) {
            let msg = match scene::load(path, &config.parse, &config.limits) {
                Ok(scene) => match frame::build(&scene, &config.settings) {
                    Ok(data) => {
                        // The textures this scene uses, from now on.
                        files.follow(&[vec![path.clone()], scene.texture_files()].concat(), &folders);
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
        if let (Some(folder), true) = (&config.shaders, changed.iter().any(in_folder)) {
            if tx.send(folder.compile()).is_err() {
                return;
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
