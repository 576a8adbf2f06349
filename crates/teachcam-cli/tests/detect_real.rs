//! `teachcam detect` with its default flags on footage nobody here made: the real PS3 Eye IR
//! recording (`../shared/data/real-ir/normal.avi`, five saturated, block-compressed markers).
//! The limits are measured from the recording (notes/detect-learned.md).

#[path = "support/run.rs"]
mod run;

use std::collections::BTreeMap;

#[test]
fn default_flags_find_the_five_markers_of_the_real_ir_video() {
    if !teachcam_testdata::ffmpeg("detect_real") {
        return;
    }
    let Some(data) = teachcam_testdata::shared_data("real-ir") else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let rec = dir.path().join("rec");
    std::fs::create_dir(&rec).unwrap();
    std::os::unix::fs::symlink(
        data.join("normal.avi").canonicalize().unwrap(),
        rec.join("cam0.avi"),
    )
    .unwrap();
    let out = dir.path().join("detections.csv");
    let o = run::teachcam(&["detect", rec.to_str().unwrap(), "-o", out.to_str().unwrap()]);
    let printed =
        String::from_utf8_lossy(&o.stdout).to_string() + &String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{printed}");
    // The measured limits in one line.
    let limits: Vec<&str> = printed
        .lines()
        .filter(|l| l.starts_with("detect limits"))
        .collect();
    assert_eq!(limits.len(), 1, "{printed}");
    assert!(limits[0].contains("threshold background +"), "{printed}");
    let mut per_frame: BTreeMap<usize, usize> = BTreeMap::new();
    let text = std::fs::read_to_string(&out).unwrap();
    for line in text.lines().skip(1) {
        let frame: usize = line.split(',').nth(1).unwrap().parse().unwrap();
        *per_frame.entry(frame).or_default() += 1;
    }
    let five = (0..402)
        .filter(|f| per_frame.get(f).copied() == Some(5))
        .count();
    let more = per_frame.values().filter(|&&n| n > 5).count();
    eprintln!("five markers in {five} of 402 frames, more than five in {more}");
    // The tool leaves the view in the last frames (frames 400 and 401 hold no pixel above
    // 115 DN, frame 399 shows four markers, one of 2 px). Measured: 398 of 402; frame 398's
    // fifth marker is 5 px at peak 130, under the learned smallest blob (6 px).
    assert!(five >= 398, "five markers in {five} of 402 frames");
    // No speck, halo or compression artefact counted as a marker.
    assert_eq!(more, 0, "{more} frames with more than five blobs");
}
