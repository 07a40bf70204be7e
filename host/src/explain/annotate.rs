//! `explain -o`: the student's picture faded, each finding's pixels in its
//! own colour and the unexplained ones in another, above a legend written
//! in a small built-in font (5x7 capitals, digits and punctuation).

use super::Explanation;
use crate::image_io::Rgb8;

/// The findings' colours, in order; the unexplained pixels' last.
const PALETTE: [[u8; 3]; 5] = [[230, 25, 75], [60, 180, 75], [0, 130, 200], [245, 130, 48], [145, 30, 180]];
const UNEXPLAINED: [u8; 3] = [255, 225, 25];

/// Glyphs of 5 columns by 7 rows, a row a byte (bit 4 the leftmost column).
const FONT: &[(char, [u8; 7])] = &[
    ('A', [14, 17, 17, 31, 17, 17, 17]),
    ('B', [30, 17, 17, 30, 17, 17, 30]),
    ('C', [14, 17, 16, 16, 16, 17, 14]),
    ('D', [28, 18, 17, 17, 17, 18, 28]),
    ('E', [31, 16, 16, 30, 16, 16, 31]),
    ('F', [31, 16, 16, 30, 16, 16, 16]),
    ('G', [14, 17, 16, 23, 17, 17, 15]),
    ('H', [17, 17, 17, 31, 17, 17, 17]),
    ('I', [14, 4, 4, 4, 4, 4, 14]),
    ('J', [7, 2, 2, 2, 2, 18, 12]),
    ('K', [17, 18, 20, 24, 20, 18, 17]),
    ('L', [16, 16, 16, 16, 16, 16, 31]),
    ('M', [17, 27, 21, 21, 17, 17, 17]),
    ('N', [17, 17, 25, 21, 19, 17, 17]),
    ('O', [14, 17, 17, 17, 17, 17, 14]),
    ('P', [30, 17, 17, 30, 16, 16, 16]),
    ('Q', [14, 17, 17, 17, 21, 18, 13]),
    ('R', [30, 17, 17, 30, 20, 18, 17]),
    ('S', [15, 16, 16, 14, 1, 1, 30]),
    ('T', [31, 4, 4, 4, 4, 4, 4]),
    ('U', [17, 17, 17, 17, 17, 17, 14]),
    ('V', [17, 17, 17, 17, 17, 10, 4]),
    ('W', [17, 17, 17, 21, 21, 21, 10]),
    ('X', [17, 17, 10, 4, 10, 17, 17]),
    ('Y', [17, 17, 10, 4, 4, 4, 4]),
    ('Z', [31, 1, 2, 4, 8, 16, 31]),
    ('0', [14, 17, 19, 21, 25, 17, 14]),
    ('1', [4, 12, 4, 4, 4, 4, 14]),
    ('2', [14, 17, 1, 2, 4, 8, 31]),
    ('3', [31, 2, 4, 2, 1, 17, 14]),
    ('4', [2, 6, 10, 18, 31, 2, 2]),
    ('5', [31, 16, 30, 1, 1, 17, 14]),
    ('6', [6, 8, 16, 30, 17, 17, 14]),
    ('7', [31, 1, 2, 4, 8, 8, 8]),
    ('8', [14, 17, 17, 14, 17, 17, 14]),
    ('9', [14, 17, 17, 15, 1, 2, 12]),
    ('.', [0, 0, 0, 0, 0, 12, 12]),
    (',', [0, 0, 0, 0, 12, 4, 8]),
    ('%', [24, 25, 2, 4, 8, 19, 3]),
    ('(', [2, 4, 8, 8, 8, 4, 2]),
    (')', [8, 4, 2, 2, 2, 4, 8]),
    (':', [0, 12, 12, 0, 12, 12, 0]),
    ('-', [0, 0, 0, 31, 0, 0, 0]),
    ('/', [0, 1, 2, 4, 8, 16, 0]),
    ('+', [0, 4, 4, 31, 4, 4, 0]),
    ('=', [0, 0, 31, 0, 31, 0, 0]),
    ('\'', [12, 4, 8, 0, 0, 0, 0]),
    ('_', [0, 0, 0, 0, 0, 0, 31]),
];

/// `text` in capitals at (x, y) of `image`, each font pixel `scale` pixels
/// square, in `colour`; what does not fit is cut.
fn write(image: &mut Rgb8, x: usize, y: usize, scale: usize, text: &str, colour: [u8; 3]) {
    let (w, h) = (image.width as usize, image.height as usize);
    for (k, c) in text.chars().enumerate() {
        let c = c.to_ascii_uppercase();
        let Some((_, rows)) = FONT.iter().find(|(g, _)| *g == c) else { continue };
        let x0 = x + k * 6 * scale;
        for (r, bits) in rows.iter().enumerate() {
            for col in 0..5 {
                if bits & (16 >> col) == 0 {
                    continue;
                }
                for dy in 0..scale {
                    for dx in 0..scale {
                        let (px, py) = (x0 + col * scale + dx, y + r * scale + dy);
                        if px < w && py < h {
                            image.data[(py * w + px) * 3..][..3].copy_from_slice(&colour);
                        }
                    }
                }
            }
        }
    }
}

/// The student's picture `mine` with what `e` found drawn on it: the
/// pixels that agree faded to a third, each finding's in its colour, the
/// unexplained in yellow; below, a line a finding (its colour, its number,
/// its cause and its share).
pub fn annotated(mine: &Rgb8, e: &Explanation) -> Rgb8 {
    let (w, h) = (mine.width as usize, mine.height as usize);
    let scale = if w >= 480 { 2 } else { 1 };
    let line = 9 * scale;
    let mut lines: Vec<([u8; 3], String)> = Vec::new();
    if e.passes {
        lines.push(([255, 255, 255], "matches raycast: no finding".into()));
    }
    for (k, f) in e.findings.iter().enumerate() {
        lines.push((PALETTE[k % PALETTE.len()], format!("{} {}: {:.0}%", k + 1, f.cause, 100.0 * f.share)));
    }
    if e.unexplained > 0 {
        lines.push((UNEXPLAINED, format!("? unexplained: {} px", e.unexplained)));
    }
    let legend = lines.len() * line + 2 * scale;
    let mut out = Rgb8 { width: mine.width, height: (h + legend) as u32, data: vec![0; w * (h + legend) * 3] };
    for i in 0..w * h {
        let px = &mine.data[i * 3..][..3];
        let colour = match e.owner.get(i).copied().flatten() {
            Some(k) => PALETTE[k % PALETTE.len()],
            None if !e.passes && e.differs[i] => UNEXPLAINED,
            // Faded towards white, a third of the picture left.
            None => [0, 1, 2].map(|c| (u16::from(px[c]) / 3 + 170) as u8),
        };
        out.data[i * 3..][..3].copy_from_slice(&colour);
    }
    for (k, (colour, text)) in lines.iter().enumerate() {
        let y = h + scale + k * line;
        for dy in 0..7 * scale {
            for dx in 0..7 * scale {
                let (px, py) = (scale + dx, y + dy);
                if px < w {
                    out.data[(py * w + px) * 3..][..3].copy_from_slice(colour);
                }
            }
        }
        write(&mut out, 10 * scale, y, scale, text, [255, 255, 255]);
    }
    out
}
