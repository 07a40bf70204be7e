//! Triangle meshes: OBJ files (docs/scene-format.md#triangle-meshes), read
//! with the `tobj` crate after a scan of our own that names the line of the
//! first problem (tobj's errors name none).
//!
//! A mesh keeps what the file gives: positions; normals where it has `vn`
//! (the triangles of an OBJ object whose every corner has one are drawn
//! smooth, the others flat, with the face's own normal); texture
//! coordinates where it has `vt` (else 0, 0). Polygons are fanned into
//! triangles.

use std::io::BufRead;
use std::path::Path;
use std::sync::Arc;

use crate::bvh::Aabb;
pub use crate::scene::model::Mesh;
use crate::scene::model::{SceneError, SourceLoc};
use glam::DVec3;

/// A problem with an OBJ file at `line` (0: the file as a whole).
fn obj_error(path: &Path, line: u32, message: String) -> SceneError {
    let file = Arc::new(path.to_path_buf());
    let loc = (line > 0).then(|| SourceLoc { file: file.clone(), line, col: 1 });
    SceneError { loc, file, message }
}

/// Loads the OBJ file at `path` (already looked up). `used_at` is the scene
/// element that names it, for messages.
pub fn load(path: &Path, used_at: &SourceLoc) -> Result<Mesh, SceneError> {
    let cannot = |e: String| obj_error(path, 0, format!("cannot read mesh file ({e}; named at {used_at})"));
    let text = std::fs::read(path).map_err(|e| cannot(e.to_string()))?;
    scan(path, &text, used_at)?;
    let options = tobj::LoadOptions { single_index: true, triangulate: true, ignore_points: true, ignore_lines: true };
    let (models, _materials) = tobj::load_obj_buf(&mut std::io::BufReader::new(&text[..]), &options, |_| {
        Err(tobj::LoadError::GenericFailure) // materials are the scene's, not the OBJ's
    })
    .map_err(|e| obj_error(path, 0, format!("malformed OBJ file: {e} (named at {used_at})")))?;
    let mut mesh = Mesh {
        path: path.to_path_buf(),
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        triangles: Vec::new(),
        smooth: Vec::new(),
        bounds: Aabb::EMPTY,
        file_bytes: text.len() as u64,
    };
    let any_normals = models.iter().any(|m| !m.mesh.normals.is_empty());
    let any_uvs = models.iter().any(|m| !m.mesh.texcoords.is_empty());
    for model in &models {
        let m = &model.mesh;
        let base = mesh.positions.len() as u32;
        let count = m.positions.len() / 3;
        let smooth = m.normals.len() == m.positions.len();
        for v in 0..count {
            let p = [m.positions[3 * v], m.positions[3 * v + 1], m.positions[3 * v + 2]];
            let d = DVec3::new(p[0].into(), p[1].into(), p[2].into());
            mesh.bounds = mesh.bounds.union(Aabb { lo: d, hi: d });
            mesh.positions.push(p);
            if any_normals {
                mesh.normals.push(if smooth {
                    [m.normals[3 * v], m.normals[3 * v + 1], m.normals[3 * v + 2]]
                } else {
                    [0.0; 3]
                });
            }
            if any_uvs {
                let uv = if m.texcoords.len() == 2 * count {
                    [m.texcoords[2 * v], m.texcoords[2 * v + 1]]
                } else {
                    [0.0; 2]
                };
                mesh.uvs.push(uv);
            }
        }
        for t in m.indices.chunks_exact(3) {
            mesh.triangles.push([base + t[0], base + t[1], base + t[2]]);
            mesh.smooth.push(smooth);
        }
    }
    if mesh.triangles.is_empty() {
        return Err(obj_error(path, 0, format!("mesh file has no faces (f lines) to draw (named at {used_at})")));
    }
    Ok(mesh)
}

/// The checks tobj makes, with the line: every number of a `v`, `vn` or
/// `vt` line finite, every face of at least three corners, each corner's
/// indices (1-based, or negative from the end) within what came before.
fn scan(path: &Path, text: &[u8], used_at: &SourceLoc) -> Result<(), SceneError> {
    let (mut v, mut vt, mut vn) = (0i64, 0i64, 0i64);
    for (i, line) in text.lines().enumerate() {
        let n = i as u32 + 1;
        let bad = |message: String| obj_error(path, n, format!("malformed OBJ file: {message} (named at {used_at})"));
        let line = line.map_err(|e| bad(e.to_string()))?;
        let mut words = line.split_whitespace();
        let Some(key) = words.next() else { continue };
        let numbers = |need: usize, what: &str, words: std::str::SplitWhitespace| -> Result<(), SceneError> {
            let got: Vec<&str> = words.collect();
            if got.len() < need {
                return Err(bad(format!("{what} needs {need} numbers, has {}", got.len())));
            }
            for w in got {
                match w.parse::<f32>() {
                    Ok(x) if x.is_finite() => {}
                    _ => return Err(bad(format!("{what} has \"{w}\", not a finite number"))),
                }
            }
            Ok(())
        };
        match key {
            "v" => {
                numbers(3, "a vertex (v)", words)?;
                v += 1;
            }
            "vn" => {
                numbers(3, "a normal (vn)", words)?;
                vn += 1;
            }
            "vt" => {
                numbers(2, "a texture coordinate (vt)", words)?;
                vt += 1;
            }
            "f" => {
                let corners: Vec<&str> = words.collect();
                if corners.len() < 3 {
                    return Err(bad(format!("a face (f) needs 3 corners or more, has {}", corners.len())));
                }
                for c in corners {
                    let parts: Vec<&str> = c.split('/').collect();
                    if parts.len() > 3 || parts[0].is_empty() {
                        return Err(bad(format!("face corner \"{c}\" is not v, v/vt, v//vn or v/vt/vn")));
                    }
                    for (k, (part, have, what)) in parts
                        .iter()
                        .zip([(v, "vertices (v)"), (vt, "texture coordinates (vt)"), (vn, "normals (vn)")])
                        .map(|(p, (h, w))| (p, h, w))
                        .enumerate()
                    {
                        if part.is_empty() && k > 0 {
                            continue;
                        }
                        let Ok(index) = part.parse::<i64>() else {
                            return Err(bad(format!("face corner \"{c}\" has \"{part}\", not an index")));
                        };
                        let resolved = if index < 0 { have + index + 1 } else { index };
                        if index == 0 || resolved < 1 || resolved > have {
                            return Err(bad(format!(
                                "face corner \"{c}\" refers to {what} {index}, but the file has {have} of them by this line"
                            )));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    fn at() -> SourceLoc {
        SourceLoc { file: Arc::new(PathBuf::from("s.xml")), line: 3, col: 5 }
    }

    fn load_text(name: &str, text: &str) -> Result<Mesh, SceneError> {
        let dir = std::env::temp_dir().join(format!("raycast-mesh-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        std::fs::write(&path, text).unwrap();
        load(&path, &at())
    }

    #[test]
    fn a_quad_is_two_flat_triangles_and_a_triangle_with_normals_is_smooth() {
        let m = load_text("quad.obj", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\n").unwrap();
        assert_eq!((m.positions.len(), m.triangles.len(), m.normals.len(), m.uvs.len()), (4, 2, 0, 0));
        assert_eq!(m.smooth, vec![false, false]);
        assert_eq!(m.bounds.hi, DVec3::new(1.0, 1.0, 0.0));
        let m =
            load_text("smooth.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nvt 0.5 1\nf 1/1/1 2/1/1 3/1/1\n").unwrap();
        assert_eq!((m.triangles.len(), m.normals.len(), m.uvs.len()), (1, 3, 3));
        assert_eq!((m.smooth[0], m.normals[0], m.uvs[2]), (true, [0.0, 0.0, 1.0], [0.5, 1.0]));
    }

    #[test]
    fn malformed_files_name_the_line() {
        let cases = [
            ("v 0 0 0\nv 1 0 x\n", 2, "not a finite number"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n", 4, "refers to vertices (v) 4, but the file has 3"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2\n", 5, "needs 3 corners"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 3/1 2/1 1/1\n", 4, "texture coordinates (vt) 1, but the file has 0"),
            ("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -4\n", 4, "refers to vertices (v) -4"),
            ("v 1 2\n", 1, "needs 3 numbers, has 2"),
        ];
        for (text, line, what) in cases {
            let e = load_text("bad.obj", text).unwrap_err();
            let shown = e.to_string();
            assert_eq!(e.loc.as_ref().map(|l| l.line), Some(line), "{shown}");
            assert!(shown.contains(what) && shown.contains("bad.obj:") && shown.contains("s.xml:3:5"), "{shown}");
        }
        let e = load_text("empty.obj", "# nothing\nv 0 0 0\n").unwrap_err().to_string();
        assert!(e.contains("no faces"), "{e}");
        let e = load(Path::new("/nonexistent/raycast/x.obj"), &at()).unwrap_err().to_string();
        assert!(e.contains("cannot read mesh file") && e.contains("x.obj"), "{e}");
    }

    #[test]
    fn negative_indices_count_from_the_end() {
        let m = load_text("neg.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -3 -2 -1\n").unwrap();
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
    }
}
