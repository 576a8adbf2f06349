//! teachcam: program an industrial robot by demonstration.
//!
//! A person moves a hand tool (a paintbrush) carrying reflective spheres; three or more
//! calibrated, synchronised cameras film it; teachcam turns the images into a smooth, checked
//! 6-DOF tool trajectory and a robot program. The method is Cordier et al.'s trinocular
//! tracker (`paper.md`): detect → correspond → triangulate → identify → register → smooth →
//! check → export.
//!
//! # Conventions
//! - Lengths in millimetres, time in seconds, angles in radians, `f64` everywhere; other units
//!   carry a suffix in the name (`cutoff_hz`, `noise_px`).
//! - A transform `a_from_b` maps coordinates in frame `b` into frame `a`: `x_a = a_from_b * x_b`.
//! - Cameras follow OpenCV: `x_cam = R * X_world + t`; camera z forward, x right, y down.
//! - Pixels follow OpenCV: the centre of the top-left pixel is `(0, 0)`.
//! - Distortion is OpenCV's `[k1, k2, p1, p2, k3]`.
//! - Quaternions are Hamilton, unit, written `(qw, qx, qy, qz)`, `qw >= 0` unless continuity
//!   along a trajectory asks for the other sign.
//! - Frame numbers are 0-based indices in the recording's order.
//!
//! # Modules, in the order data flows
//! - [`geometry`]: frames, transforms, points, pixels, rays, ids.
//! - [`camera`]: the camera model, distortion and epipolar geometry.
//! - [`tool`]: the tracked tool's markers and tip.
//! - [`trajectory`]: poses over time, with explicit gaps.
//! - [`io`]: the contract's files (rig, tool, recording, trajectory CSV, camera YAML).
//! - [`calib`]: chessboard corners, Zhang intrinsics, rig extrinsics and bundle adjustment (§II-A).
//! - [`detect`]: marker blobs in an image, with sub-pixel centres (§II-A, §IV-A).
//! - [`correspond`]: which blobs in different cameras show the same marker (§II-A).
//! - [`sync`]: unsynchronised cameras: each camera's time offset estimated from the blob
//!   tracks, and the blobs moved to common frame times before correspondence.
//! - [`triangulate`]: 3-D points from corresponding blobs.
//! - [`identify`]: which point is which marker, by distance-matrix voting (§II-B).
//! - [`register`]: the tool's pose by SVD registration (§II-C).
//! - [`track`]: the stages above per frame, frames in parallel.
//! - [`smooth`]: the paper's four smoothers (low-pass, spline, Bezier, NURBS), SO(3)-aware,
//!   with spectrum, cut-off suggestion and gap filling.
//! - [`metrology`]: tool-tip uncertainty by Monte Carlo and first-order propagation (§IV).
//! - [`robot`]: vision↔robot frames, IRB 120 kinematics, the robot check, RAPID/KRL/URScript (§V).
//! - [`c3d`]: C3D motion-capture files in and out.
//! - [`vendor`]: OptiTrack Motive CSV and Qualisys TSV marker exports in, Motive-like CSV out.
//! - [`sim`]: the simulator that feeds every test, benchmark and the demo (recordings, and
//!   chessboard views for rig calibration).
//! - [`source`]: where frames come from: recording folders (PNG or video via FFmpeg), V4L2
//!   cameras, the simulator at a rate; pairing across cameras.
//! - [`pipeline`]: the conductor: a source's frames detected and tracked as they come.
//! - [`report`]: what a run's report and the studio's review show (figures as data, a typed
//!   summary), computed once for every front end.
//! - [`ros2`]: ROS 2 messages in CDR and MCAP takes (`export mcap`, `live --ros2`).

pub mod stats;
pub mod geometry;
pub mod camera;
pub mod tool;
pub mod trajectory;
pub mod io;
pub mod calib;
pub mod detect;
pub mod correspond;
pub mod sync;
pub mod triangulate;
pub mod identify;
pub mod register;
pub mod track;
pub mod doctor;
pub mod smooth;
pub mod metrology;
pub mod robot;
pub mod c3d;
pub mod vendor;
pub mod sim;
pub mod source;
pub mod pipeline;
pub mod report;
pub mod ros2;
