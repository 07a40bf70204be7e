//! raycast: a ray caster that runs as a Vulkan compute shader over
//! CS1230/CS123/Comp175 XML scenes.
//!
//! Parts (see README "Architecture"): `scene` reads scene files, `frame`
//! turns a scene into the buffers of `layout`, `gpu` runs kernels on a
//! Vulkan device, `render` runs the render kernel, `image_io` reads, writes
//! and compares pictures, `cli` is the command line.

pub mod bvh;
pub mod bench;
pub mod cli;
pub mod check;
pub mod cpu;
pub mod frame;
pub mod gen;
pub mod gpu;
pub mod harness;
pub mod image_io;
pub mod layout;
pub mod preview;
pub mod render;
pub mod scene;
pub mod versus;
