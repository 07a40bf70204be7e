//! raycast: a ray caster that runs as a Vulkan compute shader over
//! CS1230/CS123/Comp175 XML scenes.
//!
//! Parts (see README "Architecture"): `scene` reads scene files, `frame`
//! turns a scene into the GPU buffers of `layout`, `gpu` runs kernels on a
//! Vulkan device, `render` ties them together, `image_io` reads and writes
//! pictures, `cli` is the command line.

pub mod layout;
pub mod scene;
pub mod gpu;
