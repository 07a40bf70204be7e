//! Reading and writing pictures, and comparing two pictures under a stated
//! rule with a report a person can act on.

use crate::error::Error;
use std::fmt;
use std::path::{Path, PathBuf};

/// An 8-bit RGB image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Rgb8 {
    pub width: u32,
    pub height: u32,
    pub data: Vec<u8>,
}

impl Rgb8 {
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }
}

/// Writes PNG whatever the name's extension (`check_output_path` refuses
/// other image extensions before the work). Encoded in memory, then
/// written whole (`write_whole`), every error reported: the image crate's
/// own file writer flushes its buffer as it is dropped, where an error (a
/// full disk; `-o /dev/full`) was lost and the command said it wrote the
/// picture.
pub fn write_png(path: &Path, image: &Rgb8) -> Result<(), Error> {
    let mut bytes = Vec::new();
    image::ImageEncoder::write_image(
        image::codecs::png::PngEncoder::new(&mut bytes),
        &image.data,
        image.width,
        image.height,
        image::ExtendedColorType::Rgb8,
    )
    .map_err(|e| Error::Failed(format!("cannot write {}: {e}", path.display())))?;
    crate::output::write_whole(path, &bytes)
}

/// Whether `path` names something there that is not a file or a link to
/// one (a device such as /dev/stdout, a pipe): written as it is, by name.
pub fn not_a_file(path: &Path) -> bool {
    std::fs::metadata(path).is_ok_and(|m| !m.is_file())
}

/// A picture's name ends in .png or has no extension (a device such as
/// /dev/stdout): raycast writes PNG, and `out.jpg` holding PNG bytes would
/// mislead. Its error is a usage error (exit 2: a malformed value).
pub fn check_output_name(path: &Path) -> Result<(), Error> {
    match path.extension().filter(|e| !e.eq_ignore_ascii_case("png")) {
        Some(ext) => Err(Error::Usage(format!(
            "cannot write {}: raycast writes PNG pictures; name the file .png, not .{}",
            path.display(),
            ext.to_string_lossy()
        ))),
        None => Ok(()),
    }
}

/// Whether a picture could be written to `path`, asked before the work that
/// makes it (its name asked apart: `check_output_name`): its folder exists
/// and takes a new file, and it is not itself a folder. (The write can
/// still fail later, on a full disk; `write_png` says so.)
pub fn check_output_path(path: &Path) -> Result<(), Error> {
    let cannot = |why: &str| Err(Error::Failed(format!("cannot write {}: {why}", path.display())));
    if path.is_dir() {
        return cannot("it is a folder");
    }
    let folder = match path.parent() {
        Some(p) if !p.as_os_str().is_empty() => p,
        _ => Path::new("."),
    };
    if !folder.is_dir() {
        return cannot(&format!("no folder {}", folder.display()));
    }
    // A folder that takes no new file (/proc, a read-only disk), found
    // before the work rather than after the render (write_whole writes a
    // temporary file beside the picture): a probe file made and removed.
    // A device (/dev/stdout) is written as it is; a writable file in a
    // folder that takes none is written in place (write_whole), so either
    // passes.
    if not_a_file(path) {
        return Ok(());
    }
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let probe = folder.join(format!(".{name}.{}.probe", std::process::id()));
    match std::fs::OpenOptions::new().write(true).create_new(true).open(&probe) {
        Ok(_) => {
            let _ = std::fs::remove_file(&probe);
            Ok(())
        }
        // A probe left by an earlier process of this id: the folder takes files.
        Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => Ok(()),
        Err(_) if std::fs::OpenOptions::new().write(true).open(path).is_ok() => Ok(()),
        Err(e) => cannot(&format!("its folder {} takes no new file ({e})", folder.display())),
    }
}

/// Whether a picture can be written to `path` (the two checks above): a
/// name of another format is a usage error (exit 2), a folder that is not
/// there or takes no file an error (exit 1).
pub fn check_output(path: &Path) -> Result<(), Error> {
    check_output_name(path)?;
    check_output_path(path)
}

/// Largest width or height of a picture raycast renders or reads (the
/// pixel buffer of 16384² is 8 GiB); `frame::MAX_IMAGE_SIDE` is this one.
pub const MAX_IMAGE_SIDE: u32 = 16384;

/// The most pixels a picture read whole may have (`read_picture`: compare,
/// the conformance references): the largest picture raycast renders,
/// `MAX_IMAGE_SIDE` squared (16384 × 16384).
pub const MAX_PICTURE_PIXELS: u64 = MAX_IMAGE_SIDE as u64 * MAX_IMAGE_SIDE as u64;

/// The picture formats raycast reads (the image crate's features in
/// host/Cargo.toml), for messages.
pub const PICTURE_FORMATS: &str = "PNG, JPEG, BMP and PNM (PPM, PGM, PBM)";

/// A picture file opened with its format told by its content, whatever its
/// name's extension says (a PNG named .jpg is read as PNG).
fn picture_reader(path: &Path) -> Result<image::ImageReader<std::io::BufReader<std::fs::File>>, String> {
    let metadata = std::fs::metadata(path).map_err(|e| e.to_string())?;
    if metadata.is_dir() {
        return Err("it is a folder".into());
    }
    if metadata.is_file() && metadata.len() == 0 {
        return Err("the file is empty".into());
    }
    let reader = image::ImageReader::open(path).and_then(|r| r.with_guessed_format()).map_err(|e| e.to_string())?;
    // Content that starts as no picture format does: said so, not judged
    // by the name (the image crate falls back on the extension: "Invalid
    // PNG signature" for a .png, "extension not recognized" for a .xml).
    let mut start = [0u8; 64];
    let n = std::io::Read::read(&mut std::fs::File::open(path).map_err(|e| e.to_string())?, &mut start).unwrap_or(0);
    if image::guess_format(&start[..n]).is_err() {
        // Markup (a scene file given where a picture goes) said as such.
        let text = start[..n].strip_prefix("\u{feff}".as_bytes()).unwrap_or(&start[..n]);
        let what = if text.trim_ascii_start().starts_with(b"<") { "XML (a scene file?)" } else { "not a picture" };
        return Err(format!(
            "its content is {what}, not a picture raycast reads ({PICTURE_FORMATS}), whatever its name says"
        ));
    }
    Ok(reader)
}

/// The picture format `path`'s content starts as ("PNG", "JPEG", …), if
/// any: whatever the name says, and None for a file that cannot be read.
/// What a command names when a picture is given where a scene goes.
pub fn picture_format(path: &Path) -> Option<String> {
    let mut start = [0u8; 16];
    let n = std::io::Read::read(&mut std::fs::File::open(path).ok()?, &mut start).ok()?;
    image::guess_format(&start[..n]).ok().map(|f| format!("{f:?}").to_uppercase())
}

/// The image crate's error, with the formats raycast reads where the
/// picture's is not one of them (not where a format raycast reads has a
/// feature its decoder lacks: a BMP's unusual bit fields, say).
fn picture_error(e: image::ImageError) -> String {
    match e {
        image::ImageError::Unsupported(ref u) if matches!(u.kind(), image::error::UnsupportedErrorKind::Format(_)) => {
            format!("{e}; raycast reads {PICTURE_FORMATS} pictures")
        }
        image::ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            "the file ends before its picture does (cut short?)".into()
        }
        _ => e.to_string(),
    }
}

/// A picture file's width and height from its header alone, before it is
/// decoded (a picture too large can be refused with its size). Errors are
/// the reason; the caller names the file.
pub fn picture_size(path: &Path) -> Result<(u32, u32), String> {
    // The header alone, whatever size it gives (the decoder's memory limit
    // refused a 300000000x1 header as "Memory limit exceeded").
    let mut reader = picture_reader(path)?;
    reader.no_limits();
    reader.into_dimensions().map_err(picture_error)
}

/// A picture file decoded whole, its format told by its content. The
/// caller has measured it (`picture_size`) and decided that it fits, so
/// the decoder's own memory limit is lifted. Errors are the reason; the
/// caller names the file.
pub fn decode_picture(path: &Path) -> Result<image::DynamicImage, String> {
    let mut reader = picture_reader(path)?;
    reader.no_limits();
    reader.decode().map_err(picture_error)
}

/// `read_picture_counting_alpha`'s picture alone.
pub fn read_picture(path: &Path) -> Result<Rgb8, Error> {
    read_picture_counting_alpha(path).map(|(rgb, _)| rgb)
}

/// A picture as 8-bit RGB (16-bit, grey and palette pictures converted;
/// alpha dropped) and how many of its pixels were not opaque, so that a
/// caller can say their alpha was not compared. At most
/// `MAX_PICTURE_PIXELS`, told with the picture's size before it is decoded.
pub fn read_picture_counting_alpha(path: &Path) -> Result<(Rgb8, usize), Error> {
    let cannot = |e: String| Error::Failed(format!("cannot read {}: {e}", path.display()));
    let (width, height) = picture_size(path).map_err(cannot)?;
    if u64::from(width) * u64::from(height) > MAX_PICTURE_PIXELS {
        let side = MAX_IMAGE_SIDE;
        return Err(cannot(format!(
            "the picture is {width}x{height}, more than the {} pixels ({side}x{side}) of the largest picture raycast renders",
            crate::units::thousands(MAX_PICTURE_PIXELS)
        )));
    }
    let img = decode_picture(path).map_err(cannot)?;
    let translucent = translucent_pixels(&img);
    let rgb = img.to_rgb8();
    Ok((Rgb8 { width: rgb.width(), height: rgb.height(), data: rgb.into_raw() }, translucent))
}

/// How many of a picture's pixels are not opaque (0 without alpha), read
/// in the picture's own type.
fn translucent_pixels(img: &image::DynamicImage) -> usize {
    use image::DynamicImage as D;
    match img {
        D::ImageLumaA8(i) => i.pixels().filter(|p| p.0[1] != u8::MAX).count(),
        D::ImageRgba8(i) => i.pixels().filter(|p| p.0[3] != u8::MAX).count(),
        D::ImageLumaA16(i) => i.pixels().filter(|p| p.0[1] != u16::MAX).count(),
        D::ImageRgba16(i) => i.pixels().filter(|p| p.0[3] != u16::MAX).count(),
        D::ImageRgba32F(i) => i.pixels().filter(|p| p.0[3] != 1.0).count(),
        other if other.color().has_alpha() => other.to_rgba32f().pixels().filter(|p| p.0[3] != 1.0).count(),
        _ => 0,
    }
}

/// Result of comparing an actual picture with an expected one: pixels whose
/// largest channel difference exceeds `tolerance` count as different.
#[derive(Clone, Debug)]
pub struct ImageDiff {
    pub tolerance: u8,
    pub total: usize,
    pub differing: usize,
    /// First differing pixel in row-major order: (x, y, actual, expected).
    pub first: Option<(u32, u32, [u8; 3], [u8; 3])>,
    /// Pixel with the largest channel difference: (x, y, difference).
    pub worst: Option<(u32, u32, u8)>,
    /// Every channel's squared difference, summed (for `psnr`).
    pub squared_error: u64,
    /// Black where equal within tolerance; red scaled by the difference elsewhere.
    pub diff_image: Rgb8,
}

impl ImageDiff {
    pub fn fraction(&self) -> f64 {
        self.differing as f64 / self.total.max(1) as f64
    }

    /// Peak signal-to-noise ratio in dB over every channel of every pixel:
    /// 10 log10(255^2 / mean squared difference); None for identical pictures.
    pub fn psnr(&self) -> Option<f64> {
        (self.squared_error > 0).then(|| {
            let mse = self.squared_error as f64 / (3 * self.total.max(1)) as f64;
            10.0 * (255.0 * 255.0 / mse).log10()
        })
    }

    /// The same as its text, for JSON (serde): "pixels", "differing",
    /// "percent", "tolerance", "first" ({"at", "actual", "expected"} or
    /// null) and "worst" ({"at", "by"} or null).
    pub fn json(&self) -> DiffJson {
        DiffJson {
            pixels: self.total,
            differing: self.differing,
            percent: 100.0 * self.fraction(),
            psnr_db: self.psnr().map(|db| (db * 100.0).round() / 100.0),
            tolerance: self.tolerance,
            first: self.first.map(|(x, y, actual, expected)| FirstJson { at: [x, y], actual, expected }),
            worst: self.worst.map(|(x, y, by)| WorstJson { at: [x, y], by }),
        }
    }
}

/// `ImageDiff::json`: its numbers, as `compare --json` writes them.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DiffJson {
    pub pixels: usize,
    pub differing: usize,
    #[serde(serialize_with = "json_number")]
    pub percent: f64,
    /// `ImageDiff::psnr`, to 0.01 dB; null for identical pictures.
    pub psnr_db: Option<f64>,
    pub tolerance: u8,
    pub first: Option<FirstJson>,
    pub worst: Option<WorstJson>,
}

/// The first differing pixel: where, and its two colours.
#[derive(Clone, Debug, serde::Serialize)]
pub struct FirstJson {
    pub at: [u32; 2],
    pub actual: [u8; 3],
    pub expected: [u8; 3],
}

/// The pixel that differs most: where, and by how much (of 255).
#[derive(Clone, Debug, serde::Serialize)]
pub struct WorstJson {
    pub at: [u32; 2],
    pub by: u8,
}

/// A number as Rust prints it: a whole one without a fraction (`0`, `25`,
/// not serde_json's `0.0`), as `compare --json` always wrote it.
pub fn json_number<S: serde::Serializer>(value: &f64, serializer: S) -> Result<S::Ok, S::Error> {
    if value.fract() == 0.0 && value.abs() < 9_007_199_254_740_992.0 {
        serializer.serialize_i64(*value as i64)
    } else {
        serializer.serialize_f64(*value)
    }
}

impl fmt::Display for ImageDiff {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} of {} pixels ({:.4}%) differ by more than {}/255",
            self.differing,
            self.total,
            100.0 * self.fraction(),
            self.tolerance
        )?;
        if let Some((x, y, a, e)) = self.first {
            write!(f, "; first at ({x}, {y}): actual {a:?}, expected {e:?}")?;
        }
        if let Some((x, y, d)) = self.worst {
            write!(f, "; worst at ({x}, {y}): {d}/255")?;
        }
        Ok(())
    }
}

/// Compares two pictures of the same size. Errors if the sizes differ.
pub fn compare(actual: &Rgb8, expected: &Rgb8, tolerance: u8) -> Result<ImageDiff, Error> {
    if (actual.width, actual.height) != (expected.width, expected.height) {
        return Err(Error::Failed(format!(
            "sizes differ: actual {}x{}, expected {}x{}",
            actual.width, actual.height, expected.width, expected.height
        )));
    }
    let mut diff = ImageDiff {
        tolerance,
        total: (actual.width * actual.height) as usize,
        differing: 0,
        first: None,
        worst: None,
        squared_error: 0,
        diff_image: Rgb8 { width: actual.width, height: actual.height, data: vec![0; actual.data.len()] },
    };
    for y in 0..actual.height {
        for x in 0..actual.width {
            let (a, e) = (actual.pixel(x, y), expected.pixel(x, y));
            let d = (0..3).map(|c| a[c].abs_diff(e[c])).max().unwrap_or(0);
            diff.squared_error += (0..3).map(|c| u64::from(a[c].abs_diff(e[c])).pow(2)).sum::<u64>();
            if d > diff.worst.map_or(0, |w| w.2) {
                diff.worst = Some((x, y, d));
            }
            if d > tolerance {
                diff.differing += 1;
                diff.first.get_or_insert((x, y, a, e));
                let i = 3 * (y * actual.width + x) as usize;
                diff.diff_image.data[i] = 64u8.saturating_add(d.saturating_mul(4).min(191));
            }
        }
    }
    Ok(diff)
}

/// How far `highlight_diff` fades the reference towards white: a pixel's
/// grey `g` is drawn as `255 - FADE * (255 - g)` (pixelmatch's alpha 0.1),
/// so every pixel of the background is 229 or lighter and a red one shows.
pub const FADE: f32 = 0.1;

/// The diff picture `compare` writes: pure red (255, 0, 0) where a pixel of
/// `actual` differs from `expected` by more than `tolerance` (the largest
/// channel difference, as `compare` counts them), elsewhere the expected
/// picture in grey faded towards white (`FADE`), so that one wrong pixel
/// stands out. The two pictures are of the same size (`compare` said so).
pub fn highlight_diff(actual: &Rgb8, expected: &Rgb8, tolerance: u8) -> Rgb8 {
    assert_eq!((actual.width, actual.height), (expected.width, expected.height), "highlight_diff: sizes differ");
    let data = actual
        .data
        .chunks_exact(3)
        .zip(expected.data.chunks_exact(3))
        .flat_map(|(a, e)| {
            if (0..3).any(|c| a[c].abs_diff(e[c]) > tolerance) {
                [255, 0, 0]
            } else {
                let grey = 0.299 * f32::from(e[0]) + 0.587 * f32::from(e[1]) + 0.114 * f32::from(e[2]);
                let v = (255.0 - FADE * (255.0 - grey)).round() as u8;
                [v, v, v]
            }
        })
        .collect();
    Rgb8 { width: expected.width, height: expected.height, data }
}

/// Where `write_diff_images` puts the actual, expected and diff pictures of `name`.
pub fn diff_image_paths(dir: &Path, name: &str) -> [PathBuf; 3] {
    ["actual", "expected", "diff"].map(|kind| dir.join(format!("{name}-{kind}.png")))
}

/// Removes those of `paths` that exist (pictures of a failure an earlier
/// run wrote, which would say it still fails) and returns them; an error
/// names the file that could not be removed.
pub fn remove_stale(paths: &[PathBuf]) -> Result<Vec<PathBuf>, Error> {
    let mut removed = Vec::new();
    for path in paths {
        match std::fs::remove_file(path) {
            Ok(()) => removed.push(path.clone()),
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
            Err(e) => {
                return Err(Error::Failed(format!(
                    "cannot remove {}, a picture of an earlier run: {e}",
                    path.display()
                )))
            }
        }
    }
    Ok(removed)
}

/// Writes `<dir>/<name>-actual.png`, `-expected.png` and `-diff.png` (the
/// expected picture faded, each pixel beyond the tolerance in red:
/// [`highlight_diff`]) and returns their paths.
pub fn write_diff_images(
    dir: &Path,
    name: &str,
    actual: &Rgb8,
    expected: &Rgb8,
    diff: &ImageDiff,
) -> Result<[PathBuf; 3], Error> {
    std::fs::create_dir_all(dir).map_err(|e| Error::Failed(format!("cannot create {}: {e}", dir.display())))?;
    let paths = diff_image_paths(dir, name);
    write_png(&paths[0], actual)?;
    write_png(&paths[1], expected)?;
    write_png(&paths[2], &highlight_diff(actual, expected, diff.tolerance))?;
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn solid(w: u32, h: u32, c: [u8; 3]) -> Rgb8 {
        Rgb8 { width: w, height: h, data: c.iter().copied().cycle().take((w * h * 3) as usize).collect() }
    }

    /// PSNR by its definition: none for identical pictures; one channel of
    /// one pixel in four off by 255 (MSE 255²/12) is 10 log10(12) dB.
    #[test]
    fn psnr_is_ten_log_of_peak_over_mean_square() {
        let psnr = |a: &Rgb8, b: &Rgb8| compare(a, b, 0).map(|d| d.psnr());
        let a = solid(2, 2, [0, 0, 0]);
        assert_eq!(psnr(&a, &a).unwrap(), None);
        let mut c = a.clone();
        c.data[0] = 255;
        assert!((psnr(&c, &a).unwrap().unwrap() - 10.0 * 12f64.log10()).abs() < 1e-12);
        c.data[5] = 255;
        assert!((psnr(&c, &a).unwrap().unwrap() - 10.0 * 6f64.log10()).abs() < 1e-12);
        assert!(psnr(&solid(1, 2, [0; 3]), &a).is_err());
    }

    /// A picture is written whole: over an old one by renaming a finished
    /// temporary file (none left behind), through a link as a link, and to
    /// a device as it is.
    #[test]
    fn pictures_are_written_whole() {
        let dir = std::env::temp_dir().join(format!("raycast-write-whole-{}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("p.png");
        for colour in [[1, 2, 3], [200, 100, 50]] {
            write_png(&path, &solid(3, 2, colour)).unwrap();
            assert_eq!(read_picture(&path).unwrap(), solid(3, 2, colour));
        }
        let link = dir.join("link.png");
        std::os::unix::fs::symlink(&path, &link).unwrap();
        write_png(&link, &solid(1, 1, [9, 9, 9])).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink(), "the link was replaced");
        assert_eq!(read_picture(&path).unwrap(), solid(1, 1, [9, 9, 9]));
        let mut names: Vec<String> =
            std::fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
        names.sort();
        assert_eq!(names, ["link.png", "p.png"], "a temporary file was left");
        write_png(Path::new("/dev/null"), &solid(1, 1, [0, 0, 0])).unwrap();
        let full = write_png(Path::new("/dev/full"), &solid(1, 1, [0, 0, 0])).unwrap_err().to_string();
        assert!(full.starts_with("cannot write /dev/full: "), "{full}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn compare_counts_first_and_worst() {
        let expected = solid(4, 2, [10, 10, 10]);
        let mut actual = expected.clone();
        actual.data[3 * 5] = 13; // (1, 1) off by 3
        actual.data[3 * 6 + 2] = 2; // (2, 1) off by 8
        actual.data[3 * 7 + 1] = 12; // (3, 1) off by 2: within tolerance
        let d = compare(&actual, &expected, 2).unwrap();
        assert_eq!(d.differing, 2);
        assert_eq!(d.first, Some((1, 1, [13, 10, 10], [10, 10, 10])));
        assert_eq!(d.worst, Some((2, 1, 8)));
        assert!(d.to_string().starts_with("2 of 8 pixels (25.0000%) differ by more than 2/255"), "{d}");
        assert_eq!(d.diff_image.pixel(0, 0), [0, 0, 0]);
        assert_ne!(d.diff_image.pixel(2, 1), [0, 0, 0]);
    }

    /// Grey, 16-bit and RGBA pictures are read as 8-bit RGB; the pixels
    /// whose alpha is not opaque are counted (compare says it ignores them).
    #[test]
    fn pictures_of_other_kinds_read_as_rgb() {
        let dir = std::env::temp_dir().join(format!("raycast-image-io-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let rgba = dir.join("rgba.png");
        let mut img = image::RgbaImage::from_pixel(3, 2, image::Rgba([10, 20, 30, 255]));
        img.put_pixel(1, 1, image::Rgba([40, 50, 60, 0]));
        img.put_pixel(2, 0, image::Rgba([70, 80, 90, 254]));
        img.save(&rgba).unwrap();
        let (rgb, translucent) = read_picture_counting_alpha(&rgba).unwrap();
        assert_eq!((rgb.width, rgb.height, translucent), (3, 2, 2));
        assert_eq!((rgb.pixel(0, 0), rgb.pixel(1, 1)), ([10, 20, 30], [40, 50, 60]));
        let grey16 = dir.join("grey16.png");
        image::ImageBuffer::<image::Luma<u16>, _>::from_pixel(2, 2, image::Luma([0x8080u16])).save(&grey16).unwrap();
        let (rgb, translucent) = read_picture_counting_alpha(&grey16).unwrap();
        assert_eq!((rgb.pixel(1, 1), translucent), ([128, 128, 128], 0));
        let grey_alpha16 = dir.join("grey-alpha16.png");
        let mut img = image::ImageBuffer::<image::LumaA<u16>, _>::from_pixel(2, 2, image::LumaA([0x8080u16, u16::MAX]));
        img.put_pixel(0, 1, image::LumaA([0, 0xfffe]));
        img.save(&grey_alpha16).unwrap();
        let (rgb, translucent) = read_picture_counting_alpha(&grey_alpha16).unwrap();
        assert_eq!((rgb.pixel(1, 1), rgb.pixel(0, 1), translucent), ([128, 128, 128], [0, 0, 0], 1));
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// Pictures are read by their content, whatever their names say: a PNG
    /// named .jpg, a JPEG, a BMP; a picture beyond `MAX_PICTURE_PIXELS` is
    /// refused with its size before it is decoded; a format raycast does
    /// not read is named with the ones it does.
    #[test]
    fn pictures_are_read_by_their_content() {
        let dir = std::env::temp_dir().join(format!("raycast-image-io-formats-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let img = image::RgbImage::from_fn(16, 8, |x, y| image::Rgb([(x * 16) as u8, (y * 32) as u8, 100]));
        let png_as_jpg = dir.join("png.jpg");
        img.write_to(
            &mut std::io::BufWriter::new(std::fs::File::create(&png_as_jpg).unwrap()),
            image::ImageFormat::Png,
        )
        .unwrap();
        assert_eq!(read_picture(&png_as_jpg).unwrap().data, img.as_raw().clone());
        let bmp = dir.join("a.bmp");
        img.save(&bmp).unwrap();
        assert_eq!(read_picture(&bmp).unwrap().data, img.as_raw().clone());
        // JPEG is lossy: a solid colour comes back within a step or two.
        let jpg = dir.join("a.jpg");
        image::RgbImage::from_pixel(16, 8, image::Rgb([200, 40, 90])).save(&jpg).unwrap();
        let back = read_picture(&jpg).unwrap();
        assert_eq!((back.width, back.height), (16, 8));
        assert!(
            back.data.chunks(3).all(|p| p.iter().zip([200u8, 40, 90]).all(|(a, b)| a.abs_diff(b) <= 2)),
            "{back:?}"
        );
        let huge = dir.join("huge.png");
        std::fs::write(&huge, b"P6\n20000 16384\n255\n").unwrap();
        let e = read_picture(&huge).unwrap_err().to_string();
        assert!(
            e.contains("huge.png: the picture is 20000x16384, more than the 268,435,456 pixels (16384x16384)"),
            "{e}"
        );
        let empty = dir.join("empty.png");
        std::fs::write(&empty, b"").unwrap();
        assert_eq!(
            read_picture(&empty).unwrap_err().to_string(),
            format!("cannot read {}: the file is empty", empty.display())
        );
        let cut = dir.join("cut.bmp");
        std::fs::write(&cut, &std::fs::read(&bmp).unwrap()[..20]).unwrap();
        let e = read_picture(&cut).unwrap_err().to_string();
        assert!(e.ends_with("cut.bmp: the file ends before its picture does (cut short?)"), "{e}");
        let gif = dir.join("a.gif");
        std::fs::write(&gif, b"GIF89a\x01\x00\x01\x00\x00\x00\x00;").unwrap();
        let e = read_picture(&gif).unwrap_err().to_string();
        assert!(e.contains("a.gif") && e.contains(PICTURE_FORMATS), "{e}");
        // Content that is no picture, whatever the name (the image crate
        // judged it by the name: "Invalid PNG signature", "extension not
        // recognized"); a folder said to be one.
        for name in ["text.png", "text.xml"] {
            std::fs::write(dir.join(name), b"<scenefile></scenefile>").unwrap();
            let e = read_picture(&dir.join(name)).unwrap_err().to_string();
            let why = format!(
                "{name}: its content is XML (a scene file?), not a picture raycast reads ({PICTURE_FORMATS}), whatever its name says"
            );
            assert!(e.ends_with(&why), "{e}");
        }
        assert!(read_picture(&dir).unwrap_err().to_string().ends_with(": it is a folder"));
        // A PNG header of 300000000x1 is measured, not refused by the
        // decoder's memory limit ("Memory limit exceeded").
        let crc = |bytes: &[u8]| {
            !bytes.iter().fold(!0u32, |c, &b| {
                (0..8).fold(c ^ u32::from(b), |c, _| if c & 1 != 0 { (c >> 1) ^ 0xedb8_8320 } else { c >> 1 })
            })
        };
        let mut ihdr = b"IHDR".to_vec();
        ihdr.extend(300_000_000u32.to_be_bytes());
        ihdr.extend(1u32.to_be_bytes());
        ihdr.extend([8, 2, 0, 0, 0]);
        let mut wide = b"\x89PNG\r\n\x1a\n".to_vec();
        wide.extend(13u32.to_be_bytes());
        wide.extend(&ihdr);
        wide.extend(crc(&ihdr).to_be_bytes());
        // An empty IDAT: the decoder reads up to the first before it tells the size.
        wide.extend(0u32.to_be_bytes());
        wide.extend(b"IDAT");
        wide.extend(crc(b"IDAT").to_be_bytes());
        std::fs::write(dir.join("wide.png"), &wide).unwrap();
        let e = read_picture(&dir.join("wide.png")).unwrap_err().to_string();
        assert!(e.ends_with("wide.png: the picture is 300000000x1, more than the 268,435,456 pixels (16384x16384) of the largest picture raycast renders"), "{e}");
        let _ = std::fs::remove_dir_all(&dir);
    }

    /// A differing pixel is pure red; an equal one (or one within the
    /// tolerance) is the reference's grey faded towards white, lighter
    /// than it was and never red.
    #[test]
    fn highlight_diff_marks_differing_pixels_red_over_a_faded_reference() {
        let expected = Rgb8 { width: 3, height: 1, data: vec![0, 0, 0, 200, 40, 90, 255, 255, 255] };
        let mut actual = expected.clone();
        actual.data[0] = 3; // (0, 0) off by 3: differs
        actual.data[4] = 42; // (1, 0) off by 2: within tolerance
        let d = highlight_diff(&actual, &expected, 2);
        assert_eq!((d.width, d.height), (3, 1));
        assert_eq!(d.pixel(0, 0), [255, 0, 0]);
        let grey = d.pixel(1, 0);
        assert!(grey[0] == grey[1] && grey[1] == grey[2] && grey[0] >= 229 && grey[0] < 255, "{grey:?}");
        assert!(grey[0] > 200, "not lighter than the reference: {grey:?}");
        assert_eq!(d.pixel(2, 0), [255, 255, 255]);
        assert_eq!(highlight_diff(&expected, &expected, 0).pixel(0, 0), [230, 230, 230]);
    }

    #[test]
    fn compare_rejects_size_mismatch() {
        assert!(compare(&solid(2, 2, [0; 3]), &solid(2, 3, [0; 3]), 0).unwrap_err().to_string().contains("2x2"));
    }
}
