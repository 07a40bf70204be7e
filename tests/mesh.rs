//! Triangle meshes drawn by the CPU build of the shared GLSL (the check
//! suite holds the device to the same bits):
//!
//! - Watertight: a pinwheel of 8 triangles around a shared centre vertex,
//!   its edges along the axes and diagonals, fills a square picture of odd
//!   side; the centre pixel's ray passes exactly through the shared vertex,
//!   the centre row's and column's exactly along shared edges, the
//!   diagonals' exactly through the diagonal edges. Rule: every pixel hits,
//!   none slips through (0 misses).
//! - The corpus's mesh/sphere.obj (radius 1, 800 faces) scaled by 0.5
//!   against the analytic sphere, the same camera: coverage, every pixel hit
//!   by one and not the other lies on the analytic silhouette (within a
//!   pixel of it: the facets, 9 degrees apart in longitude and latitude,
//!   cut at most 0.0015 inside the sphere, 0.6 pixel here); normals where
//!   both hit within 9 degrees, one facet's step (smooth normals
//!   interpolated from the vertices', at a point on the facet).
//!   The measured figures are printed.

use raycast::cpu::CpuRenderer;
use raycast::frame::{self, RenderSettings};
use raycast::layout::NO_HIT;
use raycast::scene::{self, FlattenLimits, ParseOptions};
use std::path::{Path, PathBuf};

mod common;

fn temp_dir(name: &str) -> PathBuf {
    let dir = Path::new(env!("CARGO_TARGET_TMPDIR")).join("mesh").join(name);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

fn scene_xml(camera_z: f32, objects: &str) -> String {
    format!(
        r#"<scenefile>
  <globaldata><ambientcoeff v="0.5"/><diffusecoeff v="0.5"/><specularcoeff v="0.5"/></globaldata>
  <cameradata><pos x="0" y="0" z="{camera_z}"/><look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="30"/></cameradata>
  <lightdata><id v="0"/><type v="directional"/><color r="1" g="1" b="1"/><direction x="0" y="0" z="-1"/></lightdata>
  <object type="tree" name="root">{objects}</object>
</scenefile>"#
    )
}

fn render(dir: &Path, xml: &str, assets: Vec<PathBuf>, side: u32) -> raycast::render::Picture {
    let path = dir.join("scene.xml");
    std::fs::write(&path, xml).unwrap();
    let scene = scene::load(&path, &ParseOptions { assets, ..ParseOptions::default() }, &FlattenLimits::default())
        .unwrap_or_else(|e| panic!("{e}"));
    let settings = RenderSettings { width: side, height: side, ..RenderSettings::default() };
    let data = frame::build(&scene, &settings).unwrap();
    CpuRenderer::new().unwrap().render(&data).unwrap()
}

#[test]
fn rays_through_shared_edges_and_vertices_never_slip_through() {
    let dir = temp_dir("pinwheel");
    // Centre 1, then the 8 points around it; triangles (1, k, k + 1).
    let mut obj = String::from("v 0 0 0\n");
    for (x, y) in [(1, 0), (1, 1), (0, 1), (-1, 1), (-1, 0), (-1, -1), (0, -1), (1, -1)] {
        obj += &format!("v {x} {y} 0\n");
    }
    for k in 0..8 {
        obj += &format!("f 1 {} {}\n", k + 2, (k + 1) % 8 + 2);
    }
    std::fs::write(dir.join("pinwheel.obj"), obj).unwrap();
    // The square spans more than the picture: every pixel's ray meets it.
    for (side, z) in [(63u32, 2.0f32), (101, 1.5), (7, 3.0)] {
        let mesh = r#"<transblock><object type="primitive" name="mesh" meshfile="pinwheel.obj"><diffuse r="1" g="1" b="1"/></object></transblock>"#;
        let picture = render(&dir, &scene_xml(z, mesh), vec![], side);
        let misses = picture.pixels.iter().filter(|p| p.id == NO_HIT).count();
        let c = (side / 2) as usize;
        println!("pinwheel {side}x{side} from z = {z}: {misses} of {} pixels miss (rule: 0)", side * side);
        assert_eq!(misses, 0, "rays slipped through the shared edges");
        assert_eq!(picture.pixels[c * side as usize + c].id, 0, "the centre ray, through the shared vertex");
    }
}

#[test]
fn the_mesh_sphere_matches_the_analytic_sphere() {
    let Some(corpus) = common::corpus("the mesh sphere against the analytic sphere") else { return };
    let dir = temp_dir("sphere");
    let side = 255u32;
    let placed = |object: &str| {
        format!(r#"<transblock><object type="primitive" {object}><diffuse r="1" g="1" b="1"/></object></transblock>"#)
    };
    let analytic = render(&dir, &scene_xml(2.5, &placed(r#"name="sphere""#)), vec![], side);
    let mesh_object = r#"<transblock><scale x="0.5" y="0.5" z="0.5"/><object type="primitive" name="mesh" meshfile="mesh/sphere.obj"><diffuse r="1" g="1" b="1"/></object></transblock>"#;
    let mesh = render(&dir, &scene_xml(2.5, mesh_object), vec![corpus], side);
    let hit = |p: &raycast::layout::PixelOut| p.id != NO_HIT;
    let s = side as usize;
    // On the analytic silhouette: the pixel or one of its 8 neighbours is
    // hit where another is not.
    let on_silhouette = |i: usize| {
        let (x, y) = ((i % s) as i64, (i / s) as i64);
        let mut kinds = [false, false];
        for dy in -1..=1 {
            for dx in -1..=1 {
                let (nx, ny) = (x + dx, y + dy);
                let h = nx >= 0
                    && ny >= 0
                    && nx < s as i64
                    && ny < s as i64
                    && hit(&analytic.pixels[ny as usize * s + nx as usize]);
                kinds[usize::from(h)] = true;
            }
        }
        kinds[0] && kinds[1]
    };
    let differ: Vec<usize> = (0..s * s).filter(|&i| hit(&analytic.pixels[i]) != hit(&mesh.pixels[i])).collect();
    let off_silhouette = differ.iter().filter(|&&i| !on_silhouette(i)).count();
    let silhouette = (0..s * s).filter(|&i| on_silhouette(i)).count();
    let (mut worst, mut sum, mut both) = (0.0f64, 0.0f64, 0usize);
    for (a, m) in analytic.pixels.iter().zip(&mesh.pixels).filter(|(a, m)| hit(a) && hit(m)) {
        let (na, nm) = (a.normal, m.normal);
        let dot: f64 = (0..3).map(|k| f64::from(na[k]) * f64::from(nm[k])).sum();
        let angle = dot.clamp(-1.0, 1.0).acos().to_degrees();
        worst = worst.max(angle);
        sum += angle;
        both += 1;
    }
    println!(
        "mesh sphere against the analytic sphere, {side}x{side}: coverage differs in {} pixels, {off_silhouette} of \
         them off the analytic silhouette's {silhouette} pixels (rule: 0 off it); normals at most {worst:.3} degrees \
         apart, {:.3} on average over {both} pixels (rule: at most 9, the facets' angular step)",
        differ.len(),
        sum / both as f64
    );
    assert_eq!(off_silhouette, 0, "coverage differs away from the silhouette");
    assert!(worst <= 9.0, "normals {worst} degrees apart");
}
