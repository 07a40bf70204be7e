//! Quantities as people read them.

/// `3435973836` → `3.2 GiB (3435973836 bytes)`.
pub fn fmt_bytes(bytes: u64) -> String {
    const UNITS: [&str; 4] = ["KiB", "MiB", "GiB", "TiB"];
    if bytes < 1024 {
        return format!("{bytes} bytes");
    }
    let mut value = bytes as f64 / 1024.0;
    let mut unit = 0;
    while value >= 1024.0 && unit + 1 < UNITS.len() {
        value /= 1024.0;
        unit += 1;
    }
    let number = format!("{value:.1}");
    let number = number.strip_suffix(".0").unwrap_or(&number);
    format!("{number} {} ({bytes} bytes)", UNITS[unit])
}

/// Whether `x` stays finite as the renderer's f32 (`x as f32`, as the host
/// packs its numbers): beyond about 3.4e38 it becomes an infinity, which
/// drops a shape or light from the picture without a word.
pub(crate) fn f32_holds(x: f64) -> bool {
    (x as f32).is_finite()
}

/// A coordinate as a message shows it: `0.25`, `-3` as written, or
/// `1e-300` and `1e39` where the plain form would run to hundreds of digits.
/// An f32 in the fewest digits that give it back (`1e-45`, not the f64's
/// `1.401298464324817e-45`).
pub(crate) fn fmt_number<T>(x: T) -> String
where
    T: Copy + Into<f64> + std::fmt::Display + std::fmt::LowerExp,
{
    if x.into() == 0.0 || (1e-4..1e16).contains(&x.into().abs()) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A vector as a message shows it: `(0, 1e-300, 0)`.
pub(crate) fn fmt_vector(v: glam::DVec3) -> String {
    format!("({}, {}, {})", fmt_number(v.x), fmt_number(v.y), fmt_number(v.z))
}

/// `1234567` → `1,234,567`.
pub(crate) fn thousands(n: u64) -> String {
    let s = n.to_string();
    let mut out = String::new();
    for (i, c) in s.chars().enumerate() {
        if i > 0 && (s.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

/// Items in a sentence: "a", "a and b", "a, b and c" (`word`: "and", "or").
pub(crate) fn listed(items: &[impl AsRef<str>], word: &str) -> String {
    match items {
        [] => String::new(),
        [one] => one.as_ref().to_string(),
        [rest @ .., last] => {
            let rest: Vec<&str> = rest.iter().map(AsRef::as_ref).collect();
            format!("{} {word} {}", rest.join(", "), last.as_ref())
        }
    }
}

/// The median of `values` (the mean of the middle two for an even count);
/// NaN when there are none. The one median of bench's frames, versus's
/// ratios and the preview's frame rates and pixel cost.
pub fn median(values: impl IntoIterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.into_iter().collect();
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => (v[n / 2 - 1] + v[n / 2]) / 2.0,
    }
}

/// `value` as one line of JSON (`--json`), through serde. The reports
/// serialized are structs of plain fields, which cannot fail to serialize.
pub(crate) fn to_json(value: &impl serde::Serialize) -> String {
    serde_json::to_string(value).expect("a --json report serializes")
}

/// `x` rounded to `decimals` decimals, for JSON's numbers: the nearest f64
/// to the rounded decimal, whose shortest digits are that decimal.
pub(crate) fn rounded(x: f64, decimals: i32) -> f64 {
    let scale = 10f64.powi(decimals);
    (x * scale).round() / scale
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_in_binary_units_with_the_exact_count() {
        assert_eq!(fmt_bytes(16), "16 bytes");
        assert_eq!(fmt_bytes(2 << 30), "2 GiB (2147483648 bytes)");
        assert_eq!(fmt_bytes(3_435_973_836), "3.2 GiB (3435973836 bytes)");
    }

    #[test]
    fn items_listed_in_a_sentence() {
        assert_eq!(listed(&["a"], "and"), "a");
        assert_eq!(listed(&["a", "b"], "or"), "a or b");
        assert_eq!(listed(&["a", "b", "c"], "and"), "a, b and c");
    }

    #[test]
    fn numbers_short_at_either_end() {
        let v = glam::DVec3::new(0.0, 1e-300, -0.25);
        assert_eq!(fmt_vector(v), "(0, 1e-300, -0.25)");
        assert_eq!(fmt_number(1e39), "1e39");
        assert_eq!(fmt_number(-3.0), "-3");
        assert_eq!(fmt_number(123456.5), "123456.5");
    }
}
