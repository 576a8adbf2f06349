//! CPU time of detection per frame, for comparing with OpenCV on a loaded machine, where
//! wall-clock benchmarks (criterion) inflate with other processes' load but CPU time does
//! not: runs `detect` (default config, one thread) `N` times on each benchmark frame and
//! prints CPU milliseconds per frame from `/proc/self/stat` (Linux; 10 ms ticks, so `N`
//! should make each total at least a second).
//!
//! Usage: `cargo run --release -p teachcam --example detect_cpu -- [N]` (default 2000).

#[path = "../tests/support/discs.rs"]
mod discs;

use std::hint::black_box;

use teachcam::detect::{DetectConfig, detect};

/// User + system CPU time of this process, seconds (`/proc/self/stat` fields 14 and 15).
fn cpu_s() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    // Fields after the command name, which is in parentheses and may hold spaces.
    let rest = stat.rsplit_once(')')?.1;
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = fields.get(11)?.parse::<f64>().ok()? + fields.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let n: usize = std::env::args().nth(1).map_or(Ok(2000), |s| s.parse())?;
    let cfg = DetectConfig::default();
    for count in [4, 16, 50] {
        let (frame, _) = discs::benchmark_frame(count, 0);
        let start = cpu_s().ok_or("no /proc/self/stat")?;
        let mut blobs = 0;
        for _ in 0..n {
            blobs = detect(black_box(&frame), &cfg)?.len();
        }
        let cpu = cpu_s().ok_or("no /proc/self/stat")? - start;
        let line = format!(
            "{count:2} markers ({blobs} found): {:.3} ms CPU per frame over {n} runs\n",
            1e3 * cpu / n as f64
        );
        std::io::Write::write_all(&mut std::io::stdout(), line.as_bytes())?;
    }
    Ok(())
}
