//! PNG decoding of one rendered 1280×1024 8-bit frame of the paper scenario (noisy
//! background, 4 markers; written as `teachcam simulate` writes it: fast deflate, Sub filter),
//! single-threaded: `read_frame` (the path `track` and `detect` use: file read, then
//! `io::gray_png`) and `io::gray_png` from memory against `image` from memory, the `png` crate
//! alone, and `fdeflate`'s inflate of the same zlib stream (the floor any PNG decoder built on
//! it has). `zune-png` 0.4.10 and `libdeflater` 1.26 were measured
//! here too, slower (6.2 ms and 2.5 ms for inflate alone against fdeflate's 1.5 ms), and left
//! out so that they are not built for every check; their code is in notes/speed.md
//! (issue 21).

#![allow(
    clippy::expect_used,
    clippy::print_stderr,
    reason = "benchmark fixtures; says which files it left out"
)]

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use std::hint::black_box;
use teachcam::io::recording::{GrayFrame, read_frame, write_frame_png};
use teachcam::sim::{Scenario, build_scene, render_frame};

/// The `png` crate alone, no transformation (gray stays gray at its depth).
fn png_direct(bytes: &[u8]) -> Vec<u8> {
    let mut decoder = png::Decoder::new(std::io::Cursor::new(bytes));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let mut reader = decoder.read_info().expect("a PNG");
    let mut pixels = vec![0; reader.output_buffer_size().expect("a size")];
    reader.next_frame(&mut pixels).expect("decoded");
    pixels
}

/// The zlib stream of a PNG: its IDAT chunks' data, concatenated (for timing inflate alone).
fn idat_stream(bytes: &[u8]) -> Vec<u8> {
    let mut stream = Vec::new();
    let mut at = 8;
    while at + 12 <= bytes.len() {
        let length = u32::from_be_bytes(bytes[at..at + 4].try_into().expect("4 bytes")) as usize;
        if &bytes[at + 4..at + 8] == b"IDAT" {
            stream.extend_from_slice(&bytes[at + 8..at + 8 + length]);
        }
        at += 12 + length;
    }
    stream
}

fn bench_decode(c: &mut Criterion) {
    let scene = build_scene(Scenario::Paper, 1);
    let view = render_frame(&scene, 30, 1).swap_remove(0);
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("000030.png");
    let frame = GrayFrame::Eight(view.image);
    write_frame_png(&path, &frame).expect("written");
    let bytes = std::fs::read(&path).expect("read back");
    let GrayFrame::Eight(image) = &frame else {
        unreachable!()
    };
    assert_eq!(png_direct(&bytes), image.as_raw().as_slice());
    assert_eq!(read_frame(&path, None).ok().as_ref(), Some(&frame));

    let mut group = c.benchmark_group("png_decode_paper_1280x1024");
    group.throughput(Throughput::Elements(1));
    group.sample_size(30);
    group.bench_function("read_frame", |b| {
        b.iter(|| read_frame(black_box(&path), Some((1280, 1024))))
    });
    assert_eq!(
        teachcam::io::gray_png::decode_gray8(&bytes).as_ref(),
        Some(image)
    );
    group.bench_function("gray_png_from_memory", |b| {
        b.iter(|| teachcam::io::gray_png::decode_gray8(black_box(&bytes)))
    });
    group.bench_function("image_from_memory", |b| {
        b.iter(|| image::load_from_memory_with_format(black_box(&bytes), image::ImageFormat::Png))
    });
    group.bench_function("png_direct", |b| b.iter(|| png_direct(black_box(&bytes))));
    let stream = idat_stream(&bytes);
    let filtered_len = 1024 * (1280 + 1);
    assert_eq!(
        fdeflate::decompress_to_vec(&stream).map(|v| v.len()).ok(),
        Some(filtered_len)
    );
    group.bench_function("inflate_only_fdeflate", |b| {
        b.iter(|| fdeflate::decompress_to_vec(black_box(&stream)))
    });
    group.finish();
    bench_other_writers(c, &path, image);
}

/// The same frame as other programs write it (issue 31): FFmpeg's PNG encoder (system zlib,
/// adaptive filters) at levels 1 and 9, and the `png` crate's zlib-like `High` setting with
/// the Sub filter; `io::gray_png` against `image`. FFmpeg's files are left out, with a
/// message, when `ffmpeg` is not on the path. (OpenCV's files: `scripts/reencode_png.py`,
/// measured with `teachcam track` in BENCHMARKS.md.)
fn bench_other_writers(c: &mut Criterion, source: &std::path::Path, image: &image::GrayImage) {
    let dir = source.parent().expect("a folder");
    let mut files: Vec<(String, Vec<u8>)> = Vec::new();
    for level in [1, 9] {
        let out = dir.join(format!("ffmpeg_{level}.png"));
        let written = std::process::Command::new("ffmpeg")
            .args(["-nostdin", "-v", "error", "-y", "-i"])
            .arg(source)
            .args(["-pred", "mixed", "-compression_level", &level.to_string()])
            .arg(&out)
            .status()
            .is_ok_and(|s| s.success());
        if written {
            files.push((
                format!("ffmpeg_level{level}"),
                std::fs::read(&out).expect("read"),
            ));
        } else {
            eprintln!("ffmpeg not available: its PNG files not benchmarked");
        }
    }
    let mut high = Vec::new();
    let mut encoder = png::Encoder::new(&mut high, image.width(), image.height());
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_compression(png::Compression::High);
    encoder.set_filter(png::Filter::Sub);
    encoder
        .write_header()
        .and_then(|mut w| w.write_image_data(image.as_raw()))
        .expect("png");
    files.push(("png_crate_high_sub".to_string(), high));
    let mut group = c.benchmark_group("png_decode_other_writers_1280x1024");
    group.throughput(Throughput::Elements(1));
    group.sample_size(20);
    for (name, bytes) in &files {
        assert_eq!(
            teachcam::io::gray_png::decode_gray8(bytes).as_ref(),
            Some(image),
            "{name}"
        );
        group.bench_function(format!("{name}/gray_png_from_memory"), |b| {
            b.iter(|| teachcam::io::gray_png::decode_gray8(black_box(bytes)))
        });
        group.bench_function(format!("{name}/image_from_memory"), |b| {
            b.iter(|| {
                image::load_from_memory_with_format(black_box(bytes), image::ImageFormat::Png)
            })
        });
    }
    group.finish();
}

criterion_group!(benches, bench_decode);
criterion_main!(benches);
