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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_in_binary_units_with_the_exact_count() {
        assert_eq!(fmt_bytes(16), "16 bytes");
        assert_eq!(fmt_bytes(2 << 30), "2 GiB (2147483648 bytes)");
        assert_eq!(fmt_bytes(3_435_973_836), "3.2 GiB (3435973836 bytes)");
    }
}
