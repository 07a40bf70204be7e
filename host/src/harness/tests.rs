//! The harness on lavapipe with the validation layer on.

use super::*;

fn harness() -> Harness {
    let opts = HarnessOptions {
        shaders: None,
        device: Some(DeviceSelector::Name("llvmpipe".into())),
        validation: true,
        timeout: crate::gpu::GpuOptions::default().timeout,
    };
    Harness::new(&opts).unwrap_or_else(|e| panic!("{e}"))
}

fn assert_no_messages(h: &Harness) {
    let m = h.take_validation_messages();
    assert!(m.is_empty(), "validation messages:\n{}", m.join("\n"));
}

#[test]
fn cases_pass_fail_and_report_readably() {
    let mut h = harness();
    let cases = [
        Case::new("dot3").input("a", [1.0f32, 2.0, 3.0]).input("b", [4.0f32, 5.0, 6.0]).expect(32.0f32, Rule::Exact),
        Case::new("dot3")
            .named("dot3 with a wrong expectation")
            .input("a", [1.0f32, 2.0, 3.0])
            .input("b", [4.0f32, 5.0, 6.0])
            .expect(33.0f32, Rule::Ulp(1)),
        Case::new("min_f").input("a", f32::NAN).input("b", 1.0f32).same_as_cpu(Rule::Exact),
        Case::new("quadratic_roots")
            .input("a", 1.0f32)
            .input("b", -3.0f32)
            .input("c", 2.0f32)
            .expect([1.0f32, 2.0], Rule::Exact),
    ];
    let r = h.run(&cases);
    assert!(r[0].passed, "{}", r[0].report);
    assert!(!r[1].passed);
    assert!(r[2].passed, "{}", r[2].report);
    assert!(r[3].passed, "{}", r[3].report);
    assert_eq!(r[0].device, Some(Value::Float(32.0)));
    assert_eq!(r[0].cpu, Some(Value::Float(32.0)));
    let report = &r[1].report;
    for needle in [
        "FAIL dot3 with a wrong expectation",
        "function: float dot3(vec3 a, vec3 b)",
        "a = (1.0, 2.0, 3.0) [0x3f800000 0x40000000 0x40400000]",
        "rule:     ulp 1",
        "33.0 (0x42040000)",
        "32.0 (0x42000000)",
        "262144",
        "<< device, cpu",
    ] {
        assert!(report.contains(needle), "report lacks {needle:?}:\n{report}");
    }
    assert_eq!(summary(&r).lines().last(), Some("3 passed, 1 failed"));
    assert!(summary(&r).contains("1 of 4 cases failed; the first: dot3 with a wrong expectation"));
    assert_no_messages(&h);
}

#[test]
fn scene_buffers_reach_the_function() {
    let mut h = harness();
    // A 3x3 image, identity world_from_film, eye at the origin: the centre
    // pixel's ray is (0, 0, -1) (as host/cpu/intersect_test.cpp).
    let frame = layout::Frame {
        world_from_film: glam::Mat4::IDENTITY.to_cols_array_2d(),
        eye: [0.0, 0.0, 0.0, 1.0],
        width: 3,
        height: 3,
        ..Default::default()
    };
    let scene = Arc::new(SceneBuffers::new().frame(&frame));
    let ray = Value::ray([0.0f32, 0.0, 0.0], [0.0f32, 0.0, -1.0]);
    let centre = Case::new("camera_ray")
        .input("j", 1u32)
        .input("i", 1u32)
        .input("offset", [0.0f32, 0.0])
        .expect(ray, Rule::Exact)
        .scene(scene.clone());
    // One unit cube at the origin; a miss returns id NO_HIT = the sentinel's
    // bits, which the written word tells apart from "never written".
    let cube = layout::Primitive {
        object_from_world: glam::Mat4::IDENTITY.to_cols_array_2d(),
        shape: layout::SHAPE_CUBE,
        ..Default::default()
    };
    let one = Arc::new(SceneBuffers::new().frame(&layout::Frame { primitive_count: 1, ..frame }).primitives(&[cube]));
    let miss = Case::new("trace").input("r", Value::ray([0.0f32, 0.0, 2.0], [0.0f32, 0.0, 1.0])).scene(one.clone());
    let hit = Case::new("trace").input("r", Value::ray([0.0f32, 0.0, 2.0], [0.0f32, 0.0, -1.0])).scene(one);
    let r = h.run(&[centre, miss, hit]);
    for x in &r {
        assert!(x.passed, "{}", x.report);
    }
    let miss = r[1].device.as_ref().unwrap();
    assert_eq!(miss.get("id"), Some(&Value::Uint(layout::NO_HIT)));
    let hit = r[2].device.as_ref().unwrap();
    assert_eq!(hit.get("id"), Some(&Value::Uint(0)));
    assert_eq!(hit.get("t"), Some(&Value::Float(1.5)));
    assert_no_messages(&h);
}

#[test]
fn mistakes_in_a_case_fail_it_with_the_reason() {
    let mut h = harness();
    let r = h.run(&[
        Case::new("no_such_function").expect(1.0f32, Rule::Exact),
        Case::new("dot3").input("a", [1.0f32, 2.0, 3.0]).expect(1.0f32, Rule::Exact),
        Case::new("dot3").input("a", [1.0f32, 2.0, 3.0]).input("b", 1.0f32).expect(1.0f32, Rule::Exact),
        Case::new("dot3")
            .input("a", [1.0f32, 2.0, 3.0])
            .input("b", [1.0f32, 2.0, 3.0])
            .same_as_cpu(Rule::Exact)
            .without_cpu(),
    ]);
    assert!(r.iter().all(|x| !x.passed));
    assert!(r[0].report.contains("no top-level function \"no_such_function\""), "{}", r[0].report);
    assert!(r[1].report.contains("input b of float dot3(vec3 a, vec3 b) is missing"), "{}", r[1].report);
    assert!(r[2].report.contains("input b: expected a vec3"), "{}", r[2].report);
    assert!(r[3].report.contains("needs the C++ build"), "{}", r[3].report);
}

#[test]
fn an_unwritten_case_fails_even_when_its_words_could_be_legitimate() {
    // What the device returns when the kernel never reached a case: every
    // word still the sentinel. For `trace`, id = 0xffffffff is also NO_HIT,
    // a legitimate result; the written word is what tells them apart.
    let info = ShaderInfo::load(&source_root().join("shaders")).unwrap();
    let f = info.function("pack_rgba8").unwrap().clone();
    let case =
        Case::new("pack_rgba8").input("c", [1.0f32, 1.0, 1.0]).expect(Value::Uint(u32::MAX), Rule::Exact).without_cpu();
    let p = Prepared { function: f, input: vec![0; 3], expected: Some(vec![u32::MAX]), scene: Vec::new() };
    let unwritten = judge(&case, &p, &Ok(vec![codegen::SENTINEL; 2]), None);
    assert!(!unwritten.passed);
    assert!(unwritten.report.contains("the case was never written"), "{}", unwritten.report);
    let written = judge(&case, &p, &Ok(vec![codegen::WRITTEN, u32::MAX]), None);
    assert!(written.passed, "{}", written.report);
}
