//! Comparison rules: every case states one.

use crate::check::ulp_distance;

/// How a result is compared with what it should be. Applies to float words;
/// int, uint and bool words are always compared exactly.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Rule {
    /// The same bits. NaN equals NaN whatever its bits (GLSL does not define
    /// NaN payloads); +0 and -0 differ.
    Exact,
    /// At most N representable floats apart (`check::ulp_distance`).
    Ulp(u64),
    /// |actual - expected| <= ε, computed in f64.
    Abs(f64),
}

impl Rule {
    /// `exact`, `ulp 4`, `abs 1e-6`.
    pub fn parse(text: &str) -> Result<Rule, String> {
        let words: Vec<&str> = text.split_whitespace().collect();
        let bad = || format!("rule {text:?}: write \"exact\", \"ulp N\" or \"abs E\"");
        match words[..] {
            ["exact"] => Ok(Rule::Exact),
            ["ulp", n] => n.parse::<u64>().map(Rule::Ulp).map_err(|_| bad()),
            ["abs", e] => match e.parse::<f64>() {
                Ok(e) if e >= 0.0 && e.is_finite() => Ok(Rule::Abs(e)),
                _ => Err(bad()),
            },
            _ => Err(bad()),
        }
    }

    /// Whether float `actual` passes against `expected`.
    pub fn float_ok(self, expected: f32, actual: f32) -> bool {
        if expected.is_nan() || actual.is_nan() {
            return expected.is_nan() && actual.is_nan();
        }
        match self {
            Rule::Exact => expected.to_bits() == actual.to_bits(),
            Rule::Ulp(n) => ulp_distance(expected, actual) <= n,
            Rule::Abs(e) => expected == actual || (f64::from(actual) - f64::from(expected)).abs() <= e,
        }
    }
}

impl std::fmt::Display for Rule {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Rule::Exact => write!(f, "exact"),
            Rule::Ulp(n) => write!(f, "ulp {n}"),
            Rule::Abs(e) => write!(f, "abs {e:e}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rules_parse_and_apply() {
        assert_eq!(Rule::parse("exact").unwrap(), Rule::Exact);
        assert_eq!(Rule::parse("ulp 4").unwrap(), Rule::Ulp(4));
        assert_eq!(Rule::parse(" abs  1e-6 ").unwrap(), Rule::Abs(1e-6));
        assert!(Rule::parse("close").unwrap_err().contains("\"ulp N\""));
        assert!(Rule::parse("abs -1").is_err());
        let next = f32::from_bits(1.0f32.to_bits() + 1);
        assert!(!Rule::Exact.float_ok(1.0, next));
        assert!(Rule::Ulp(1).float_ok(1.0, next));
        assert!(Rule::Abs(1e-6).float_ok(1.0, next));
        assert!(!Rule::Exact.float_ok(0.0, -0.0));
        assert!(Rule::Exact.float_ok(f32::NAN, f32::from_bits(0xffc0_0000)));
        assert!(!Rule::Ulp(u64::MAX - 1).float_ok(f32::NAN, 1.0));
        assert!(Rule::Abs(0.0).float_ok(f32::INFINITY, f32::INFINITY));
    }
}
