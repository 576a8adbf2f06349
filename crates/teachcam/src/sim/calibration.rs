//! The `calibration` scenarios: a rig films a chessboard held in placements around the working
//! volume, plus one lying flat on the work object that sets the world frame (§V-A), so that
//! `teachcam calibrate rig` can be checked against the true rig.
//!
//! Board: 9x6 inner corners, 50 mm squares ([`CALIBRATION_BOARD`]). The world view's board lies
//! on the work object, printed side up, its centre 70 mm from the world origin (so that every
//! camera sees its corners; its sheet's margin may leave an image): its frame (OpenCV's,
//! z into the board, i.e. down) is the world turned half a turn about x and shifted,
//! [`world_from_world_board`]. A rig calibrated with `--world world` is therefore in that
//! board's frame; `camera_from_world_board = camera_from_world * world_from_world_board`
//! converts the truth to it. Placements: the board's centre anywhere in
//! `x, y ∈ ±120 mm, z ∈ 30..250 mm`, facing a pair of cameras (one of them a camera with the
//! fewest images so far) or, three times in ten, all of them, wobbled by up to 20° and spun by
//! any angle about its normal; a placement is kept when at least two cameras see the whole sheet
//! from the front within 60° of its normal (a view only one camera sees links nothing).
//! A camera's rotation σ after the bundle adjustment is set by its principal point's and falls
//! as one over the root of its own image count; the placement style (tilts to 55°, boards
//! nearer the image borders or the cameras) moved it by less than 10 % in a study
//! (`notes/rig.md`), so balancing the image count between cameras is what the placements do.

use std::path::Path;

use nalgebra::{Unit, UnitQuaternion, Vector3};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::board::{BoardImage, BoardLook, render_board};
use super::render::RenderConfig;
use super::view_seed;
use crate::calib::Chessboard;
use crate::camera::{Camera, Rig};
use crate::geometry::{Pose, pose_from_parts, rotation_rows};
use crate::io::FileError;

/// The board of the calibration scenarios: OpenCV's 9x6 pattern, 50 mm squares.
pub const CALIBRATION_BOARD: Chessboard = Chessboard {
    inner_cols: 9,
    inner_rows: 6,
    square_mm: 50.0,
};

/// The name of the view whose board lies on the work object.
pub const WORLD_VIEW: &str = "world";

/// One board placement.
#[derive(Debug, Clone, PartialEq)]
pub struct Placement {
    /// The view's name: the file stem of its images.
    pub name: String,
    /// The board's pose.
    pub world_from_board: Pose,
}

/// A calibration scene: a rig, a board and where it is held.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationScene {
    /// The true rig.
    pub rig: Rig,
    /// The board.
    pub board: Chessboard,
    /// Its look.
    pub look: BoardLook,
    /// Image formation.
    pub render: RenderConfig,
    /// The world view first, then the held placements.
    pub placements: Vec<Placement>,
}

impl CalibrationScene {
    /// What `camera` sees of the board held at `placement`, with its truth.
    pub fn board_view<R: rand::Rng>(
        &self,
        camera: &Camera,
        placement: &Placement,
        rng: &mut R,
    ) -> BoardImage {
        render_board(
            camera,
            &self.board,
            &placement.world_from_board,
            &self.look,
            &self.render,
            rng,
        )
    }
}

/// Where the world view's board centre lies on the work object, millimetres: 70 mm towards
/// -y puts every inner corner at least 88 px inside every image of the paper's rig and the
/// four-camera rig (found by a search over in-plane turns and offsets; no pose on z = 0 puts
/// the whole 550 x 400 mm sheet inside all three images of the paper's rig).
pub const WORLD_BOARD_CENTRE_MM: [f64; 2] = [0.0, -70.0];

/// The world view's images show its corners at least this far inside the image, pixels: the
/// corner finder's 23 px window and 5 px ring fit, though the sheet's margin may be cut.
pub const WORLD_VIEW_BORDER_PX: f64 = 40.0;

/// The pose of the board lying on the work object, printed side up, its rows along world x,
/// its centre at [`WORLD_BOARD_CENTRE_MM`]: `(x, y, z)_board → (x - 200, 55 - y, -z)_world`
/// for the 9x6, 50 mm board.
#[must_use]
pub fn world_from_world_board(board: &Chessboard) -> Pose {
    let half_x = (board.inner_cols - 1) as f64 * board.square_mm / 2.0;
    let half_y = (board.inner_rows - 1) as f64 * board.square_mm / 2.0;
    let [x, y] = WORLD_BOARD_CENTRE_MM;
    pose_from_parts(
        Vector3::new(x - half_x, y + half_y, 0.0),
        UnitQuaternion::from_axis_angle(&Vector3::x_axis(), std::f64::consts::PI),
    )
}

/// A held board faces its cameras to within this angle, degrees.
const MAX_WOBBLE_DEG: f64 = 20.0;

/// A camera whose line of sight meets the board more obliquely than this (from the board's
/// normal), degrees, gets no image: a person calibrating would not keep such a view, and the
/// corner finder's lattice growth is not meant for it.
pub const MAX_OBLIQUITY_DEG: f64 = 60.0;

/// True when `camera` has an image of `placement`: the whole sheet from the front, within
/// [`MAX_OBLIQUITY_DEG`], for a held board; for the world view, every inner corner
/// [`WORLD_VIEW_BORDER_PX`] inside the image.
#[must_use]
pub fn has_image(
    camera: &Camera,
    board: &Chessboard,
    look: &BoardLook,
    placement: &Placement,
) -> bool {
    if placement.name == WORLD_VIEW {
        super::board::sees_corners_front(
            camera,
            board,
            &placement.world_from_board,
            WORLD_VIEW_BORDER_PX,
        )
    } else {
        let pose = &placement.world_from_board;
        let centre = pose
            * crate::geometry::Point3::new(
                (board.inner_cols - 1) as f64 * board.square_mm / 2.0,
                (board.inner_rows - 1) as f64 * board.square_mm / 2.0,
                0.0,
            );
        let towards_camera = (camera.center_in_world() - centre).normalize();
        let obliquity = (-(pose.rotation * Vector3::z())).angle(&towards_camera);
        obliquity <= MAX_OBLIQUITY_DEG.to_radians()
            && super::board::sees_whole_front(camera, board, look, pose)
    }
}

/// How many held placements a calibration scene gets.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlacementCount {
    /// Exactly this many besides the world view (fewer if the rig cannot see the board).
    Held(usize),
    /// Until every camera has at least this many images of held boards.
    ImagesPerCamera(usize),
}

/// Images per camera that bring every camera's rotation σ to at most 0.0067° (3σ ≤ 0.02°)
/// on the paper's rig and the four-camera rig at the detector's measured corner noise
/// (0.025 px per coordinate, `notes/rig.md`): σ ≈ 0.039° / √images.
pub const IMAGES_PER_CAMERA_FOR_0_02_DEG: usize = 40;

/// Builds a calibration scene for `rig` with `held` placements besides the world view.
#[must_use]
pub fn calibration_scene(rig: Rig, held: usize, seed: u64) -> CalibrationScene {
    calibration_scene_with(rig, PlacementCount::Held(held), seed)
}

/// Builds a calibration scene for `rig` with as many placements as `count` asks.
#[must_use]
pub fn calibration_scene_with(rig: Rig, count: PlacementCount, seed: u64) -> CalibrationScene {
    let board = CALIBRATION_BOARD;
    let look = BoardLook::default();
    let mut placements = vec![Placement {
        name: WORLD_VIEW.to_owned(),
        world_from_board: world_from_world_board(&board),
    }];
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6368_6573_7362_6f61);
    let centre_in_board = Vector3::new(
        (board.inner_cols - 1) as f64 * board.square_mm / 2.0,
        (board.inner_rows - 1) as f64 * board.square_mm / 2.0,
        0.0,
    );
    let eyes: Vec<Vector3<f64>> = rig
        .cameras
        .iter()
        .map(|c| c.center_in_world().coords)
        .collect();
    let mut images = vec![0usize; eyes.len()];
    // Bounded: a rig that cannot see the board yields fewer placements, not a hang.
    let attempts = match count {
        PlacementCount::Held(held) => 100 * held.max(1),
        PlacementCount::ImagesPerCamera(images) => 100 * images.max(1) * eyes.len(),
    };
    for _ in 0..attempts {
        let done = match count {
            PlacementCount::Held(held) => placements.len() > held,
            PlacementCount::ImagesPerCamera(wanted) => images.iter().all(|n| *n >= wanted),
        };
        if done || eyes.len() < 2 {
            break;
        }
        let centre = Vector3::new(
            rng.random_range(-120.0..120.0),
            rng.random_range(-120.0..120.0),
            rng.random_range(30.0..250.0),
        );
        // Face a pair of cameras, or all of them, as a person holding the board would; the
        // pair includes a camera with the fewest images so far, since a camera's rotation σ
        // falls as one over the root of its own image count (notes/rig.md).
        let fewest = images.iter().copied().min().unwrap_or(0);
        let starved: Vec<usize> = (0..eyes.len()).filter(|c| images[*c] == fewest).collect();
        let first = starved[rng.random_range(0..starved.len())];
        let second = (first + rng.random_range(1..eyes.len())) % eyes.len();
        let facing: Vec<usize> = if rng.random_range(0.0..1.0) < 0.3 {
            (0..eyes.len()).collect()
        } else {
            vec![first, second]
        };
        let towards: Vector3<f64> = facing
            .iter()
            .map(|k| (eyes[*k] - centre).normalize())
            .sum::<Vector3<f64>>()
            .normalize();
        let heading = rng.random_range(0.0..std::f64::consts::TAU);
        let wobble = UnitQuaternion::from_axis_angle(
            &Unit::new_normalize(towards.cross(&Vector3::new(heading.cos(), heading.sin(), 0.3))),
            rng.random_range(0.0..MAX_WOBBLE_DEG.to_radians()),
        );
        let spin = rng.random_range(-std::f64::consts::PI..std::f64::consts::PI);
        // Board z points away from the cameras it faces.
        let Some(facing_rotation) =
            UnitQuaternion::rotation_between(&Vector3::z(), &-(wobble * towards))
        else {
            continue;
        };
        let rotation = facing_rotation * UnitQuaternion::from_axis_angle(&Vector3::z_axis(), spin);
        let placement = Placement {
            name: format!("v{:03}", placements.len() - 1),
            world_from_board: pose_from_parts(centre - rotation * centre_in_board, rotation),
        };
        let seen: Vec<usize> = (0..eyes.len())
            .filter(|c| has_image(&rig.cameras[*c], &board, &look, &placement))
            .collect();
        if seen.len() >= 2 {
            seen.iter().for_each(|c| images[*c] += 1);
            placements.push(placement);
        }
    }
    CalibrationScene {
        rig,
        board,
        look,
        render: RenderConfig::default(),
        placements,
    }
}

#[derive(Serialize)]
struct PoseFile {
    rotation: [[f64; 3]; 3],
    translation: [f64; 3],
}

impl PoseFile {
    fn of(pose: &Pose) -> Self {
        Self {
            rotation: rotation_rows(&pose.rotation),
            translation: pose.translation.vector.into(),
        }
    }
}

#[derive(Serialize)]
struct BoardFile {
    inner_cols: usize,
    inner_rows: usize,
    square_mm: f64,
    margin_mm: f64,
}

#[derive(Serialize)]
struct ViewFile {
    name: String,
    world_from_board: PoseFile,
    cameras: Vec<String>,
}

#[derive(Serialize)]
struct BoardsFile {
    units: &'static str,
    board: BoardFile,
    views: Vec<ViewFile>,
}

#[derive(Serialize)]
struct CalibrationFile {
    about: &'static str,
    world_view: String,
    world_from_world_board: PoseFile,
    command: String,
}

/// Writes the scene: `<camera>/<view>.png` for every view a camera sees whole from the front,
/// `rig.json` (the truth), `boards.json` (each view's `world_from_board` and the cameras that
/// have its image), `corners.csv` (`camera,view,corner,x_px,y_px`: the exact projection of
/// every inner corner in every written image) and `calibration.json` (the world view, the
/// offset of its board from the world, the command that calibrates the images). Views are
/// rendered in parallel; `on_view` is called once per placement.
///
/// All or nothing, as [`super::write_scene`].
///
/// # Errors
/// [`FileError`] when a file cannot be written.
pub fn write_calibration(
    scene: &CalibrationScene,
    out: &Path,
    seed: u64,
    on_view: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    let staged = crate::io::StagedFolder::new(out)?;
    write_calibration_into(scene, staged.path(), out, seed, on_view)?;
    staged.commit().map(drop)
}

/// Writes into `out`; `named` is the folder the files will end up in, for the command they name.
fn write_calibration_into(
    scene: &CalibrationScene,
    out: &Path,
    named: &Path,
    seed: u64,
    on_view: &(dyn Fn() + Sync),
) -> Result<(), FileError> {
    for camera in &scene.rig.cameras {
        crate::io::create_folder(&out.join(&camera.name))?;
    }
    let written: Vec<(Vec<String>, String)> = scene
        .placements
        .par_iter()
        .enumerate()
        .map(|(index, placement)| {
            let mut cameras = Vec::new();
            let mut rows = String::new();
            for (camera_id, camera) in scene.rig.iter() {
                if !has_image(camera, &scene.board, &scene.look, placement) {
                    continue;
                }
                let mut rng = ChaCha8Rng::seed_from_u64(view_seed(seed, camera_id, index));
                let view = scene.board_view(camera, placement, &mut rng);
                let path = out
                    .join(&camera.name)
                    .join(format!("{}.png", placement.name));
                crate::io::recording::write_png(&path, &view.image)?;
                for (k, corner) in view.corners.iter().enumerate() {
                    if let Some(c) = corner {
                        rows.push_str(&format!(
                            "{},{},{k},{:.6},{:.6}\n",
                            camera.name, placement.name, c.x, c.y
                        ));
                    }
                }
                cameras.push(camera.name.clone());
            }
            on_view();
            Ok((cameras, rows))
        })
        .collect::<Result<_, FileError>>()?;
    let mut corners = String::from("camera,view,corner,x_px,y_px\n");
    written.iter().for_each(|(_, rows)| corners.push_str(rows));
    crate::io::write_atomically(&out.join("corners.csv"), corners.as_bytes())?;
    let boards = BoardsFile {
        units: "mm",
        board: BoardFile {
            inner_cols: scene.board.inner_cols,
            inner_rows: scene.board.inner_rows,
            square_mm: scene.board.square_mm,
            margin_mm: scene.look.margin_mm,
        },
        views: scene
            .placements
            .iter()
            .zip(&written)
            .map(|(p, (cameras, _))| ViewFile {
                name: p.name.clone(),
                world_from_board: PoseFile::of(&p.world_from_board),
                cameras: cameras.clone(),
            })
            .collect(),
    };
    crate::io::write_json(&out.join("boards.json"), &boards)?;
    let world = scene.placements.first().map_or_else(
        || world_from_world_board(&scene.board),
        |p| p.world_from_board,
    );
    let calibration = CalibrationFile {
        about: "the view whose board lies on the work object sets the world frame of `teachcam calibrate rig --world`: that board's frame, z into the board; the true rig.json is in the simulator's world (z up), offset from it by world_from_world_board",
        world_view: WORLD_VIEW.to_owned(),
        world_from_world_board: PoseFile::of(&world),
        command: format!(
            "teachcam calibrate rig --pattern chessboard --inner {}x{} --square {} {} --world {WORLD_VIEW} -o calibrated-rig.json",
            scene.board.inner_cols,
            scene.board.inner_rows,
            scene.board.square_mm,
            named.display()
        ),
    };
    crate::io::write_json(&out.join("calibration.json"), &calibration)?;
    crate::io::rig::write_rig(&out.join("rig.json"), &scene.rig)
}
