//! The world frame from a marker frame lying still on the work object: tracked through the
//! wand-calibrated rig in every frame, the poses averaged, its tool frame made the world.

use nalgebra::Vector3;

use super::WandError;
use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{Pose, Quat};
use crate::tool::Tool;
use crate::track::{TrackConfig, Tracker};

/// How the ground frame was set.
#[derive(Debug, Clone, PartialEq)]
pub struct GroundReport {
    /// Frames of the ground recording posed.
    pub posed: usize,
    /// Frames in the ground recording.
    pub frames: usize,
    /// The marker frame's pose in the old world (camera 0), the average over posed frames.
    pub old_from_ground: Pose,
    /// RMS scatter of the posed frames' origins about the average, millimetres.
    pub scatter_mm: f64,
    /// Mean registration RMS of the posed frames, millimetres.
    pub registration_rms_mm: f64,
    /// Cameras whose centre lies below the ground frame's x-y plane (z < 0 in the new world).
    /// All of them: the frame's z points into the work object, away from the cameras that film
    /// it (a tool file whose z is meant up, read upside down, or a frame laid face down).
    pub cameras_below: Vec<String>,
}

/// Frames of the ground recording that must be posed: 3, and at least half of them.
const MIN_GROUND_FRAMES: usize = 3;

/// `rig` with its world moved to the tool frame of `ground` (a marker frame lying still on the
/// work object), tracked through `rig` in every frame of `frames` and averaged.
///
/// # Errors
/// [`WandError::Ground`] when fewer than half of the frames (or 3) are posed.
pub fn set_ground(
    rig: &Rig,
    frames: &[Views],
    ground: &Tool,
) -> Result<(Rig, GroundReport), WandError> {
    let tracker = Tracker::new(rig, ground, TrackConfig::default());
    let poses: Vec<(Pose, f64)> = frames
        .iter()
        .filter_map(|views| {
            let pose = tracker.track_frame(views).outcome.ok()?;
            Some((pose.world_from_tool, pose.rms_mm))
        })
        .collect();
    let needed = MIN_GROUND_FRAMES.max(frames.len().div_ceil(2));
    if poses.len() < needed {
        return Err(WandError::Ground {
            tool: ground.name.clone(),
            posed: poses.len(),
            frames: frames.len(),
            needed,
        });
    }
    // The average: mean translation, chordal mean rotation (the normalised quaternion sum,
    // signs aligned to the first).
    let count = poses.len() as f64;
    let translation = poses
        .iter()
        .fold(Vector3::zeros(), |s, (p, _)| s + p.translation.vector)
        / count;
    let first = Quat::from_rotation(&poses[0].0.rotation);
    let sum = poses.iter().fold([0.0; 4], |s, (p, _)| {
        let q = Quat::from_rotation(&p.rotation).continuous_with(&first);
        [s[0] + q.w, s[1] + q.x, s[2] + q.y, s[3] + q.z]
    });
    let sum = nalgebra::Quaternion::new(sum[0], sum[1], sum[2], sum[3]);
    if !(sum.norm().is_finite() && sum.norm() > 0.0) {
        return Err(WandError::Ground {
            tool: ground.name.clone(),
            posed: 0,
            frames: frames.len(),
            needed,
        });
    }
    let rotation = nalgebra::UnitQuaternion::from_quaternion(sum);
    let old_from_ground = crate::geometry::pose_from_parts(translation, rotation);
    let scatter_mm = (poses
        .iter()
        .map(|(p, _)| (p.translation.vector - translation).norm_squared())
        .sum::<f64>()
        / count)
        .sqrt();
    let registration_rms_mm = poses.iter().map(|(_, r)| r).sum::<f64>() / count;
    let mut moved = rig.clone();
    for camera in &mut moved.cameras {
        camera.camera_from_world *= old_from_ground;
    }
    let cameras_below = moved
        .cameras
        .iter()
        .filter(|c| c.center_in_world().z < 0.0)
        .map(|c| c.name.clone())
        .collect();
    Ok((
        moved,
        GroundReport {
            cameras_below,
            posed: poses.len(),
            frames: frames.len(),
            old_from_ground,
            scatter_mm,
            registration_rms_mm,
        },
    ))
}
