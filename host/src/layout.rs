//! Rust mirrors of the structs in `shaders/layout.h`.
//!
//! The GLSL header is the definition; these mirrors are checked against the
//! naga reflection of every compiled kernel at start-up
//! (`gpu::reflect::check_layouts`), field by field, so drifting apart is an
//! error at start-up and never a wrong picture.

use bytemuck::{Pod, Zeroable};

// BINDING_*, WORKGROUP_SIZE, SHAPE_*, LIGHT_*, AOV_*, FLAG_*, NO_HIT: generated
// by build.rs from the `#define`s of shaders/layout.h, so they exist once.
include!(concat!(env!("OUT_DIR"), "/layout_consts.rs"));

mod preview_kernel;
pub use preview_kernel::*;

pub type Vec4 = [f32; 4];
/// Column-major, as GLSL's and GLM's mat4: `m[column][row]`.
pub type Mat4 = [[f32; 4]; 4];

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Frame {
    pub world_from_film: Mat4,
    pub eye: Vec4,
    pub k: Vec4,
    /// AOV_DEPTH: the distances drawn white and black; AOV_COST: the
    /// passes drawn hottest (`frame::aov_scale`).
    pub aov_scale: Vec4,
    pub width: u32,
    pub height: u32,
    pub primitive_count: u32,
    pub light_count: u32,
    pub aov: u32,
    pub flags: u32,
    pub max_depth: u32,
    pub spp: u32,
    pub texture_filter: u32,
    pub root_node: u32,
    pub node_count: u32,
    /// LOOP_CANARY (raycast.glsl loop_budget_ok).
    pub loop_canary: u32,
    /// render.comp: the first row of the band a dispatch draws (`GpuRenderer::render_marked`).
    pub row_offset: u32,
    /// FLAG_DOF: the thin lens's radius and the distance in focus (camera.glsl lens_ray).
    pub lens_radius: f32,
    pub focal_distance: f32,
    /// Points on each area light a sample (LIGHT_AREA).
    pub light_samples: u32,
}

impl Frame {
    /// The camera rays of one frame as the rate lines count them: `spp` a pixel.
    pub fn camera_rays(&self) -> u64 {
        u64::from(self.width) * u64::from(self.height) * u64::from(self.spp.max(1))
    }

    /// The uint fields, named, in layout.h's order.
    pub fn uints(&self) -> [(&'static str, u32); 14] {
        [
            ("width", self.width),
            ("height", self.height),
            ("primitive_count", self.primitive_count),
            ("light_count", self.light_count),
            ("aov", self.aov),
            ("flags", self.flags),
            ("max_depth", self.max_depth),
            ("spp", self.spp),
            ("texture_filter", self.texture_filter),
            ("root_node", self.root_node),
            ("node_count", self.node_count),
            ("loop_canary", self.loop_canary),
            ("row_offset", self.row_offset),
            ("light_samples", self.light_samples),
        ]
    }

    /// The first uint that scene_buffers.glsl's frame_unfolded would
    /// change (it takes each uint's min with ~gl_LocalInvocationIndex, at
    /// least 2^32 - 64 in a work group of 64): none for any frame the
    /// settings' bounds allow, but `fits_uniform` keeps such a frame off
    /// the uniform kernels (which copy the frame so on a CPU device).
    pub fn not_unfolded(&self) -> Option<(&'static str, u32)> {
        self.uints().into_iter().find(|&(_, v)| v >= u32::MAX - 63)
    }
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Primitive {
    pub object_from_world: Mat4,
    pub shape: u32,
    pub material: u32,
    pub id_offset: u32,
    /// SHAPE_MESH: its mesh's root in the mesh nodes; 0 otherwise.
    pub mesh: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct MeshTriangle {
    pub a: u32,
    pub b: u32,
    pub c: u32,
    pub flags: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct MeshVertex {
    /// w: the texture u.
    pub position: Vec4,
    /// w: the texture v (0 at the image's top row).
    pub normal: Vec4,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct BvhNode {
    pub lo: Vec4,
    pub hi: Vec4,
    pub first: u32,
    pub count: u32,
    pub axis: u32,
    pub primitives: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct LeafItem {
    pub item: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Instance {
    pub object_from_parent: Mat4,
    pub root: u32,
    pub id_offset: u32,
    pub pad0: u32,
    pub pad1: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Material {
    pub diffuse: Vec4,
    pub ambient: Vec4,
    pub specular: Vec4,
    pub reflective: Vec4,
    pub transparent: Vec4,
    pub emissive: Vec4,
    pub shininess: f32,
    pub blend: f32,
    pub ior: f32,
    pub texture: i32,
    pub texture_repeat: Vec4,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Texture {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub pad0: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Texel {
    pub rgba: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct Light {
    pub color: Vec4,
    pub position: Vec4,
    pub direction_to_light: Vec4,
    pub spot_axis: Vec4,
    pub attenuation: Vec4,
    pub kind: u32,
    pub angle_deg: f32,
    pub penumbra_deg: f32,
    pub pad0: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct PixelOut {
    /// xyz the world normal; w the camera ray's walk passes in an AOV other
    /// than colour, 0 in colour (layout.h).
    pub normal: Vec4,
    pub t: f32,
    pub id: u32,
    pub rgba: u32,
    /// Rays traced for the pixel: camera, shadow and mirror rays of every sample.
    pub rays: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct SampleSum {
    pub color: Vec4,
    pub samples: u32,
    pub rays: u32,
    pub pad0: u32,
    pub pad1: u32,
}

/// A pixel's walk through the course's adaptive supersampling between
/// render.comp's dispatches (layout.h, course_sampling.glsl).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct CourseSum {
    pub a0: Vec4,
    pub b0: Vec4,
    pub c0: Vec4,
    pub a1: Vec4,
    pub b1: Vec4,
    pub c1: Vec4,
    pub c2: Vec4,
    pub state: u32,
    pub samples: u32,
    pub rays: u32,
    pub pad0: u32,
}

#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct FmaCase {
    pub a: f32,
    pub b: f32,
    pub c: f32,
    pub r: f32,
}

/// One member of a struct as the host lays it out.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct FieldLayout {
    pub name: &'static str,
    pub offset: u32,
    pub size: u32,
}

/// A struct as the host lays it out: its name in the GLSL, its size and members.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct StructLayout {
    pub name: &'static str,
    pub size: u32,
    pub fields: Vec<FieldLayout>,
}

/// What a storage-buffer binding holds.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BufferShape {
    /// The block's only member is one struct (e.g. `Frame frame;`).
    Single(StructLayout),
    /// The block's only member is a runtime-sized array (e.g. `Primitive primitives[];`).
    RuntimeArray(StructLayout),
    /// A uniform block (std140) whose only member is one struct.
    UniformSingle(StructLayout),
}

impl BufferShape {
    /// Bound as a uniform buffer (else a storage buffer).
    pub fn is_uniform(&self) -> bool {
        matches!(self, BufferShape::UniformSingle(_))
    }

    /// The struct it holds.
    pub fn layout(&self) -> &StructLayout {
        match self {
            BufferShape::Single(s) | BufferShape::RuntimeArray(s) | BufferShape::UniformSingle(s) => s,
        }
    }
}

/// One binding of descriptor set 0 as the host expects it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct BindingLayout {
    pub binding: u32,
    pub shape: BufferShape,
    /// True when the kernel writes the buffer (not `readonly`).
    pub writable: bool,
}

impl BindingLayout {
    /// A read-only block of one `layout` at `binding`.
    pub fn single(binding: u32, layout: StructLayout) -> BindingLayout {
        BindingLayout { binding, shape: BufferShape::Single(layout), writable: false }
    }

    /// A read-only runtime array of `element`s at `binding`.
    pub fn array(binding: u32, element: StructLayout) -> BindingLayout {
        BindingLayout { binding, shape: BufferShape::RuntimeArray(element), writable: false }
    }

    /// The same binding, written by the kernel.
    pub fn writable(self) -> BindingLayout {
        BindingLayout { writable: true, ..self }
    }
}

/// Builds the [`StructLayout`] of a `#[repr(C)]` struct from its fields,
/// with offsets and sizes taken from the compiler.
macro_rules! struct_layout {
    ($ty:ty, $glsl_name:literal, [$($field:ident),* $(,)?]) => {{
        fn size_of_field<T, F>(_: impl Fn(&T) -> &F) -> u32 {
            std::mem::size_of::<F>() as u32
        }
        StructLayout {
            name: $glsl_name,
            size: std::mem::size_of::<$ty>() as u32,
            fields: vec![$(FieldLayout {
                name: stringify!($field),
                offset: std::mem::offset_of!($ty, $field) as u32,
                size: size_of_field(|s: &$ty| &s.$field),
            }),*],
        }
    }};
}

impl Frame {
    pub fn layout() -> StructLayout {
        struct_layout!(
            Frame,
            "Frame",
            [
                world_from_film,
                eye,
                k,
                aov_scale,
                width,
                height,
                primitive_count,
                light_count,
                aov,
                flags,
                max_depth,
                spp,
                texture_filter,
                root_node,
                node_count,
                loop_canary,
                row_offset,
                lens_radius,
                focal_distance,
                light_samples
            ]
        )
    }
}

impl Primitive {
    pub fn layout() -> StructLayout {
        struct_layout!(Primitive, "Primitive", [object_from_world, shape, material, id_offset, mesh])
    }
}

impl MeshTriangle {
    pub fn layout() -> StructLayout {
        struct_layout!(MeshTriangle, "MeshTriangle", [a, b, c, flags])
    }
}

impl MeshVertex {
    pub fn layout() -> StructLayout {
        struct_layout!(MeshVertex, "MeshVertex", [position, normal])
    }
}

impl BvhNode {
    pub fn layout() -> StructLayout {
        struct_layout!(BvhNode, "BvhNode", [lo, hi, first, count, axis, primitives])
    }
}

impl LeafItem {
    pub fn layout() -> StructLayout {
        struct_layout!(LeafItem, "LeafItem", [item])
    }
}

impl Instance {
    pub fn layout() -> StructLayout {
        struct_layout!(Instance, "Instance", [object_from_parent, root, id_offset, pad0, pad1])
    }
}

impl Material {
    pub fn layout() -> StructLayout {
        struct_layout!(
            Material,
            "Material",
            [
                diffuse,
                ambient,
                specular,
                reflective,
                transparent,
                emissive,
                shininess,
                blend,
                ior,
                texture,
                texture_repeat
            ]
        )
    }
}

impl Texture {
    pub fn layout() -> StructLayout {
        struct_layout!(Texture, "Texture", [offset, width, height, pad0])
    }
}

impl Texel {
    pub fn layout() -> StructLayout {
        struct_layout!(Texel, "Texel", [rgba])
    }
}

impl Light {
    pub fn layout() -> StructLayout {
        struct_layout!(
            Light,
            "Light",
            [color, position, direction_to_light, spot_axis, attenuation, kind, angle_deg, penumbra_deg, pad0]
        )
    }
}

/// One step of a pixel's sample in the CPU build's trace (layout.h TraceStep).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, Pod, Zeroable, PartialEq)]
pub struct TraceStep {
    pub origin: Vec4,
    /// w: the ray's t_max.
    pub direction: Vec4,
    /// A hit's world normal and (w) t; a term or a colour.
    pub value: Vec4,
    /// A level's mirror weight.
    pub extra: Vec4,
    pub kind: u32,
    pub level: u32,
    pub light: u32,
    /// The primitive hit (NO_HIT), or TRACE_LIGHT_*.
    pub id: u32,
    pub passes: u32,
    pub pad0: u32,
    pub pad1: u32,
    pub pad2: u32,
}

impl TraceStep {
    /// A ray's step (camera, mirror, refracted or shadow): one of the pixel's traced rays.
    pub fn is_ray(&self) -> bool {
        matches!(self.kind, TRACE_CAMERA | TRACE_MIRROR | TRACE_REFRACT | TRACE_SHADOW)
    }

    pub fn layout() -> StructLayout {
        struct_layout!(
            TraceStep,
            "TraceStep",
            [origin, direction, value, extra, kind, level, light, id, passes, pad0, pad1, pad2]
        )
    }
}

impl PixelOut {
    pub fn layout() -> StructLayout {
        struct_layout!(PixelOut, "PixelOut", [normal, t, id, rgba, rays])
    }
}

impl PixelOut {
    /// The device cut this pixel's loops short (RAYS_CUT_SHORT): its values are wrong.
    pub fn is_cut_short(&self) -> bool {
        self.rays & RAYS_CUT_SHORT != 0
    }
}

impl SampleSum {
    pub fn layout() -> StructLayout {
        struct_layout!(SampleSum, "SampleSum", [color, samples, rays, pad0, pad1])
    }
}

impl CourseSum {
    pub fn layout() -> StructLayout {
        struct_layout!(CourseSum, "CourseSum", [a0, b0, c0, a1, b1, c1, c2, state, samples, rays, pad0])
    }
}

impl FmaCase {
    pub fn layout() -> StructLayout {
        struct_layout!(FmaCase, "FmaCase", [a, b, c, r])
    }
}

/// fma_probe.comp's bindings: its cases, and the same cases with r filled in.
pub fn fma_probe_bindings() -> Vec<BindingLayout> {
    vec![
        BindingLayout::array(BINDING_FMA_CASES, FmaCase::layout()),
        BindingLayout::array(BINDING_FMA_RESULTS, FmaCase::layout()).writable(),
    ]
}

/// The scene's read-only bindings, as shaders/scene_buffers.glsl declares them
/// for every kernel that includes raycast.glsl.
pub fn scene_bindings() -> Vec<BindingLayout> {
    vec![
        BindingLayout::single(BINDING_FRAME, Frame::layout()),
        BindingLayout::array(BINDING_PRIMITIVES, Primitive::layout()),
        BindingLayout::array(BINDING_MATERIALS, Material::layout()),
        BindingLayout::array(BINDING_LIGHTS, Light::layout()),
        BindingLayout::array(BINDING_TEXTURES, Texture::layout()),
        BindingLayout::array(BINDING_TEXELS, Texel::layout()),
        BindingLayout::array(BINDING_NODES, BvhNode::layout()),
        BindingLayout::array(BINDING_LEAF_ITEMS, LeafItem::layout()),
        BindingLayout::array(BINDING_INSTANCES, Instance::layout()),
        BindingLayout::array(BINDING_MESH_NODES, BvhNode::layout()),
        BindingLayout::array(BINDING_MESH_TRIANGLES, MeshTriangle::layout()),
        BindingLayout::array(BINDING_MESH_VERTICES, MeshVertex::layout()),
    ]
}

/// The scene arrays render_uniform.comp and preview_uniform.comp read from
/// rgba32ui storage images (scene_buffers.glsl, SCENE_UNIFORM; layout.h,
/// IMAGE_WIDTH): every array the walk and the shading read, the same bytes
/// but primitives and instances packed (`padded_for_uniform`).
pub const UNIFORM_KERNEL_IMAGES: [u32; 6] =
    [BINDING_PRIMITIVES, BINDING_MATERIALS, BINDING_LIGHTS, BINDING_NODES, BINDING_INSTANCES, BINDING_LEAF_ITEMS];

/// The most bytes an array may have in the uniform kernels' images:
/// IMAGE_ROWS rows of IMAGE_WIDTH 16-byte texels.
pub const UNIFORM_KERNEL_IMAGE_BYTES: usize = IMAGE_WIDTH as usize * IMAGE_ROWS as usize * 16;

/// `UNIFORM_KERNEL_IMAGES` as a kernel's image bindings.
pub fn uniform_kernel_images() -> Vec<ImageBinding> {
    UNIFORM_KERNEL_IMAGES
        .iter()
        .map(|&binding| ImageBinding { binding, writable: false, format: ImageFormat::Rgba32Uint })
        .collect()
}

/// A storage image a kernel declares: its binding, whether the kernel
/// writes it, and its format; checked by naga's reflection like the
/// storage buffers (`gpu::Kernel::with_images`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ImageBinding {
    pub binding: u32,
    /// True when the kernel writes it (not `readonly`).
    pub writable: bool,
    pub format: ImageFormat,
}

/// What a storage image holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ImageFormat {
    /// A picture (`gpu::StorageImage`): `layout(rgba8) uniform image2D`.
    Rgba8,
    /// Data, 16 bytes a texel, in rows of IMAGE_WIDTH (`gpu::DataImage`, or
    /// `GpuContext::run_passes` from an input's bytes):
    /// `layout(rgba32ui) readonly uniform uimage2D`.
    Rgba32Uint,
}

/// The scene's buffer bindings in render_uniform.comp and
/// preview_uniform.comp: the frame as a uniform block, the textures and
/// texels as in `scene_bindings` (the arrays are images).
pub fn uniform_kernel_scene_bindings() -> Vec<BindingLayout> {
    let mut b: Vec<BindingLayout> =
        scene_bindings().into_iter().filter(|b| !UNIFORM_KERNEL_IMAGES.contains(&b.binding)).collect();
    for binding in &mut b {
        if binding.binding == BINDING_FRAME {
            binding.shape = BufferShape::UniformSingle(Frame::layout());
        }
    }
    b
}

/// `bytes` of scene binding `binding` as the uniform kernels take them: an
/// array they read as an image, primitives and instances packed into four
/// texels each (`packed_records`), padded with zeros to
/// `uniform_image_bytes`; anything else as it is.
pub fn padded_for_uniform(binding: u32, bytes: &[u8]) -> std::borrow::Cow<'_, [u8]> {
    use std::borrow::Cow;
    if !UNIFORM_KERNEL_IMAGES.contains(&binding) {
        return Cow::Borrowed(bytes);
    }
    let len = uniform_image_bytes(binding, bytes.len());
    let bytes = match binding {
        BINDING_PRIMITIVES | BINDING_INSTANCES => Cow::Owned(packed_records(bytes)),
        _ => Cow::Borrowed(bytes),
    };
    if len == bytes.len() {
        return bytes;
    }
    let mut v = bytes.into_owned();
    v.resize(len, 0);
    Cow::Owned(v)
}

/// The bytes an array of `len` bytes of scene binding `binding` takes in
/// the uniform kernels' images: 4 texels a primitive or instance where the
/// struct has 5 (`packed_records`), then at least one texel and, past one
/// row, whole rows of IMAGE_WIDTH texels (a data image,
/// `GpuContext::run_passes`); `len` for any other binding.
pub fn uniform_image_bytes(binding: u32, len: usize) -> usize {
    if !UNIFORM_KERNEL_IMAGES.contains(&binding) {
        return len;
    }
    let len = match binding {
        BINDING_PRIMITIVES | BINDING_INSTANCES => len / PACKED_RECORD * PACKED_TEXELS as usize * 16,
        _ => len,
    };
    let row = IMAGE_WIDTH as usize * 16;
    if len <= row {
        len.max(16).next_multiple_of(16)
    } else {
        len.next_multiple_of(row)
    }
}

/// A Primitive's and an Instance's bytes: a mat4 and four words.
const PACKED_RECORD: usize = std::mem::size_of::<Primitive>();
const _: () = assert!(PACKED_RECORD == 80 && std::mem::size_of::<Instance>() == PACKED_RECORD);
const _: () = assert!(PACKED_TEXELS as usize * 16 == 64, "the mat4's four columns");

/// Primitives or instances as the uniform kernels' images hold them
/// (scene_buffers.glsl, PACKED_TEXELS): each record's matrix, its four
/// columns with the four words after it in their w, where the matrix's
/// bottom row was (no kernel reads it: exact.glsl transforms by the
/// columns' xyz). Four texels a record where the struct takes five.
fn packed_records(bytes: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(bytes.len() / PACKED_RECORD * 64);
    for record in bytes.chunks_exact(PACKED_RECORD) {
        for k in 0..4 {
            out.extend_from_slice(&record[16 * k..16 * k + 12]);
            out.extend_from_slice(&record[64 + 4 * k..64 + 4 * k + 4]);
        }
    }
    out
}

/// The buffer bindings of render_uniform.comp: `render_bindings` with the
/// scene as `uniform_kernel_scene_bindings`.
pub fn render_uniform_bindings() -> Vec<BindingLayout> {
    let mut b = uniform_kernel_scene_bindings();
    let own = [BINDING_PIXELS, BINDING_SAMPLE_SUMS, BINDING_COURSE_SUMS];
    b.extend(render_bindings().into_iter().filter(|r| own.contains(&r.binding)));
    b
}

/// The bindings of every kernel that writes pixels: the scene and the pixels.
pub fn pixel_kernel_bindings() -> Vec<BindingLayout> {
    let mut b = scene_bindings();
    b.push(BindingLayout::array(BINDING_PIXELS, PixelOut::layout()).writable());
    b
}

/// The bindings of the render kernel (`shaders/render.comp`): the scene, the
/// pixels and the running sums of their samples.
pub fn render_bindings() -> Vec<BindingLayout> {
    let mut b = pixel_kernel_bindings();
    b.push(BindingLayout::array(BINDING_SAMPLE_SUMS, SampleSum::layout()).writable());
    b.push(BindingLayout::array(BINDING_COURSE_SUMS, CourseSum::layout()).writable());
    b
}

#[cfg(test)]
mod packing_tests {
    use super::*;

    /// A primitive's image texels: each matrix column's xyz, then one of
    /// the four words after the matrix in its w; padded to one texel per
    /// record; the other arrays' bytes unchanged. Rule: exact.
    #[test]
    fn primitives_take_four_texels() {
        let m: [f32; 16] = std::array::from_fn(|i| i as f32 + 0.5);
        let p = Primitive {
            object_from_world: [
                [m[0], m[1], m[2], m[3]],
                [m[4], m[5], m[6], m[7]],
                [m[8], m[9], m[10], m[11]],
                [m[12], m[13], m[14], m[15]],
            ],
            shape: 7,
            material: 8,
            id_offset: 9,
            mesh: 10,
        };
        let bytes = bytemuck::bytes_of(&p);
        let packed = padded_for_uniform(BINDING_PRIMITIVES, bytes);
        let words: &[u32] = bytemuck::cast_slice(&packed);
        let f = |x: f32| x.to_bits();
        let expected: Vec<u32> =
            (0..4).flat_map(|k| [f(m[4 * k]), f(m[4 * k + 1]), f(m[4 * k + 2]), 7 + k as u32]).collect();
        assert_eq!(words, &expected[..]);
        assert_eq!(uniform_image_bytes(BINDING_PRIMITIVES, 3 * 80), 3 * 64);
        assert_eq!(uniform_image_bytes(BINDING_INSTANCES, 80), 64);
        let node = [1u8; 48];
        assert_eq!(&padded_for_uniform(BINDING_NODES, &node)[..], &node[..]);
        assert_eq!(uniform_image_bytes(BINDING_NODES, 8), 16);
        assert_eq!(uniform_image_bytes(BINDING_TEXELS, 8), 8);
    }
}

#[cfg(test)]
mod frame_unfolded_tests {
    /// The uint fields of a GLSL struct `name` in `source`, in order.
    fn uint_fields(source: &str, name: &str) -> Vec<String> {
        let start = source.find(&format!("struct {name} {{")).expect("the struct");
        let body = &source[start..start + source[start..].find("};").expect("its end")];
        body.lines()
            .filter_map(|line| line.trim().strip_prefix("uint ")?.split(';').next().map(|f| f.trim().to_string()))
            .collect()
    }

    /// On a CPU device the uniform kernels read every uint of the frame
    /// from scene_buffers.glsl's frame_unfolded, which hides it from
    /// lavapipe's folding of uniform values (a kernel built again at every
    /// dispatch where a branch reads one). A uint added to Frame and not to
    /// frame_unfolded would bring the builds back: this names it. Rule: the
    /// same fields, in the same order.
    #[test]
    fn frame_unfolded_hides_every_uint_of_the_frame() {
        let fields = uint_fields(include_str!("../../shaders/layout.h"), "Frame");
        assert!(fields.len() >= 14 && fields.contains(&"loop_canary".to_string()), "{fields:?}");
        let buffers = include_str!("../../shaders/scene_buffers.glsl");
        let start = buffers.find("Frame frame_unfolded() {").expect("scene_buffers.glsl declares frame_unfolded");
        let body = &buffers[start..start + buffers[start..].find("\n}").expect("its end")];
        let hidden: Vec<String> = body
            .lines()
            .filter_map(|line| {
                let field = line.trim().strip_prefix("f.")?.split(' ').next()?;
                (line.trim() == format!("f.{field} = min(f.{field}, open);")).then(|| field.to_string())
            })
            .collect();
        assert_eq!(hidden, fields, "frame_unfolded's fields against layout.h's uints of Frame");
        let named: Vec<String> = super::Frame::default().uints().iter().map(|(n, _)| n.to_string()).collect();
        assert_eq!(named, fields, "Frame::uints against layout.h's uints of Frame");
    }

    /// A frame whose uint would not survive frame_unfolded's min (2^32 -
    /// 64 or more) is named; one just below is not. Rule: exact.
    #[test]
    fn frames_too_large_to_unfold_are_named() {
        let mut frame = super::Frame { width: 512, height: 384, ..Default::default() };
        assert_eq!(frame.not_unfolded(), None);
        frame.row_offset = u32::MAX - 64;
        assert_eq!(frame.not_unfolded(), None);
        frame.row_offset = u32::MAX - 63;
        assert_eq!(frame.not_unfolded(), Some(("row_offset", u32::MAX - 63)));
    }
}
