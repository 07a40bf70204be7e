//! `raycast explain` against planted bugs: each a mistake students make,
//! written into a copy of the shaders (`--shaders DIR`, drawn on the
//! device), one at a time, over corpus scenes at 256x192. The top finding
//! must name the planted cause (and, where the bug is local, its shape or
//! part); a correct picture (raycast's own, and the course's official
//! renders) must give no finding. Rules: the planted cause first for at
//! least 80% of the pictures and among the first three for at least 95%;
//! no finding for every correct picture. The table of every case is printed.

mod common;

use common::{corpus, repo, text};
use std::path::{Path, PathBuf};
use std::process::Command;

/// A planted bug: its name, the causes that count as naming it, the
/// shader file and the text replaced (which must be there), the scenes
/// drawn with it, and the shape (and part) the top finding must be on.
struct Bug {
    name: &'static str,
    causes: &'static [&'static str],
    edits: &'static [(&'static str, &'static str, &'static str)],
    scenes: &'static [&'static str],
    on: Option<(&'static str, &'static str)>,
}

const PHONG: &str = "test_intersect/phong_total.xml";

const BUGS: &[Bug] = &[
    Bug {
        name: "ambient term dropped",
        causes: &["no-ambient"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 base = frame.k.x * xyz(m.ambient) + xyz(m.emissive);",
            "precise vec3 base = xyz(m.emissive);",
        )],
        scenes: &[PHONG, "test_intersect/phong_ambient.xml"],
        on: None,
    },
    Bug {
        name: "ambient term counted twice",
        causes: &["double-ambient"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 base = frame.k.x * xyz(m.ambient) + xyz(m.emissive);",
            "precise vec3 base = 2.0f * (frame.k.x * xyz(m.ambient)) + xyz(m.emissive);",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "diffuse term dropped",
        causes: &["no-diffuse"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 term = s.diffuse * max_f(0.0f, n_dot_l);",
            "precise vec3 term = vec3(0.0f, 0.0f, 0.0f);",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "diffuse term counted twice",
        causes: &["double-diffuse"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 diffuse = frame.k.y * xyz(m.diffuse);",
            "precise vec3 diffuse = 2.0f * (frame.k.y * xyz(m.diffuse));",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "specular term dropped",
        causes: &["no-specular"],
        edits: &[("lighting.glsl", "term = term + s.specular * highlight;", "term = term;")],
        scenes: &[PHONG, "test_light/spot_light_1.xml"],
        on: None,
    },
    Bug {
        name: "specular without k_s",
        causes: &["unweighted-specular"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 specular = frame.k.z * xyz(m.specular);",
            "precise vec3 specular = xyz(m.specular);",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "attenuation ignored",
        causes: &["no-attenuation"],
        edits: &[(
            "lighting.glsl",
            "precise float att = min_f(1.0f, div_rn(1.0f, falloff));",
            "precise float att = 1.0f;",
        )],
        scenes: &["test_feature/attenuation.xml", "test_light/point_light_1.xml"],
        on: None,
    },
    Bug {
        name: "spot lights without their cone",
        causes: &["spot-as-point"],
        edits: &[("lighting.glsl", "if (HAS_SPOT_LIGHTS && l.kind == LIGHT_SPOT) {", "if (false) {")],
        scenes: &["test_light/spot_light_1.xml", "test_light/spot_light_2.xml"],
        on: None,
    },
    Bug {
        name: "no shadow rays",
        causes: &["no-shadows"],
        edits: &[(
            "trace.glsl",
            "bool shadows = HAS_SHADOWS && (frame.flags & FLAG_SHADOWS) != 0u;",
            "bool shadows = false;",
        )],
        scenes: &["test_feature/shadow_test.xml"],
        on: None,
    },
    Bug {
        name: "no mirror rays",
        causes: &["no-reflections"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 mirror = frame.k.z * xyz(m.reflective);",
            "precise vec3 mirror = vec3(0.0f, 0.0f, 0.0f);",
        )],
        scenes: &["test_feature/reflection.xml", "test_feature/mirror_refl.xml"],
        on: None,
    },
    Bug {
        name: "texture replaces the diffuse colour",
        causes: &["blend-ignored"],
        edits: &[("lighting.glsl", "diffuse = (1.0f - m.blend) * diffuse + m.blend * texel;", "diffuse = texel;")],
        scenes: &["test_feature/texture_uv.xml"],
        on: None,
    },
    Bug {
        name: "u reversed",
        causes: &["flip-u"],
        edits: &[(
            "textures.glsl",
            "precise float x = (clamp01(uv.x) * m.texture_repeat.x) * float(tex.width);",
            "precise float x = ((1.0f - clamp01(uv.x)) * m.texture_repeat.x) * float(tex.width);",
        )],
        scenes: &["test_feature/texture_uv.xml"],
        on: None,
    },
    Bug {
        name: "v reversed",
        causes: &["flip-v"],
        edits: &[(
            "textures.glsl",
            "precise float y = (clamp01(uv.y) * m.texture_repeat.y) * float(tex.height);",
            "precise float y = ((1.0f - clamp01(uv.y)) * m.texture_repeat.y) * float(tex.height);",
        )],
        scenes: &["test_feature/texture_uv.xml", "test_feature/texture_sphere.xml"],
        on: None,
    },
    Bug {
        name: "texture repeat ignored",
        causes: &["no-repeat"],
        edits: &[
            (
                "textures.glsl",
                "precise float x = (clamp01(uv.x) * m.texture_repeat.x) * float(tex.width);",
                "precise float x = clamp01(uv.x) * float(tex.width);",
            ),
            (
                "textures.glsl",
                "precise float y = (clamp01(uv.y) * m.texture_repeat.y) * float(tex.height);",
                "precise float y = clamp01(uv.y) * float(tex.height);",
            ),
        ],
        scenes: &["test_feature/texture_sphere.xml", "test_feature/texture_cyl2.xml"],
        on: None,
    },
    Bug {
        name: "bilinear filter where the course takes the nearest texel",
        causes: &["filter-bilinear"],
        edits: &[(
            "textures.glsl",
            "if (HAS_BILINEAR && frame.texture_filter != FILTER_NEAREST) {\n        return bilinear(tex, x, y, (frame.texture_filter == FILTER_COURSE) ? 0.0f : 0.5f);",
            "if (true) {\n        return bilinear(tex, x, y, 0.5f);",
        )],
        scenes: &["test_feature/texture_uv.xml"],
        on: None,
    },
    Bug {
        name: "normals reversed",
        causes: &["flip-normals"],
        edits: &[(
            "traversal.glsl",
            "        best.normal = long_normals ? n_world : unit(n_world);\n",
            "        best.normal = -unit(n_world);\n",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "normals mapped as vectors (no inverse transpose)",
        causes: &["untransposed-normals"],
        edits: &[(
            "traversal.glsl",
            "precise vec3 n_world = explained_normal(hit_primitive.object_from_world, n_object);",
            "precise vec3 n_world = inverse(mat3(hit_primitive.object_from_world)) * n_object;",
        )],
        scenes: &["own:explain/stretched.xml"],
        on: None,
    },
    Bug {
        name: "rays through the pixels' corners",
        causes: &["pixel-corner"],
        edits: &[
            ("camera.glsl", "div_rn((float(j) + 0.5f) + offset.x,", "div_rn(float(j) + offset.x,"),
            ("camera.glsl", "div_rn((float(i) + 0.5f) + offset.y,", "div_rn(float(i) + offset.y,"),
        ],
        scenes: &[PHONG, "test_feature/shadow_test.xml"],
        on: None,
    },
    Bug {
        name: "picture upside down",
        causes: &["upside-down"],
        edits: &[(
            "camera.glsl",
            "precise float y = 1.0f - div_rn((float(i) + 0.5f) + offset.y, float(frame.height)) * 2.0f;",
            "precise float y = div_rn((float(i) + 0.5f) + offset.y, float(frame.height)) * 2.0f - 1.0f;",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "the height angle not halved",
        causes: &["whole-height-angle"],
        edits: &[(
            "camera.glsl",
            "    r.direction = transform_vector(frame.world_from_film, vec3(x, y, -1.0f));",
            "    float t = length(xyz(frame.world_from_film[1]));\n    float f = tan(2.0f * atan(t)) / t;\n    r.direction = transform_vector(frame.world_from_film, vec3(f * x, f * y, -1.0f));",
        )],
        scenes: &[PHONG, "test_feature/shadow_test.xml"],
        on: None,
    },
    Bug {
        name: "the aspect ratio ignored",
        causes: &["aspect-ignored"],
        edits: &[(
            "camera.glsl",
            "    r.direction = transform_vector(frame.world_from_film, vec3(x, y, -1.0f));",
            "    r.direction = transform_vector(frame.world_from_film, vec3(x * float(frame.height) / float(frame.width), y, -1.0f));",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "cylinder's top cap missing",
        causes: &["no-caps", "missing-geometry"],
        edits: &[("shape_cylinder.glsl", "    best = cap(best, r, 0.5f, 1.0f);\n", "")],
        scenes: &["test_unit/unit_cylinder.xml"],
        on: Some(("cylinder", "top cap")),
    },
    Bug {
        name: "cylinder missing",
        causes: &["missing-geometry"],
        edits: &[("shape_cylinder.glsl", "ShapeHit intersect_cylinder(Ray r) {\n", "ShapeHit intersect_cylinder(Ray r) {\n    return no_hit();\n")],
        scenes: &[PHONG],
        on: Some(("cylinder", "")),
    },
    Bug {
        name: "8-bit values rounded",
        causes: &["rounded"],
        edits: &[
            ("aov.glsl", "precise float r = floor(255.0f * c.x);", "precise float r = floor(255.0f * c.x + 0.5f);"),
            ("aov.glsl", "precise float g = floor(255.0f * c.y);", "precise float g = floor(255.0f * c.y + 0.5f);"),
            ("aov.glsl", "precise float b = floor(255.0f * c.z);", "precise float b = floor(255.0f * c.z + 0.5f);"),
        ],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "a gamma correction of 2.2 before the 8-bit value",
        causes: &["tone-curve"],
        edits: &[(
            "aov.glsl",
            "    precise float r = floor(255.0f * c.x);",
            "    c = pow(max(c, vec3(0.0f)), vec3(1.0f / 2.2f));\n    precise float r = floor(255.0f * c.x);",
        )],
        scenes: &[PHONG, "test_feature/texture_uv.xml"],
        on: None,
    },
    Bug {
        name: "colours not clamped",
        causes: &["no-clamp"],
        edits: &[
            ("lighting.glsl", "    return vec3(clamp01(c.x), clamp01(c.y), clamp01(c.z));", "    return c;"),
            (
                "aov.glsl",
                "    return (uint(r) | (uint(g) << 8u)) | ((uint(b) << 16u) | (255u << 24u));",
                "    return ((uint(r) & 255u) | ((uint(g) & 255u) << 8u)) | (((uint(b) & 255u) << 16u) | (255u << 24u));",
            ),
        ],
        scenes: &[PHONG, "test_feature/texture_uv.xml"],
        on: None,
    },
    // Mistakes no variant draws as they are: a term computed otherwise,
    // or weighted by another factor.
    Bug {
        name: "specular exponent doubled",
        causes: &["specular-term-changed", "weighted-specular-term"],
        edits: &[(
            "lighting.glsl",
            "pow_portable(max_f(0.0f, toward), s.shininess);",
            "pow_portable(max_f(0.0f, toward), 2.0f * s.shininess);",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "spot falloff linear, not smooth",
        causes: &["spot-falloff-changed"],
        edits: &[(
            "lighting.glsl",
            "precise float smooth_step = (3.0f * (x * x)) - 2.0f * ((x * x) * x);",
            "precise float smooth_step = x;",
        )],
        scenes: &["test_light/spot_light_1.xml", "test_light/spot_light_2.xml"],
        on: None,
    },
    Bug {
        name: "attenuation without its d² term",
        // attenuation.xml's light has only the d² term: without it, none.
        causes: &["distance-attenuation-changed", "no-attenuation"],
        edits: &[(
            "lighting.glsl",
            "precise float falloff = (l.attenuation.x + l.attenuation.y * dist) + l.attenuation.z * (dist * dist);",
            "precise float falloff = l.attenuation.x + l.attenuation.y * dist;",
        )],
        scenes: &["test_feature/attenuation.xml"],
        on: None,
    },
    Bug {
        name: "ambient term at half weight",
        causes: &["weighted-ambient-term"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 base = frame.k.x * xyz(m.ambient) + xyz(m.emissive);",
            "precise vec3 base = 0.5f * (frame.k.x * xyz(m.ambient)) + xyz(m.emissive);",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "mirror ray reflected about the wrong axis",
        causes: &["mirror-reflection-changed"],
        edits: &[(
            "trace.glsl",
            "precise vec3 mirror = d - (2.0f * dot3(surface.n, d)) * surface.n;",
            "precise vec3 mirror = (2.0f * dot3(surface.n, d)) * surface.n - d;",
        )],
        scenes: &["test_feature/reflection.xml"],
        on: None,
    },
    Bug {
        name: "shadow rays leaving from the surface itself (acne)",
        causes: &["shadow-acne"],
        edits: &[(
            "trace.glsl",
            "precise vec3 shadow_origin = surface.p + ray_offset(surface.p, ray.origin) * to_light;",
            "precise vec3 shadow_origin = surface.p;",
        )],
        scenes: &["test_feature/shadow_test.xml", "test_light/point_light_1.xml"],
        on: None,
    },
    Bug {
        name: "mirror rays leaving from the surface itself (acne)",
        causes: &["mirror-acne"],
        edits: &[(
            "trace.glsl",
            "precise vec3 mirror_origin = surface.p + ray_offset(surface.p, ray.origin) * mirror;",
            "precise vec3 mirror_origin = surface.p;",
        )],
        scenes: &["test_feature/reflection.xml", "test_feature/mirror_depth.xml"],
        on: None,
    },
    Bug {
        name: "the mirror reflection without k_s",
        causes: &["unweighted-reflection"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 mirror = frame.k.z * xyz(m.reflective);",
            "precise vec3 mirror = xyz(m.reflective);",
        )],
        scenes: &["test_feature/reflection.xml"],
        on: None,
    },
    Bug {
        name: "light colours ignored",
        causes: &["white-lights"],
        edits: &[("lighting.glsl", "precise vec3 intensity = xyz(l.color);", "precise vec3 intensity = vec3(1.0f);")],
        scenes: &["test_feature/shadow_test.xml"],
        on: None,
    },
    Bug {
        name: "directional lights ignored",
        causes: &["no-light"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 intensity = light_intensity(l, to_light, dist);",
            "precise vec3 intensity = (l.kind == LIGHT_DIRECTIONAL) ? vec3(0.0f) : light_intensity(l, to_light, dist);",
        )],
        scenes: &["test_light/directional_light_2.xml", "test_feature/shadow_test.xml"],
        on: None,
    },
    Bug {
        name: "Blinn-Phong highlights (the half vector)",
        causes: &["blinn-phong"],
        edits: &[(
            "lighting.glsl",
            "precise float toward = dot3(reflected, s.v);",
            "precise float toward = dot3(unit(to_light + s.v), s.n);",
        )],
        scenes: &[PHONG, "test_light/point_light_1.xml"],
        on: None,
    },
    Bug {
        name: "n.l not clamped at 0",
        causes: &["negative-light"],
        edits: &[(
            "lighting.glsl",
            "precise vec3 term = s.diffuse * max_f(0.0f, n_dot_l);",
            "precise vec3 term = s.diffuse * n_dot_l;",
        )],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "world normals not made unit length",
        causes: &["long-normals"],
        edits: &[
            (
                "traversal.glsl",
                "precise vec3 n_object = long_normals ? unit(best.n_object) : best.n_object;",
                "precise vec3 n_object = unit(best.n_object);",
            ),
            ("traversal.glsl", "best.normal = long_normals ? n_world : unit(n_world);", "best.normal = n_world;"),
        ],
        scenes: &[PHONG],
        on: None,
    },
    Bug {
        name: "attenuation not capped at 1",
        causes: &["uncapped-attenuation"],
        edits: &[(
            "lighting.glsl",
            "precise float att = min_f(1.0f, div_rn(1.0f, falloff));",
            "precise float att = div_rn(1.0f, falloff);",
        )],
        scenes: &["test_feature/attenuation.xml"],
        on: None,
    },
    Bug {
        name: "refraction left out",
        causes: &["no-refraction"],
        edits: &[("lighting.glsl", "        s.transmit = transmit;\n", "")],
        scenes: &["own:refract/refract_nested.xml"],
        on: None,
    },
];

/// The folder the tests write in.
fn out_dir(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join("explain").join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A scene's path: in the corpus, or (`own:`) the repository's tests/scenes.
fn scene_path(corpus: &Path, scene: &str) -> PathBuf {
    match scene.strip_prefix("own:") {
        Some(name) => repo().join("tests/scenes").join(name),
        None => corpus.join(scene),
    }
}

fn raycast(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_raycast")).args(args).env("RAYCAST_VALIDATION", "1").output().unwrap()
}

/// `raycast explain --json` of `picture`: the causes of its findings, in
/// order, the top finding's groups (shape, part), whether it passes, and
/// whether it is raycast's picture to the bit.
fn explained(corpus: &Path, scene: &Path, picture: &Path) -> (Vec<String>, Vec<(String, String)>, bool, bool) {
    let corpus = corpus.to_str().unwrap();
    let o = raycast(&["explain", scene.to_str().unwrap(), picture.to_str().unwrap(), "--json", "--assets", corpus]);
    let (out, err) = text(&o);
    assert!(matches!(o.status.code(), Some(0 | 4)), "explain {}: {out}{err}", picture.display());
    let json: serde_json::Value = serde_json::from_str(out.trim()).unwrap_or_else(|e| panic!("{e}: {out}"));
    let findings = json["findings"].as_array().unwrap();
    // A finding's cause, and any other that draws the same picture, count alike.
    let causes = findings
        .iter()
        .map(|f| {
            let also = f["also"].as_array().unwrap().iter().map(|a| a.as_str().unwrap());
            std::iter::once(f["cause"].as_str().unwrap()).chain(also).collect::<Vec<_>>().join("|")
        })
        .collect();
    let on = findings
        .first()
        .map(|f| {
            f["on"]
                .as_array()
                .unwrap()
                .iter()
                .map(|g| (g["shape"].as_str().unwrap().to_string(), g["part"].as_str().unwrap().to_string()))
                .collect()
        })
        .unwrap_or_default();
    (causes, on, json["passes"].as_bool().unwrap(), json["psnr"].is_null())
}

#[test]
fn explain_names_planted_bugs_and_passes_correct_pictures() {
    let Some(corpus) = corpus("explain against planted bugs") else { return };
    let root = out_dir("planted");
    // A picture of the size drawn, for `render --like`: the course's
    // settings for it, as `explain` takes them.
    let like = root.join("like.png");
    let blank = raycast::image_io::Rgb8 { width: 256, height: 192, data: vec![0; 256 * 192 * 3] };
    raycast::image_io::write_png(&like, &blank).unwrap();
    let (like, assets) = (like.to_str().unwrap().to_string(), corpus.to_str().unwrap().to_string());

    let mut rows = Vec::new();
    let (mut first, mut top3, mut cases) = (0, 0, 0);
    for (k, bug) in BUGS.iter().enumerate() {
        let shaders = root.join(format!("bug{k}"));
        std::fs::create_dir_all(&shaders).unwrap();
        for entry in std::fs::read_dir(repo().join("shaders")).unwrap() {
            let p = entry.unwrap().path();
            std::fs::copy(&p, shaders.join(p.file_name().unwrap())).unwrap();
        }
        for (file, from, to) in bug.edits {
            let path = shaders.join(file);
            let text = std::fs::read_to_string(&path).unwrap();
            assert_eq!(text.matches(from).count(), 1, "{}: {from:?} once in {file}", bug.name);
            std::fs::write(&path, text.replacen(from, to, 1)).unwrap();
        }
        let pictures = shaders.join("out");
        let scenes: Vec<PathBuf> = bug.scenes.iter().map(|s| scene_path(&corpus, s)).collect();
        let mut args =
            vec!["render", "-q", "--shaders", shaders.to_str().unwrap(), "--like", &like, "--assets", &assets];
        args.extend(["--out-dir", pictures.to_str().unwrap()]);
        let names: Vec<String> = scenes.iter().map(|s| s.to_str().unwrap().to_string()).collect();
        args.extend(names.iter().map(String::as_str));
        let o = raycast(&args);
        assert!(o.status.success(), "{}: {:?}", bug.name, text(&o));
        for scene in &scenes {
            let picture = pictures.join(format!("{}.png", scene.file_stem().unwrap().to_str().unwrap()));
            let (causes, on, passes, identical) = explained(&corpus, scene, &picture);
            // A bug that changes nothing in the scene is no case.
            assert!(
                !identical,
                "{}: {} is raycast's own picture; choose a scene the bug shows in",
                bug.name,
                scene.display()
            );
            let rank = causes.iter().position(|c| c.split('|').any(|c| bug.causes.contains(&c)));
            // On the planted shape (and part, where one is named), first.
            let located = bug.on.is_none_or(|(shape, part)| {
                on.first().is_some_and(|g| g.0 == shape && (part.is_empty() || g.1 == part))
            });
            cases += 1;
            if rank == Some(0) && located {
                first += 1;
            }
            if rank.is_some_and(|r| r < 3) {
                top3 += 1;
            }
            let scene_name = scene.file_name().unwrap().to_string_lossy().into_owned();
            rows.push(format!(
                "{:<50} {:<24} {:<22} {}{}",
                bug.name,
                scene_name,
                rank.map_or("not found".to_string(), |r| format!("finding {}", r + 1)),
                causes.join(", "),
                if passes {
                    " (passes: no finding)"
                } else if located {
                    ""
                } else {
                    " (not on the planted part)"
                }
            ));
        }
    }

    // Correct pictures: raycast's own, and the course's official renders.
    let own = out_dir("correct");
    let own_scenes: Vec<String> = [PHONG, "test_feature/shadow_test.xml", "test_feature/texture_uv.xml"]
        .iter()
        .map(|s| corpus.join(s).to_str().unwrap().to_string())
        .collect();
    let mut args = vec!["render", "-q", "--like", &like, "--assets", &assets, "--out-dir", own.to_str().unwrap()];
    args.extend(own_scenes.iter().map(String::as_str));
    assert!(raycast(&args).status.success());
    let mut correct: Vec<(PathBuf, PathBuf)> = own_scenes
        .iter()
        .map(|s| {
            let s = PathBuf::from(s);
            let png = own.join(format!("{}.png", s.file_stem().unwrap().to_str().unwrap()));
            (s, png)
        })
        .collect();
    for (scene, reference) in [
        ("test_intersect/phong_total.xml", "bench/grading_illuminate/test_intersect_phong_total.png"),
        ("test_feature/shadow_test.xml", "bench/grading_illuminate/test_feature_shadow_test.png"),
        ("test_feature/texture_uv.xml", "bench/grading_illuminate/test_feature_texture_uv.png"),
        ("test_light/spot_light_1.xml", "bench/grading_illuminate/test_light_spot_light_1.png"),
        ("test_efficiency/recursiveSpheres3.xml", "bench/grading_illuminate/test_efficiency_recursiveSpheres3.png"),
    ] {
        correct.push((corpus.join(scene), corpus.join(reference)));
    }
    let mut wrong = Vec::new();
    for (scene, picture) in &correct {
        let (causes, _, passes, _) = explained(&corpus, scene, picture);
        rows.push(format!(
            "{:<50} {:<24} {:<22} {}",
            "correct picture",
            scene.file_name().unwrap().to_string_lossy(),
            if causes.is_empty() { "no finding" } else { "FINDINGS" },
            if passes { "passes".to_string() } else { causes.join(", ") }
        ));
        if !causes.is_empty() {
            wrong.push(picture.display().to_string());
        }
    }
    println!(
        "planted bug / picture                              scene                    planted cause          findings"
    );
    for r in &rows {
        println!("{r}");
    }
    let (rate1, rate3) = (first as f64 / cases as f64, top3 as f64 / cases as f64);
    println!(
        "hit rate: the planted cause first (and on its part) in {first} of {cases} pictures ({:.0}%), among the first three in {top3} ({:.0}%); \
         rule: at least 80% and 95%",
        100.0 * rate1,
        100.0 * rate3
    );
    assert!(rate1 >= 0.8 && rate3 >= 0.95, "hit rate below the rule:\n{}", rows.join("\n"));
    assert!(wrong.is_empty(), "correct pictures with findings: {wrong:?}\n{}", rows.join("\n"));
}
