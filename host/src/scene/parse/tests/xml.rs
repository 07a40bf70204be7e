//! Tests of xml.rs and position.rs: malformed XML and unreadable files,
//! nesting bounds, files cut or mangled, positions on long lines and old
//! Mac line ends.

use super::*;
use crate::scene::mutate::Rng;
use crate::scene::parse::xml::too_deep;

#[test]
fn xml_and_file_errors() {
    let e = bad_at(
        "<scenefile>\n<object type=\"tree\" name=\"root\">\n<transblock>\n</object>\n</scenefile>",
        4,
        1,
        "malformed XML",
    );
    assert!(e.message.contains("found </object> while <transblock> is still open"), "{e}");
    bad_at("<scenefile>\n<object", 2, 8, "malformed XML");
    bad_at("<scenefile>\n", 2, 1, "malformed XML: the file ends");
    bad_at("", 1, 1, "malformed XML");
    bad_at("<scene>\n</scene>", 1, 1, "the root element is <scene>, expected <scenefile>");
    bad_at("<scenefile><a x=\"1\" x=\"2\"/></scenefile>", 1, 21, "malformed XML: attribute 'x'");
    // A byte-order mark does not shift columns.
    let f = p(&format!("\u{feff}{}", prim("cube", "<glow/>"))).unwrap();
    warned_at(&f, 5, 1, "<glow>");

    let dir = std::env::temp_dir().join(format!("raycast-parse-io-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let missing = dir.join("missing.xml");
    let e = parse_file(&missing, &opts()).unwrap_err();
    assert!(e.loc.is_none());
    assert!(e.message.contains("missing.xml") && e.message.contains("cannot read"), "{e}");
    let latin1 = dir.join("latin1.xml");
    std::fs::write(&latin1, b"<scenefile>\n<!-- caf\xe9 -->\n</scenefile>").unwrap();
    let e = parse_file(&latin1, &opts()).unwrap_err();
    assert_eq!(at(&e), (2, 9));
    assert!(e.message.contains("not valid UTF-8"), "{e}");
    let good = dir.join("good.xml");
    std::fs::write(&good, prim("cube", "")).unwrap();
    let f = parse_file(&good, &opts()).unwrap();
    assert_eq!(*f.path, good);
    let _ = std::fs::remove_dir_all(&dir);
}

fn nested(depth: usize) -> String {
    let mut s = String::from("<scenefile><object type=\"tree\" name=\"root\">");
    for _ in 0..depth - 1 {
        s.push_str("<transblock><object type=\"tree\">");
    }
    s.push_str("<transblock><object type=\"primitive\" name=\"cube\"/></transblock>");
    for _ in 0..depth - 1 {
        s.push_str("</object></transblock>");
    }
    s.push_str("</object></scenefile>");
    s
}

#[test]
fn nesting_is_limited() {
    ok(&nested(MAX_NESTING));
    let e = bad(&nested(MAX_NESTING + 1));
    assert!(e.message.contains("nested more than 256 deep"), "{e}");
    // Far deeper: still an error, not a stack overflow.
    let e = bad(&nested(50_000));
    assert!(e.message.contains("elements are nested more than 1024 deep"), "{e}");
    let pile = format!("<scenefile>\n{}", "<a>".repeat(100_000));
    bad_at(&pile, 2, 3070, "elements are nested more than 1024 deep");
    // Markup that does not nest is not counted.
    let flat = format!(
        "<scenefile><!-- <a><a> -->{}<![CDATA[<a><a>]]><?pi <a> ?></scenefile>",
        "<b x='<<' y=\"/>\"/><c></c>".repeat(5000)
    );
    assert_eq!(too_deep(&flat, 3), None);
    assert_eq!(too_deep("<a><b><c><d>", 3), Some(9));
    bad_at("<!DOCTYPE s [<!ENTITY e \"<a/>\">]>\n<scenefile/>", 1, 1, "a DTD with declarations is not supported");
}

#[test]
fn never_panics_on_mangled_input() {
    let base = with_top(
        "<globaldata><ambientcoeff v=\"0.5\"/></globaldata><cameradata><pos x=\"1\" y=\"2\" z=\"3\"/><focus x=\"0\" y=\"0\" z=\"0\"/></cameradata>\
         <lightdata><type v=\"spot\"/><direction x=\"0\" y=\"-1\" z=\"0\"/><function a=\"1\" b=\"0\" c=\"0\"/></lightdata>\
         <object type=\"tree\" name=\"m\"><transblock><rotate x=\"1\" y=\"0\" z=\"0\" angle=\"30\"/><object type=\"primitive\" name=\"sphere\"><diffuse r=\"1\" g=\"0\" b=\"0\"/><texture file=\"t.png\"/></object></transblock></object>",
    );
    // Every prefix.
    for (i, _) in base.char_indices() {
        let _ = p(&base[..i]);
    }
    // Byte edits from a seed (`Rng`): the same cases every run.
    const SEED: u64 = 0x2545_f491_4f6c_dd1d;
    let mut rng = Rng::seeded(SEED);
    let chars: Vec<char> = base.chars().collect();
    let alphabet: Vec<char> = "<>/=\" x0.-e\u{e9}\n".chars().collect();
    for case in 0..3000 {
        let mut c = chars.clone();
        for _ in 0..3 {
            let at = rng.below(c.len());
            let ch = alphabet[rng.below(alphabet.len())];
            match rng.below(3) {
                0 => c[at] = ch,
                1 => c.insert(at, ch),
                _ => {
                    c.remove(at);
                }
            }
        }
        let s: String = c.into_iter().collect();
        let outcome = std::panic::catch_unwind(|| {
            if let Ok(f) = p(&s) {
                let _ = crate::scene::flatten(&f, &Default::default());
            }
        });
        assert!(outcome.is_ok(), "case {case} of seed {SEED:#x} panicked; its text: {s:?}");
    }
}

#[test]
fn one_long_line_is_fast_and_positions_exact() {
    let blocks = "<transblock><object type=\"primitive\" name=\"cube\"/></transblock>".repeat(20_000);
    let xml = format!("<scenefile><object type=\"tree\" name=\"root\">{blocks}<transblock><object type=\"primitive\" name=\"cub\"/></transblock></object></scenefile>");
    let t = std::time::Instant::now();
    bad_at_str(&xml, "name=\"cub\"", "did you mean \"cube\"?");
    assert!(t.elapsed().as_secs_f64() < 2.0);
    // Positions asked for out of order are still right.
    let xml = "<scenefile><object type=\"tree\" name=\"a\"/><object type=\"tree\" name=\"a\"/></scenefile>";
    bad_at_str(xml, "name=\"a\"/></scenefile>", "a second tree named \"a\" (the first is at 1:12)");
}

#[test]
fn what_follows_the_root_element_is_named() {
    let doc = "<scenefile>\n<object type=\"tree\" name=\"root\"/>\n</scenefile>\n";
    bad_at(
        &format!("{doc}<x a=\"1\"/>\n"),
        4,
        1,
        "malformed XML: a second root element <x> after </scenefile>: a scene file has one <scenefile>",
    );
    bad_at(&format!("{doc}  hello\n"), 4, 3, "malformed XML: text \"hello\" after the root element </scenefile>");
    bad_at(&format!("{doc}</scenefile>\n"), 4, 1, "malformed XML: a close tag </scenefile> after the root element");
    // Comments after the root are fine.
    ok(&format!("{doc}<!-- end -->\n"));
    // Inside the root, an unknown token is still reported as one.
    bad_at("<scenefile>\n<!x>\n</scenefile>", 2, 1, "malformed XML: unknown token");
}

#[test]
fn a_lone_carriage_return_ends_a_line() {
    // Old Mac files end lines with CR alone; XML reads it as a line break.
    let cr = "<scenefile>\r\r<cameradata><heightangle v=\"x\"/></cameradata>\r</scenefile>";
    bad_at(cr, 3, 26, "attribute `v` of <heightangle> is \"x\"");
    bad_at(&cr.replace('\r', "\r\n"), 3, 26, "attribute `v` of <heightangle> is \"x\"");
    bad_at(&cr.replacen('\r', "\r\n", 1), 3, 26, "attribute `v` of <heightangle> is \"x\"");
    // Warnings, and the XML parser's own positions.
    let f = ok(&prim("cube", "<glow/>").replace('\n', "\r"));
    warned_at(&f, 5, 1, "<glow>");
    bad_at(
        "<scenefile>\r<object type=\"tree\" name=\"root\">\r<transblock>\r</object>\r</scenefile>",
        4,
        1,
        "found </object> while <transblock> is still open",
    );
    bad_at("<scenefile>\r<object", 2, 8, "malformed XML");
    bad_at("<scenefile>\r<a x=\"1\" x=\"2\"/></scenefile>", 2, 10, "malformed XML: attribute 'x'");
    // Bytes that are not UTF-8.
    let dir = std::env::temp_dir().join(format!("raycast-parse-cr-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let latin1 = dir.join("latin1.xml");
    std::fs::write(&latin1, b"<scenefile>\r<!-- caf\xe9 -->\r</scenefile>").unwrap();
    let e = parse_file(&latin1, &opts()).unwrap_err();
    assert_eq!(at(&e), (2, 9), "{e}");
    let _ = std::fs::remove_dir_all(&dir);
}
