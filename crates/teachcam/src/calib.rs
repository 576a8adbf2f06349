//! Camera calibration: chessboard corners, Zhang's intrinsics, and the whole rig in one world
//! frame (the paper's §II-A; the world frame on the painted object as in §V-A).
//!
//! Model: a planar board with corners `X_k = (c s, r s, 0)` (column `c`, row `r`, square `s`
//! millimetres) is seen by camera `i` in view `v` at the pixel
//! `u = project(K_i, d_i, camera_from_world_i * world_from_board_v * X_k)` (see
//! [`crate::camera`]). Calibration minimises `Σ |u_observed - u|²` over everything unknown:
//! 1. [`chessboard`]: corners found in photographs, sub-pixel, in OpenCV's order;
//! 2. [`zhang`]: homographies and Zhang's closed form (Zhang 2000, *A flexible new technique
//!    for camera calibration*, IEEE TPAMI 22(11));
//! 3. [`intrinsics`]: Levenberg–Marquardt over `fx, fy, cx, cy, k1, k2, p1, p2, k3` and every
//!    board pose ([`lm`]);
//! 4. [`rig`]: extrinsics of N cameras from boards seen by several at once, the world set by
//!    one board, then a bundle adjustment of all cameras and board poses.
//!
//! One camera's result is written by [`crate::io::camera_file`] (`camera.json`, OpenCV
//! `FileStorage` YAML, ROS `camera_info` YAML).

pub(crate) mod bundle;
pub mod chessboard;
pub mod intrinsics;
pub mod lm;
pub mod refine;
pub mod refine_intrinsics;
pub mod rig;
pub mod wand;
pub mod zhang;

use crate::geometry::Point3;

/// A chessboard target: its inner corner grid and square size.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chessboard {
    /// Inner corners per row (OpenCV's `pattern_size.width`).
    pub inner_cols: usize,
    /// Rows of inner corners (OpenCV's `pattern_size.height`).
    pub inner_rows: usize,
    /// Side of a square, millimetres.
    pub square_mm: f64,
}

impl Chessboard {
    /// Number of inner corners.
    #[must_use]
    pub const fn corner_count(&self) -> usize {
        self.inner_cols * self.inner_rows
    }

    /// The inner corners in the board's frame (z = 0), in OpenCV's order: `(c s, r s, 0)`
    /// row by row.
    #[must_use]
    pub fn corners_in_board(&self) -> Vec<Point3> {
        (0..self.inner_rows)
            .flat_map(|r| {
                (0..self.inner_cols).map(move |c| {
                    Point3::new(c as f64 * self.square_mm, r as f64 * self.square_mm, 0.0)
                })
            })
            .collect()
    }
}

/// The corners of one target seen in one image, in the target's point order.
#[derive(Debug, Clone, PartialEq)]
pub struct BoardView {
    /// What the view is called in messages and reports (its image file).
    pub name: String,
    /// One pixel per target point.
    pub corners: Vec<crate::geometry::Pixel>,
}

/// Why a calibration was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum CalibError {
    /// Not enough views for the unknowns.
    #[error("{views} usable views, calibration needs at least {needed}")]
    TooFewViews {
        /// Views given.
        views: usize,
        /// Views needed.
        needed: usize,
    },
    /// A view's corner count differs from the target's.
    #[error("view {view}: {found} corners, the target has {expected}")]
    CornerCount {
        /// The view.
        view: String,
        /// Corners in the view.
        found: usize,
        /// Points of the target.
        expected: usize,
    },
    /// A corner is NaN or infinite.
    #[error("view {view}: corner {corner} is not finite")]
    NotFinite {
        /// The view.
        view: String,
        /// Index of the corner.
        corner: usize,
    },
    /// The target's points are not all on z = 0.
    #[error("target point {point} is not on the plane z = 0")]
    NotPlanar {
        /// Index of the point.
        point: usize,
    },
    /// One view's corners determine no board pose (collinear corners).
    #[error("view {view}: the corners are degenerate (collinear); no board pose")]
    DegenerateView {
        /// The view.
        view: String,
    },
    /// The views together do not determine the camera (boards all parallel).
    #[error(
        "the views are degenerate (boards all parallel to each other or to the image): the camera is not determined; tilt the board between views"
    )]
    DegenerateViews,
    /// The optimisation ended somewhere meaningless.
    #[error("calibration diverged: {detail}")]
    Diverged {
        /// What was wrong.
        detail: String,
    },
    /// A camera of the rig is linked to the world by no chain of shared views.
    #[error("camera {camera} shares no board view with the cameras linked to the world frame")]
    Unlinked {
        /// The camera's name.
        camera: String,
    },
    /// An observation names a camera the rig does not have.
    #[error("{camera} (named by {view}) is not among the cameras")]
    UnknownCamera {
        /// The camera id.
        camera: String,
        /// Where it was named.
        view: String,
    },
    /// One camera saw one board placement twice.
    #[error("camera {camera} has two observations of view {view}")]
    DuplicateObservation {
        /// The camera's name.
        camera: String,
        /// The view.
        view: String,
    },
    /// The view chosen to set the world frame is not among the views.
    #[error("world view {view} is not among the views")]
    UnknownWorldView {
        /// The view.
        view: String,
    },
}
