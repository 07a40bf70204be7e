//! Light that does not arrive: a light left out, or blocked where nothing
//! blocks it. raycast draws the scene once without each light (its colour
//! 0: no term, so no shadow ray), which gives each light's share of every
//! pixel; a student's pixel that is raycast's less the shares of some of
//! the lights is lit by the others only. Where that pattern is speckled
//! (lit and blocked pixels side by side on one surface) it is shadow acne:
//! a shadow ray that leaves from the surface point itself meets the
//! surface it leaves, or not, as the last bit of each hit falls.

use super::{rgb, told_by, Candidate, Category, SPECKLE, TOLERANCE};
use crate::error::Error;
use crate::frame::FrameData;
use crate::render::{Picture, Renderer};
use crate::scene::{LightKind, Scene};

/// Lights beyond this many are not looked at one by one (each costs a
/// render, and a pixel tries every subset of the lights that reach it).
const MAX_LIGHTS: usize = 10;

/// Light blocked is told only where it is at least this share of the
/// differing pixels: a darker pixel of another mistake (a mirror showing
/// something else) can be raycast's less some lights' shares by chance.
const BLOCKED_SHARE: f64 = 0.2;

/// ... and at least this share of the differing pixels on the surfaces
/// where it shows.
const SURFACE_SHARE: f64 = 0.7;

/// The light kinds (layout.h LIGHT_*) of which `data` has two lights or
/// more: each is also left out as a whole (a kind the student's code
/// skips).
fn shared_kinds(data: &FrameData) -> Vec<u32> {
    let mut kinds: Vec<u32> = data.lights.iter().map(|l| l.kind).collect();
    kinds.sort_unstable();
    kinds.dedup();
    kinds.into_iter().filter(|&k| data.lights.iter().filter(|l| l.kind == k).count() > 1).collect()
}

/// How many renders `candidates` makes for `data`.
pub fn renders(data: &FrameData) -> usize {
    if data.lights.len() <= MAX_LIGHTS {
        data.lights.len() + shared_kinds(data).len()
    } else {
        0
    }
}

fn kind_name(kind: LightKind) -> &'static str {
    match kind {
        LightKind::Point => "point",
        LightKind::Directional => "directional",
        LightKind::Spot => "spot",
        LightKind::Area => "area",
    }
}

/// The candidates of light that does not arrive: each light left out (a
/// variant: raycast drawn without it), and light blocked where nothing
/// blocks it (`shadow-acne` where speckled, else `extra-shadows`): each
/// differing pixel darker than raycast's by the shares of some of the
/// lights that reach it. `told(k)` after the k-th of `renders(data)` renders.
pub fn candidates(
    scene: &Scene,
    data: &FrameData,
    renderer: &dyn Renderer,
    reference: &Picture,
    (theirs, ours, differs): (&[[u8; 3]], &[[u8; 3]], &[bool]),
    told: &dyn Fn(usize),
) -> Result<Vec<Candidate>, Error> {
    let count = ours.len();
    let mut out = Vec::new();
    // raycast drawn without the lights `dark` (their colour 0: no term, no
    // shadow ray), as the candidate of their being left out.
    let left_out = |dark: &dyn Fn(usize) -> bool, named: String| -> Result<(Vec<[u8; 3]>, Candidate), Error> {
        let mut without = data.clone();
        for (i, l) in without.lights.iter_mut().enumerate() {
            if dark(i) {
                l.color = [0.0; 4];
            }
        }
        let (picture, _) = renderer.render_frame(&without, &|_| {})?;
        let colours: Vec<[u8; 3]> = picture.pixels.iter().map(rgb).collect();
        let (changes, explains) = told_by(&colours, ours, theirs, differs);
        let candidate = Candidate {
            cause: "no-light".into(),
            what: format!("{named} left out"),
            also: Vec::new(),
            category: Category::Lighting,
            colours: Some(colours.clone()),
            explains,
            changes,
        };
        Ok((colours, candidate))
    };
    // Each light's share of each pixel: raycast's less raycast's without it.
    let lights = if renders(data) > 0 { data.lights.len() } else { 0 };
    let mut shares: Vec<Vec<[i16; 3]>> = Vec::with_capacity(lights);
    for i in 0..lights {
        let named = scene
            .lights
            .get(i)
            .map_or_else(|| format!("light {}", i + 1), |l| format!("the {} light at {}", kind_name(l.kind), l.loc));
        let (colours, candidate) = left_out(&|k| k == i, named)?;
        told(i + 1);
        shares.push((0..count).map(|p| [0, 1, 2].map(|c| i16::from(ours[p][c]) - i16::from(colours[p][c]))).collect());
        if candidate.changes.iter().any(|&c| c) {
            out.push(candidate);
        }
    }
    for (n, kind) in shared_kinds(data).into_iter().enumerate().take_while(|_| lights > 0) {
        let name =
            scene.lights.iter().zip(&data.lights).find(|(_, l)| l.kind == kind).map_or("", |(l, _)| kind_name(l.kind));
        let (_, candidate) = left_out(&|k| data.lights[k].kind == kind, format!("every {name} light"))?;
        told(lights + n + 1);
        if candidate.changes.iter().any(|&c| c) {
            out.push(candidate);
        }
    }
    if lights == 0 {
        return Ok(out);
    }
    // A differing pixel that is raycast's less the shares of a set of the
    // lights that reach it, each share's own truncation allowed for (the
    // sums of every set built up from the set less its lowest light).
    let reaches = |i: usize, p: usize| shares[i][p] != [0; 3];
    let blocked: Vec<bool> = (0..count)
        .map(|p| {
            if !differs[p] {
                return false;
            }
            let reaching: Vec<usize> = (0..lights).filter(|&i| reaches(i, p)).collect();
            let mut sums = vec![[0i16; 3]; 1 << reaching.len()];
            (1..sums.len()).any(|set| {
                let low = set.trailing_zeros() as usize;
                let less = [0, 1, 2].map(|c| sums[set & (set - 1)][c] + shares[reaching[low]][p][c]);
                sums[set] = less;
                let slack = i16::from(TOLERANCE) + set.count_ones() as i16 - 1;
                (0..3).all(|c| (i16::from(ours[p][c]) - less[c] - i16::from(theirs[p][c])).abs() <= slack)
            })
        })
        .collect();
    let total = blocked.iter().filter(|&&b| b).count();
    let differing = differs.iter().filter(|&&d| d).count();
    if total == 0 || (total as f64) < BLOCKED_SHARE * differing as f64 {
        return Ok(out);
    }
    // On the surfaces where it shows, blocked light is most of what
    // differs: a shading mistake (a normal not of unit length, say) darkens
    // a surface smoothly, and only a band of its pixels matches some
    // lights' shares by chance.
    let mut by_surface = std::collections::HashMap::<u32, (usize, usize)>::new();
    for p in (0..count).filter(|&p| differs[p]) {
        let e = by_surface.entry(reference.pixels[p].id).or_default();
        e.0 += usize::from(blocked[p]);
        e.1 += 1;
    }
    let (on, of) = by_surface.values().filter(|e| e.0 > 0).fold((0, 0), |(a, b), e| (a + e.0, b + e.1));
    if (on as f64) < SURFACE_SHARE * of as f64 {
        return Ok(out);
    }
    // Where raycast drawn without some lights (a light or a kind left out)
    // tells the same pixels as well, that is the cause, not blocked light:
    // it matches 90% of them and changes few pixels that agree.
    let told_already = out.iter().any(|c| {
        let both = (0..count).filter(|&p| blocked[p] && c.explains[p]).count();
        let against = (0..count).filter(|&p| c.changes[p] && !differs[p]).count();
        both as f64 >= 0.9 * total as f64 && against as f64 <= 0.05 * both as f64
    });
    if told_already {
        return Ok(out);
    }
    // Speckle: blocked pixels beside a pixel of the same surface that some
    // light reaches and that agrees with raycast's.
    let lit_and_right = |q: usize| !differs[q] && (0..lights).any(|i| reaches(i, q));
    let beside_lit = (0..count).filter(|&p| blocked[p] && super::beside(reference, p, &lit_and_right)).count();
    let speckled = beside_lit as f64 >= SPECKLE * total as f64;
    let (cause, what) = if speckled {
        (
            "shadow-acne",
            "shadow acne: surfaces shadow themselves in speckles (a shadow ray that starts on the surface meets \
             the surface it leaves as the last bit falls; start it a little off the surface)",
        )
    } else {
        (
            "extra-shadows",
            "shadows where nothing blocks the light (a shadow ray that meets the surface it leaves, counts hits \
             behind its start or beyond a point light)",
        )
    };
    out.push(Candidate {
        cause: cause.into(),
        what: what.into(),
        also: Vec::new(),
        category: Category::Lighting,
        colours: None,
        changes: blocked.clone(),
        explains: blocked,
    });
    Ok(out)
}
