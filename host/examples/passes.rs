// Throwaway: decode `render --aov cost --cost-max 255` PNGs into pass counts.
fn main() {
    let heat = |x: f32| -> [u8; 3] {
        let s = 4.0 * x.clamp(0.0, 1.0);
        [3.0f32, 2.0, 1.0].map(|c| ((1.5 - (s - c).abs()).clamp(0.0, 1.0) * 255.0).floor() as u8)
    };
    let table: Vec<[u8; 3]> = (0..=255u32).map(|n| heat(n as f32 / 255.0)).collect();
    for path in std::env::args().skip(1) {
        let img = raycast::image_io::read_png(std::path::Path::new(&path)).unwrap();
        let mut v: Vec<u32> = img.data.chunks(3).map(|c| table.iter().position(|t| t == c).expect("on the scale") as u32).collect();
        v.sort();
        let n = v.len();
        let mean = v.iter().map(|&x| x as f64).sum::<f64>() / n as f64;
        let sat = v.iter().filter(|&&x| x == 255).count();
        println!("{path}: mean {mean:.2} median {} p90 {} p99 {} max {} saturated {sat}", v[n / 2], v[n * 9 / 10], v[n * 99 / 100], v[n - 1]);
    }
}
