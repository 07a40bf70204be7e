//! Triangle meshes packed for the kernels (layout.h BINDING_MESH_*): each
//! mesh's own hierarchy, built once however many primitives draw it.

use crate::bvh::{self, Aabb};
use crate::error::Error;
use crate::layout;
use crate::scene::Scene;
use glam::DVec3;

/// Every mesh of a scene as the device buffers hold them (layout.h,
/// BINDING_MESH_*): each its own hierarchy, built once however many
/// primitives draw it.
#[derive(Default)]
pub(super) struct PackedMeshes {
    pub(super) nodes: Vec<layout::BvhNode>,
    pub(super) triangles: Vec<layout::MeshTriangle>,
    pub(super) vertices: Vec<layout::MeshVertex>,
    /// Each mesh's root node.
    pub(super) roots: Vec<u32>,
}

/// Builds each mesh's hierarchy over its triangles (bvh.rs, the groups'
/// builder: binned SAH, at most 4 triangles a leaf) and packs its nodes,
/// its triangles in leaf order and its vertices, with global indices.
pub(super) fn pack_meshes(scene: &Scene) -> Result<PackedMeshes, Error> {
    let mut out = PackedMeshes::default();
    for mesh in &scene.meshes {
        let too_many = |what: &str| {
            Error::Scene(format!(
                "{}: error: the meshes together have more {what} than the shader can index",
                mesh.path.display()
            ))
        };
        let vertex_base = u32::try_from(out.vertices.len()).map_err(|_| too_many("vertices"))?;
        let triangle_base = u32::try_from(out.triangles.len()).map_err(|_| too_many("triangles"))?;
        let node_base = u32::try_from(out.nodes.len()).map_err(|_| too_many("nodes"))?;
        let bounds: Vec<Aabb> = mesh
            .triangles
            .iter()
            .map(|t| {
                t.iter().fold(Aabb::EMPTY, |b, &v| {
                    let p = mesh.positions[v as usize];
                    let d = DVec3::new(p[0].into(), p[1].into(), p[2].into());
                    b.union(Aabb { lo: d, hi: d })
                })
            })
            .collect();
        let built = bvh::build(&bounds, bounds.len());
        // The walk keeps at most depth + 1 entries (shape_mesh.glsl).
        if built.depth as usize + 1 > layout::MESH_STACK_SIZE as usize {
            return Err(Error::Scene(format!(
                "{}: error: the mesh's hierarchy is {} deep, more than the shader's {} (degenerate triangles?)",
                mesh.path.display(),
                built.depth,
                layout::MESH_STACK_SIZE - 1
            )));
        }
        out.roots.push(node_base);
        for node in &built.nodes {
            let (lo, hi) = node.bounds.padded_f32();
            let first = if node.count == 0 { node_base + node.first } else { triangle_base + node.first };
            out.nodes.push(layout::BvhNode {
                lo,
                hi,
                first,
                count: node.count,
                axis: node.axis,
                primitives: node.count,
            });
        }
        for &t in &built.order {
            let [a, b, c] = mesh.triangles[t as usize];
            let flags = if mesh.smooth[t as usize] { layout::MESH_SMOOTH } else { 0 };
            out.triangles.push(layout::MeshTriangle {
                a: vertex_base + a,
                b: vertex_base + b,
                c: vertex_base + c,
                flags,
            });
        }
        for (i, p) in mesh.positions.iter().enumerate() {
            let n = mesh.normals.get(i).copied().unwrap_or([0.0; 3]);
            // OBJ's v = 0 is the image's bottom row, the textures' top (textures.glsl).
            let [u, v] = mesh.uvs.get(i).map_or([0.0, 0.0], |&[u, v]| [u, 1.0 - v]);
            out.vertices.push(layout::MeshVertex { position: [p[0], p[1], p[2], u], normal: [n[0], n[1], n[2], v] });
        }
    }
    if out.nodes.len() > layout::MAX_INDEX as usize || out.vertices.len() > layout::MAX_INDEX as usize {
        return Err(Error::Scene(format!(
            "{}: error: the scene's meshes need more nodes or vertices than the shader can index ({})",
            scene.path.display(),
            layout::MAX_INDEX
        )));
    }
    Ok(out)
}
