// layout.h: every struct and binding number shared by the host and the
// shaders, written once. Included by the GLSL kernels and by the C++ build of
// the shared code; the Rust host mirrors these structs in host/src/layout.rs
// and checks its mirror against naga's reflection of the compiled SPIR-V at
// start-up, so a mismatch is an error, not a wrong picture.
//
// Rules that keep one text valid GLSL (std430) and C++ (GLM) with identical
// byte layouts: only vec4 / mat4 / float / int / uint members, vec4 before
// scalars, every struct a multiple of 16 bytes. No vec3 (std430 aligns it to
// 16 bytes, C++ to 4).
#ifndef RAYCAST_LAYOUT_H
#define RAYCAST_LAYOUT_H

// Descriptor set 0 bindings: storage buffers in render.comp and preview.comp;
// render_uniform.comp and preview_uniform.comp read some of the scene's arrays
// from storage images and the frame from a uniform block (scene_buffers.glsl).
#define BINDING_FRAME 0      // Frame (one)
#define BINDING_PRIMITIVES 1 // Primitive[]
#define BINDING_MATERIALS 2  // Material[]
#define BINDING_LIGHTS 3     // Light[]
#define BINDING_PIXELS 4     // PixelOut[], written by the kernel
// 5 to 7 and 19: the preview kernel's own (shaders/preview.h)
#define BINDING_TEXTURES 8   // Texture[]
#define BINDING_TEXELS 9     // Texel[]: every texture's texels, row 0 at the top
#define BINDING_NODES 10     // BvhNode[]: every group's hierarchy
#define BINDING_LEAF_ITEMS 11 // LeafItem[]: what the leaves hold
#define BINDING_INSTANCES 12 // Instance[]: placed copies of a group (a master tree)
// 20, 21: the shader-test harness's own
#define BINDING_SAMPLE_SUMS 13 // SampleSum[]: render.comp's own, read and written
// Triangle meshes (docs/scene-format.md#triangle-meshes), storage buffers in
// every kernel (the uniform kernels too): each mesh file once, however many
// primitives draw it.
#define BINDING_MESH_NODES 14     // BvhNode[]: every mesh's own hierarchy, in the mesh's space
#define BINDING_MESH_TRIANGLES 15 // MeshTriangle[]: every mesh's triangles, in its leaves' order
#define BINDING_MESH_VERTICES 16  // MeshVertex[]: every mesh's vertices
#define BINDING_COUNT 17     // bindings 0 .. BINDING_COUNT-1 of the scene and the pixels (13: render.comp's own)
#define BINDING_COURSE_SUMS 22 // CourseSum[]: render.comp's own under FLAG_COURSE_SAMPLING

#define MAX_LEVELS 16  // deepest nesting of instances
#define STACK_SIZE 128 // traversal stack entries (the host proves a scene fits)
#define ITEM_INSTANCE 2147483648u // LeafItem.item bit: an instance, not a primitive
// A stack word: ITEM_INSTANCE | index or a node index in bits 0-26, the level in 27-30.
#define STACK_LEVEL_SHIFT 27u
#define STACK_ENTRY_MASK 2281701375u // 0x87ffffff: the flag and 27 index bits
#define MAX_INDEX 134217727u // 2^27 - 1: most nodes, instances or primitives

#define MAX_DEPTH 16 // the most mirror bounces --depth accepts

// The uniform kernels (render_uniform.comp, preview_uniform.comp) keep the
// frame in a uniform block and the scene's arrays (primitives, materials,
// lights, nodes, instances, leaf items) in rgba32ui storage images of
// IMAGE_WIDTH texels a row and at most IMAGE_ROWS rows (the least
// maxImageDimension2D Vulkan allows): element i of a struct N texels long
// (its size / 16) is texels N i .. N i + N - 1, its bytes in order, texel t
// at (t % IMAGE_WIDTH, t / IMAGE_WIDTH); leaf items go four to a texel.
// Lavapipe loads a 128-bit texel per lane, where a uniform block costs a
// 32-bit load per lane and component and a storage buffer a branch per
// lane. A scene with more than IMAGE_WIDTH x IMAGE_ROWS texels of an array
// takes the storage-buffer kernels.
#define IMAGE_WIDTH 4096
#define IMAGE_WIDTH_SHIFT 12u // log2(IMAGE_WIDTH)
#define IMAGE_ROWS 4096
#define MATERIAL_TEXELS 8  // sizeof(Material) / 16
#define LIGHT_TEXELS 6     // sizeof(Light) / 16
#define NODE_TEXELS 3      // sizeof(BvhNode) / 16
#define PACKED_TEXELS 4u   // a Primitive or an Instance in the images (scene_buffers.glsl)
#define LEAF_ITEMS_PER_TEXEL 4

#define WORKGROUP_SIZE 8 // 8x8 invocations, one pixel each

// Specialization constants (their constant_id): what a kernel may leave out.
// scene_buffers.glsl (the shapes': shapes.glsl) declares them as HAS_*
// bools, true unless the host says otherwise; the C++ build has them all
// true (but its lean copy, host/cpu/shared.hpp). Lavapipe runs every
// branch of a shader whether or not any lane takes it, so a kernel pays for
// the cone test, spot lights or bilinear filtering in every pass even when
// the scene has none; the host turns off what a scene and its frame flags
// cannot use (render::Specialization::of) and the compiler drops that code.
// A constant turned off only removes code the scene never reaches, so the
// pixels are the same bit for bit (`raycast check` compares the specialised
// kernel with the CPU build).
#define SPEC_INSTANCES 0         // the scene places instances of groups
#define SPEC_POSITIONED_LIGHTS 1 // a point or spot light (attenuation)
#define SPEC_SPOT_LIGHTS 2
#define SPEC_TEXTURES 3          // a textured material, and FLAG_TEXTURES
#define SPEC_BILINEAR 4          // ... with FILTER_BILINEAR
#define SPEC_SPECULAR 5          // a material with shininess > 0
#define SPEC_SHADOWS 6           // FLAG_SHADOWS
#define SPEC_REFLECTIONS 7       // FLAG_REFLECTIONS and a mirror material
#define SPEC_INNER_NODES 8       // a hierarchy node with children (not only leaves)
#define SPEC_SEVERAL_PRIMITIVE_LEAVES 9 // a leaf holds more than one primitive
#define SPEC_HIERARCHY 10        // frame.node_count > 0: the walk's hierarchy steps
#define SPEC_FLAT_LIST 11        // frame.node_count == 0: the walk's primitives in order
#define SPEC_BOX_RECORDS 12      // an instance record holds a box
#define SPEC_SPHERE_RECORDS 13   // an instance record holds a sphere (RECORD_SPHERE)
#define SPEC_AOVS 14             // frame.aov other than AOV_COLOR (and the walk's pass count)
#define SPEC_REFRACTION 15       // FLAG_REFRACTION and a transparent material (k_t O_t not 0)
#define SPEC_AREA_LIGHTS 16      // an area light (LIGHT_AREA): its samples over the rectangle
#define SPEC_DOF 17              // FLAG_DOF: the thin lens (camera.glsl)
#define SPEC_COURSE_SAMPLING 18  // FLAG_COURSE_SAMPLING
#define SPEC_EXPLAIN 19          // a FLAG_EXPLAIN_* bit: `raycast explain`'s variants of the code
// Not a feature left out, a form chosen: the walk keeps each instance
// level's ray, first id and instance in arrays indexed by the lane's level,
// which lavapipe reads and writes lane by lane (a scalar loop over the 8
// lanes for every word), or in registers: each access a select over the
// scene's REGISTER_LEVELS levels, constant indices once the loops over them
// unroll (traversal.glsl, walk). A kernel specialised for a scene has them in
// registers, as many as the scene nests (render::Specialization; 0.78 to
// 0.90 of the dispatch at every depth of the recursive spheres, docs/scale.md#shaped-for-lavapipe); the C++ build and a kernel not
// specialised, in arrays.
#define SPEC_LEVELS_IN_REGISTERS 20 // a bool
#define SPEC_REGISTER_LEVELS 21     // a count: the levels the walk keeps, 1 to MAX_LEVELS
// The walk's form, as SPEC_LEVELS_IN_REGISTERS: a leaf's met instance
// records go on the stack as one entry, ITEM_INSTANCE | records <<
// RECORD_MASK_SHIFT | RECORD_LOW_FIRST or not | mask (the texel of its
// first record, a bit a met record), taken a record at a time. With the
// AOVs, highest bit first: the order, and so the passes, of one entry a
// record, as the CPU build walks; in colour, from the end of the mask whose
// record lies nearer along the ray, or farther for a shadow ray
// (RECORD_LOW_FIRST: the lowest bit first), which only the passes can tell
// (traversal.glsl, walk). Set where
// every record's texel is below RECORD_MASKS_TEXELS
// (render::Specialization); off in the C++ build.
#define SPEC_RECORD_MASKS 22      // a bool
#define RECORD_MASKS_TEXELS 262144u // 2^18: the texel, the order bit and 8 mask bits fill the 27 index bits
#define RECORD_MASK_SHIFT 9u
#define RECORD_LOW_FIRST 256u
// Then one a shape, SPEC_SHAPES + its id (Primitive.shape): shapes.glsl
// registers the shapes, their SHAPE_* ids and SPEC_* constants, and
// SPEC_COUNT after them.
#define SPEC_SHAPES 23

// Light.kind
#define LIGHT_POINT 0u
#define LIGHT_DIRECTIONAL 1u
#define LIGHT_SPOT 2u
#define LIGHT_AREA 3u // a rectangle: Frame.light_samples points (docs/scene-format.md#area-lights)

// Frame.aov: what PixelOut.rgba holds (aov.glsl aov_color). The
// others than colour see the first hit only: no shadow or mirror ray.
#define AOV_COLOR 0u
#define AOV_NORMAL 1u // the world normal, (n + 1) / 2; black on a miss
#define AOV_DEPTH 2u  // grey by distance along the camera ray (Frame.aov_scale xy); black on a miss
#define AOV_ID 3u     // a colour per primitive id; black on a miss
#define AOV_COST 4u   // the camera ray's walk: its passes on a heat scale (Frame.aov_scale z), hit or miss
#define AOV_SAMPLES 6u  // the pixel's samples (camera rays) on the heat scale, dark red at COURSE_MAX_SAMPLES
#define AOV_COST_ALL 5u // every ray of the pixel (camera, shadow, mirror) traced as in colour: their walks' passes summed, on the same scale
// As AOV_COST_ALL, with what a GPU's lanes spend, for `bench --lanes`:
// PixelOut.normal holds the passes of the camera ray, of the shadow rays and
// of the mirror and refracted rays, and w all of them; t the bytes of the
// hierarchy (nodes, instance records and instances) and id the
// bytes of primitives the walks fetched. A mesh's own walk is counted in
// (traversal.glsl primitive_hit): a pass a node, its nodes' and
// triangles' bytes.
#define AOV_LANES 7u

// Frame.flags
#define FLAG_SHADOWS 1u
#define FLAG_REFLECTIONS 2u
#define FLAG_TEXTURES 4u
#define FLAG_NO_BVH 8u // test every primitive: the hierarchy's boxes are ignored
#define FLAG_REFRACTION 16u // refracted rays through transparent materials, and their shadows
#define FLAG_DOF 32u   // a thin lens: Frame.lens_radius and focal_distance (camera.glsl)
#define FLAG_COURSE_SAMPLING 64u // the course's adaptive supersampling (course_sampling.glsl), not frame.spp
// `raycast explain`'s variants: a student's mistake drawn on purpose, to
// compare with their picture (host/src/explain/). Each only where
// HAS_EXPLAIN (SPEC_EXPLAIN) keeps the code: a kernel specialised without
// them, and the CPU build's lean copy, have none of it.
#define FLAG_EXPLAIN_FLIP_NORMALS 65536u       // the shading normal reversed
#define FLAG_EXPLAIN_UNTRANSPOSED_NORMALS 131072u // normals mapped by the inverse of object_from_world, not its transpose
#define FLAG_EXPLAIN_NO_CAPS 262144u           // the cone's and cylinder's flat caps left out
#define FLAG_EXPLAIN_ROUND 524288u             // the 8-bit value rounded to nearest, not floor(255 c)
#define FLAG_EXPLAIN_NO_CLAMP 1048576u         // colours not clamped to [0, 1]; the 8-bit value wraps
#define FLAG_EXPLAIN_BLINN 2097152u            // the specular highlight from the half vector (Blinn-Phong)
#define FLAG_EXPLAIN_LONG_NORMALS 4194304u     // the world normal not made unit length (the object's is)
#define FLAG_EXPLAIN_NEGATIVE_LIGHT 8388608u   // n.l not clamped at 0: a light darkens what faces away
#define FLAG_EXPLAIN_UNCAPPED_ATTENUATION 16777216u // attenuation 1/falloff not capped at 1
#define FLAG_EXPLAIN_ALL 33488896u             // every FLAG_EXPLAIN_* bit

// Frame.texture_filter
#define FILTER_NEAREST 0u
#define FILTER_BILINEAR 1u
#define FILTER_COURSE 2u // bilinear between texels floor(x) and floor(x) + 1: no half-texel shift

// PixelOut.id of a pixel whose ray hit nothing.
#define NO_HIT 0xffffffffu

// Frame.loop_canary: what the host sets (sampling.glsl loop_budget_ok).
#define LOOP_CANARY 2u
// PixelOut.rays bit: the device cut this pixel's loops short (Mesa's
// llvmpipe gives an invocation 65535 loop iterations in all); every value of
// the pixel is suspect. Never set by the CPU build.
#define RAYS_CUT_SHORT 0x80000000u

struct Frame {
    // Maps film space (x, y in [-1, 1], z = -1 on the film plane) to world
    // space: translate(eye) * rotation(u, v, w) * scale^-1 (seed handout).
    mat4 world_from_film;
    vec4 eye; // w unused
    // Global Phong coefficients k_a, k_d, k_s, k_t.
    vec4 k;
    // AOV_DEPTH: x the distance from the eye drawn white, y the distance
    // drawn black (and beyond). AOV_COST: z the walk passes drawn at the
    // hot end of the scale (and beyond). w unused.
    vec4 aov_scale;
    uint width;
    uint height;
    uint primitive_count;
    uint light_count;
    uint aov;
    uint flags;
    uint max_depth; // mirror bounces, at most MAX_DEPTH
    uint spp;       // samples per pixel (fixed pattern: sampling.glsl sample_offset)
    uint texture_filter;
    uint root_node;  // the root group's hierarchy
    uint node_count; // 0: no hierarchy; primitives are tested in order
    uint loop_canary; // LOOP_CANARY: the trip count of sampling.glsl's loop_budget_ok
    // render.comp: the first row of the band this dispatch draws; its
    // buffers hold that band alone (a picture larger than one storage
    // buffer renders in bands). 0 elsewhere.
    uint row_offset;
    // FLAG_DOF: the thin lens's radius and the distance in focus, world
    // units along the view axis (camera.glsl lens_ray); 0 without.
    float lens_radius;
    float focal_distance;
    // Points taken on each area light a sample (LIGHT_AREA; --light-samples).
    uint light_samples;
};

// A primitive of a group. Its matrix maps the group's space (the world for
// the root group) to the primitive's object space.
struct Primitive {
    mat4 object_from_world;
    uint shape;     // SHAPE_* (shapes.glsl)
    uint material;
    uint id_offset; // its id is the group's first id plus this
    uint mesh;      // SHAPE_MESH: its mesh's root node in mesh_nodes; 0 otherwise
};

// A node of a group's bounding volume hierarchy, in the group's space.
// count > 0: a leaf of count items: its `primitives` primitives at
// leaf_items[first ..), then, from the next multiple of 4, one record of
// four words (a texel of the leaf-item image) per instance:
// (lo.x | lo.y << 16, lo.z | hi.x << 16, hi.y | hi.z << 16,
// ITEM_INSTANCE | instance index), the instance's box in the leaf's box
// quantised to BOX_STEPS steps: lo = node.lo + q * step and hi = node.hi -
// q * step, step = (node.hi - node.lo) / BOX_STEPS, computed in f32 as
// written (frame.rs chooses q so the box holds the instance's; a box test
// then reads one texel, where the instance's own box took three). Or, with
// RECORD_SPHERE in the last word, a sphere that holds the instance's
// primitives (frame.rs uses one where its surface is smaller than the
// box's): (c.x | c.y << 16, c.z, the radius's f32 bits, RECORD_SPHERE |
// ITEM_INSTANCE | instance index), the centre in steps as lo above.
// A leaf's `axis` is its first primitive (leaf_items[first]; 0 when it has
// none), so that a leaf of one primitive needs no leaf-item read.
// count = 0: children first and first + 1, split along axis.
struct BvhNode {
    vec4 lo;
    vec4 hi;
    uint first;
    uint count;
    uint axis;
    uint primitives; // a leaf: how many of its items are primitives; 0 for an inner node
};

// Steps of a leaf's box in an instance record's box (above).
#define BOX_STEPS 65535u
// An instance record's last word: a bounding sphere, not a box (above).
#define RECORD_SPHERE 1073741824u // bit 30, above the 27 index bits

// A primitive index, or a word of an instance record (BvhNode).
struct LeafItem {
    uint item;
};


// A group placed in its parent group's space.
// Its box, in the parent group's space, is in the record of the leaf that
// holds it (BvhNode): a leaf pushes the instance only when the ray meets it.
struct Instance {
    mat4 object_from_parent; // parent group's space -> the placed group's space
    uint root;      // the placed group's root node
    uint id_offset; // ids of its primitives start at the parent's first id plus this
    uint pad0;
    uint pad1;
};

// A mesh's hierarchy is a BvhNode tree (count > 0: a leaf of `count`
// triangles at mesh_triangles[first ..); count = 0: children first and
// first + 1, split along axis), its boxes in the mesh's own space (the OBJ
// file's coordinates). The walk holds at most MESH_STACK_SIZE entries: the
// host refuses a deeper tree.
#define MESH_STACK_SIZE 64
// MeshTriangle.flags: interpolate the vertices' normals (the file gave
// them); otherwise the face's own normal, (b - a) x (c - a).
#define MESH_SMOOTH 1u

// A triangle: its vertices' indices in mesh_vertices (the mesh's offset
// added), counter-clockwise seen from outside as OBJ writes them.
struct MeshTriangle {
    uint a;
    uint b;
    uint c;
    uint flags;
};

// A vertex: position (w: its texture u) and normal (w: its texture v,
// already flipped so that v = 0 is the image's top row; u = v = 0 where
// the file gives no coordinates).
struct MeshVertex {
    vec4 position;
    vec4 normal;
};

struct Material {
    vec4 diffuse;     // O_d
    vec4 ambient;     // O_a
    vec4 specular;    // O_s
    vec4 reflective;  // O_r
    vec4 transparent; // O_t
    vec4 emissive;
    float shininess; // n; 0 turns specular off
    float blend;
    float ior;
    int texture; // index of the texture, -1 for none
    vec4 texture_repeat; // u, v repeat counts in x, y
};

// One texture's place in the texel buffer.
struct Texture {
    uint offset; // index of its first texel
    uint width;
    uint height;
    uint pad0;
};

// One texel, RGBA8 with R in the low byte.
struct Texel {
    uint rgba;
};

// An area light (LIGHT_AREA) is the rectangle position + a e_u + b e_v,
// a and b in [-1/2, 1/2], with its edges e_u (width long) in
// direction_to_light and e_v (height long) in spot_axis, which it uses for
// nothing else (frame.rs area_edges; docs/scene-format.md#area-lights).
struct Light {
    vec4 color;
    vec4 position;
    vec4 direction_to_light; // -normalize(direction), computed on the host; area: e_u
    vec4 spot_axis;          // normalize(direction), computed on the host; area: e_v
    vec4 attenuation;        // constant, linear, quadratic
    uint kind;
    float angle_deg;    // spot: outer half-angle
    float penumbra_deg; // spot: falloff band inside it
    uint pad0;
};

struct PixelOut {
    vec4 normal; // xyz: world-space unit normal, 0 on a miss; w: the camera
                 // ray's walk passes in an AOV other than colour (kernels
                 // with HAS_AOVS: rays.glsl SceneHit.passes), 0 in colour
    float t;     // ray parameter of the nearest hit (ray direction not unit); 0 on a miss
    uint id;     // index of the primitive hit, NO_HIT on a miss
    uint rgba;   // 8-bit RGBA, R in the low byte
    uint rays;   // rays traced for the pixel: camera, shadow and mirror rays of every sample;
                 // RAYS_CUT_SHORT added when the device cut its loops short
};

// One step of a pixel's sample as the CPU build's trace records it
// (`raycast trace`; trace.glsl TRACE, which is nothing in a kernel).
#define TRACE_CAMERA 0u  // the camera ray: origin, direction (w: t_max), hit
#define TRACE_MIRROR 1u  // a mirror ray of bounce `level`: the same
#define TRACE_SHADOW 2u  // light `light`'s shadow ray: the same (id: what blocks it)
#define TRACE_LIGHT 3u   // light `light`'s term at `level`: value; id: TRACE_LIGHT_*
#define TRACE_LEVEL 4u   // the level's own colour (value) and mirror weight (extra); origin: its refracted weight
#define TRACE_PIXEL 5u   // the sample's colour (value), the levels folded; id: as 8-bit RGBA
#define TRACE_SURFACE 6u // a hit's surface: point (origin), ambient + emissive (value), diffuse (extra)
#define TRACE_REFRACT 7u // a refracted ray of bounce `level` (inside reflection where total): as TRACE_MIRROR
#define TRACE_LIGHT_ADDED 0u   // added, no shadow ray (shadows off)
#define TRACE_LIGHT_SHADOW 1u  // a shadow ray decides (the next step)
#define TRACE_LIGHT_NOTHING 2u // every channel 0 or subnormal: skipped
struct TraceStep {
    vec4 origin;    // a ray's origin
    vec4 direction; // a ray's direction; w: its t_max
    vec4 value;     // a hit's world normal and (w) t; a term or a colour
    vec4 extra;     // a level's mirror weight
    uint kind;      // TRACE_*
    uint level;     // 0 for the camera ray's hit, n for bounce n
    uint light;     // the light's index
    uint id;        // the primitive hit (NO_HIT), or TRACE_LIGHT_*
    uint passes;    // the ray's walk passes through the hierarchy
    uint pad0;
    uint pad1;
    uint pad2;
};

// A pixel's samples summed so far, kept by render.comp between its
// dispatches (one sample of every pixel each; the host zeroes it first).
struct SampleSum {
    vec4 color;   // xyz: the samples' colours added in sample order; w unused
    uint samples; // how many are in it: the next dispatch computes this sample
    uint rays;    // their rays (RAYS_CUT_SHORT added when any was cut short)
    uint pad0;
    uint pad1;
};

// The course's adaptive supersampling (course_sampling.glsl): squares of
// 4 samples refined down to COURSE_LEVELS levels, at most
// COURSE_MAX_SAMPLES = 4 + 16 + 64 samples a pixel.
#define COURSE_LEVELS 3
#define COURSE_MAX_SAMPLES 84

// A pixel's walk through the adaptive scheme between render.comp's
// dispatches (course_sampling.glsl course_add): per level of the square
// being sampled, its samples' min (a), max (b) and sum (c); a refined
// square's `a` sums its quadrants' values instead. Zeroed by the host: the
// first sample is next.
struct CourseSum {
    vec4 a0;
    vec4 b0;
    vec4 c0;
    vec4 a1;
    vec4 b1;
    vec4 c1;
    vec4 c2;      // level 2 is never refined: its sum alone
    uint state;   // course_sampling.glsl: quadrant, level, path, COURSE_DONE
    uint samples; // taken so far
    uint rays;    // their rays (RAYS_CUT_SHORT added when any was cut short)
    uint pad0;
};

// shaders/fma_probe.comp: fma(a, b, c) as the device computes it, case by
// case, so that the host can see whether its fma() rounds once
// (host/src/gpu/fma_probe.rs; exact.glsl FUSED_FMA).
#define BINDING_FMA_CASES 0   // FmaCase[], read
#define BINDING_FMA_RESULTS 1 // FmaCase[], written: each case with r = fma(a, b, c)
struct FmaCase {
    float a;
    float b;
    float c;
    float r;
};

#endif
