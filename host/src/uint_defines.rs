// The one reading of the shaders' `#define NAME value` lines as uint
// constants: included by build.rs (layout.h and preview.h become Rust
// constants) and a module of the library (the shader-test harness reads
// the same constants at run time).

/// Every `#define NAME 12`, `#define NAME 3u` or `#define NAME
/// 0xffffffffu` of `text` as (NAME, value), in order; other lines and
/// defines of other values are left out.
pub fn uint_defines(text: &str) -> Vec<(&str, u32)> {
    let mut defines = Vec::new();
    for line in text.lines() {
        let mut words = line.split_whitespace();
        if words.next() != Some("#define") {
            continue;
        }
        let (Some(name), Some(value)) = (words.next(), words.next()) else { continue };
        let digits = value.trim_end_matches('u');
        let parsed = match digits.strip_prefix("0x") {
            Some(hex) => u32::from_str_radix(hex, 16).ok(),
            None => digits.parse::<u32>().ok(),
        };
        if let Some(v) = parsed {
            defines.push((name, v));
        }
    }
    defines
}

#[cfg(test)]
mod tests {
    #[test]
    fn reads_decimal_suffixed_and_hex_values_and_nothing_else() {
        let text = "#define A 12\n  #define B 3u // note\n#define C 0xffffffffu\n#define D 1.5f\n#define E\n// #define F 1\nconst uint G = 2u;\n#define H 0x10\n";
        assert_eq!(super::uint_defines(text), vec![("A", 12), ("B", 3), ("C", u32::MAX), ("H", 16)]);
    }
}
