//! Pairing frames across cameras into sets of one instant.
//!
//! Cameras triggered together carry the trigger's sequence number: frames with equal numbers
//! belong together, and a camera without that number missed the trigger. Free-running cameras
//! carry only timestamps: the earliest waiting frame sets the instant `t`, and every camera
//! whose next frame lies within half a period of `t` contributes it (the nearest frame, since
//! its frames are a period apart); a camera whose next frame is later has none at `t`. The
//! spread of times inside each set and the frames left alone are counted, so the mismatch is
//! reported, never hidden.

use std::collections::VecDeque;

use super::{CameraFrame, SourceStats};

/// How frames of different cameras are matched.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum PairBy {
    /// Equal trigger sequence numbers.
    Sequence,
    /// Nearest exposure time within half a period.
    Timestamp {
        /// The cameras' frame period, seconds.
        period_s: f64,
    },
}

/// Frames waiting per camera, and what pairing left over.
#[derive(Debug, Clone)]
pub struct Pairer {
    by: PairBy,
    queues: Vec<VecDeque<CameraFrame>>,
    ended: Vec<bool>,
    stats: SourceStats,
}

impl Pairer {
    /// A pairer for `cameras` cameras.
    #[must_use]
    pub fn new(cameras: usize, by: PairBy) -> Self {
        Self {
            by,
            queues: vec![VecDeque::new(); cameras],
            ended: vec![false; cameras],
            stats: SourceStats {
                unpaired_frames: vec![0; cameras],
                ..SourceStats::default()
            },
        }
    }

    /// Adds a camera's next frame (frames of one camera arrive in order).
    pub fn push(&mut self, camera: usize, frame: CameraFrame) {
        if let Some(queue) = self.queues.get_mut(camera) {
            queue.push_back(frame);
        }
    }

    /// Marks a camera's stream as ended: sets no longer wait for it.
    pub fn end(&mut self, camera: usize) {
        if let Some(ended) = self.ended.get_mut(camera) {
            *ended = true;
        }
    }

    /// What pairing counted so far.
    #[must_use]
    pub fn stats(&self) -> &SourceStats {
        &self.stats
    }

    /// The next complete set, in camera order, once every camera that has not ended has a frame
    /// waiting; `None` while a camera is still to deliver (or nothing is left).
    pub fn pop(&mut self) -> Option<Vec<Option<CameraFrame>>> {
        let ready = self
            .queues
            .iter()
            .zip(&self.ended)
            .all(|(q, ended)| !q.is_empty() || *ended);
        if !ready || self.queues.iter().all(VecDeque::is_empty) {
            return None;
        }
        let belongs: Vec<bool> = match self.by {
            PairBy::Sequence => {
                let first = self
                    .queues
                    .iter()
                    .filter_map(|q| q.front().and_then(|f| f.sequence))
                    .min();
                self.queues
                    .iter()
                    .map(|q| q.front().is_some_and(|f| f.sequence == first))
                    .collect()
            }
            PairBy::Timestamp { period_s } => {
                let first = self
                    .queues
                    .iter()
                    .filter_map(|q| q.front().map(|f| f.time_s))
                    .fold(f64::INFINITY, f64::min);
                self.queues
                    .iter()
                    .map(|q| q.front().is_some_and(|f| f.time_s - first < 0.5 * period_s))
                    .collect()
            }
        };
        let set: Vec<Option<CameraFrame>> = self
            .queues
            .iter_mut()
            .zip(&belongs)
            .map(|(q, &take)| if take { q.pop_front() } else { None })
            .collect();
        let times: Vec<f64> = set.iter().flatten().map(|f| f.time_s).collect();
        let spread = times.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - times.iter().copied().fold(f64::INFINITY, f64::min);
        if times.len() == 1 {
            if let Some(camera) = set.iter().position(Option::is_some) {
                self.stats.unpaired_frames[camera] += 1;
            }
        } else if spread.is_finite() {
            self.stats.max_pair_spread_s = self.stats.max_pair_spread_s.max(spread);
        }
        Some(set)
    }
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use super::*;
    use crate::io::recording::GrayFrame;
    use crate::source::FrameData;

    fn frame(frame: usize, time_s: f64, sequence: Option<u64>) -> CameraFrame {
        CameraFrame {
            frame,
            time_s,
            sequence,
            data: FrameData::Decoded(Arc::new(GrayFrame::Eight(image::GrayImage::new(1, 1)))),
        }
    }

    fn frames_of(set: &[Option<CameraFrame>]) -> Vec<Option<usize>> {
        set.iter().map(|f| f.as_ref().map(|f| f.frame)).collect()
    }

    #[test]
    fn free_running_cameras_pair_within_half_a_period_and_report_the_rest() {
        // Camera 1 runs 4 ms behind camera 0 at 50 Hz and misses its third frame.
        let mut pairer = Pairer::new(2, PairBy::Timestamp { period_s: 0.02 });
        for i in 0..4 {
            pairer.push(0, frame(i, i as f64 * 0.02, None));
        }
        for (n, i) in [0, 1, 3].into_iter().enumerate() {
            pairer.push(1, frame(n, i as f64 * 0.02 + 0.004, None));
        }
        pairer.end(0);
        pairer.end(1);
        let mut sets = Vec::new();
        while let Some(set) = pairer.pop() {
            sets.push(frames_of(&set));
        }
        assert_eq!(
            sets,
            vec![
                vec![Some(0), Some(0)],
                vec![Some(1), Some(1)],
                vec![Some(2), None],
                vec![Some(3), Some(2)],
            ]
        );
        assert_eq!(pairer.stats().unpaired_frames, vec![1, 0]);
        assert!((pairer.stats().max_pair_spread_s - 0.004).abs() < 1e-12);
    }

    #[test]
    fn triggered_cameras_pair_by_sequence_whatever_their_clocks_say() {
        let mut pairer = Pairer::new(2, PairBy::Sequence);
        pairer.push(0, frame(0, 0.0, Some(10)));
        pairer.push(0, frame(1, 0.033, Some(11)));
        pairer.push(1, frame(0, 0.5, Some(11)));
        pairer.end(0);
        pairer.end(1);
        assert_eq!(frames_of(&pairer.pop().unwrap()), vec![Some(0), None]);
        assert_eq!(frames_of(&pairer.pop().unwrap()), vec![Some(1), Some(0)]);
        assert!(pairer.pop().is_none());
    }

    #[test]
    fn waits_for_every_running_camera() {
        let mut pairer = Pairer::new(2, PairBy::Timestamp { period_s: 0.02 });
        pairer.push(0, frame(0, 0.0, None));
        assert!(pairer.pop().is_none());
        pairer.push(1, frame(0, 0.001, None));
        assert_eq!(frames_of(&pairer.pop().unwrap()), vec![Some(0), Some(0)]);
    }
}
