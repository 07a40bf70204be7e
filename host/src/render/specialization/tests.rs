//! Which constants a scene turns on, and how they are named.

use super::*;
use crate::frame::{Aov, RenderSettings};

fn data(xml: &str, settings: &RenderSettings) -> FrameData {
    let scene = crate::scene::from_xml(xml, "t.xml");
    crate::frame::build(&scene, settings).unwrap()
}

/// The features' constants that are on, by SPEC_* name, as `describe` lists them.
fn on(s: Specialization) -> Vec<u32> {
    let mut ids: Vec<u32> =
        (0..SPEC_COUNT as u32).filter(|&id| is_feature(id) && s.constants()[id as usize] == 1).collect();
    ids.sort_by_key(|&id| listed_order(id));
    ids
}

/// A constant is on exactly when the scene and the flags can reach its
/// code: shapes, instances, light kinds, textures, filters, specular,
/// shadows, mirrors, inner hierarchy nodes, leaves of several
/// primitives, and the hierarchy or the flat list, each turned off where
/// absent.
#[test]
fn specialization_keeps_what_the_scene_can_reach() {
    let plain = r#"<scenefile><globaldata><specularcoeff v="0.5"/></globaldata>
      <lightdata><id v="0"/><type v="directional"/><direction x="0" y="-1" z="0"/></lightdata>
      <object type="tree" name="root"><transblock><object type="primitive" name="cube">
        <reflective r="0" g="0.5" b="0"/></object></transblock></object></scenefile>"#;
    let d = data(plain, &RenderSettings::default());
    assert_eq!(
        on(Specialization::of(&d, &d.frame)),
        [layout::SPEC_CUBES, layout::SPEC_SHADOWS, layout::SPEC_REFLECTIONS, layout::SPEC_FLAT_LIST]
    );
    let flat = RenderSettings { shadows: false, reflections: false, ..RenderSettings::default() };
    let d = data(plain, &flat);
    assert_eq!(on(Specialization::of(&d, &d.frame)), [layout::SPEC_CUBES, layout::SPEC_FLAT_LIST]);

    let rich = r#"<scenefile><globaldata><specularcoeff v="0"/></globaldata>
      <lightdata><id v="0"/><type v="spot"/><direction x="0" y="-1" z="0"/><angle v="30"/><penumbra v="5"/></lightdata>
      <object type="tree" name="m"><transblock><object type="primitive" name="cone">
        <reflective r="1" g="1" b="1"/><shininess v="20"/></object></transblock></object>
      <object type="tree" name="root">
        <transblock><object type="primitive" name="sphere"/></transblock>
        <transblock><object type="primitive" name="cylinder"/></transblock>
        <transblock><translate x="2" y="0" z="0"/><object type="master" name="m"/></transblock>
        <transblock><translate x="4" y="0" z="0"/><object type="master" name="m"/></transblock></object></scenefile>"#;
    let d = data(rich, &RenderSettings::default());
    let s = on(Specialization::of(&d, &d.frame));
    // k_s = 0: no mirror weight, so no reflections; no texture.
    let expect = [
        layout::SPEC_CONES,
        layout::SPEC_CYLINDERS,
        layout::SPEC_SPHERES,
        layout::SPEC_INSTANCES,
        layout::SPEC_POSITIONED_LIGHTS,
        layout::SPEC_SPOT_LIGHTS,
        layout::SPEC_SPECULAR,
        layout::SPEC_SHADOWS,
        layout::SPEC_SEVERAL_PRIMITIVE_LEAVES,
        layout::SPEC_HIERARCHY,
        layout::SPEC_SPHERE_RECORDS,
    ];
    assert_eq!(s, expect);
    assert_ne!(Specialization::of(&d, &d.frame), Specialization::ALL);
    assert_eq!(
        Specialization::of(&d, &d.frame).describe(),
        "keeps cones, cylinders, spheres, instances, point and spot lights, spot falloff, specular, shadows, \
         leaves of several primitives, the hierarchy walk, instance spheres; leaves out cubes, tori, meshes, textures, bilinear filtering, \
         mirrors, inner hierarchy nodes, the flat primitive list, instance boxes, the normal, depth, id and cost AOVs, \
         refraction, area lights, depth of field, the course's adaptive supersampling, explain's variants; the walk's 2 levels in registers; \
         a leaf's met instances one stack entry"
    );
    // The CPU build's lean copy draws it; never everything.
    assert!(Specialization::of(&d, &d.frame).cpu_lean());
    assert!(!Specialization::ALL.cpu_lean());
    // An AOV other than colour keeps its code, and the CPU build's whole copy draws it.
    for aov in [Aov::Normal, Aov::Depth, Aov::Id, Aov::Cost, Aov::CostAll] {
        let d = data(rich, &RenderSettings { aov, ..RenderSettings::default() });
        assert!(on(Specialization::of(&d, &d.frame)).contains(&layout::SPEC_AOVS), "{aov:?}");
        assert!(!Specialization::of(&d, &d.frame).cpu_lean(), "{aov:?}");
    }
    // Each group of `rich` fits one leaf; twenty cubes in a row do not.
    let d = data(&crate::scene::row_of_cubes_xml(20), &RenderSettings::default());
    assert!(d.nodes.iter().any(|n| n.count == 0), "twenty primitives make inner nodes");
    assert!(on(Specialization::of(&d, &d.frame)).contains(&layout::SPEC_INNER_NODES));
    // One sphere and its child instances in each group's one leaf: neither.
    let options = crate::gen::GenOptions { texture: None };
    let spheres = crate::gen::generate(crate::gen::Family::RecursiveSpheres, 3, &options).unwrap();
    let d = data(&spheres, &RenderSettings::default());
    let s = on(Specialization::of(&d, &d.frame));
    assert!(!s.contains(&layout::SPEC_INNER_NODES) && !s.contains(&layout::SPEC_SEVERAL_PRIMITIVE_LEAVES), "{s:?}");
    // Their instances are bounded by spheres; a long thin one by its box.
    assert!(s.contains(&layout::SPEC_SPHERE_RECORDS) && !s.contains(&layout::SPEC_BOX_RECORDS), "{s:?}");
    let plank = r#"<scenefile><object type="tree" name="m"><transblock><object type="primitive" name="cube"/></transblock></object>
      <object type="tree" name="root"><transblock><scale x="10" y="0.1" z="0.1"/><object type="master" name="m"/></transblock></object></scenefile>"#;
    let d = data(plank, &RenderSettings::default());
    let s = on(Specialization::of(&d, &d.frame));
    assert!(s.contains(&layout::SPEC_BOX_RECORDS) && !s.contains(&layout::SPEC_SPHERE_RECORDS), "{s:?}");
    assert!(Specialization::ALL.describe().ends_with("leaves out nothing"));
    // Every feature's constant has its name, once.
    let mut ids: Vec<u32> = spec_names().iter().map(|(id, _)| *id).collect();
    ids.sort();
    assert_eq!(ids, (0..SPEC_COUNT as u32).filter(|&id| is_feature(id)).collect::<Vec<_>>());
}

/// FLAG_REFRACTION and SPEC_REFRACTION: on only where a material lets
/// light through (k_t O_t has a channel other than 0) and refraction is
/// not turned off; a transparent colour with k_t = 0, or k_t with no
/// transparent colour, keeps the opaque kernel.
#[test]
fn refraction_is_kept_only_where_a_material_transmits() {
    let scene = |kt: &str, transparent: &str| {
        format!(
            r#"<scenefile><globaldata><transparentcoeff v="{kt}"/></globaldata><object type="tree" name="root">
              <transblock><object type="primitive" name="sphere"><transparent r="{transparent}" g="0" b="0"/><ior v="1.5"/></object></transblock>
              </object></scenefile>"#
        )
    };
    for (kt, transparent, settings, want) in [
        ("0.5", "0.8", RenderSettings::default(), true),
        ("0.5", "0.8", RenderSettings { refraction: false, ..RenderSettings::default() }, false),
        ("0", "0.8", RenderSettings::default(), false),
        ("0.5", "0", RenderSettings::default(), false),
    ] {
        let d = data(&scene(kt, transparent), &settings);
        assert_eq!(d.frame.flags & layout::FLAG_REFRACTION != 0, want, "k_t {kt}, O_t {transparent}, {settings:?}");
        let s = on(Specialization::of(&d, &d.frame));
        assert_eq!(s.contains(&layout::SPEC_REFRACTION), want, "k_t {kt}, O_t {transparent}: {s:?}");
    }
}

/// A kernel specialised for a scene keeps the walk's levels in
/// registers, as many as the scene nests (layout.h); `ALL`, in arrays.
#[test]
fn specialization_chooses_the_walks_form_by_the_levels() {
    let levels = |depth: u32| {
        let options = crate::gen::GenOptions { texture: None };
        let xml = crate::gen::generate(crate::gen::Family::RecursiveSpheres, depth, &options).unwrap();
        let d = data(&xml, &RenderSettings::default());
        let c = Specialization::of(&d, &d.frame).constants();
        (d.levels, c[layout::SPEC_LEVELS_IN_REGISTERS as usize], c[layout::SPEC_REGISTER_LEVELS as usize])
    };
    // Depth N: the root and N - 1 masters nested.
    assert_eq!(levels(1), (1, 1, 1));
    assert_eq!(levels(4), (4, 1, 4));
    assert_eq!(levels(10), (10, 1, 10));
    let d = data(&crate::scene::row_of_cubes_xml(20), &RenderSettings::default());
    assert_eq!(d.levels, 1);
    assert!(Specialization::of(&d, &d.frame).describe().ends_with("; the walk's one level in registers"));
    assert_eq!(Specialization::ALL.constants()[layout::SPEC_LEVELS_IN_REGISTERS as usize], 0);
}

/// A leaf's met instance records go on the stack as one entry where the
/// scene has instances and every record's texel fits the entry's bits;
/// `ALL` (the C++ build's form), one entry a record.
#[test]
fn record_masks_where_instances_fit_the_entry() {
    let masks = |xml: &str| {
        let d = data(xml, &RenderSettings::default());
        Specialization::of(&d, &d.frame).constants()[layout::SPEC_RECORD_MASKS as usize]
    };
    let options = crate::gen::GenOptions { texture: None };
    assert_eq!(masks(&crate::gen::generate(crate::gen::Family::RecursiveSpheres, 3, &options).unwrap()), 1);
    assert_eq!(masks(&crate::scene::row_of_cubes_xml(20)), 0, "no instances");
    assert_eq!(Specialization::ALL.constants()[layout::SPEC_RECORD_MASKS as usize], 0);
    // The last texel an entry can name, and one past it.
    let words = 4 * layout::RECORD_MASKS_TEXELS as usize;
    assert!(records_fit_masks(words) && records_fit_masks(words - 3));
    assert!(!records_fit_masks(words + 1));
}
