//! naga reflection of compiled kernels: validates the SPIR-V and checks its
//! storage buffers, field by field, against the host's `BindingLayout`s.

use std::collections::{BTreeMap, BTreeSet};

use naga::{AddressSpace, ArraySize, Handle, Module, ShaderStage, StorageAccess, Type, TypeInner};

use super::spirv::{
    self, instructions, BUILT_IN_LOCAL_INVOCATION_INDEX, BUILT_IN_NUM_SUBGROUPS, BUILT_IN_SUBGROUP_ID,
    BUILT_IN_SUBGROUP_LOCAL_INVOCATION_ID, BUILT_IN_SUBGROUP_SIZE, CLASS_STORAGE_BUFFER, CLASS_UNIFORM, DEC_BINDING,
    DEC_BUILT_IN, DEC_NON_READABLE, DEC_NON_WRITABLE, DEC_SET, OP_CONSTANT_NULL, OP_COPY_OBJECT, OP_DECORATE,
    OP_FUNCTION, OP_GROUP_NON_UNIFORM_FIRST, OP_GROUP_NON_UNIFORM_LAST, OP_MEMBER_DECORATE, OP_TYPE_POINTER,
    OP_TYPE_STRUCT, OP_VARIABLE,
};
use super::{GpuError, ImageBinding};
use crate::layout::{BindingLayout, BufferShape, StructLayout};

/// Where the host's layouts live, named in every host-vs-shader mismatch.
const HOST_FILE: &str = "host/src/layout.rs";

/// What the host needs to know about a validated kernel.
#[derive(Clone, Debug)]
pub(crate) struct Reflection {
    pub workgroup_size: [u32; 3],
}

/// Validates `spirv` with naga and checks its bindings and struct layouts
/// against `expected`; every mismatch is listed in one error.
pub fn check_layouts(name: &str, spirv: &[u8], expected: &[BindingLayout]) -> Result<(), GpuError> {
    reflect(name, spirv, expected, &[]).map(|_| ())
}

/// [`check_layouts`] for a kernel that also has storage images (`images`).
pub fn check_layouts_with_images(
    name: &str,
    spirv: &[u8],
    expected: &[BindingLayout],
    images: &[ImageBinding],
) -> Result<(), GpuError> {
    reflect(name, spirv, expected, images).map(|_| ())
}

/// [`check_layouts_with_images`], returning the kernel's workgroup size.
pub(crate) fn reflect(
    name: &str,
    spirv: &[u8],
    expected: &[BindingLayout],
    images: &[ImageBinding],
) -> Result<Reflection, GpuError> {
    let invalid = |message: String| GpuError::InvalidSpirv { kernel: name.to_string(), message };
    let options = naga::front::spv::Options {
        adjust_coordinate_space: false,
        strict_capabilities: false,
        block_ctx_dump_prefix: None,
    };
    // naga's reader has panicked on valid SPIR-V (see for_naga): a kernel
    // edit it cannot read is an error, not a crash.
    let parsed = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
        naga::front::spv::parse_u8_slice(&for_naga(spirv), &options)
    }));
    let module = match parsed {
        Ok(parsed) => parsed.map_err(|e| invalid(error_chain(&e)))?,
        Err(_) => {
            return Err(invalid("naga's SPIR-V reader panicked on it (a naga bug; its message is above)".to_string()))
        }
    };
    naga::valid::Validator::new(naga::valid::ValidationFlags::all(), naga::valid::Capabilities::all())
        .validate(&module)
        .map_err(|e| {
            // naga names a clash by its handles ("Bindings for [4] conflict"): the resources, by name.
            let clashes = binding_clashes(&module);
            let said = if clashes.is_empty() { String::new() } else { format!(" ({})", clashes.join("; ")) };
            invalid(format!("{}{said}", error_chain(e.as_inner())))
        })?;
    let entry = module
        .entry_points
        .iter()
        .find(|e| e.name == "main" && e.stage == ShaderStage::Compute)
        .ok_or_else(|| invalid("it has no compute entry point named \"main\"".to_string()))?;
    let workgroup_size = entry.workgroup_size;

    let access = spirv_storage_access(spirv);
    let mismatches = Checker { kernel: name, module: &module, access: &access, images }.check(expected);
    if mismatches.is_empty() {
        Ok(Reflection { workgroup_size })
    } else {
        Err(GpuError::LayoutMismatch { kernel: name.to_string(), mismatches })
    }
}

/// The resources the module declares at one (set, binding), each with the
/// others there: `binding 0 holds FrameBlock and primitive_texels`.
fn binding_clashes(module: &naga::Module) -> Vec<String> {
    let mut at: BTreeMap<(u32, u32), Vec<String>> = BTreeMap::new();
    for (_, var) in module.global_variables.iter() {
        let Some(b) = &var.binding else { continue };
        // A block without an instance name is known by its type's (FrameBlock).
        let name = var.name.clone().filter(|n| !n.is_empty()).or_else(|| module.types[var.ty].name.clone());
        at.entry((b.group, b.binding)).or_default().push(name.unwrap_or_else(|| "an unnamed resource".to_string()));
    }
    at.into_iter()
        .filter(|(_, names)| names.len() > 1)
        .map(|((set, binding), names)| {
            let set = if set == 0 { String::new() } else { format!("set {set} ") };
            format!("{set}binding {binding} holds {}", names.join(" and "))
        })
        .collect()
}

/// An error and its `source()` chain on one line.
fn error_chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(": ");
        text.push_str(&s.to_string());
        source = s.source();
    }
    text
}

/// `Frame` or `Primitive[]`: how a binding is named in messages.
pub(crate) fn shape_label(shape: &BufferShape) -> String {
    match shape {
        BufferShape::Single(s) => s.name.to_string(),
        BufferShape::RuntimeArray(s) => format!("{}[]", s.name),
        BufferShape::UniformSingle(s) => format!("uniform {}", s.name),
    }
}

/// Whether a variable of this storage class is a buffer (uniform or storage block).
fn buffer_class(class: u32) -> bool {
    class == CLASS_STORAGE_BUFFER || class == CLASS_UNIFORM
}

/// The module as naga is given it, which its reflection needs and the
/// driver never sees (the driver gets the module unchanged):
/// - without the `NonReadable` decoration of buffer variables. glslang 15
///   (Debian 13) puts it on a `writeonly buffer`'s variable, where glslang
///   11 (Debian 12) put it on the members only, and naga's spv-in turns it
///   into a store-only storage access that its validator refuses (WGSL has
///   no write-only buffers). The access check reads it from the SPIR-V
///   itself ([`spirv_storage_access`]);
/// - with a copy of a null constant of its type for each subgroup
///   operation (a kernel edit's: `--shaders`, `--versus`): naga 30's spv-in
///   panics on a subgroup operation whose operand comes from a loop
///   (gfx-rs/wgpu#8389), and what a subgroup computes is nothing the
///   layout check reads;
/// - with the subgroup's id and a lane's id in it as other builtins of
///   their type, which naga refuses in a workgroup of more than one
///   dimension (the kernels' 8x8).
fn for_naga(spirv: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    let Some(words) = spirv::words(spirv) else { return spirv.into() };
    let buffers: BTreeSet<u32> = instructions(&words)
        .filter_map(|(_, op, ops)| match (op, ops) {
            (OP_VARIABLE, [_, id, class, ..]) if buffer_class(*class) => Some(*id),
            _ => None,
        })
        .collect();
    // A null constant of each subgroup operation's result type, new ids
    // from the module's bound on (naga reads an OpUndef in a function
    // body into an expression its validator then refuses).
    let mut bound = words.get(3).copied().unwrap_or(0);
    let mut nulls = BTreeMap::<u32, u32>::new();
    for (_, op, ops) in instructions(&words) {
        if let (OP_GROUP_NON_UNIFORM_FIRST..=OP_GROUP_NON_UNIFORM_LAST, [ty, ..]) = (op, ops) {
            nulls.entry(*ty).or_insert_with(|| {
                bound += 1;
                bound - 1
            });
        }
    }
    // Builtins naga refuses in a workgroup of more than one dimension
    // (WGSL's rule, not Vulkan's): each in a u32 builtin the module leaves
    // unused, as the layout check never reads them.
    let builtins: BTreeSet<u32> = instructions(&words)
        .filter_map(|(_, op, ops)| match (op, ops) {
            (OP_DECORATE, [_, DEC_BUILT_IN, b]) => Some(*b),
            _ => None,
        })
        .collect();
    let mut spare = [BUILT_IN_NUM_SUBGROUPS, BUILT_IN_SUBGROUP_SIZE, BUILT_IN_LOCAL_INVOCATION_INDEX]
        .into_iter()
        .filter(|b| !builtins.contains(b));
    let renamed: BTreeMap<u32, u32> = [BUILT_IN_SUBGROUP_ID, BUILT_IN_SUBGROUP_LOCAL_INVOCATION_ID]
        .into_iter()
        .filter(|b| builtins.contains(b))
        .filter_map(|b| Some((b, spare.next()?)))
        .collect();
    let first_function = instructions(&words).find(|(_, op, _)| *op == OP_FUNCTION).map(|(at, _, _)| at);
    // Each changed instruction: where it starts and ends, and what takes its place.
    let mut changed: Vec<(usize, usize, Vec<u32>)> = instructions(&words)
        .filter_map(|(at, op, ops)| {
            let end = at + 1 + ops.len();
            match (op, ops) {
                (OP_DECORATE, [target, DEC_NON_READABLE]) if buffers.contains(target) => Some((at, end, vec![])),
                (OP_DECORATE, [target, DEC_BUILT_IN, b]) if renamed.contains_key(b) => {
                    Some((at, end, vec![words[at], *target, DEC_BUILT_IN, renamed[b]]))
                }
                (OP_GROUP_NON_UNIFORM_FIRST..=OP_GROUP_NON_UNIFORM_LAST, [ty, id, ..]) => {
                    Some((at, end, vec![(4 << 16) | OP_COPY_OBJECT, *ty, *id, nulls[ty]]))
                }
                _ => None,
            }
        })
        .collect();
    if changed.is_empty() {
        return spirv.into();
    }
    if let Some(at) = first_function.filter(|_| !nulls.is_empty()) {
        let constants = nulls.iter().flat_map(|(ty, id)| [(3 << 16) | OP_CONSTANT_NULL, *ty, *id]).collect();
        changed.push((at, at, constants));
        changed.sort_by_key(|c| c.0);
    }
    let mut kept: Vec<u32> = Vec::with_capacity(words.len() + 3 * nulls.len());
    let mut from = 0;
    for (start, end, instead) in changed {
        kept.extend_from_slice(&words[from..start]);
        kept.extend(instead);
        from = end;
    }
    kept.extend_from_slice(&words[from..]);
    if let Some(b) = kept.get_mut(3) {
        *b = bound;
    }
    kept.iter().flat_map(|w| w.to_le_bytes()).collect::<Vec<u8>>().into()
}

/// Access of each storage buffer `(set, binding)`, read from the SPIR-V decorations.
///
/// naga's spv-in drops the member-level `NonWritable`/`NonReadable` that
/// glslang puts on `readonly`/`writeonly` blocks when the block is a
/// SPIR-V 1.3 `Block` in the StorageBuffer class (Vulkan 1.1 targets), so
/// every such buffer looks read-write (gfx-rs/wgpu#4916). As naga intends:
/// the members' access ORed together, ANDed with the variable's.
fn spirv_storage_access(spirv: &[u8]) -> BTreeMap<(u32, u32), StorageAccess> {
    let mut out = BTreeMap::new();
    let Some(words) = spirv::words(spirv) else { return out };

    let denied = |dec: u32| match dec {
        DEC_NON_WRITABLE => StorageAccess::STORE,
        DEC_NON_READABLE => StorageAccess::LOAD,
        _ => StorageAccess::empty(),
    };
    let all = StorageAccess::LOAD | StorageAccess::STORE;
    let mut member_denied: BTreeMap<(u32, u32), StorageAccess> = BTreeMap::new();
    let mut var_denied: BTreeMap<u32, StorageAccess> = BTreeMap::new();
    let mut binding: BTreeMap<u32, u32> = BTreeMap::new();
    let mut set: BTreeMap<u32, u32> = BTreeMap::new();
    let mut member_count: BTreeMap<u32, u32> = BTreeMap::new();
    let mut pointee: BTreeMap<u32, u32> = BTreeMap::new();
    let mut variables = Vec::new();
    for (_, op, ops) in instructions(&words) {
        match (op, ops) {
            (OP_DECORATE, [target, DEC_BINDING, b, ..]) => _ = binding.insert(*target, *b),
            (OP_DECORATE, [target, DEC_SET, s, ..]) => _ = set.insert(*target, *s),
            (OP_DECORATE, [target, dec, ..]) => *var_denied.entry(*target).or_default() |= denied(*dec),
            (OP_MEMBER_DECORATE, [ty, member, dec, ..]) => {
                *member_denied.entry((*ty, *member)).or_default() |= denied(*dec)
            }
            (OP_TYPE_STRUCT, [id, members @ ..]) => _ = member_count.insert(*id, members.len() as u32),
            (OP_TYPE_POINTER, [id, _class, ty]) => _ = pointee.insert(*id, *ty),
            (OP_VARIABLE, [ptr, id, class, ..]) if buffer_class(*class) => variables.push((*ptr, *id)),
            _ => {}
        }
    }
    for (ptr, var) in variables {
        let (Some(&b), Some(&block)) = (binding.get(&var), pointee.get(&ptr)) else { continue };
        let members = member_count.get(&block).copied().unwrap_or(0);
        let mut access = if members == 0 { all } else { StorageAccess::empty() };
        for m in 0..members {
            access |= all - member_denied.get(&(block, m)).copied().unwrap_or_default();
        }
        access &= all - var_denied.get(&var).copied().unwrap_or_default();
        out.insert((set.get(&var).copied().unwrap_or(0), b), access);
    }
    out
}

struct Checker<'a> {
    kernel: &'a str,
    module: &'a Module,
    /// Storage access by `(set, binding)` from [`spirv_storage_access`].
    access: &'a BTreeMap<(u32, u32), StorageAccess>,
    /// Bindings the host expects to be 2D storage images.
    images: &'a [ImageBinding],
}

impl Checker<'_> {
    /// Every mismatch, ordered by binding number.
    fn check(&self, expected: &[BindingLayout]) -> Vec<String> {
        let mut out: Vec<(u32, String)> = Vec::new();
        let kernel = self.kernel;
        let by_binding: BTreeMap<u32, &BindingLayout> = expected.iter().map(|b| (b.binding, b)).collect();
        if by_binding.len() != expected.len() {
            out.push((0, format!("kernel {kernel}: the host lists a binding number twice ({HOST_FILE})")));
        }

        let mut seen = BTreeMap::new();
        for (_, var) in self.module.global_variables.iter() {
            let Some(rb) = &var.binding else { continue };
            // glslang names an anonymous block's variable ""; the block type has the name.
            let var_name = var
                .name
                .clone()
                .filter(|n| !n.is_empty())
                .or_else(|| self.module.types[var.ty].name.clone())
                .unwrap_or_else(|| "?".into());
            if let (AddressSpace::Handle, Some(image)) =
                (var.space, self.images.iter().find(|i| i.binding == rb.binding && rb.group == 0))
            {
                seen.insert(rb.binding, ());
                if let Some(line) = self.check_image(image, var.ty) {
                    out.push((rb.binding, line));
                }
                continue;
            }
            let access = match var.space {
                AddressSpace::Storage { access } => {
                    access & self.access.get(&(rb.group, rb.binding)).copied().unwrap_or(access)
                }
                // Uniform buffers are read-only.
                AddressSpace::Uniform => StorageAccess::LOAD,
                other => {
                    out.push((
                        rb.binding,
                        format!(
                            "kernel {kernel}: binding {} ({var_name}) is a {} in the shader; only storage and \
                         uniform buffers are supported",
                            rb.binding,
                            space_name(other)
                        ),
                    ));
                    continue;
                }
            };
            if rb.group != 0 {
                out.push((
                    rb.binding,
                    format!(
                        "kernel {kernel}: binding {} ({var_name}) is in descriptor set {} in the shader; every \
                     binding must be in set 0",
                        rb.binding, rb.group
                    ),
                ));
                continue;
            }
            seen.insert(rb.binding, ());
            match by_binding.get(&rb.binding) {
                Some(exp) if exp.shape.is_uniform() != (var.space == AddressSpace::Uniform) => {
                    out.push((rb.binding, format!(
                        "kernel {kernel}: binding {} ({var_name}) is a {} in the shader, a {} on the host ({HOST_FILE})",
                        rb.binding,
                        if var.space == AddressSpace::Uniform { "uniform buffer" } else { "storage buffer" },
                        if exp.shape.is_uniform() { "uniform buffer" } else { "storage buffer" },
                    )));
                }
                Some(exp) => {
                    let mut lines = Vec::new();
                    self.check_binding(exp, var.ty, access, &mut lines);
                    out.extend(lines.into_iter().map(|l| (rb.binding, l)));
                }
                None => out.push((
                    rb.binding,
                    format!(
                        "kernel {kernel}: binding {} ({}) is declared in the shader but not on the host ({HOST_FILE})",
                        rb.binding,
                        self.block_label(var.ty).unwrap_or(var_name)
                    ),
                )),
            }
        }
        for image in self.images {
            if by_binding.contains_key(&image.binding) {
                out.push((
                    image.binding,
                    format!(
                        "kernel {kernel}: binding {} is listed as both a buffer and an image on the host",
                        image.binding
                    ),
                ));
            } else if !seen.contains_key(&image.binding) {
                out.push((
                    image.binding,
                    format!(
                        "kernel {kernel}: binding {} (storage image) is expected by the host but not declared in \
                     the shader (as `{}`)",
                        image.binding,
                        image.format.glsl()
                    ),
                ));
            }
        }
        for exp in expected {
            if !seen.contains_key(&exp.binding) {
                out.push((
                    exp.binding,
                    format!(
                        "kernel {kernel}: binding {} ({}) is expected by the host ({HOST_FILE}) but not declared \
                     in the shader",
                        exp.binding,
                        shape_label(&exp.shape)
                    ),
                ));
            }
        }
        out.sort_by_key(|(binding, _)| *binding);
        out.into_iter().map(|(_, line)| line).collect()
    }

    /// The mismatch, if any, of a storage image binding: a 2D, non-arrayed
    /// storage image of the host's format, writable exactly when the host
    /// says so.
    fn check_image(&self, exp: &ImageBinding, ty: Handle<Type>) -> Option<String> {
        let at = format!("kernel {}: binding {} (storage image)", self.kernel, exp.binding);
        match &self.module.types[ty].inner {
            TypeInner::Image {
                dim: naga::ImageDimension::D2,
                arrayed: false,
                class: naga::ImageClass::Storage { format, access },
            } if *format == exp.format.naga() => {
                let writable = access.contains(StorageAccess::STORE);
                (writable != exp.writable).then(|| {
                    format!(
                        "{at}: {} in the shader, {} on the host",
                        if writable { "writable" } else { "read-only" },
                        if exp.writable { "writable" } else { "read-only" }
                    )
                })
            }
            other => Some(format!("{at}: the shader declares {other:?}; expected `{}`", exp.format.glsl())),
        }
    }

    /// `Foo[]` / `Foo` for the shader's block type, when it has the expected form.
    fn block_label(&self, block: Handle<Type>) -> Option<String> {
        let TypeInner::Struct { members, .. } = &self.module.types[block].inner else { return None };
        let member = members.first()?;
        match &self.module.types[member.ty].inner {
            TypeInner::Array { base, size: ArraySize::Dynamic, .. } => Some(format!("{}[]", self.type_name(*base))),
            _ => Some(self.type_name(member.ty)),
        }
    }

    fn type_name(&self, ty: Handle<Type>) -> String {
        self.module.types[ty].name.clone().unwrap_or_else(|| self.describe(ty))
    }

    /// A short description of a shader type for messages.
    fn describe(&self, ty: Handle<Type>) -> String {
        let t = &self.module.types[ty];
        match &t.inner {
            TypeInner::Struct { .. } => format!("struct {}", t.name.as_deref().unwrap_or("(unnamed)")),
            TypeInner::Array { base, size: ArraySize::Dynamic, .. } => {
                format!("runtime-sized array of {}", self.describe(*base))
            }
            TypeInner::Array { base, size: ArraySize::Constant(n), .. } => {
                format!("array of {n} {}", self.describe(*base))
            }
            TypeInner::Array { base, .. } => format!("array of {}", self.describe(*base)),
            TypeInner::Scalar(s) => format!("{:?}{}", s.kind, s.width * 8).to_lowercase(),
            TypeInner::Vector { size, scalar } => {
                format!("vec{} of {:?}{}", *size as u8, scalar.kind, scalar.width * 8).to_lowercase()
            }
            TypeInner::Matrix { columns, rows, .. } => format!("mat{}x{}", *columns as u8, *rows as u8),
            other => format!("{other:?}"),
        }
    }

    fn check_binding(&self, exp: &BindingLayout, block: Handle<Type>, access: StorageAccess, out: &mut Vec<String>) {
        let at = format!("kernel {}: binding {} ({})", self.kernel, exp.binding, shape_label(&exp.shape));
        let writable = access.contains(StorageAccess::STORE);
        if writable != exp.writable {
            out.push(if writable {
                format!(
                    "{at}: writable in the shader, read-only on the host; declare it readonly in the \
                         shader or set writable: true ({HOST_FILE})"
                )
            } else {
                format!(
                    "{at}: read-only in the shader, writable on the host; drop readonly in the shader \
                         or set writable: false ({HOST_FILE})"
                )
            });
        }

        let TypeInner::Struct { members, .. } = &self.module.types[block].inner else {
            out.push(format!("{at}: the shader declares a {}, not a buffer block", self.describe(block)));
            return;
        };
        if members.len() != 1 {
            out.push(format!(
                "{at}: the buffer block has {} members in the shader; the host expects exactly one",
                members.len()
            ));
            return;
        }
        let member_ty = members[0].ty;
        match (&exp.shape, &self.module.types[member_ty].inner) {
            (BufferShape::Single(s) | BufferShape::UniformSingle(s), TypeInner::Struct { .. }) => {
                self.check_struct(&at, s, member_ty, out)
            }
            (BufferShape::RuntimeArray(s), &TypeInner::Array { base, size: ArraySize::Dynamic, stride })
                if matches!(self.module.types[base].inner, TypeInner::Struct { .. }) =>
            {
                if stride != s.size {
                    out.push(format!(
                        "{at}: array stride {stride} in the shader, {} on the host ({HOST_FILE})",
                        s.size
                    ));
                }
                self.check_struct(&at, s, base, out);
            }
            (BufferShape::Single(s) | BufferShape::UniformSingle(s), _) => out.push(format!(
                "{at}: the block's member is a {} in the shader, a single struct {} on the host ({HOST_FILE})",
                self.describe(member_ty),
                s.name
            )),
            (BufferShape::RuntimeArray(s), _) => out.push(format!(
                "{at}: the block's member is a {} in the shader, a runtime-sized array of struct {} on the \
                 host ({HOST_FILE})",
                self.describe(member_ty),
                s.name
            )),
        }
    }

    fn check_struct(&self, at: &str, exp: &StructLayout, ty: Handle<Type>, out: &mut Vec<String>) {
        let t = &self.module.types[ty];
        let TypeInner::Struct { members, span } = &t.inner else { return };
        let shader_name = t.name.as_deref().unwrap_or("(unnamed)");
        if shader_name != exp.name {
            out.push(format!(
                "{at}: the struct is named {shader_name:?} in the shader, {:?} on the host ({HOST_FILE})",
                exp.name
            ));
        }
        if *span != exp.size {
            out.push(format!("{at}: struct size {span} in the shader, {} on the host ({HOST_FILE})", exp.size));
        }
        let gctx = self.module.to_ctx();
        for field in &exp.fields {
            let Some(m) = members.iter().find(|m| m.name.as_deref() == Some(field.name)) else {
                out.push(format!("{at}: member {:?} is on the host but not in the shader ({HOST_FILE})", field.name));
                continue;
            };
            if m.offset != field.offset {
                out.push(format!(
                    "{at}: member {:?}: offset {} in the shader, {} on the host ({HOST_FILE})",
                    field.name, m.offset, field.offset
                ));
            }
            match self.module.types[m.ty].inner.try_size(gctx) {
                Some(size) if size == field.size => {}
                Some(size) => out.push(format!(
                    "{at}: member {:?}: size {size} in the shader, {} on the host ({HOST_FILE})",
                    field.name, field.size
                )),
                None => out.push(format!("{at}: member {:?}: naga cannot size its type", field.name)),
            }
        }
        for m in members {
            let name = m.name.as_deref().unwrap_or("(unnamed)");
            if !exp.fields.iter().any(|f| f.name == name) {
                out.push(format!(
                    "{at}: member {name:?} (offset {}) is in the shader but not on the host ({HOST_FILE})",
                    m.offset
                ));
            }
        }
    }
}

fn space_name(space: AddressSpace) -> &'static str {
    match space {
        AddressSpace::Uniform => "uniform buffer",
        AddressSpace::Handle => "texture, image or sampler",
        _ => "non-storage resource",
    }
}
