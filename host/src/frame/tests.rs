//! Packing scenes into frames: the camera, textures, checks, records and nesting.

use super::records::{box_steps, record_steps, stepped};
use super::*;
use crate::bvh::Aabb;
use crate::layout::Mat4;
use crate::scene::Camera;
use glam::DMat4;

/// The film corner (1, 1, -1) must map to the direction of the top-right
/// pixel edge given by docs/scene-format.md#camera: U/2·u + V/2·v - w.
#[test]
fn world_from_film_matches_the_documented_camera() {
    let cam = Camera {
        pos: DVec3::new(1.0, 2.0, 3.0),
        look: DVec3::new(0.0, 0.0, -2.0),
        up: DVec3::new(0.0, 1.0, 0.0),
        height_angle_deg: 90.0,
        ..Camera::default()
    };
    let m = world_from_film(&cam, 200, 100);
    // Looking down -z with y up: u = +x, v = +y, w = +z. V = 2, U = 4.
    let p = m.transform_point3(DVec3::new(1.0, 1.0, -1.0));
    let expect = DVec3::new(1.0 + 2.0, 2.0 + 1.0, 3.0 - 1.0);
    assert!((p - expect).length() < 1e-12, "film corner went to {p}, expected {expect}");
    let eye = m.transform_point3(DVec3::ZERO);
    assert!((eye - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12, "film origin went to {eye}, expected the eye");
}

/// Every primitive id is reached exactly once walking the packed
/// hierarchy from the root through every instance, every leaf's axis
/// is its first primitive, every node's box holds its children's, every instance record's box (as the shader
/// computes it) its root's, and every record's sphere the points of
/// every primitive it leads to.
#[test]
fn packed_hierarchy_reaches_every_primitive_once() {
    let xml = r#"<scenefile>
      <object type="tree" name="leaf"><transblock><object type="primitive" name="sphere"/></transblock>
        <transblock><translate x="1" y="0" z="0"/><object type="primitive" name="cube"/></transblock></object>
      <object type="tree" name="mid">
        <transblock><object type="primitive" name="cone"/></transblock>
        <transblock><translate x="3" y="0" z="0"/><object type="master" name="leaf"/></transblock>
        <transblock><translate x="0" y="3" z="0"/><scale x="2" y="2" z="2"/><object type="master" name="leaf"/></transblock></object>
      <object type="tree" name="root">
        <transblock><object type="master" name="mid"/></transblock>
        <transblock><rotate x="0" y="1" z="0" angle="30"/><translate x="10" y="0" z="0"/><object type="master" name="mid"/></transblock>
        <transblock><object type="primitive" name="cylinder"/></transblock>
        <transblock><translate x="-4" y="0" z="0"/><object type="master" name="leaf"/></transblock>
        <transblock><translate x="0" y="-6" z="0"/><scale x="8" y="0.25" z="0.25"/><object type="master" name="leaf"/></transblock>
      </object></scenefile>"#;
    let scene = crate::scene::from_xml(xml, "t.xml");
    assert_eq!(scene.primitive_count(), 2 * 5 + 1 + 2 + 2);
    let mut kinds = check_packed_hierarchy(&scene);
    // The generated families: spheres, upright cones, axis-aligned cubes.
    for family in
        [crate::gen::Family::RecursiveSpheres, crate::gen::Family::RecursiveCones, crate::gen::Family::RecursiveCubes]
    {
        let xml = crate::gen::generate(family, 3, &crate::gen::GenOptions { texture: None }).unwrap();
        let file = crate::scene::parse_str(&xml, std::path::Path::new("gen.xml"), &Default::default()).unwrap();
        let (boxes, spheres) = check_packed_hierarchy(&crate::scene::flatten(&file, &Default::default()).unwrap());
        kinds = (kinds.0 + boxes, kinds.1 + spheres);
    }
    assert!(kinds.0 > 0 && kinds.1 > 0, "records (boxes, spheres) {kinds:?}: both kinds checked");
}

/// A chain of masters `levels` deep: each a sphere and two smaller
/// copies of the one below, turned (the root places the top one).
fn chain(levels: usize) -> String {
    let mut xml = String::from(
        r#"<scenefile><object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>"#,
    );
    for i in 1..levels {
        xml += &format!(
            r#"<object type="tree" name="m{i}"><transblock><object type="primitive" name="sphere"/></transblock>
            <transblock><translate x="0.75" y="0" z="0"/><rotate x="0" y="1" z="0" angle="40"/><scale x="0.6" y="0.6" z="0.6"/><object type="master" name="m{}"/></transblock>
            <transblock><translate x="0" y="0.75" z="0"/><scale x="0.5" y="0.5" z="0.5"/><object type="master" name="m{}"/></transblock></object>"#,
            i - 1,
            i - 1
        );
    }
    xml + &format!(
        r#"<object type="tree" name="root"><transblock><object type="master" name="m{}"/></transblock></object></scenefile>"#,
        levels - 1
    )
}

/// Masters nested deeper than the shader's levels render: the deepest
/// levels are written out into the masters that place them until the
/// nesting fits, every primitive still reached once with its id; a
/// scene that fits is packed as it is.
#[test]
fn masters_nested_too_deeply_are_written_out_until_they_fit() {
    let max = layout::MAX_LEVELS as usize - 1;
    let fits = crate::scene::from_xml(chain(max), "fits.xml");
    let data = build(&fits, &RenderSettings::default()).unwrap();
    assert_eq!((data.levels, data.groups, data.notes.len()), (layout::MAX_LEVELS, max + 1, 0), "{:?}", data.notes);
    let deep = crate::scene::from_xml(chain(max + 3), "deep.xml");
    let data = build(&deep, &RenderSettings::default()).unwrap();
    assert_eq!((data.levels, data.groups), (layout::MAX_LEVELS, max + 1));
    assert_eq!(data.expanded, (1 << (max + 3)) - 1);
    assert_eq!(
        data.notes,
        [format!(
            "deep.xml: masters are nested {} deep, more than the shader's {max} levels: the deepest 3 levels written \
             out into the masters that place them ({} primitives stored, now {}, in {} groups)",
            max + 3,
            max + 3,
            (max - 1) + 15,
            max + 1
        )]
    );
    check_packed_hierarchy(&deep);
    // A long chain, each master placing the one before once (a file of
    // 2.8 MB): written out in one pass over the groups, where a round
    // per level over every group took minutes (cubic in the depth).
    let n = 20_000;
    let mut xml = String::from(
        r#"<scenefile><object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>"#,
    );
    for i in 1..n {
        xml += &format!(
            r#"<object type="tree" name="m{i}"><transblock><translate x="0.0001" y="0" z="0"/><object type="master" name="m{}"/></transblock></object>"#,
            i - 1
        );
    }
    xml += &format!(
        r#"<object type="tree" name="root"><transblock><object type="master" name="m{}"/></transblock></object></scenefile>"#,
        n - 1
    );
    let data = build(&crate::scene::from_xml(&xml, "long.xml"), &RenderSettings::default()).unwrap();
    assert_eq!((data.expanded, data.primitives.len(), data.groups), (1, 1, max + 1), "{:?}", data.notes);
    assert!(data.notes[0].contains(&format!("the deepest {} levels written out", n - max)), "{:?}", data.notes);
}

/// Points on a canonical shape's surface, its farthest from the centre.
fn surface_points(shape: u32) -> Vec<DVec3> {
    let mut points = Vec::new();
    for i in 0..27 {
        let d = DVec3::new((i % 3) as f64 - 1.0, ((i / 3) % 3) as f64 - 1.0, (i / 9) as f64 - 1.0);
        match shape {
            layout::SHAPE_SPHERE if d != DVec3::ZERO => points.push(d.normalize() * 0.5),
            layout::SHAPE_CUBE if d.abs() == DVec3::ONE => points.push(d * 0.5),
            _ => {}
        }
    }
    if shape == layout::SHAPE_CONE || shape == layout::SHAPE_CYLINDER {
        for k in 0..16 {
            let a = k as f64 * std::f64::consts::TAU / 16.0;
            points.push(DVec3::new(0.5 * a.cos(), -0.5, 0.5 * a.sin()));
            points.push(DVec3::new(0.5 * a.cos(), 0.5, 0.5 * a.sin()));
        }
    }
    points
}

/// The walk of `packed_hierarchy_reaches_every_primitive_once` over one
/// scene; how many box and sphere records it checked.
fn check_packed_hierarchy(scene: &Scene) -> (usize, usize) {
    let data = build(scene, &RenderSettings::default()).unwrap();
    assert!(data.frame.node_count > 0);
    let mat = |m: &Mat4| glam::Mat4::from_cols_array_2d(m).as_dmat4();
    let mut seen = vec![0u32; scene.primitive_count() as usize];
    let mut kinds = (0, 0);
    // (node, first id of the group, world from the group's space, the
    // spheres of the records that led there: their space from the
    // world's, centre, radius)
    type Spheres = Vec<(DMat4, DVec3, f64)>;
    let mut stack: Vec<(u32, u32, DMat4, Spheres)> = vec![(data.frame.root_node, 0u32, DMat4::IDENTITY, Vec::new())];
    while let Some((n, first_id, world_from_group, spheres)) = stack.pop() {
        let node = data.nodes[n as usize];
        if node.count == 0 {
            for c in [node.first, node.first + 1] {
                let child = data.nodes[c as usize];
                for a in 0..3 {
                    assert!(node.lo[a] <= child.lo[a] && node.hi[a] >= child.hi[a], "node {n} does not hold child {c}");
                }
                stack.push((c, first_id, world_from_group, spheres.clone()));
            }
            continue;
        }
        // A leaf's axis is its first primitive (the walk reads it in place of that item).
        let first = if node.primitives > 0 { data.leaf_items[node.first as usize].item } else { 0 };
        assert_eq!(node.axis, first, "node {n}: its axis is not its first primitive");
        for k in node.first..node.first + node.primitives {
            let item = data.leaf_items[k as usize].item;
            assert_eq!(item & layout::ITEM_INSTANCE, 0, "node {n}: item {k} is not a primitive");
            let p = &data.primitives[item as usize];
            seen[(first_id + p.id_offset) as usize] += 1;
            let world_from_object = world_from_group * mat(&p.object_from_world).inverse();
            for point in surface_points(p.shape) {
                let w = world_from_object.transform_point3(point);
                for (space_from_world, c, r) in &spheres {
                    let d = (space_from_world.transform_point3(w) - *c).length();
                    assert!(
                        d <= r * (1.0 + 1e-4),
                        "node {n}: primitive {item}'s point {w} is {d} from a record's sphere's centre {c}, radius {r}"
                    );
                }
            }
        }
        // The instances' records, from the next multiple of 4: each box,
        // as the shader computes it, holds the instance's root box mapped
        // back from the placed group's space (within rounding); each
        // sphere is checked at the primitives below it.
        let records = (node.first + node.primitives).next_multiple_of(4);
        for r in 0..node.count - node.primitives {
            let w: [u32; 4] = std::array::from_fn(|i| data.leaf_items[(records + 4 * r) as usize + i].item);
            assert_ne!(w[3] & layout::ITEM_INSTANCE, 0, "node {n}: record {r} is not an instance");
            let inst = data.instances[(w[3] & !(layout::ITEM_INSTANCE | layout::RECORD_SPHERE)) as usize];
            let m = mat(&inst.object_from_parent).inverse();
            let mut below = spheres.clone();
            let (q_lo, q_hi) = record_steps(w);
            if w[3] & layout::RECORD_SPHERE != 0 {
                kinds.1 += 1;
                let c = DVec3::from(std::array::from_fn::<f64, 3, _>(|a| {
                    f64::from(stepped(node.lo[a], node.hi[a], q_lo[a], 0).0)
                }));
                below.push((world_from_group.inverse(), c, f64::from(f32::from_bits(w[2]))));
            } else {
                kinds.0 += 1;
                let sides: [(f32, f32); 3] = std::array::from_fn(|a| stepped(node.lo[a], node.hi[a], q_lo[a], q_hi[a]));
                let (lo, hi) = (DVec3::from(sides.map(|s| f64::from(s.0))), DVec3::from(sides.map(|s| f64::from(s.1))));
                let root = data.nodes[inst.root as usize];
                let root_box = Aabb {
                    lo: glam::Vec3::from_slice(&root.lo).as_dvec3(),
                    hi: glam::Vec3::from_slice(&root.hi).as_dvec3(),
                };
                let slack = (hi - lo).max_element() * 1e-4;
                for corner in root_box.corners() {
                    let p = m.transform_point3(corner);
                    assert!(
                        p.cmpge(lo - slack).all() && p.cmple(hi + slack).all(),
                        "node {n}, record {r}: the root box's corner {p} is outside the record's box {lo} .. {hi}"
                    );
                }
            }
            stack.push((inst.root, first_id + inst.id_offset, world_from_group * m, below));
        }
    }
    assert!(seen.iter().all(|&s| s == 1), "ids reached other than once: {seen:?}");
    // Ids follow flatten order: the world matrices of primitive(id) agree.
    let flat = scene.flat_primitives();
    for (id, p) in flat.iter().enumerate() {
        assert_eq!(scene.primitive(id as u64).unwrap().world_from_object, p.world_from_object, "id {id}");
    }
    kinds
}

/// Steps hold the box exactly as the shader computes them, as tight as
/// a step allows; boxes outside the leaf, or too large for f32 steps,
/// have none.
#[test]
fn box_steps_hold_the_box_and_are_tight() {
    let leaf = ([-3.0f32, 1000.0, -1e-3, 0.0], [5.0f32, 1001.0, 1e-3, 0.0]);
    let inner = ([-1.0f32, 1000.25, -1e-3, 0.0], [4.999f32, 1000.5, 0.0, 0.0]);
    let (q_lo, q_hi) = box_steps(leaf, inner).unwrap();
    for a in 0..3 {
        let (lo, hi) = stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a]);
        assert!(lo <= inner.0[a] && hi >= inner.1[a], "axis {a}: {lo}..{hi}");
        // One step more is too many (or the count is at its largest).
        let (lo1, _) = stepped(leaf.0[a], leaf.1[a], q_lo[a] + 1, q_hi[a]);
        let (_, hi1) = stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a] + 1);
        assert!(lo1 > inner.0[a] || q_lo[a] == layout::BOX_STEPS, "axis {a}: low side not tight");
        assert!(hi1 < inner.1[a] || q_hi[a] == layout::BOX_STEPS, "axis {a}: high side not tight");
    }
    // The leaf itself: its own sides (some steps round to nothing at 1000).
    let (q_lo, q_hi) = box_steps(leaf, leaf).unwrap();
    for a in 0..3 {
        assert_eq!(stepped(leaf.0[a], leaf.1[a], q_lo[a], q_hi[a]), (leaf.0[a], leaf.1[a]), "axis {a}");
    }
    assert_eq!(box_steps(leaf, ([-4.0, 1000.0, 0.0, 0.0], [0.0, 1000.5, 0.0, 0.0])), None, "outside the leaf");
    let huge = ([-3e38f32, 0.0, 0.0, 0.0], [3e38f32, 1.0, 1.0, 0.0]);
    assert_eq!(box_steps(huge, huge), None, "a span beyond f32");
}

/// Leaves without instances hold their primitives and nothing else: the
/// padding before instance records is only where records follow.
#[test]
fn flat_leaves_are_not_padded() {
    let mut xml = String::from("<scenefile><object type=\"tree\" name=\"root\">");
    for k in 0..20 {
        xml.push_str(&format!(
            "<transblock><translate x=\"{}\" y=\"0\" z=\"0\"/><object type=\"primitive\" name=\"cube\"/></transblock>",
            3 * k
        ));
    }
    xml.push_str("</object></scenefile>");
    let scene = crate::scene::from_xml(xml, "t.xml");
    let data = build(&scene, &RenderSettings::default()).unwrap();
    assert!(data.frame.node_count > 1, "20 primitives get a hierarchy");
    assert_eq!(data.leaf_items.len(), 20);
}

#[test]
fn settings_reject_zero_and_absurd_sizes() {
    let mut s = RenderSettings { width: 0, ..RenderSettings::default() };
    assert!(s.validate().unwrap_err().0.contains("--width 0"));
    s.width = 10;
    s.height = MAX_IMAGE_SIDE + 1;
    assert!(s.validate().unwrap_err().0.contains("--height"));
    s.height = 10;
    assert!(s.validate().is_ok());
}

/// Materials written the same on several primitives are one material;
/// each primitive still gets the values it wrote.
#[test]
fn repeated_materials_are_folded() {
    let xml = r#"<scenefile><object type="tree" name="root">
        <transblock><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/></object></transblock>
        <transblock><translate x="2" y="0" z="0"/><object type="primitive" name="cube"><diffuse r="0" g="1" b="0"/></object></transblock>
        <transblock><translate x="4" y="0" z="0"/><object type="primitive" name="cone"><diffuse r="1" g="0" b="0"/></object></transblock>
        <transblock><translate x="6" y="0" z="0"/><object type="primitive" name="sphere"><diffuse r="1" g="0" b="0"/><shininess v="3"/></object></transblock>
      </object></scenefile>"#;
    let scene = crate::scene::from_xml(xml, "t.xml");
    assert_eq!(scene.materials.len(), 4, "the file writes four");
    let data = build(&scene, &RenderSettings::default()).unwrap();
    assert_eq!(data.materials.len(), 3, "red, green, red with a highlight");
    // Every primitive's packed material holds the values its element wrote.
    for (k, p) in scene.groups.iter().flat_map(|g| &g.primitives).enumerate() {
        let wrote = &scene.materials[p.material as usize];
        let got = &data.materials[data.primitives[k].material as usize];
        assert_eq!(got.diffuse[..3], wrote.diffuse, "primitive {k}");
        assert_eq!(got.shininess, wrote.shininess, "primitive {k}");
    }
    let first_red = data.primitives.iter().map(|p| p.material).collect::<Vec<_>>();
    assert_eq!(first_red[0], first_red[2], "the two plain red ones share one");
}

/// A texture is measured from its header before it is decoded: one
/// whose header claims 60000x60000 texels is refused with its size (it
/// was the image crate's "Memory limit exceeded"); a truncated one names
/// the file (and its size, where its header was whole); small ones load,
/// their format told by their content.
#[test]
fn textures_are_measured_before_they_are_decoded() {
    let dir = std::env::temp_dir().join(format!("raycast-frame-tex-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let texture = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        std::fs::write(&path, bytes).unwrap();
        let loc = crate::scene::SourceLoc { file: std::sync::Arc::new("t.xml".into()), line: 3, col: 7 };
        TextureRef { file: name.into(), resolved: Some(path), repeat_u: 1.0, repeat_v: 1.0, loc }
    };
    let mut table = TextureTable::default();
    // A PPM header alone: its size is read, its pixels never.
    let e = table.add(&texture("huge.ppm", b"P6\n60000 60000\n255\n")).unwrap_err().to_string();
    assert!(e.starts_with("t.xml:3:7: error: texture ") && e.contains("huge.ppm (60000x60000) does not fit"), "{e}");
    let e = table.add(&texture("header.ppm", b"P6\n4")).unwrap_err().to_string();
    assert!(e.starts_with("t.xml:3:7: error: cannot read texture ") && e.contains("header.ppm"), "{e}");
    // Its header whole, its pixels cut short: told with the size.
    let e = table.add(&texture("cut.ppm", b"P6\n4 4\n255\n\x01\x02")).unwrap_err().to_string();
    assert!(
        e.starts_with("t.xml:3:7: error: cannot read texture ") && e.contains("cut.ppm") && e.ends_with("(4x4)"),
        "{e}"
    );
    let small = dir.join("small.png");
    image::RgbImage::from_pixel(3, 2, image::Rgb([1, 2, 3])).save(&small).unwrap();
    let small = std::fs::read(&small).unwrap();
    assert_eq!(table.add(&texture("small2.png", &small)).ok(), Some(0));
    assert_eq!((table.textures[0].width, table.textures[0].height, table.texels.len()), (3, 2, 6));
    // Other formats, told by their content: a BMP under a .png name.
    let bmp = dir.join("small.bmp");
    image::RgbImage::from_pixel(2, 2, image::Rgb([4, 5, 6])).save(&bmp).unwrap();
    assert_eq!(table.add(&texture("bmp.png", &std::fs::read(&bmp).unwrap())).ok(), Some(1));
    assert_eq!(
        table.texels[6..].iter().map(|t| t.rgba).collect::<Vec<_>>(),
        vec![u32::from_le_bytes([4, 5, 6, 255]); 4]
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// A camera whose rows are closer than the floats resolve is refused,
/// by its angle a row (the picture's height counts): heightangle 1e-5
/// degrees at 384 rows, at its `<heightangle>`; 0.01 degrees there
/// renders, as 1e-5 at 1 row.
#[test]
fn rows_narrower_than_the_floats_resolve_are_refused() {
    let scene = |degrees: &str| {
        crate::scene::from_xml(
            format!(
                r#"<scenefile><cameradata><pos x="0" y="0" z="1e7"/><focus x="0" y="0" z="0"/><up x="0" y="1" z="0"/><heightangle v="{degrees}"/></cameradata>
<object type="tree" name="root"><transblock><object type="primitive" name="sphere"/></transblock></object></scenefile>"#
            ),
            "t.xml",
        )
    };
    let e = build(&scene("1e-5"), &RenderSettings::default()).map(|_| ()).unwrap_err().to_string();
    assert!(
        e.starts_with("t.xml:1:99: error: the camera's heightangle of 1e-5° over 384 rows is 4.5e-10 radians a row"),
        "{e}"
    );
    build(&scene("0.01"), &RenderSettings::default()).unwrap();
    build(&scene("1e-5"), &RenderSettings { width: 1, height: 1, ..RenderSettings::default() }).unwrap();
}

/// Lights whose distance the renderer's f32 cannot square are errors at
/// the element, not a light that lights nothing; just inside, they
/// render, as do transforms and a camera just inside f32 (beyond it:
/// flatten's `singular_transforms_are_errors_at_the_transblock` and the parser's
/// `camera_errors`).
#[test]
fn far_lights_are_errors_and_f32_extremes_render() {
    let scene_with = |camera: &str, light: &str, block: &str| {
        format!(
            r#"<scenefile><cameradata>{camera}<look x="0" y="0" z="-1"/><up x="0" y="1" z="0"/><heightangle v="45"/></cameradata>
<lightdata><id v="0"/><color r="1" g="1" b="1"/>{light}</lightdata>
<object type="tree" name="inner"><transblock><object type="primitive" name="cube"/></transblock></object>
<object type="tree" name="root">{block}</object></scenefile>"#
        )
    };
    let near_camera = r#"<pos x="0" y="0" z="5"/>"#;
    let near_light = r#"<position x="1" y="2" z="3"/>"#;
    let sphere =
        |transform: &str| format!(r#"<transblock>{transform}<object type="primitive" name="sphere"/></transblock>"#);
    let master =
        |transform: &str| format!(r#"<transblock>{transform}<object type="master" name="inner"/></transblock>"#);
    let outcome = |xml: String| {
        build(&crate::scene::from_xml(&xml, "t.xml"), &RenderSettings::default()).map(|_| ()).map_err(|e| e.to_string())
    };
    // Just inside: a translation of 1e38, a master scaled by 2e-15 and a
    // sphere by 5e14 (MAX_SCALING), a light 1e18 away, a camera at 1e38.
    for ok in [
        scene_with(near_camera, near_light, &sphere(r#"<translate x="1e38" y="0" z="0"/>"#)),
        scene_with(near_camera, near_light, &master(r#"<scale x="2e-15" y="1" z="1"/>"#)),
        scene_with(near_camera, near_light, &sphere(r#"<scale x="5e14" y="5e14" z="5e14"/>"#)),
        scene_with(near_camera, r#"<position x="1e18" y="0" z="0"/>"#, &sphere("")),
        scene_with(r#"<pos x="0" y="0" z="1e38"/>"#, near_light, &sphere("")),
    ] {
        outcome(ok).unwrap_or_else(|e| panic!("{e}"));
    }
    let e = outcome(scene_with(near_camera, r#"<position x="0" y="0" z="-2e19"/>"#, &sphere("")))
        .expect_err("a light 2e19 away");
    assert!(e.starts_with("t.xml:2:") && e.contains("this light is 2.000e19 units from the origin"), "{e}");
    // Beyond MAX_SCALING, an error at the element (a sphere scaled by
    // 1e20 drew as a ring; a master scaled by 1e-16; one scaled by 3e22
    // placing one scaled by 1e-23, 0.3 in all, drew nothing with the
    // hierarchy and the sphere with --no-bvh).
    let beyond = |xml: String, at: &str, scale: &str| {
        let e = outcome(xml).expect_err(at);
        assert!(e.starts_with(at) && e.contains(&format!("is scaled by {scale} in all")), "{e}");
    };
    beyond(
        scene_with(near_camera, near_light, &sphere(r#"<scale x="1e20" y="1e20" z="1e20"/>"#)),
        "t.xml:4:",
        "up to 1.0e20",
    );
    beyond(
        scene_with(near_camera, near_light, &master(r#"<scale x="1e-16" y="1" z="1"/>"#)),
        "t.xml:4:",
        "down to 1.0e-16",
    );
    let chain = r#"<scenefile><cameradata><pos x="0" y="0" z="5"/><look x="0" y="0" z="-1"/></cameradata>
<object type="tree" name="m0"><transblock><object type="primitive" name="sphere"/></transblock></object>
<object type="tree" name="m1"><transblock><scale x="1e-23" y="1e-23" z="1e-23"/><object type="master" name="m0"/></transblock></object>
<object type="tree" name="root"><transblock><scale x="3e22" y="3e22" z="3e22"/><object type="master" name="m1"/></transblock></object></scenefile>"#;
    beyond(chain.to_string(), "t.xml:4:", "up to 3.0e22");
    // The ranges compound down a chain of masters, each within the bound.
    let compound = chain.replace("3e22", "1e8").replace("1e-23", "1e8");
    beyond(compound, "t.xml:3:", "up to 1.0e16");
}
