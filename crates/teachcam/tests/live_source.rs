//! The simulator as a live source through the conductor, alone in its test binary so that no
//! other test competes with its clock for the cores.

#![allow(
    clippy::unwrap_used,
    reason = "a test fails loudly on a broken fixture"
)]

use teachcam::pipeline::{StreamOptions, TrackStream};
use teachcam::sim::Scenario;
use teachcam::source::FrameSource;
use teachcam::source::sim::{SimConfig, SimSource};
use teachcam::trajectory::Status;

/// Acceptance of the live path: the simulator at 60 Hz for 10 s, every set tracked, none
/// dropped (the queue holds 4 sets, 67 ms: a set takes about 1 ms of CPU).
#[test]
fn the_simulated_live_source_runs_ten_seconds_at_60_hz_with_nothing_dropped() {
    let config = SimConfig {
        max_sets: Some(600),
        cached_frames: 30,
        ..SimConfig::default()
    };
    let scene = teachcam::source::sim::scene(Scenario::Paper, &config);
    let mut source = SimSource::start(Scenario::Paper, &config).unwrap();
    let started = std::time::Instant::now();
    let mut frames = 0;
    let mut posed = 0;
    {
        let stream = TrackStream::new(
            &mut source,
            &scene.rig,
            &scene.tool,
            StreamOptions::live(60.0),
        )
        .unwrap();
        for frame in stream {
            let frame = frame.unwrap();
            assert_eq!(frame.detections.index, frames, "a set went missing");
            assert!(frame.latency_s().is_some());
            posed += usize::from(frame.track.outcome.is_ok());
            // The gates are learned from the first 2 s (120 sets): until then a frame is at
            // best degraded, never ok; after, the clean paper scene is ok throughout.
            if frames < 120 {
                assert_eq!(frame.status(), Status::Degraded, "set {frames}");
            } else {
                assert_eq!(
                    frame.status(),
                    Status::Ok,
                    "set {frames}: {}",
                    frame.reason()
                );
            }
            frames += 1;
        }
    }
    let elapsed = started.elapsed().as_secs_f64();
    assert_eq!(frames, 600);
    assert_eq!(source.stats().dropped_sets, 0);
    assert_eq!(posed, 600);
    // Paced by the clock: 600 sets at 60 Hz take 10 s (599 periods), not less.
    assert!(elapsed > 9.9, "{elapsed} s");
}
