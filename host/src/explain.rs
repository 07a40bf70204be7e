//! `raycast explain`: why a student's picture differs from raycast's render
//! of the same scene, not only that it does. raycast draws its own
//! reference (the CPU build: the exact pixels, with every hit's primitive),
//! finds the pixels that differ, and tries each mistake it knows
//! (`variants`: a term left out, doubled or unweighted, a convention
//! changed), drawn on purpose: the variant that the student's pixels match,
//! where the reference does not, is the likeliest cause. Its pixels are
//! told by what the scene holds there (`regions`: the primitive and its
//! XML element, its shape and part, its material). Light that does not
//! arrive (`lights`: a light or a kind of light left out, shadow acne) is
//! told from each light's share of the pixels; mirror acne by its speckle
//! on mirror surfaces; a gamma correction as a tone curve fitted over the
//! picture. What no variant explains is told as missing or extra geometry
//! where the student's picture shows the background, or the reverse.
//!
//! The search is greedy: the variant that explains the most differing
//! pixels, less those it would change where the student's picture agrees
//! with the reference, is the first finding; its pixels are taken away and
//! the next is sought among the rest.

mod annotate;
mod lights;
mod regions;
#[cfg(test)]
mod tests;
mod variants;

pub use annotate::annotated;
pub use regions::{Group, Regions};
pub use variants::{variant, Category, Variant, VARIANTS};

use crate::error::Error;
use crate::frame::FrameData;
use crate::image_io::Rgb8;
use crate::layout::NO_HIT;
use crate::render::{Picture, Renderer};
use crate::scene::Scene;
use serde::Serialize;

/// Per channel, a pixel differs when off by more than this (as `compare`).
pub const TOLERANCE: u8 = 2;
/// The most findings told.
const MAX_FINDINGS: usize = 5;
/// A finding explains at least this many pixels, and this share of those
/// that differ: fewer are noise (a last bit at a silhouette).
const MIN_PIXELS: usize = 4;
const MIN_SHARE: f64 = 0.02;

/// What the student's picture is compared by, and when it is right.
#[derive(Clone, Copy, Debug)]
pub struct Rule {
    /// At most this share of the pixels may differ (by more than TOLERANCE).
    pub max_fraction: f64,
    /// Or, for a sampled reference, at least this PSNR (dB) over the picture.
    pub min_psnr: Option<f64>,
}

impl Default for Rule {
    /// `compare`'s: at most 0.1% of the pixels differ.
    fn default() -> Self {
        Rule { max_fraction: crate::conformance::MAX_FRACTION, min_psnr: None }
    }
}

/// The likeliest cause of some of the differences.
#[derive(Clone, Debug, Serialize)]
pub struct Finding {
    /// `no-specular`, or `missing-geometry` / `extra-geometry`.
    pub cause: String,
    /// For people: "no specular term".
    pub what: String,
    /// Other mistakes that draw this scene's picture the same (say, the
    /// specular term counted twice and without k_s = 0.5): as likely.
    pub also: Vec<String>,
    pub category: Category,
    /// The differing pixels it explains.
    pub pixels: usize,
    /// Their share of every differing pixel.
    pub share: f64,
    /// Whether the picture matches raycast drawn with the mistake on its
    /// pixels (within TOLERANCE): false for a term computed otherwise and
    /// for missing or extra geometry, which no variant draws.
    pub matches: bool,
    /// PSNR of the student's pixels against raycast drawn with the mistake,
    /// over the pixels it explains and those it changes (dB; None: identical).
    pub fit_db: Option<f64>,
    /// Pixels the mistake changes where the student's picture agrees with
    /// the reference (against it).
    pub contradicted: usize,
    /// Where its pixels are, by what the scene holds there.
    pub on: Vec<Group>,
    /// The pixel that tells it best: the one it explains off by the most.
    pub pixel: (u32, u32),
}

/// What `explain` found.
#[derive(Clone, Debug, Serialize)]
pub struct Explanation {
    pub width: u32,
    pub height: u32,
    /// Pixels off by more than TOLERANCE in a channel.
    pub differing: usize,
    pub total: usize,
    /// PSNR of the student's picture against the reference (dB; None: identical).
    pub psnr: Option<f64>,
    /// Whether the picture passes the rule: then there is no finding.
    pub passes: bool,
    pub findings: Vec<Finding>,
    /// Differing pixels no finding explains.
    pub unexplained: usize,
    /// Where those are.
    pub unexplained_on: Vec<Group>,
    /// Each pixel's finding (index into `findings`), None for none.
    #[serde(skip)]
    pub owner: Vec<Option<usize>>,
    /// Whether each pixel differs.
    #[serde(skip)]
    pub differs: Vec<bool>,
}

fn rgb(p: &crate::layout::PixelOut) -> [u8; 3] {
    let b = p.rgba.to_le_bytes();
    [b[0], b[1], b[2]]
}

fn near(a: [u8; 3], b: [u8; 3]) -> bool {
    a.iter().zip(&b).all(|(x, y)| x.abs_diff(*y) <= TOLERANCE)
}

/// Where a picture drawn with a mistake (`colours`) changes raycast's
/// (`ours`), and the differing pixels where it matches the student's
/// (`theirs`): what a candidate changes and what it explains.
fn told_by(colours: &[[u8; 3]], ours: &[[u8; 3]], theirs: &[[u8; 3]], differs: &[bool]) -> (Vec<bool>, Vec<bool>) {
    let changes: Vec<bool> = (0..ours.len()).map(|i| !near(colours[i], ours[i])).collect();
    let explains = (0..ours.len()).map(|i| differs[i] && changes[i] && near(colours[i], theirs[i])).collect();
    (changes, explains)
}

fn off_by(a: [u8; 3], b: [u8; 3]) -> u8 {
    a.iter().zip(&b).map(|(x, y)| x.abs_diff(*y)).max().unwrap_or(0)
}

/// PSNR (dB, over R, G and B) of `a` against `b` at `pixels`; None where they agree.
fn psnr(a: &[[u8; 3]], b: &[[u8; 3]], pixels: impl Iterator<Item = usize>) -> Option<f64> {
    let (mut sum, mut n) = (0.0f64, 0usize);
    for i in pixels {
        for c in 0..3 {
            let d = f64::from(a[i][c]) - f64::from(b[i][c]);
            sum += d * d;
        }
        n += 3;
    }
    (n > 0 && sum > 0.0).then(|| 10.0 * (255.0f64 * 255.0 / (sum / n as f64)).log10())
}

/// A candidate: a variant's picture (its colours), or a kind of geometry
/// told by the background.
struct Candidate {
    cause: String,
    what: String,
    also: Vec<String>,
    category: Category,
    colours: Option<Vec<[u8; 3]>>,
    /// Pixels it explains among any (before the search takes some away).
    explains: Vec<bool>,
    /// Pixels it changes from the reference.
    changes: Vec<bool>,
}

/// Why `mine` differs from raycast's render of `scene` packed as `data`
/// (the size `mine` has), drawn by `renderer` (the CPU build: exact, and
/// it runs the variants' code), under `rule`.
pub fn explain(
    scene: &Scene,
    data: &FrameData,
    mine: &Rgb8,
    renderer: &dyn Renderer,
    rule: Rule,
    told: &dyn Fn(usize, usize),
) -> Result<Explanation, Error> {
    let f = &data.frame;
    if (mine.width, mine.height) != (f.width, f.height) {
        return Err(Error::Failed(format!(
            "the picture is {}x{} and the reference {}x{}: render it at the picture's size",
            mine.width, mine.height, f.width, f.height
        )));
    }
    let applies: Vec<&Variant> = VARIANTS.iter().filter(|v| (v.applies)(data)).collect();
    let renders = applies.len() + 1 + lights::renders(data);
    told(0, renders);
    let (reference, _) = renderer.render_frame(data, &|_| {})?;
    let count = reference.pixels.len();
    let theirs: Vec<[u8; 3]> = mine.data.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
    let ours: Vec<[u8; 3]> = reference.pixels.iter().map(rgb).collect();
    let differs: Vec<bool> = (0..count).map(|i| !near(theirs[i], ours[i])).collect();
    let differing = differs.iter().filter(|&&d| d).count();
    let psnr_all = psnr(&theirs, &ours, 0..count);
    let passes = differing as f64 <= rule.max_fraction * count as f64
        || rule.min_psnr.is_some_and(|bound| psnr_all.is_none_or(|p| p >= bound));
    let mut explanation = Explanation {
        width: f.width,
        height: f.height,
        differing,
        total: count,
        psnr: psnr_all,
        passes,
        findings: Vec::new(),
        unexplained: 0,
        unexplained_on: Vec::new(),
        owner: vec![None; count],
        differs: differs.clone(),
    };
    let regions = Regions::of(scene, data, &reference);
    if passes {
        // Within the rule, the one mistake left to see is the 8-bit
        // rounding: off by one almost everywhere it matters, which the
        // tolerance hides. It counts where the picture matches raycast drawn
        // with it exactly far more often than raycast as it is.
        if let Some(finding) = rounding(data, renderer, &theirs, &ours, &regions)? {
            for (i, owner) in explanation.owner.iter_mut().enumerate() {
                if theirs[i] != ours[i] {
                    *owner = Some(0);
                }
            }
            explanation.passes = false;
            explanation.findings.push(finding);
        }
        return Ok(explanation);
    }

    let mut candidates = Vec::new();
    for (k, v) in applies.iter().enumerate() {
        let mut variant_data = data.clone();
        (v.apply)(&mut variant_data);
        let (picture, _) = renderer.render_frame(&variant_data, &|_| {})?;
        told(k + 1, renders);
        let colours: Vec<[u8; 3]> = picture.pixels.iter().map(rgb).collect();
        let (changes, explains) = told_by(&colours, &ours, &theirs, &differs);
        if !changes.iter().any(|&c| c) {
            continue;
        }
        // A variant that draws the same picture as one before is another
        // name for it here.
        if let Some(same) = candidates.iter_mut().find(|c: &&mut Candidate| c.colours.as_ref() == Some(&colours)) {
            same.also.push(v.id.to_string());
            continue;
        }
        candidates.push(Candidate {
            cause: v.id.to_string(),
            what: v.what.to_string(),
            also: Vec::new(),
            category: v.category,
            colours: Some(colours),
            explains,
            changes,
        });
    }
    let scaled: Vec<Candidate> = candidates
        .iter()
        .filter(|c| SCALABLE.contains(&c.cause.as_str()))
        .filter_map(|c| scaled_term(c, &theirs, &ours, &differs))
        .collect();
    candidates.extend(scaled);
    let told_light = |k: usize| told(applies.len() + 1 + k, renders);
    let pictures = (theirs.as_slice(), ours.as_slice(), differs.as_slice());
    for c in lights::candidates(scene, data, renderer, &reference, pictures, &told_light)? {
        match candidates.iter_mut().find(|d| c.colours.is_some() && d.colours == c.colours) {
            Some(same) => same.also.push(c.cause),
            None => candidates.push(c),
        }
    }
    candidates.extend(mirror_acne(scene, data, &reference, &differs, &regions));
    candidates.extend(tone_curve(&ours, &theirs, &differs));
    candidates.extend(geometry_candidates(&reference, &theirs, &ours, &differs, &regions));

    // Greedy: the candidate that explains the most of what is left, net of
    // what it would change where the pictures agree.
    let mut left = differs.clone();
    let min = MIN_PIXELS.max((MIN_SHARE * differing as f64).ceil() as usize);
    let mut used = vec![false; candidates.len()];
    while explanation.findings.len() < MAX_FINDINGS {
        // A variant that matches only part of the differing pixels where it
        // changes any (COVERAGE) is a term computed otherwise, not left out:
        // the second search below tells it so.
        let score = |c: &Candidate| -> (i64, usize, usize) {
            let explained = (0..count).filter(|&i| left[i] && c.explains[i]).count();
            let region = (0..count).filter(|&i| left[i] && c.changes[i]).count();
            if (explained as f64) < COVERAGE * region as f64 {
                return (0, 0, 0);
            }
            let contradicted = (0..count).filter(|&i| c.changes[i] && !differs[i]).count();
            (explained as i64 - contradicted as i64, explained, contradicted)
        };
        let best = candidates
            .iter()
            .enumerate()
            .filter(|(k, _)| !used[*k])
            .map(|(k, c)| (k, score(c)))
            .max_by_key(|&(k, (net, _, _))| (net, std::cmp::Reverse(k)));
        let Some((k, (net, explained, contradicted))) = best else { break };
        if explained < min || net <= 0 || net < (explained as i64) / 2 {
            break;
        }
        used[k] = true;
        let c = &candidates[k];
        let mine_pixels: Vec<usize> = (0..count).filter(|&i| left[i] && c.explains[i]).collect();
        let finding_index = explanation.findings.len();
        for &i in &mine_pixels {
            left[i] = false;
            explanation.owner[i] = Some(finding_index);
        }
        let fit_db = c.colours.as_ref().and_then(|colours| {
            let region = (0..count).filter(|&i| c.explains[i] || (c.changes[i] && differs[i]));
            psnr(&theirs, colours, region)
        });
        let telling = mine_pixels.iter().copied().max_by_key(|&i| (off_by(theirs[i], ours[i]), std::cmp::Reverse(i)));
        let telling = telling.unwrap_or(0);
        explanation.findings.push(Finding {
            cause: c.cause.clone(),
            what: c.what.clone(),
            also: c.also.clone(),
            category: c.category,
            pixels: explained,
            share: explained as f64 / differing.max(1) as f64,
            matches: c.colours.is_some(),
            fit_db,
            contradicted,
            on: regions.groups(mine_pixels.iter().copied()),
            pixel: ((telling % f.width as usize) as u32, (telling / f.width as usize) as u32),
        });
    }
    // What is left, where it lies just where one term of the model shows:
    // that term computed otherwise. Most of what is left lies where the
    // term's variant changes the picture (RECALL), and a fair share of
    // those pixels differ (PRECISION); the best by recall times the root
    // of precision first.
    while explanation.findings.len() < MAX_FINDINGS {
        let remaining = left.iter().filter(|&&l| l).count();
        if remaining < min {
            break;
        }
        let fit = |c: &Candidate| {
            let both = (0..count).filter(|&i| left[i] && c.changes[i]).count() as f64;
            let changed = (0..count).filter(|&i| c.changes[i] && (left[i] || !differs[i])).count() as f64;
            let (recall, precision) = (both / remaining as f64, both / changed.max(1.0));
            if recall >= RECALL && precision >= PRECISION {
                recall * precision.sqrt()
            } else {
                0.0
            }
        };
        let best = candidates
            .iter()
            .enumerate()
            .filter(|(k, c)| !used[*k] && term_of(&c.cause).is_some())
            .map(|(k, c)| (k, fit(c)))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)));
        let Some((k, _)) = best.filter(|b| b.1 > 0.0) else { break };
        used[k] = true;
        let c = &candidates[k];
        let region: Vec<usize> = (0..count).filter(|&i| left[i] && c.changes[i]).collect();
        let finding_index = explanation.findings.len();
        for &i in &region {
            left[i] = false;
            explanation.owner[i] = Some(finding_index);
        }
        let telling = region.iter().copied().max_by_key(|&i| (off_by(theirs[i], ours[i]), std::cmp::Reverse(i)));
        let telling = telling.unwrap_or(0);
        let term = term_of(&c.cause).expect("a term's variant");
        explanation.findings.push(Finding {
            cause: format!("{}-changed", term.replace(' ', "-")),
            what: format!(
                "the {term} computed otherwise: the picture differs where raycast drawn with {} does, by other amounts",
                c.what
            ),
            also: Vec::new(),
            category: c.category,
            pixels: region.len(),
            share: region.len() as f64 / differing.max(1) as f64,
            matches: false,
            fit_db: None,
            contradicted: (0..count).filter(|&i| c.changes[i] && !differs[i]).count(),
            on: regions.groups(region.iter().copied()),
            pixel: ((telling % f.width as usize) as u32, (telling / f.width as usize) as u32),
        });
    }
    let rest: Vec<usize> = (0..count).filter(|&i| left[i]).collect();
    explanation.unexplained = rest.len();
    explanation.unexplained_on = regions.groups(rest.into_iter());
    Ok(explanation)
}

/// The variants whose term scales: a picture `mine` of such a term weighted
/// by another factor is raycast's plus that factor times the term.
const SCALABLE: &[&str] = &["no-ambient", "no-diffuse", "no-specular", "no-reflections", "no-shadows"];

/// The terms of the lighting model, by the variant that leaves each out:
/// where what is left unexplained lies just where one of them shows, it is
/// that term computed otherwise.
const TERMS: &[(&str, &str)] = &[
    ("no-ambient", "ambient term"),
    ("no-diffuse", "diffuse term"),
    ("no-specular", "specular term"),
    ("no-reflections", "mirror reflection"),
    ("no-shadows", "shadow test"),
    ("no-attenuation", "distance attenuation"),
    ("spot-as-point", "spot cone"),
    ("hard-spot-edge", "spot falloff"),
    ("no-textures", "texture mapping"),
    ("no-refraction", "refraction"),
];

/// The term variant `id` leaves out (`TERMS`).
fn term_of(id: &str) -> Option<&'static str> {
    TERMS.iter().find(|(v, _)| *v == id).map(|(_, term)| *term)
}

/// The share of the differing pixels it changes that a variant must match
/// to be told as the cause (the rest: a term computed otherwise).
const COVERAGE: f64 = 0.9;

/// What is left unexplained is told as a term computed otherwise where at
/// least RECALL of it lies where the term's variant changes the picture,
/// and at least PRECISION of those pixels differ.
const RECALL: f64 = 0.6;
const PRECISION: f64 = 0.2;

/// The term that variant `c` leaves out (`no-specular`: what raycast draws
/// less what it draws without), weighted by the factor a that fits the
/// student's picture best over the differing pixels where the term shows
/// (least squares): a candidate drawn as the variant plus a times the term,
/// named by a, where a is neither 0 (the variant itself) nor 1.
fn scaled_term(c: &Candidate, theirs: &[[u8; 3]], ours: &[[u8; 3]], differs: &[bool]) -> Option<Candidate> {
    let without = c.colours.as_ref()?;
    let count = theirs.len();
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for i in (0..count).filter(|&i| differs[i]) {
        for ch in 0..3 {
            let term = f64::from(ours[i][ch]) - f64::from(without[i][ch]);
            // Where the reference is clamped, its term is not the whole term.
            if term.abs() >= 3.0 && ours[i][ch] < 255 {
                num += (f64::from(theirs[i][ch]) - f64::from(without[i][ch])) * term;
                den += term * term;
            }
        }
    }
    if den == 0.0 {
        return None;
    }
    let a = num / den;
    if !(-4.0..=8.0).contains(&a) || a.abs() < 0.05 || (a - 1.0).abs() < 0.05 || (a - 2.0).abs() < 0.05 {
        return None;
    }
    let colours: Vec<[u8; 3]> = (0..count)
        .map(|i| {
            [0, 1, 2].map(|ch| {
                let term = f64::from(ours[i][ch]) - f64::from(without[i][ch]);
                (f64::from(without[i][ch]) + a * term).round().clamp(0.0, 255.0) as u8
            })
        })
        .collect();
    let (changes, explains) = told_by(&colours, ours, theirs, differs);
    let term = term_of(&c.cause)?;
    Some(Candidate {
        cause: format!("weighted-{}", term.replace(' ', "-")),
        what: format!("the {term} weighted {a:.2} times raycast's"),
        also: Vec::new(),
        category: c.category,
        colours: Some(colours),
        explains,
        changes,
    })
}

/// A tone curve over the whole picture, which no variant draws: each
/// channel of the student's pixel is raycast's to a power g (a gamma
/// correction: g = 1/2.2), the power fitted over the differing pixels
/// (least squares in log space, channels 16 to 250 of 255). A pixel is
/// told where the student's value lies within the tolerance of the curve
/// over the 8-bit step raycast's value stands for; the curve must tell
/// 90% of the differing pixels.
fn tone_curve(ours: &[[u8; 3]], theirs: &[[u8; 3]], differs: &[bool]) -> Option<Candidate> {
    let (mut num, mut den) = (0.0f64, 0.0f64);
    for p in (0..ours.len()).filter(|&p| differs[p]) {
        for c in 0..3 {
            let (a, b) = (f64::from(ours[p][c]), f64::from(theirs[p][c]));
            if (16.0..=250.0).contains(&a) && (1.0..=254.0).contains(&b) {
                let (x, y) = (((a + 0.5) / 255.0).ln(), ((b + 0.5) / 255.0).ln());
                num += x * y;
                den += x * x;
            }
        }
    }
    let g = num / den;
    if den == 0.0 || !(0.2..=5.0).contains(&g) || (g - 1.0).abs() < 0.05 {
        return None;
    }
    let level = |v: f64| (255.0 * (v / 255.0).powf(g)).floor();
    let on_curve = |a: u8, b: u8| {
        let (lo, hi) = (level(f64::from(a)), level(f64::from(a) + 1.0));
        let t = f64::from(TOLERANCE);
        (lo - t..=hi + t).contains(&f64::from(b))
    };
    let told: Vec<bool> =
        (0..ours.len()).map(|p| differs[p] && (0..3).all(|c| on_curve(ours[p][c], theirs[p][c]))).collect();
    let n = told.iter().filter(|&&t| t).count();
    let differing = differs.iter().filter(|&&d| d).count();
    (n as f64 >= 0.9 * differing as f64).then(|| Candidate {
        cause: "tone-curve".into(),
        what: format!(
            "every colour put through a curve: each channel to the power {g:.2} (a gamma correction of {:.1}), \
             which the course does not apply",
            1.0 / g
        ),
        also: Vec::new(),
        category: Category::Clamping,
        colours: None,
        changes: told.clone(),
        explains: told,
    })
}

/// A share of a finding's pixels beside a right pixel of the same surface
/// at least this large is speckle: acne, not a region drawn otherwise.
const SPECKLE: f64 = 0.25;

/// Whether pixel `p` of `reference` has a 4-neighbour on the same surface
/// (the same primitive, or the background) for which `ok` holds.
fn beside(reference: &Picture, p: usize, ok: &dyn Fn(usize) -> bool) -> bool {
    let (w, h) = (reference.width as usize, reference.height as usize);
    let (x, y) = (p % w, p / w);
    let around =
        [(x > 0).then(|| p - 1), (x + 1 < w).then(|| p + 1), (y > 0).then(|| p - w), (y + 1 < h).then(|| p + w)];
    around.into_iter().flatten().any(|q| reference.pixels[q].id == reference.pixels[p].id && ok(q))
}

/// Mirror acne, which no variant draws (it falls as the last bit of each
/// hit does): most differing pixels lie on mirror surfaces, away from
/// silhouettes, speckled among pixels of the same surface that are right,
/// and few differ elsewhere.
fn mirror_acne(
    scene: &Scene,
    data: &FrameData,
    reference: &Picture,
    differs: &[bool],
    regions: &Regions,
) -> Option<Candidate> {
    let f = &data.frame;
    if f.flags & crate::layout::FLAG_REFLECTIONS == 0 || f.k[2] == 0.0 {
        return None;
    }
    // Whether each primitive hit is a mirror, looked up once per primitive.
    let mut mirrors = std::collections::HashMap::<u32, bool>::new();
    let mut mirror = |p: usize| {
        let id = reference.pixels[p].id;
        id != NO_HIT
            && *mirrors.entry(id).or_insert_with(|| {
                scene
                    .primitive(u64::from(id))
                    .and_then(|prim| scene.materials.get(prim.material as usize))
                    .is_some_and(|m| m.reflective.iter().any(|&c| c != 0.0))
            })
    };
    let count = differs.len();
    let inside: Vec<bool> = (0..count).map(|p| differs[p] && !regions.silhouette(p)).collect();
    let on: Vec<bool> = (0..count).map(|p| inside[p] && mirror(p)).collect();
    let total = on.iter().filter(|&&o| o).count();
    let speckled = (0..count).filter(|&p| on[p] && beside(reference, p, &|q| !differs[q])).count();
    let mostly = total as f64 >= 0.8 * inside.iter().filter(|&&d| d).count() as f64;
    (total > 0 && mostly && speckled as f64 >= SPECKLE * total as f64).then(|| Candidate {
        cause: "mirror-acne".into(),
        what: "mirror acne: reflections speckled (a mirror ray that starts on the surface meets the surface it leaves \
               as the last bit falls; start it a little off the surface)"
            .into(),
        also: Vec::new(),
        category: Category::Lighting,
        colours: None,
        changes: on.clone(),
        explains: on,
    })
}

/// What no variant draws: where the student's picture shows the background
/// and raycast a surface (missing geometry), or the reverse (extra), away
/// from silhouettes (a last bit or a student's supersampling moves those).
fn geometry_candidates(
    reference: &Picture,
    theirs: &[[u8; 3]],
    ours: &[[u8; 3]],
    differs: &[bool],
    regions: &Regions,
) -> Vec<Candidate> {
    let count = reference.pixels.len();
    // The background: what the reference shows where its rays miss.
    let background =
        reference.pixels.iter().position(|p| p.id == NO_HIT).map_or([0, 0, 0], |i| rgb(&reference.pixels[i]));
    let missing: Vec<bool> = (0..count)
        .map(|i| {
            differs[i] && reference.pixels[i].id != NO_HIT && near(theirs[i], background) && !regions.silhouette(i)
        })
        .collect();
    let extra: Vec<bool> = (0..count)
        .map(|i| differs[i] && reference.pixels[i].id == NO_HIT && !near(theirs[i], ours[i]) && !regions.silhouette(i))
        .collect();
    vec![
        Candidate {
            cause: "missing-geometry".into(),
            what: "surfaces missing: the background where the scene has them".into(),
            also: Vec::new(),
            category: Category::Geometry,
            colours: None,
            changes: missing.clone(),
            explains: missing,
        },
        Candidate {
            cause: "extra-geometry".into(),
            also: Vec::new(),
            what: "surfaces where the scene has none (a hit behind the camera, or outside a shape's bounds)".into(),
            category: Category::Geometry,
            colours: None,
            changes: extra.clone(),
            explains: extra,
        },
    ]
}

/// Below the tolerance: whether the picture is raycast's rounded to the
/// nearest 8-bit value rather than truncated (the `rounded` variant): of
/// the pixels not the same to the bit (at least 1% of them), raycast drawn
/// rounded matches at least 95% exactly, and changes few that do match.
fn rounding(
    data: &FrameData,
    renderer: &dyn Renderer,
    theirs: &[[u8; 3]],
    ours: &[[u8; 3]],
    regions: &Regions,
) -> Result<Option<Finding>, Error> {
    let count = theirs.len();
    let off: Vec<usize> = (0..count).filter(|&i| theirs[i] != ours[i]).collect();
    if off.len() < MIN_PIXELS.max(count / 100) {
        return Ok(None);
    }
    let v = variant("rounded").expect("the rounding variant");
    let mut rounded = data.clone();
    (v.apply)(&mut rounded);
    let (picture, _) = renderer.render_frame(&rounded, &|_| {})?;
    let colours: Vec<[u8; 3]> = picture.pixels.iter().map(rgb).collect();
    let matched = off.iter().filter(|&&i| theirs[i] == colours[i]).count();
    let broken = (0..count).filter(|&i| theirs[i] == ours[i] && colours[i] != ours[i]).count();
    if (matched as f64) < 0.95 * off.len() as f64 || broken > off.len() / 20 {
        return Ok(None);
    }
    let telling = off.first().copied().unwrap_or(0);
    let width = data.frame.width as usize;
    Ok(Some(Finding {
        cause: v.id.to_string(),
        what: v.what.to_string(),
        also: Vec::new(),
        category: v.category,
        pixels: matched,
        share: matched as f64 / off.len() as f64,
        matches: true,
        fit_db: psnr(theirs, &colours, off.iter().copied()),
        contradicted: broken,
        on: regions.groups(off.iter().copied()),
        pixel: ((telling % width) as u32, (telling / width) as u32),
    }))
}
