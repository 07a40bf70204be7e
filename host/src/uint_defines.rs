// The one reading of the shaders' `#define NAME value` lines as uint
// constants: included by build.rs (layout.h, shapes.glsl and preview.h
// become Rust constants) and a module of the library (the shader-test
// harness reads the same constants at run time).

/// Every `#define NAME 12`, `#define NAME 3u`, `#define NAME 0xffffffffu`,
/// `#define NAME OTHER` or `#define NAME (OTHER + 4)` of `text` as (NAME,
/// value), in order: a name stands for its value among the defines before
/// it or in `known` (those of files read before). Other lines, and defines
/// of other values, are left out.
pub fn uint_defines<'a>(text: &'a str, known: &[(&str, u32)]) -> Vec<(&'a str, u32)> {
    let mut defines: Vec<(&'a str, u32)> = Vec::new();
    for line in text.lines() {
        let Some(rest) = line.trim_start().strip_prefix("#define") else { continue };
        let rest = rest.split("//").next().unwrap_or("").trim();
        let Some((name, value)) = rest.split_once(char::is_whitespace) else { continue };
        if name.contains('(') {
            continue; // a macro with arguments
        }
        let lookup =
            |term: &str| defines.iter().rev().chain(known.iter().rev()).find(|(n, _)| *n == term).map(|&(_, v)| v);
        let value = value.trim();
        let sum = value.strip_prefix('(').and_then(|v| v.strip_suffix(')')).unwrap_or(value);
        let terms: Option<Vec<u32>> = sum.split('+').map(|t| literal(t.trim()).or_else(|| lookup(t.trim()))).collect();
        if let Some(v) = terms.and_then(|t| t.into_iter().try_fold(0u32, u32::checked_add)) {
            defines.push((name, v));
        }
    }
    defines
}

/// `12`, `3u` or `0xffffffffu`.
fn literal(word: &str) -> Option<u32> {
    let digits = word.trim_end_matches('u');
    match digits.strip_prefix("0x") {
        Some(hex) => u32::from_str_radix(hex, 16).ok(),
        None => digits.parse::<u32>().ok(),
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn reads_decimal_suffixed_and_hex_values_and_nothing_else() {
        let text = "#define A 12\n  #define B 3u // note\n#define C 0xffffffffu\n#define D 1.5f\n#define E\n// #define F 1\nconst uint G = 2u;\n#define H 0x10\n";
        assert_eq!(super::uint_defines(text, &[]), vec![("A", 12), ("B", 3), ("C", u32::MAX), ("H", 16)]);
    }

    #[test]
    fn reads_names_and_sums_of_defines_before_or_known() {
        let text = "#define A (K + 2)\n#define B A\n#define C (A + B + 1u) // note\n#define M(x, y) (x + y)\n#define U (Z + 1)\n#define V (C + C + 0xffffffffu)\n";
        assert_eq!(super::uint_defines(text, &[("K", 10)]), vec![("A", 12), ("B", 12), ("C", 25)]);
    }
}
