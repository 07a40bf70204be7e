//! The shader-test harness: runs one function of the shared GLSL
//! (`shaders/raycast.glsl` and the files it includes) on the Vulkan device
//! over a buffer of inputs, reads the results back, and checks each case by
//! its rule, by default also against the C++ build of the same function
//! (`host/cpu`).
//!
//! - Any top-level function of those files is testable: signatures and
//!   structs are read from the source (`glsl`), the kernel and the C++
//!   wrapper are generated (`codegen`), nothing is registered by hand.
//! - The device kernel includes layout.h, scene_buffers.glsl and
//!   raycast.glsl (with its includes) of the folder under test, is compiled
//!   with glslang (`gpu::compile_kernel`), validated and its layout
//!   reflected with naga (`gpu::Kernel::new`), and run with
//!   `GpuContext::run`. Its output is pre-filled with a sentinel and every
//!   case has a "written" word, so a case the kernel never wrote fails even
//!   when its values equal the sentinel.
//! - Functions that read the scene buffers (`camera_ray` reads `frame`,
//!   `trace` reads `primitives`) get them from the case's [`SceneBuffers`].
//! - Cases come from TOML files (`file`, `raycast shader-test`, see
//!   docs/writing-shader-tests.md) or from Rust ([`Case`], for generated and
//!   property tests: tests/shader_props.rs).
//!
//! Knows nothing of scene files: a case's scene is raw buffers.

mod codegen;
mod cpu;
pub mod file;
mod glsl;
mod rule;
mod value;

pub use glsl::{Function, SceneBuffer, ShaderInfo};
pub use rule::Rule;
pub use value::{word_text, Scalar, StructDef, Type, Value};

use std::collections::{BTreeMap, HashMap};
use std::fmt::Write;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use crate::check::ulp_distance;
use crate::error::Error;
use crate::gpu::{self, DeviceSelector, GpuContext, GpuOptions, Kernel};
use crate::layout::{self, BindingLayout, FieldLayout, StructLayout};
use cpu::CpuLibrary;

/// The repository the binary was built from: default shaders, test files, host/cpu.
pub fn source_root() -> PathBuf {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    root.canonicalize().unwrap_or(root)
}

/// What a case's result is compared with.
#[derive(Clone, Debug, PartialEq)]
pub enum Expected {
    /// These values, by the case's rule; the C++ build must match them by
    /// the same rule and the device bit for bit.
    Value(Value),
    /// Whatever the C++ build of the function returns, by the case's rule.
    SameAsCpu,
}

/// The scene buffers a case's function reads, by the names
/// scene_buffers.glsl gives them (`frame`, `primitives`, `materials`, …).
/// A buffer not given is one zeroed struct (so `frame.primitive_count` is 0).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SceneBuffers {
    buffers: BTreeMap<String, Vec<u32>>,
}

impl SceneBuffers {
    pub fn new() -> SceneBuffers {
        SceneBuffers::default()
    }

    /// The buffer `name` holding `items` (structs of layout.h, `#[repr(C)]`).
    pub fn with<T: bytemuck::Pod>(self, name: &str, items: &[T]) -> SceneBuffers {
        let bytes: &[u8] = bytemuck::cast_slice(items);
        let words =
            bytes.chunks(4).map(|c| u32::from_le_bytes([c[0], c[1], *c.get(2).unwrap_or(&0), *c.get(3).unwrap_or(&0)]));
        self.with_words(name, words.collect())
    }

    /// The buffer `name` as raw words.
    pub fn with_words(mut self, name: &str, words: Vec<u32>) -> SceneBuffers {
        self.buffers.insert(name.to_string(), words);
        self
    }

    pub fn frame(self, f: &layout::Frame) -> SceneBuffers {
        self.with("frame", std::slice::from_ref(f))
    }

    pub fn primitives(self, p: &[layout::Primitive]) -> SceneBuffers {
        self.with("primitives", p)
    }

    pub fn materials(self, m: &[layout::Material]) -> SceneBuffers {
        self.with("materials", m)
    }

    pub fn lights(self, l: &[layout::Light]) -> SceneBuffers {
        self.with("lights", l)
    }
}

/// One test: a function, its inputs, what it should return and the rule.
#[derive(Clone, Debug)]
pub struct Case {
    /// Empty: named after the call, `plane_t(r = …, axis = 0, s = 0.5)`.
    pub name: String,
    /// `tests/shaders/cube.toml:12` for a case from a file.
    pub location: Option<String>,
    pub function: String,
    /// Inputs by parameter name.
    pub inputs: Vec<(String, Value)>,
    pub expected: Expected,
    pub rule: Rule,
    pub scene: Option<Arc<SceneBuffers>>,
    /// Also run the C++ build and compare (true unless turned off).
    pub cpu: bool,
}

impl Case {
    /// A case of `function`, "same as CPU" by the exact rule until told otherwise.
    pub fn new(function: &str) -> Case {
        Case {
            name: String::new(),
            location: None,
            function: function.to_string(),
            inputs: Vec::new(),
            expected: Expected::SameAsCpu,
            rule: Rule::Exact,
            scene: None,
            cpu: true,
        }
    }

    pub fn named(mut self, name: impl Into<String>) -> Case {
        self.name = name.into();
        self
    }

    pub fn input(mut self, param: &str, v: impl Into<Value>) -> Case {
        self.inputs.push((param.to_string(), v.into()));
        self
    }

    pub fn expect(mut self, v: impl Into<Value>, rule: Rule) -> Case {
        self.expected = Expected::Value(v.into());
        self.rule = rule;
        self
    }

    pub fn same_as_cpu(mut self, rule: Rule) -> Case {
        self.expected = Expected::SameAsCpu;
        self.rule = rule;
        self
    }

    pub fn scene(mut self, s: Arc<SceneBuffers>) -> Case {
        self.scene = Some(s);
        self
    }

    pub fn without_cpu(mut self) -> Case {
        self.cpu = false;
        self
    }

    /// The name, or one made from the call.
    pub fn display_name(&self) -> String {
        if !self.name.is_empty() {
            return self.name.clone();
        }
        let args: Vec<String> = self.inputs.iter().map(|(n, v)| format!("{n} = {}", v.text())).collect();
        format!("{}({})", self.function, args.join(", "))
    }
}

/// What became of one case.
#[derive(Clone, Debug)]
pub struct CaseResult {
    pub name: String,
    pub location: Option<String>,
    pub passed: bool,
    /// The device's result (None when the case did not run there).
    pub device: Option<Value>,
    /// The C++ build's result (None when not run).
    pub cpu: Option<Value>,
    /// Why it failed, for people: name, location, inputs, expected and actual
    /// values in decimal and hex, ULP distances. Empty when it passed.
    pub report: String,
}

impl CaseResult {
    /// `cone: sloped ray (tests/shaders/cone.toml:31)`.
    pub fn title(&self) -> String {
        match &self.location {
            Some(l) => format!("{} ({l})", self.name),
            None => self.name.clone(),
        }
    }
}

/// The closing lines of a run: how many failed and the first, then exactly
/// `N passed, M failed`.
pub fn summary(results: &[CaseResult]) -> String {
    let failed: Vec<&CaseResult> = results.iter().filter(|r| !r.passed).collect();
    let mut s = String::new();
    if let Some(first) = failed.first() {
        let _ = writeln!(s, "{} of {} cases failed; the first: {}", failed.len(), results.len(), first.title());
    }
    let _ = write!(s, "{} passed, {} failed", results.len() - failed.len(), failed.len());
    s
}

/// Where the harness runs cases.
#[derive(Clone, Debug)]
pub struct HarnessOptions {
    /// The folder with layout.h, scene_buffers.glsl and raycast.glsl under
    /// test (both the device and the C++ build); default: the source tree's shaders/.
    pub shaders: Option<PathBuf>,
    pub device: Option<DeviceSelector>,
    /// The Khronos validation layer; read its messages with `take_validation_messages`.
    pub validation: bool,
    /// The longest one run of a kernel (or of the C++ build's cases) may
    /// take (`GpuOptions::timeout`).
    pub timeout: std::time::Duration,
}

/// The source tree's shaders on the first device, without validation,
/// with a Vulkan context's default timeout (a derived default's zero
/// timed every case out).
impl Default for HarnessOptions {
    fn default() -> Self {
        HarnessOptions {
            shaders: None,
            device: None,
            validation: false,
            timeout: crate::gpu::GpuOptions::default().timeout,
        }
    }
}

/// A device, the shaders under test, and the kernels and C++ builds made so far.
pub struct Harness {
    // Field order is drop order: kernels before their device.
    kernels: HashMap<String, Result<Kernel, String>>,
    ctx: GpuContext,
    info: ShaderInfo,
    default_shaders: PathBuf,
    cpu_dir: PathBuf,
    libraries: Vec<CpuLibrary>,
    /// Function → index in `libraries`, or why its C++ build failed.
    cpu_built: HashMap<String, Result<usize, String>>,
    /// A copy of the shaders under test beside the generated kernels.
    work: PathBuf,
    /// The longest a run may take, on the device or in the C++ build.
    timeout: std::time::Duration,
}

impl Drop for Harness {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.work);
    }
}

/// The storage-buffer struct of the harness's input and output words.
fn word_layout() -> StructLayout {
    StructLayout { name: "HarnessWord", size: 4, fields: vec![FieldLayout { name: "value", offset: 0, size: 4 }] }
}

/// The bindings of every harness kernel, as the host expects them: the
/// scene's (`layout::scene_bindings`) and the harness's input and output words.
pub fn kernel_bindings() -> Vec<BindingLayout> {
    let mut b = layout::scene_bindings();
    b.push(BindingLayout::array(codegen::BINDING_IN, word_layout()));
    b.push(BindingLayout::array(codegen::BINDING_OUT, word_layout()).writable());
    b
}

/// A case made ready to run.
struct Prepared {
    function: Function,
    input: Vec<u32>,
    expected: Option<Vec<u32>>,
    /// One word list per scene buffer, in scene_buffers.glsl's order.
    scene: Vec<Vec<u32>>,
}

impl Harness {
    pub fn new(opts: &HarnessOptions) -> Result<Harness, Error> {
        let root = source_root();
        let default_shaders = root.join("shaders");
        let dir = opts.shaders.clone().unwrap_or_else(|| default_shaders.clone());
        let dir = dir.canonicalize().map_err(|e| format!("shaders folder {}: {e}", dir.display()))?;
        let info = ShaderInfo::load(&dir)?;

        static COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
        let work = std::env::temp_dir().join(format!(
            "raycast-harness-{}-{}",
            std::process::id(),
            COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
        ));
        // The exact kernels: the harness compares the GLSL's bits with the CPU build's.
        let ctx = GpuContext::new(&GpuOptions {
            device: opts.device.clone(),
            validation: opts.validation,
            timeout: opts.timeout,
            kernel: gpu::KernelChoice::Exact,
        })?;
        if let Err(e) = copy_shaders(&dir, &work) {
            let _ = std::fs::remove_dir_all(&work);
            return Err(Error::Failed(e));
        }
        Ok(Harness {
            kernels: HashMap::new(),
            ctx,
            info,
            default_shaders,
            cpu_dir: root.join("host/cpu"),
            libraries: Vec::new(),
            cpu_built: HashMap::new(),
            work,
            timeout: opts.timeout,
        })
    }

    /// The functions of the shaders under test.
    pub fn shaders(&self) -> &ShaderInfo {
        &self.info
    }

    /// How the kernels compile division and square root on this device.
    pub fn division(&self) -> gpu::Division {
        self.ctx.division()
    }

    pub fn device(&self) -> &gpu::DeviceInfo {
        self.ctx.info()
    }

    /// Validation-layer messages since the last call.
    pub fn take_validation_messages(&self) -> Vec<String> {
        self.ctx.take_validation_messages()
    }

    /// Runs every case; the results are in the order of `cases`. Cases of
    /// one function and one scene run in one dispatch (and one C++ call).
    pub fn run(&mut self, cases: &[Case]) -> Vec<CaseResult> {
        let prepared: Vec<Result<Prepared, String>> = cases.iter().map(|c| self.prepare(c)).collect();

        // Groups: one function, one scene.
        let mut groups: Vec<Vec<usize>> = Vec::new();
        let mut index: HashMap<(String, &Vec<Vec<u32>>), usize> = HashMap::new();
        for (i, p) in prepared.iter().enumerate() {
            if let Ok(p) = p {
                let g = *index.entry((p.function.key(), &p.scene)).or_insert_with(|| {
                    groups.push(Vec::new());
                    groups.len() - 1
                });
                groups[g].push(i);
            }
        }

        // Build what is missing: a kernel per function, one C++ library for all.
        let mut wanted_cpu: Vec<&Function> = Vec::new();
        for g in &groups {
            let p = prepared[g[0]].as_ref().expect("grouped cases are prepared");
            let key = p.function.key();
            if !self.kernels.contains_key(&key) {
                let k = self.build_kernel(&p.function);
                self.kernels.insert(key.clone(), k);
            }
            let needs_cpu = g.iter().any(|&i| cases[i].cpu);
            if needs_cpu && !self.cpu_built.contains_key(&key) && !wanted_cpu.iter().any(|f| f.key() == key) {
                wanted_cpu.push(&p.function);
            }
        }
        if !wanted_cpu.is_empty() {
            let built = CpuLibrary::build(&self.info, &self.cpu_dir, &self.default_shaders, &wanted_cpu);
            let entry = match built {
                Ok(lib) => {
                    self.libraries.push(lib);
                    Ok(self.libraries.len() - 1)
                }
                Err(e) => Err(e),
            };
            for f in &wanted_cpu {
                self.cpu_built.insert(f.key(), entry.clone());
            }
        }

        let mut device: Vec<Result<Vec<u32>, String>> = vec![Err(String::new()); cases.len()];
        let mut cpu: Vec<Option<Result<Vec<u32>, String>>> = vec![None; cases.len()];
        for g in &groups {
            let p0 = prepared[g[0]].as_ref().expect("grouped cases are prepared");
            let f = &p0.function;
            let stride = codegen::out_stride(f);
            let mut input = vec![g.len() as u32];
            for &i in g {
                input.extend_from_slice(&prepared[i].as_ref().expect("prepared").input);
            }
            let out_words = g.len() * stride;
            let split = |words: Vec<u32>| -> Vec<Vec<u32>> { words.chunks(stride).map(<[u32]>::to_vec).collect() };

            let gpu_out = self.run_device(f, &p0.scene, &input, out_words).map(split);
            // The C++ build runs only the cases that ask for it (`cpu = false`
            // keeps a case off it, in a batch too).
            let on_cpu: Vec<usize> = g.iter().copied().filter(|&i| cases[i].cpu).collect();
            let cpu_out = (!on_cpu.is_empty()).then(|| {
                let mut cpu_input = vec![on_cpu.len() as u32];
                for &i in &on_cpu {
                    cpu_input.extend_from_slice(&prepared[i].as_ref().expect("prepared").input);
                }
                let lib = self.cpu_built.get(&f.key()).cloned().unwrap_or_else(|| Err("not built".into()));
                let scene: Vec<&[u32]> = p0.scene.iter().map(Vec::as_slice).collect();
                let words = on_cpu.len() * stride;
                lib.and_then(|l| self.libraries[l].run(&f.key(), &scene, &cpu_input, words, self.timeout)).map(split)
            });
            for (k, &i) in g.iter().enumerate() {
                device[i] = gpu_out.as_ref().map(|o| o[k].clone()).map_err(Clone::clone);
            }
            if let Some(out) = &cpu_out {
                for (k, &i) in on_cpu.iter().enumerate() {
                    cpu[i] = Some(out.as_ref().map(|o| o[k].clone()).map_err(Clone::clone));
                }
            }
        }

        // A build's error shared by many cases (the one C++ library of every
        // function: its compiler's output, 150 lines) in full once, at the
        // first case it fails; the others name its first line.
        let mut told: std::collections::HashSet<String> = std::collections::HashSet::new();
        let mut once = |r: &mut Result<Vec<u32>, String>| {
            if let Err(e) = r {
                if e.lines().count() > 3 && !told.insert(e.clone()) {
                    let first = e.lines().next().unwrap_or_default().to_string();
                    *e = format!("{first} (its full output is in the report of the first case it failed, above)");
                }
            }
        };
        for i in 0..cases.len() {
            once(&mut device[i]);
            if let Some(c) = cpu[i].as_mut() {
                once(c);
            }
        }

        cases
            .iter()
            .enumerate()
            .map(|(i, case)| match &prepared[i] {
                Err(e) => CaseResult {
                    name: case.display_name(),
                    location: case.location.clone(),
                    passed: false,
                    device: None,
                    cpu: None,
                    report: format!("FAIL {}\n  error: {e}\n", title(case)),
                },
                Ok(p) => judge(case, p, &device[i], cpu[i].as_ref()),
            })
            .collect()
    }

    /// Checks a case against the function's signature and the scene
    /// buffers, and flattens it.
    fn prepare(&self, case: &Case) -> Result<Prepared, String> {
        // Among overloads, the one whose parameters the inputs name and fit.
        let f = self
            .info
            .function_where(&case.function, |f| {
                f.takes(case.inputs.len(), |p, ty| {
                    case.inputs.iter().any(|(n, v)| n == p && v.encode(ty, false).is_ok())
                })
            })?
            .clone();
        for (name, _) in &case.inputs {
            if !f.params.iter().any(|(p, _)| p == name) {
                return Err(format!("{} has no parameter {name:?}", f.signature()));
            }
        }
        let mut input = Vec::with_capacity(f.input_words());
        for (name, ty) in &f.params {
            let given: Vec<&Value> = case.inputs.iter().filter(|(n, _)| n == name).map(|(_, v)| v).collect();
            match given[..] {
                [v] => input.extend(v.encode(ty, false).map_err(|e| format!("input {name}: {e}"))?),
                [] => return Err(format!("input {name} of {} is missing", f.signature())),
                _ => return Err(format!("input {name} is given {} times", given.len())),
            }
        }
        let expected = match &case.expected {
            Expected::Value(v) => {
                Some(v.encode(&f.ret, false).map_err(|e| format!("expected {}: {e}", f.ret.glsl_name()))?)
            }
            Expected::SameAsCpu if !case.cpu => {
                return Err("\"same as CPU\" needs the C++ build, which this case turns off".into())
            }
            Expected::SameAsCpu => None,
        };
        let empty = SceneBuffers::default();
        let given = case.scene.as_deref().unwrap_or(&empty);
        for name in given.buffers.keys() {
            if !self.info.scene_buffers.iter().any(|b| &b.name == name) {
                let known: Vec<&str> = self.info.scene_buffers.iter().map(|b| b.name.as_str()).collect();
                return Err(format!(
                    "scene buffer {name:?} is not in scene_buffers.glsl (it has {})",
                    known.join(", ")
                ));
            }
        }
        let mut scene = Vec::new();
        for b in &self.info.scene_buffers {
            let size = Type::Struct(b.ty.clone()).words();
            let mut words = given.buffers.get(&b.name).cloned().unwrap_or_default();
            if words.len() % size != 0 || (!b.array && words.len() > size) {
                return Err(format!(
                    "scene buffer {}: {} words, not {} {} of {size} words",
                    b.name,
                    words.len(),
                    if b.array { "a whole number of" } else { "one" },
                    b.ty.name
                ));
            }
            if words.is_empty() {
                words = vec![0; size];
            }
            scene.push(words);
        }
        self.check_counts(given, &scene)?;
        Ok(Prepared { function: f, input, expected, scene })
    }

    /// The frame's counts against the arrays the scene gives: a count past
    /// its array (`primitive_count = 1000000` over one primitive) would have
    /// the C++ build read past it (a crash `CpuLibrary::run` contains) and
    /// the device read zeros, so it is the case's error, said up front.
    /// Indices inside the arrays (a node's first item, a material) are not
    /// checked here.
    fn check_counts(&self, given: &SceneBuffers, scene: &[Vec<u32>]) -> Result<(), String> {
        let at = |name: &str| self.info.scene_buffers.iter().position(|b| b.name == name);
        let member = |buffer: &str, member: &str| -> Option<u32> {
            let i = at(buffer)?;
            let mut offset = 0;
            for (name, ty) in &self.info.scene_buffers[i].ty.members {
                if name == member {
                    return scene[i].get(offset).copied();
                }
                offset += ty.words();
            }
            None
        };
        // The structs the scene gives (an array not given holds none).
        let held = |buffer: &str| -> u32 {
            let Some(i) = at(buffer) else { return 0 };
            let size = Type::Struct(self.info.scene_buffers[i].ty.clone()).words().max(1);
            given.buffers.get(buffer).map_or(0, |w| (w.len() / size) as u32)
        };
        for (count, buffer) in [("primitive_count", "primitives"), ("light_count", "lights"), ("node_count", "nodes")] {
            if let Some(n) = member("frame", count).filter(|&n| n > held(buffer)) {
                return Err(format!(
                    "scene: frame.{count} is {n}, but the scene gives {} {buffer}: the C++ build would read past them; \
                     give the count the array holds",
                    held(buffer)
                ));
            }
        }
        if let (Some(root), Some(nodes)) = (member("frame", "root_node"), member("frame", "node_count")) {
            if nodes > 0 && root >= nodes {
                return Err(format!("scene: frame.root_node is {root}, past the {nodes} nodes (frame.node_count)"));
            }
        }
        Ok(())
    }

    fn build_kernel(&self, f: &Function) -> Result<Kernel, String> {
        let spirv = compile_in(&self.work, &self.info.dir, f, self.ctx.division())?;
        Kernel::new(&self.ctx, &kernel_name(f), &spirv, &kernel_bindings()).map_err(|e| e.to_string())
    }

    fn run_device(
        &self,
        f: &Function,
        scene: &[Vec<u32>],
        input: &[u32],
        out_words: usize,
    ) -> Result<Vec<u32>, String> {
        let kernel = match self.kernels.get(&f.key()) {
            Some(Ok(k)) => k,
            Some(Err(e)) => return Err(e.clone()),
            None => return Err(format!("no kernel for {}", f.name)),
        };
        let scene_bytes: Vec<&[u8]> = scene.iter().map(|w| bytemuck::cast_slice(w.as_slice())).collect();
        let mut inputs: Vec<(u32, &[u8])> =
            self.info.scene_buffers.iter().zip(&scene_bytes).map(|(b, bytes)| (b.binding, *bytes)).collect();
        inputs.push((codegen::BINDING_IN, bytemuck::cast_slice(input)));
        let cases = input[0];
        let (bytes, _) = self
            .ctx
            .run(
                kernel,
                &inputs,
                (codegen::BINDING_OUT, out_words * 4),
                codegen::SENTINEL,
                [cases.div_ceil(codegen::GROUP), 1, 1],
            )
            .map_err(|e| e.to_string())?;
        Ok(bytes.chunks_exact(4).map(|c| u32::from_le_bytes([c[0], c[1], c[2], c[3]])).collect())
    }
}

/// `harness_trace__Ray_float_bool`: the kernel of function `f` (its overload), in messages.
pub fn kernel_name(f: &Function) -> String {
    format!("harness_{}", f.key())
}

/// Copies the .h and .glsl files of `from` into `to`, where the generated
/// kernels are written beside them.
fn copy_shaders(from: &Path, to: &Path) -> Result<(), String> {
    std::fs::create_dir_all(to).map_err(|e| format!("cannot create {}: {e}", to.display()))?;
    for entry in std::fs::read_dir(from).map_err(|e| format!("cannot read {}: {e}", from.display()))? {
        let path = entry.map_err(|e| e.to_string())?.path();
        if matches!(path.extension().and_then(|e| e.to_str()), Some("h" | "glsl")) {
            let dest = to.join(path.file_name().unwrap_or_default());
            std::fs::copy(&path, &dest).map_err(|e| format!("cannot copy {}: {e}", path.display()))?;
        }
    }
    Ok(())
}

/// Generates the kernel of `f` in `work` (a copy of `real_dir`) and compiles
/// it with glslang. Messages name the files of `real_dir`.
fn compile_in(work: &Path, real_dir: &Path, f: &Function, division: gpu::Division) -> Result<Vec<u8>, String> {
    let src = work.join(format!("{}.comp", kernel_name(f)));
    std::fs::write(&src, codegen::kernel_source(f)).map_err(|e| format!("cannot write {}: {e}", src.display()))?;
    gpu::compile_kernel(&src, division).map_err(|e| {
        let mut msg = e;
        // Every file copy_shaders copied: layout.h, scene_buffers.glsl,
        // raycast.glsl and the files it includes.
        let copied = std::fs::read_dir(real_dir).into_iter().flatten().filter_map(|e| e.ok().map(|e| e.file_name()));
        for file in copied.filter(|f| matches!(Path::new(f).extension().and_then(|e| e.to_str()), Some("h" | "glsl"))) {
            msg = msg.replace(&work.join(&file).display().to_string(), &real_dir.join(&file).display().to_string());
        }
        format!("the kernel for {} did not compile:\n{msg}", f.signature())
    })
}

/// The SPIR-V of the harness kernel for `f`, a function of the shaders in
/// `shaders`, without a device: for checking every generated kernel with
/// naga (`gpu::reflect::check_layouts` against [`kernel_bindings`]).
pub fn kernel_spirv(shaders: &Path, f: &Function) -> Result<Vec<u8>, String> {
    static COUNTER: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let work = std::env::temp_dir().join(format!(
        "raycast-harness-spirv-{}-{}",
        std::process::id(),
        COUNTER.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    let result = copy_shaders(shaders, &work).and_then(|()| compile_in(&work, shaders, f, gpu::Division::AsGiven));
    let _ = std::fs::remove_dir_all(&work);
    result
}

fn title(case: &Case) -> String {
    match &case.location {
        Some(l) => format!("{} ({l})", case.display_name()),
        None => case.display_name(),
    }
}

/// Compares one case's results and writes the report of a failure.
fn judge(
    case: &Case,
    p: &Prepared,
    device: &Result<Vec<u32>, String>,
    cpu: Option<&Result<Vec<u32>, String>>,
) -> CaseResult {
    let f = &p.function;
    let leaves = f.ret.leaves();
    let mut problems: Vec<String> = Vec::new();
    let mut result = CaseResult {
        name: case.display_name(),
        location: case.location.clone(),
        passed: false,
        device: None,
        cpu: None,
        report: String::new(),
    };

    // A run's words: the written word first, then the result.
    let mut results = |what: &str, r: &Result<Vec<u32>, String>| -> Option<Vec<u32>> {
        match r {
            Err(e) => {
                problems.push(format!("{what}: {e}"));
                None
            }
            Ok(w) if w.first() != Some(&codegen::WRITTEN) => {
                problems.push(format!(
                    "{what}: the case was never written (its written word is {}, the sentinel is 0x{:08x})",
                    word_text(Scalar::Uint, w.first().copied().unwrap_or(codegen::SENTINEL)),
                    codegen::SENTINEL
                ));
                None
            }
            Ok(w) => Some(w[1..].to_vec()),
        }
    };
    let dev = results("device", device);
    let host = cpu.and_then(|c| results("cpu", c));
    result.device = dev.as_ref().map(|w| Value::decode(&f.ret, w));
    result.cpu = host.as_ref().map(|w| Value::decode(&f.ret, w));

    // (label, rule, reference, actual) comparisons, word by word.
    let word_ok = |rule: Rule, s: Scalar, e: u32, a: u32| match s {
        Scalar::Float => rule.float_ok(f32::from_bits(e), f32::from_bits(a)),
        _ => e == a,
    };
    let reference: Option<&Vec<u32>> = p.expected.as_ref().or(host.as_ref());
    let mut bad = vec![Vec::<&str>::new(); leaves.len()];
    let mut check = |what: &'static str, rule: Rule, e: Option<&Vec<u32>>, a: Option<&Vec<u32>>| {
        if let (Some(e), Some(a)) = (e, a) {
            for (k, leaf) in leaves.iter().enumerate() {
                if !word_ok(rule, leaf.scalar, e[k], a[k]) {
                    bad[k].push(what);
                }
            }
        }
    };
    match (&p.expected, host.is_some()) {
        (Some(_), _) => {
            check("device", case.rule, p.expected.as_ref(), dev.as_ref());
            check("cpu", case.rule, p.expected.as_ref(), host.as_ref());
            check("device≠cpu", Rule::Exact, host.as_ref(), dev.as_ref());
        }
        (None, _) => check("device", case.rule, host.as_ref(), dev.as_ref()),
    }
    let mismatches = bad.iter().filter(|b| !b.is_empty()).count();
    result.passed = problems.is_empty() && mismatches == 0;
    if result.passed {
        return result;
    }

    // The report.
    let mut r = String::new();
    let _ = writeln!(r, "FAIL {}", title(case));
    let _ = writeln!(r, "  function: {}", f.signature());
    let mut input_words = p.input.iter().copied();
    let mut first = true;
    for (name, ty) in &f.params {
        let words: Vec<u32> = input_words.by_ref().take(ty.words()).collect();
        for line in value_lines(name, ty, &words) {
            let _ = writeln!(r, "  {} {line}", if first { "inputs:  " } else { "         " });
            first = false;
        }
    }
    if f.params.is_empty() {
        let _ = writeln!(r, "  inputs:   (none)");
    }
    let how = match (&p.expected, case.cpu) {
        (Some(_), true) => format!("{} (device and cpu against expected; device against cpu bit for bit)", case.rule),
        (Some(_), false) => format!("{} (device against expected)", case.rule),
        (None, _) => format!("{} (device against cpu, \"same as CPU\")", case.rule),
    };
    let _ = writeln!(r, "  rule:     {how}");
    for p in &problems {
        let _ = writeln!(r, "  error:    {p}");
    }
    if dev.is_some() || host.is_some() {
        let show = |w: Option<&Vec<u32>>, k: usize, s: Scalar| w.map_or("-".to_string(), |w| word_text(s, w[k]));
        let mut rows = vec![[
            "result".to_string(),
            if p.expected.is_some() { "expected" } else { "expected (cpu)" }.to_string(),
            "device".to_string(),
            "cpu".to_string(),
            "ulp".to_string(),
            String::new(),
        ]];
        for (k, leaf) in leaves.iter().enumerate() {
            let ulp = match (leaf.scalar, reference, dev.as_ref()) {
                (Scalar::Float, Some(e), Some(a)) => match ulp_distance(f32::from_bits(e[k]), f32::from_bits(a[k])) {
                    u64::MAX => "nan".to_string(),
                    d => d.to_string(),
                },
                _ => "-".to_string(),
            };
            let mark = if bad[k].is_empty() { String::new() } else { format!("<< {}", bad[k].join(", ")) };
            let sentinel = dev.as_ref().is_some_and(|d| d[k] == codegen::SENTINEL);
            rows.push([
                if leaf.label.is_empty() { "value".to_string() } else { leaf.label.clone() },
                show(reference, k, leaf.scalar),
                format!("{}{}", show(dev.as_ref(), k, leaf.scalar), if sentinel { " =sentinel" } else { "" }),
                show(host.as_ref(), k, leaf.scalar),
                ulp,
                mark,
            ]);
        }
        let widths: Vec<usize> =
            (0..6).map(|c| rows.iter().map(|row| row[c].chars().count()).max().unwrap_or(0)).collect();
        for row in &rows {
            let mut line = String::from("   ");
            for (c, cell) in row.iter().enumerate() {
                let _ = write!(line, " {cell:<w$}", w = widths[c]);
            }
            let _ = writeln!(r, "{}", line.trim_end());
        }
        let _ = writeln!(
            r,
            "  {mismatches} of {} result words differ (ulp: device against {})",
            leaves.len(),
            if p.expected.is_some() { "expected" } else { "cpu" }
        );
    }
    result.report = r;
    result
}

/// `name = (1, 0.5, 0) [0x3f800000 0x3f000000 0x00000000]`, a line per
/// vector or scalar, structs member by member.
fn value_lines(name: &str, ty: &Type, words: &[u32]) -> Vec<String> {
    match ty {
        Type::Struct(def) => {
            let mut out = Vec::new();
            let mut at = 0;
            for (m, t) in &def.members {
                let n = t.words();
                out.extend(value_lines(&format!("{name}.{m}"), t, &words[at..at + n]));
                at += n;
            }
            out
        }
        Type::Scalar(s) => vec![format!("{name} = {}", word_text(*s, words[0]))],
        _ => {
            let v = Value::decode(ty, words);
            let hex: Vec<String> = words.iter().map(|w| format!("0x{w:08x}")).collect();
            vec![format!("{name} = {} [{}]", v.text(), hex.join(" "))]
        }
    }
}

#[cfg(test)]
mod tests;
