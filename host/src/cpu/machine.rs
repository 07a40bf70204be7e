//! The machine the CPU build runs on: its CPU as reports name it, and its threads.

/// The machine's CPU, for the reports that compare machines (`raycast
/// devices`, `bench --json`, BENCHMARKS.md's machine block): its name as
/// /proc/cpuinfo gives it, with what tells two CPUs of one name apart (a
/// virtual machine's "AMD EPYC" has been CPUs with and without AVX-512 from
/// one day to the next, every time moving with it): family, model and
/// stepping, the widest vector instructions, and a core's L2 and the L3
/// cache (sysfs). "unknown CPU" without /proc/cpuinfo's model name.
pub fn host_cpu() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        info.lines().find_map(|l| {
            let (k, v) = l.split_once(':')?;
            (k.trim() == name).then(|| v.trim().to_string())
        })
    };
    let Some(name) = field("model name") else { return "unknown CPU".to_string() };
    let mut parts = Vec::new();
    if let (Some(f), Some(m), Some(s)) = (field("cpu family"), field("model"), field("stepping")) {
        parts.push(format!("family {f}, model {m}, stepping {s}"));
    }
    let flags = field("flags").unwrap_or_default();
    let has = |f: &str| flags.split_whitespace().any(|x| x == f);
    parts.push(
        if has("avx512f") {
            "AVX-512"
        } else if has("avx2") {
            "AVX2"
        } else {
            "no AVX2"
        }
        .to_string(),
    );
    let caches: Vec<String> = (0..8)
        .filter_map(|i| {
            let dir = format!("/sys/devices/system/cpu/cpu0/cache/index{i}");
            let read = |f: &str| std::fs::read_to_string(format!("{dir}/{f}")).ok().map(|t| t.trim().to_string());
            let level = read("level")?;
            (level == "2" || level == "3").then(|| format!("L{level} {}", read("size").unwrap_or_default()))
        })
        .collect();
    if !caches.is_empty() {
        parts.push(caches.join(", "));
    }
    format!("{name} ({})", parts.join("; "))
}

/// The threads the CPU build renders on: one a core.
pub fn host_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
