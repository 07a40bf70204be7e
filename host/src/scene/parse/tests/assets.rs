//! Tests of assets.rs: where a texture's image is found.

use super::*;

#[test]
fn texture_resolution() {
    let dir = std::env::temp_dir().join(format!("raycast-parse-tex-{}", std::process::id()));
    let scene_dir = dir.join("scenes");
    let assets = dir.join("assets");
    std::fs::create_dir_all(scene_dir.join("img")).unwrap();
    std::fs::create_dir_all(assets.join("image")).unwrap();
    std::fs::write(scene_dir.join("img/local.png"), b"x").unwrap();
    std::fs::write(assets.join("image/a.png"), b"x").unwrap();
    std::fs::write(assets.join("x.png"), b"x").unwrap();
    let o = ParseOptions { assets: vec![assets.clone()], ..ParseOptions::default() };
    let xml_path = scene_dir.join("s.xml");
    let abs_ok = scene_dir.join("img/local.png");
    let tex = |file: &str| {
        let xml = prim("cube", &format!("<texture file=\"{file}\"/>"));
        let f = parse_str(&xml, &xml_path, &o).unwrap();
        let t = first_prim(&f).1.texture.clone().unwrap();
        (t.resolved, f.warnings)
    };
    // Relative to the XML file's folder.
    let (r, w) = tex("img/local.png");
    assert_eq!(r, Some(scene_dir.join("img/local.png")));
    assert!(w.is_empty());
    // Relative to an assets folder.
    let (r, w) = tex("image/a.png");
    assert_eq!(r, Some(assets.join("image/a.png")));
    assert!(w.is_empty());
    // Absolute and present.
    let (r, w) = tex(&abs_ok.display().to_string());
    assert_eq!(r, Some(abs_ok.clone()));
    assert!(w.is_empty());
    // Absolute and absent: its file name in the folders, with a warning.
    let (r, w) = tex("/course/cs123/data/image/x.png");
    assert_eq!(r, Some(assets.join("x.png")));
    assert_eq!(w.len(), 1);
    assert!(w[0].message.contains("does not exist; using"), "{}", w[0]);
    assert_eq!(wat(&w[0]), (5, 1));
    // Not found anywhere: None and a warning naming the places tried.
    let (r, w) = tex("image/missing.png");
    assert_eq!(r, None);
    assert_eq!(w.len(), 1);
    let m = &w[0].message;
    assert!(m.contains("not found") && m.contains(&scene_dir.join("image/missing.png").display().to_string()));
    assert!(m.contains(&assets.join("image/missing.png").display().to_string()), "{m}");
    assert!(m.contains("and the 3 folders above the scene's)"), "{m}");
    // In a folder above the scene's (a corpus root: paths relative to it),
    // after the scene's folder and the assets: used, with a warning
    // naming the folder; the scene's own folder and the assets first.
    let root = dir.canonicalize().unwrap();
    std::fs::create_dir_all(root.join("image")).unwrap();
    std::fs::write(root.join("image/up.png"), b"x").unwrap();
    std::fs::write(root.join("image/a.png"), b"x").unwrap();
    let (r, w) = tex("image/up.png");
    assert_eq!(r, Some(root.join("image/up.png")));
    assert_eq!(w.len(), 1);
    let m = &w[0].message;
    assert!(m.contains(&format!("found 1 folder above the scene's, in \"{}\"", root.display())), "{m}");
    assert!(m.contains(&format!("--assets {} says so", root.display())), "{m}");
    let (r, w) = tex("image/a.png");
    assert_eq!((r, w.len()), (Some(assets.join("image/a.png")), 0));
    // Absolute and absent, its trailing folders in a folder above the
    // scene's: the longest that is there wins, with a warning.
    let (r, w) = tex("/course/cs123/data/image/up.png");
    assert_eq!(r, Some(root.join("image/up.png")));
    assert!(w[0].message.contains(&format!("using \"{}\" instead", root.join("image/up.png").display())), "{}", w[0]);
    let (r, w) = tex("/course/cs123/data/image/a.png");
    assert_eq!(r, Some(assets.join("image/a.png")), "the assets before the folders above: {w:?}");
    let typo = ParseOptions { assets: vec![assets.clone(), dir.join("asets")], ..ParseOptions::default() };
    let f = parse_str(&prim("cube", "<texture file=\"image/gone.png\"/>"), &xml_path, &typo).unwrap();
    let m = &f.warnings[0].message;
    assert!(m.contains(&format!("; --assets {} is not a folder:", dir.join("asets").display())), "{m}");
    assert!(!m.contains(&format!("--assets {} is not", assets.display())), "{m}");
    let (r, w) = tex("/course/cs123/data/image/gone.png");
    assert_eq!(r, None);
    assert!(w[0].message.contains("and its trailing folders in those and the 3 folders above the scene's"), "{}", w[0]);
    assert!(w[0].message.contains(&assets.join("gone.png").display().to_string()), "{}", w[0]);
    // No further than FOLDERS_ABOVE: a scene four folders below the image.
    let deep = root.join("scenes/a/b/c");
    std::fs::create_dir_all(&deep).unwrap();
    let xml = prim("cube", "<texture file=\"image/up.png\"/>");
    let f = parse_str(&xml, &deep.join("s.xml"), &opts()).unwrap();
    assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, None);
    let f = parse_str(&xml, &root.join("scenes/a/b/s.xml"), &opts()).unwrap();
    assert_eq!(first_prim(&f).1.texture.as_ref().unwrap().resolved, Some(root.join("image/up.png")));
    let _ = std::fs::remove_dir_all(&dir);
}
