//! C3D reading: the 2.25 MB Vicon file (51 markers, 580 frames, float storage, 38 analog
//! channels) from disk, and from memory. The same file read by ezc3d 1.7.2 is timed by
//! `scripts/reference/c3d_bench_ezc3d.py`.

use std::hint::black_box;
use std::path::PathBuf;

use criterion::{Criterion, criterion_group, criterion_main};

fn vicon() -> Option<PathBuf> {
    let path =
        PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../../shared/data/c3d/ezc3d_Vicon.c3d");
    path.is_file().then_some(path)
}

fn read_vicon(c: &mut Criterion) {
    let Some(path) = vicon() else { return };
    let Ok(bytes) = std::fs::read(&path) else {
        return;
    };
    let mut group = c.benchmark_group("c3d");
    group.bench_function("read_file vicon 2.25 MB", |b| {
        b.iter(|| black_box(teachcam::c3d::read_file(black_box(&path)).is_ok()));
    });
    group.bench_function("read (in memory) vicon 2.25 MB", |b| {
        b.iter(|| black_box(teachcam::c3d::read(black_box(&bytes)).is_ok()));
    });
    if let Ok(file) = teachcam::c3d::read(&bytes) {
        group.bench_function("to_bytes vicon points", |b| {
            b.iter(|| black_box(teachcam::c3d::to_bytes(black_box(&file.points), 0.01).is_ok()));
        });
    }
    group.finish();
}

criterion_group!(benches, read_vicon);
criterion_main!(benches);
