//! The wand's points without images, for `teachcam calibrate wand --detections FILE`, in
//! either of two formats told apart by the header:
//! - **teachcam's `detections.csv`** (CONTRACT.md, "Detections"): `camera,frame,x_px,y_px,
//!   radius_px[,…]`, one row per blob, pixels in OpenCV's convention (the centre of the
//!   top-left pixel is (0, 0)), cameras named as in the rig file. `teachcam detect` writes it;
//!   digitised points converted to it need only these five columns (`radius_px` may be 0).
//! - **DLTdv's `xypts.csv`** (Hedrick 2008; what easyWand reads, Theriault et al. 2014): one
//!   row per frame, columns `pt1_cam1_X,pt1_cam1_Y,pt1_cam2_X,…,pt2_cam1_X,…`, `NaN` (or an
//!   empty cell) where a point was not digitised. Camera `camK` is the rig's K-th camera
//!   (file order). DLTdv counts pixels from 1; DLTdv8 measures y down from the top edge,
//!   DLTdv5–7, Argus and easyWand's own files up from the bottom edge ([`DltdvOrigin`]): the
//!   points are converted to OpenCV's convention, `x − 1` and `y − 1` (top) or
//!   `height − y` (bottom, the height from the rig file). A file saved without the header
//!   (numbers only) is read in the same layout when its column count is a multiple of
//!   2 × the rig's cameras.
//!
//! The points' order within a camera-frame carries no meaning: the wand's ends are not
//! labelled (which is which is settled by the calibration).

use std::path::Path;

use super::detections::{DETECTIONS_COLUMNS, parse_detections};
use super::{FileError, read_text};
use crate::camera::Rig;
use crate::correspond::Views;
use crate::geometry::{CameraId, Pixel};

/// Where DLTdv's y axis starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DltdvOrigin {
    /// y down from the top edge, the first pixel 1 (DLTdv8).
    Top,
    /// y up from the bottom edge, the first pixel 1 (DLTdv5–7, Argus, easyWand).
    Bottom,
}

/// Which format a points file was in.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointsFormat {
    /// teachcam's `detections.csv`.
    Detections,
    /// DLTdv's `xypts.csv` with so many points per frame.
    Dltdv {
        /// Points per frame in the header (`ptN`).
        points: usize,
    },
}

/// Every frame's points per rig camera, and the format read.
///
/// # Errors
/// [`FileError`] naming the file (and line): unreadable, a header of neither format, a
/// camera not in `rig`, a field that is not a number.
pub fn read_wand_points(
    path: &Path,
    rig: &Rig,
    origin: DltdvOrigin,
) -> Result<(Vec<Views>, PointsFormat), FileError> {
    let text = read_text(path)?;
    let header = text.lines().next().unwrap_or("").trim_end_matches('\r');
    if header.starts_with(&DETECTIONS_COLUMNS.join(",")) {
        return Ok((
            detections_views(path, &text, rig)?,
            PointsFormat::Detections,
        ));
    }
    // A DLTdv file saved without its header: numbers only, `2 · cameras` columns per point.
    let headerless = header.split(',').all(|c| {
        let c = c.trim();
        c.is_empty() || c.eq_ignore_ascii_case("nan") || c.parse::<f64>().is_ok()
    });
    let cells = header.split(',').count();
    let columns: Vec<Option<(usize, usize, bool)>> = if headerless {
        let per_point = 2 * rig.len();
        if per_point == 0 || cells % per_point != 0 {
            return Err(FileError::invalid_line(
                path,
                1,
                format!(
                    "no header and {cells} columns: DLTdv points without a header need 2 per camera per point ({} cameras: a multiple of {per_point})",
                    rig.len()
                ),
            ));
        }
        (0..cells)
            .map(|i| Some((i / per_point + 1, (i / 2) % rig.len() + 1, i % 2 == 1)))
            .collect()
    } else {
        header.split(',').map(|c| dltdv_column(c.trim())).collect()
    };
    if columns.is_empty() || columns.iter().any(Option::is_none) {
        return Err(FileError::invalid_line(
            path,
            1,
            format!(
                "header is neither teachcam's detections ({},…) nor DLTdv's xypts (pt1_cam1_X,pt1_cam1_Y,…)",
                DETECTIONS_COLUMNS.join(",")
            ),
        ));
    }
    let columns: Vec<(usize, usize, bool)> = columns.into_iter().flatten().collect();
    let points = columns.iter().map(|c| c.0).max().unwrap_or(0);
    if let Some((_, camera, _)) = columns.iter().find(|c| c.1 > rig.len()) {
        return Err(FileError::invalid_line(
            path,
            1,
            format!(
                "column cam{camera}: the rig file has {} cameras (camK is the rig's K-th camera)",
                rig.len()
            ),
        ));
    }
    let mut frames = Vec::new();
    for (index, row) in text.lines().enumerate().skip(usize::from(!headerless)) {
        let line = index + 1;
        let row = row.trim_end_matches('\r');
        if row.trim().is_empty() {
            continue;
        }
        let fields: Vec<&str> = row.split(',').collect();
        if fields.len() != columns.len() {
            return Err(FileError::invalid_line(
                path,
                line,
                format!("{} fields, header has {}", fields.len(), columns.len()),
            ));
        }
        // (point, camera) → (x, y), 1-based.
        let mut cells = std::collections::BTreeMap::<(usize, usize), [Option<f64>; 2]>::new();
        for ((point, camera, is_y), field) in columns.iter().zip(&fields) {
            let field = field.trim();
            let value = if field.is_empty() || field.eq_ignore_ascii_case("nan") {
                None
            } else {
                let v: f64 = field.parse().map_err(|_| {
                    FileError::invalid_line(
                        path,
                        line,
                        format!("pt{point}_cam{camera}: '{field}' is not a number"),
                    )
                })?;
                v.is_finite().then_some(v)
            };
            cells.entry((*point, *camera)).or_default()[usize::from(*is_y)] = value;
        }
        let mut views = Views::new();
        for ((_, camera), xy) in cells {
            let [Some(x), Some(y)] = xy else {
                continue;
            };
            let id = CameraId(camera - 1);
            let height = rig.cameras[camera - 1].image_size.height as f64;
            let pixel = match origin {
                DltdvOrigin::Top => Pixel::new(x - 1.0, y - 1.0),
                DltdvOrigin::Bottom => Pixel::new(x - 1.0, height - y),
            };
            views.entry(id).or_default().push(pixel);
        }
        frames.push(views);
    }
    Ok((frames, PointsFormat::Dltdv { points }))
}

/// `ptP_camC_X` / `_Y` (any case) → `(P, C, is_y)`, P and C from 1.
fn dltdv_column(name: &str) -> Option<(usize, usize, bool)> {
    let lower = name.to_ascii_lowercase();
    let rest = lower.strip_prefix("pt")?;
    let (point, rest) = rest.split_once("_cam")?;
    let (camera, axis) = rest.split_once('_')?;
    let is_y = match axis {
        "x" => false,
        "y" => true,
        _ => return None,
    };
    let (point, camera): (usize, usize) = (point.parse().ok()?, camera.parse().ok()?);
    (point >= 1 && camera >= 1).then_some((point, camera, is_y))
}

/// A detections file's blob centres per frame by rig camera; a camera of the file not in the
/// rig is refused.
fn detections_views(path: &Path, text: &str, rig: &Rig) -> Result<Vec<Views>, FileError> {
    let detections = parse_detections(path, text)?;
    if let Some(name) = detections
        .cameras
        .keys()
        .find(|name| !rig.cameras.iter().any(|c| &c.name == *name))
    {
        return Err(FileError::invalid(
            path,
            format!(
                "camera '{name}' is not in the rig file (its cameras: {})",
                rig.cameras
                    .iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        ));
    }
    Ok((0..detections.frame_count())
        .map(|frame| {
            rig.cameras
                .iter()
                .enumerate()
                .filter_map(|(i, camera)| {
                    let blobs = detections.blobs(&camera.name, frame);
                    (!blobs.is_empty())
                        .then(|| (CameraId(i), blobs.iter().map(|b| b.center).collect()))
                })
                .collect()
        })
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rig() -> Rig {
        crate::sim::wand::wand_scene(0).rig
    }

    #[test]
    fn reads_dltdv_points_with_nan_and_both_origins() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("xypts.csv");
        std::fs::write(
            &path,
            "pt1_cam1_X,pt1_cam1_Y,pt1_cam2_X,pt1_cam2_Y,pt2_cam1_X,pt2_cam1_Y,pt2_cam2_X,pt2_cam2_Y\n\
             11,21,NaN,NaN,31,41,51,61\n\
             NaN,NaN,,,NaN,NaN,NaN,NaN\n",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let rig = rig();
        let height = rig.cameras[0].image_size.height as f64;
        let (frames, format) =
            read_wand_points(&path, &rig, DltdvOrigin::Top).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format, PointsFormat::Dltdv { points: 2 });
        assert_eq!(frames.len(), 2);
        assert_eq!(
            frames[0][&CameraId(0)],
            vec![Pixel::new(10.0, 20.0), Pixel::new(30.0, 40.0)]
        );
        assert_eq!(frames[0][&CameraId(1)], vec![Pixel::new(50.0, 60.0)]);
        assert!(frames[1].is_empty());
        let (frames, _) =
            read_wand_points(&path, &rig, DltdvOrigin::Bottom).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(frames[0][&CameraId(0)][0], Pixel::new(10.0, height - 21.0));
        // The same without a header (four cameras: 8 columns per point).
        std::fs::write(
            &path,
            "11,21,51,61,NaN,NaN,NaN,NaN,31,41,NaN,NaN,NaN,NaN,NaN,NaN\n",
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let (frames, format) =
            read_wand_points(&path, &rig, DltdvOrigin::Top).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format, PointsFormat::Dltdv { points: 2 });
        assert_eq!(
            frames[0][&CameraId(0)],
            vec![Pixel::new(10.0, 20.0), Pixel::new(30.0, 40.0)]
        );
        assert_eq!(frames[0][&CameraId(1)], vec![Pixel::new(50.0, 60.0)]);
        std::fs::write(&path, "1,2,3\n").unwrap_or_else(|e| panic!("{e}"));
        let error = read_wand_points(&path, &rig, DltdvOrigin::Top)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(error.contains("multiple of 8"), "{error}");
        std::fs::write(&path, "pt1_cam9_X,pt1_cam9_Y\n1,2\n").unwrap_or_else(|e| panic!("{e}"));
        let error = read_wand_points(&path, &rig, DltdvOrigin::Top)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(error.contains("cam9"), "{error}");
        std::fs::write(&path, "a,b\n1,2\n").unwrap_or_else(|e| panic!("{e}"));
        let error = read_wand_points(&path, &rig, DltdvOrigin::Top)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(error.contains("neither"), "{error}");
    }

    #[test]
    fn reads_detections_by_camera_name() {
        let dir = tempfile::tempdir().unwrap_or_else(|e| panic!("{e}"));
        let path = dir.path().join("detections.csv");
        let rig = rig();
        let name = &rig.cameras[1].name;
        std::fs::write(
            &path,
            format!("camera,frame,x_px,y_px,radius_px\n{name},2,5.5,6.5,0\n{name},2,7,8,0\n"),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let (frames, format) =
            read_wand_points(&path, &rig, DltdvOrigin::Top).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(format, PointsFormat::Detections);
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[2][&CameraId(1)].len(), 2);
        std::fs::write(&path, "camera,frame,x_px,y_px,radius_px\nnope,0,1,2,0\n")
            .unwrap_or_else(|e| panic!("{e}"));
        let error = read_wand_points(&path, &rig, DltdvOrigin::Top)
            .err()
            .map(|e| e.to_string())
            .unwrap_or_default();
        assert!(error.contains("'nope'"), "{error}");
    }
}
