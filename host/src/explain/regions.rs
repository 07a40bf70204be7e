//! What the scene holds at each pixel of raycast's reference: the
//! primitive its camera ray hit, that primitive's XML element, shape, part
//! (`ShapeKind::part`: a cone's cap, a cube's face) and material; and the
//! silhouettes, where a pixel's neighbours see something else.

use crate::frame::FrameData;
use crate::layout::NO_HIT;
use crate::render::Picture;
use crate::scene::Scene;
use glam::{DMat4, DVec3};
use serde::Serialize;
use std::collections::HashMap;

/// Pixels on one part of one kind of shape, and the elements and materials
/// they show.
#[derive(Clone, Debug, Serialize)]
pub struct Group {
    /// `cone`, `sphere`, `mesh`; `background` where the reference's ray missed.
    pub shape: String,
    /// `cap`, `+x face`, or empty for a shape of one part.
    pub part: String,
    /// The primitives' XML elements (`scene.xml:42`), most pixels first.
    pub elements: Vec<String>,
    /// Their materials, by index into the scene's, most pixels first.
    pub materials: Vec<u32>,
    pub pixels: usize,
}

impl Group {
    /// "cone caps (scene.xml:42, :57)", "sphere (scene.xml:12)", "the background".
    pub fn text(&self) -> String {
        if self.shape == "background" {
            return "the background".to_string();
        }
        let what = if self.part.is_empty() { self.shape.clone() } else { format!("{} {}", self.shape, self.part) };
        let mut places: Vec<String> = Vec::new();
        let mut last_file: Option<&str> = None;
        for e in self.elements.iter().take(4) {
            let (file, line) = e.rsplit_once(':').unwrap_or((e.as_str(), ""));
            places.push(if last_file == Some(file) { format!(":{line}") } else { e.clone() });
            last_file = Some(file);
        }
        if self.elements.len() > 4 {
            places.push(format!("and {} more", self.elements.len() - 4));
        }
        format!("{what} ({})", places.join(", "))
    }
}

/// Each pixel's primitive, shape, part and material.
pub struct Regions {
    width: usize,
    /// Per pixel: its key into `keys` (None: the background).
    key: Vec<Option<usize>>,
    /// (shape, part, element, material) of each key.
    keys: Vec<(String, String, String, u32)>,
    ids: Vec<u32>,
}

impl Regions {
    /// The regions of `reference` (a render of `scene` packed as `data`):
    /// each hit pixel's point from its camera ray through the pixel's centre
    /// at the hit's distance, taken to the primitive's object space.
    pub fn of(scene: &Scene, data: &FrameData, reference: &Picture) -> Regions {
        let f = &data.frame;
        let m = DMat4::from_cols_array_2d(&f.world_from_film.map(|c| c.map(f64::from)));
        let eye = DVec3::new(f.eye[0].into(), f.eye[1].into(), f.eye[2].into());
        let (w, h) = (f.width as usize, f.height as usize);
        let mut primitives = HashMap::new();
        let mut keys: Vec<(String, String, String, u32)> = Vec::new();
        let mut index: HashMap<(String, String, String, u32), usize> = HashMap::new();
        let mut key = vec![None; reference.pixels.len()];
        for (i, p) in reference.pixels.iter().enumerate() {
            if p.id == NO_HIT {
                continue;
            }
            let Some(prim) = primitives.entry(p.id).or_insert_with(|| scene.primitive(u64::from(p.id))).as_ref() else {
                continue;
            };
            let (x, y) = ((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
            let film = DVec3::new(x / w as f64 * 2.0 - 1.0, 1.0 - y / h as f64 * 2.0, -1.0);
            let world = eye + m.transform_vector3(film) * f64::from(p.t);
            let part = prim.shape.kind().map_or("", |k| (k.part)(prim.object_from_world.transform_point3(world)));
            let loc = format!("{}:{}", prim.loc.file.display(), prim.loc.line);
            let k = (prim.shape.name().to_string(), part.to_string(), loc, prim.material);
            let next = keys.len();
            let at = *index.entry(k.clone()).or_insert(next);
            if at == next {
                keys.push(k);
            }
            key[i] = Some(at);
        }
        Regions { width: w, key, keys, ids: reference.pixels.iter().map(|p| p.id).collect() }
    }

    /// Whether pixel `i`'s 3x3 neighbourhood sees more than one primitive
    /// (or a primitive and the background).
    pub fn silhouette(&self, i: usize) -> bool {
        let (w, h) = (self.width as i64, (self.ids.len() / self.width.max(1)) as i64);
        let (x, y) = ((i as i64) % w, (i as i64) / w);
        let id = self.ids[i];
        (-1..=1).any(|dy| {
            (-1..=1).any(|dx| {
                let (nx, ny) = ((x + dx).clamp(0, w - 1), (y + dy).clamp(0, h - 1));
                self.ids[(ny * w + nx) as usize] != id
            })
        })
    }

    /// `pixels` grouped by shape and part, most pixels first, each with its
    /// elements and materials, most pixels first.
    pub fn groups(&self, pixels: impl Iterator<Item = usize>) -> Vec<Group> {
        // (shape, part) -> (pixels, by element, by material).
        type Tally = (usize, HashMap<String, usize>, HashMap<u32, usize>);
        let mut tally: HashMap<(String, String), Tally> = HashMap::new();
        for i in pixels {
            let (shape, part, element, material) = match self.key[i] {
                Some(k) => self.keys[k].clone(),
                None => ("background".to_string(), String::new(), String::new(), u32::MAX),
            };
            let t = tally.entry((shape, part)).or_default();
            t.0 += 1;
            if !element.is_empty() {
                *t.1.entry(element).or_default() += 1;
                *t.2.entry(material).or_default() += 1;
            }
        }
        fn ranked<K: Ord>(m: HashMap<K, usize>) -> Vec<K> {
            let mut v: Vec<(K, usize)> = m.into_iter().collect();
            v.sort_by(|a, b| b.1.cmp(&a.1).then_with(|| a.0.cmp(&b.0)));
            v.into_iter().map(|(k, _)| k).collect()
        }
        let mut groups: Vec<Group> = tally
            .into_iter()
            .map(|((shape, part), (pixels, elements, materials))| Group {
                shape,
                part,
                elements: ranked(elements),
                materials: ranked(materials),
                pixels,
            })
            .collect();
        groups.sort_by(|a, b| b.pixels.cmp(&a.pixels).then_with(|| (&a.shape, &a.part).cmp(&(&b.shape, &b.part))));
        groups
    }
}
