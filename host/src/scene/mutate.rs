//! Scene-file mutations from a seed, the same cases on every machine: the
//! parser's tests (bad input fails with a located error, never a panic:
//! mutation_tests.rs) and the check suite's mutated scenes (the device and
//! the CPU build agree on whatever still renders: tests/check.rs). Test
//! support, public so that the integration tests reach it.

use rand::rngs::StdRng;
use rand::{RngExt as _, SeedableRng as _};

/// The mutations' random source: rand's `StdRng` from a seed (ChaCha12 in
/// the rand that Cargo.lock holds), so that a seed names the same cases on
/// every machine; a test prints the seed with a failure. (Braced, not a
/// tuple struct: the function `Rng` below takes the constructor's name.)
pub struct Rng {
    rng: StdRng,
}

impl Rng {
    pub fn seeded(seed: u64) -> Rng {
        Rng { rng: StdRng::seed_from_u64(seed) }
    }

    /// A number below `n` (0 for an `n` of 0).
    pub fn below(&mut self, n: usize) -> usize {
        self.rng.random_range(0..n.max(1))
    }

    /// One of `items`, which are not empty.
    pub fn pick<'a>(&mut self, items: &[&'a str]) -> &'a str {
        items[self.below(items.len())]
    }
}

/// What a quoted attribute value may become: extremes, non-numbers, near
/// misses (the parser's tests).
pub const VALUES: &[&str] = &[
    "0",
    "-0",
    "1e38",
    "-1e38",
    "3.4e38",
    "1e-45",
    "nan",
    "inf",
    "-inf",
    "4294967296",
    "-1",
    "99999999999999999999",
    "0.0000001",
    "1e300",
    "65536",
    "2147483648",
    " ",
    "",
    "1,2",
    "0x10",
    "1e",
    "--1",
    "1 2",
];

/// Ordinary values, which mostly leave a scene that still renders, another
/// scene (the device against the CPU build, tests/check.rs).
pub const ORDINARY: &[&str] =
    &["0", "1", "-1", "2", "0.5", "0.3", "0.001", "0.99", "3", "10", "45", "-90", "1000", "-0.5"];

/// Words whose swap keeps the XML well formed but the scene's meaning not.
pub const WORDS: &[&str] = &[
    "tree",
    "master",
    "primitive",
    "sphere",
    "cube",
    "cone",
    "cylinder",
    "root",
    "directional",
    "point",
    "spot",
    "area",
];

fn lines_of(s: &str) -> Vec<String> {
    s.lines().map(String::from).collect()
}

/// One to four mutations of `source`: a quoted value replaced by one of
/// `values` (VALUES, ORDINARY), lines deleted, duplicated or moved, a WORDS
/// word swapped, a byte changed, the text cut short.
pub fn mutate(source: &str, rng: &mut Rng, values: &[&str]) -> String {
    let mut s = source.to_string();
    for _ in 0..1 + rng.below(4) {
        let mut lines = lines_of(&s);
        let n = lines.len().max(1);
        let a = rng.below(n).min(lines.len());
        let b = (a + 1 + rng.below(8)).min(lines.len());
        match rng.below(7) {
            0 => {
                s = replace_quoted(&s, rng, values, |_| true).unwrap_or(s);
                continue;
            }
            1 => drop(lines.drain(a..b)),
            2 => {
                let copy: Vec<String> = lines[a..b].to_vec();
                lines.splice(b..b, copy);
            }
            3 => {
                if a < lines.len() {
                    let line = lines.remove(a);
                    let to = rng.below(lines.len() + 1);
                    lines.insert(to, line);
                }
            }
            4 => {
                let (from, to) = (rng.pick(WORDS), rng.pick(WORDS));
                s = s.replacen(&format!("\"{from}\""), &format!("\"{to}\""), 1);
                continue;
            }
            5 => {
                // One byte changed to a character XML cares about.
                let mut bytes = s.into_bytes();
                if !bytes.is_empty() {
                    let i = rng.below(bytes.len());
                    bytes[i] = b"<>/\"= aZ0\n&;"[rng.below(12)];
                }
                s = String::from_utf8_lossy(&bytes).into_owned();
                continue;
            }
            _ => {
                let mut cut = rng.below(s.len());
                while !s.is_char_boundary(cut) {
                    cut -= 1;
                }
                s.truncate(cut);
                continue;
            }
        }
        s = lines.join("\n");
    }
    s
}

/// One to four numeric quoted values of `source` replaced by one of
/// `values`: the scene mostly still loads, and renders otherwise.
pub fn mutate_numbers(source: &str, rng: &mut Rng, values: &[&str]) -> String {
    let mut s = source.to_string();
    for _ in 0..1 + rng.below(4) {
        match replace_quoted(&s, rng, values, |v| v.trim().parse::<f64>().is_ok()) {
            Some(t) => s = t,
            None => break,
        }
    }
    s
}

/// `s` with one of its quoted values that `take` accepts (chosen by `rng`)
/// replaced by one of `values`; None where it has none.
fn replace_quoted(s: &str, rng: &mut Rng, values: &[&str], take: impl Fn(&str) -> bool) -> Option<String> {
    let quotes: Vec<usize> = s.match_indices('"').map(|(i, _)| i).collect();
    let quoted: Vec<(usize, usize)> =
        quotes.chunks_exact(2).map(|q| (q[0], q[1])).filter(|&(a, b)| take(&s[a + 1..b])).collect();
    if quoted.is_empty() {
        return None;
    }
    let (a, b) = quoted[rng.below(quoted.len())];
    Some(format!("{}\"{}\"{}", &s[..a], rng.pick(values), &s[b + 1..]))
}
