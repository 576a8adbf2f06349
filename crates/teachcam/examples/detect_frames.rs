//! Writes the detection benchmark's frames as PNG, for timing the same work with OpenCV
//! (`scripts/reference/bench_detect_opencv.py`) and the `teachcam detect` command:
//! ```text
//! OUT/single/markers_04.png, markers_16.png, markers_50.png   the criterion frames
//! OUT/rec/cam0..cam2/000000.png ...                          a recording, 50 markers
//! OUT/truth.csv                                              camera,frame,x_px,y_px,radius_px
//! ```
//! Usage: `cargo run --release -p teachcam --example detect_frames -- OUT [FRAMES]`
//! (FRAMES per camera, default 100).

#[path = "../tests/support/discs.rs"]
mod discs;

use std::fmt::Write as _;
use std::path::PathBuf;

use teachcam::io::recording::{frame_file_name, write_png};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let out = PathBuf::from(args.next().ok_or("usage: detect_frames OUT [FRAMES]")?);
    let frames: usize = args.next().map_or(Ok(100), |s| s.parse())?;
    std::fs::create_dir_all(out.join("single"))?;
    for count in [4, 16, 50] {
        let (frame, _) = discs::benchmark_frame(count, 0);
        write_png(&out.join(format!("single/markers_{count:02}.png")), &frame)?;
    }
    let mut truth = String::from("camera,frame,x_px,y_px,radius_px\n");
    for camera in 0..3 {
        let dir = out.join(format!("rec/cam{camera}"));
        std::fs::create_dir_all(&dir)?;
        for frame in 0..frames {
            let (image, discs) = discs::benchmark_frame(50, camera * 1000 + frame);
            write_png(&dir.join(frame_file_name(frame)), &image)?;
            for d in discs {
                writeln!(truth, "cam{camera},{frame},{},{},{}", d.x, d.y, d.radius_px)?;
            }
        }
    }
    std::fs::write(out.join("truth.csv"), truth)?;
    Ok(())
}
