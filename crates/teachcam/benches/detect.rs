//! Detection on 1280×1024 8-bit frames with 4, 16 and 50 markers (closed-form discs, blur
//! 0.8 px, noise 2 units; `tests/support/discs.rs`), single-threaded. The same frames, written
//! by `cargo run --release --example detect_frames`, are timed through OpenCV by
//! `scripts/reference/bench_detect_opencv.py`.

#[path = "../tests/support/discs.rs"]
mod discs;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use teachcam::detect::{CenterMethod, DetectConfig, GrayView, detect, estimate_background};

fn bench_detect(c: &mut Criterion) {
    let mut group = c.benchmark_group("detect");
    group.throughput(Throughput::Elements(1));
    for count in [4, 16, 50] {
        let (frame, _) = discs::benchmark_frame(count, 0);
        for method in [
            CenterMethod::Refined,
            CenterMethod::Centroid,
            CenterMethod::SmallestCircle,
        ] {
            let cfg = DetectConfig {
                method,
                ..DetectConfig::default()
            };
            group.bench_with_input(
                BenchmarkId::new(method.to_string(), count),
                &frame,
                |b, frame| b.iter(|| detect(black_box(frame), &cfg)),
            );
        }
    }
    let (frame, _) = discs::benchmark_frame(50, 0);
    group.bench_function("background_estimate", |b| {
        b.iter(|| estimate_background(GrayView::new(black_box(&frame))))
    });
    let mut png = Vec::new();
    frame
        .write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .ok();
    group.bench_function("png_decode_50", |b| {
        b.iter(|| image::load_from_memory_with_format(black_box(&png), image::ImageFormat::Png))
    });
    group.finish();
}

criterion_group!(benches, bench_detect);
criterion_main!(benches);
