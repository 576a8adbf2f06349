//! The take under review at the page's cut-off: the library's review figures
//! ([`teachcam::report::review`]: components raw / smoothed with the residual, the windowed
//! spectrum with the cut-off marked, `tip_std_mm` and status), then the paper's smoothing
//! comparison (the report's figure, the same for every take: made once), drawn by the same
//! script as the report (`web/review.js`). Nothing is computed here but which frames form the
//! take.

use std::sync::OnceLock;

use axum::extract::{Query, State};
use serde_json::{Value, json};
use teachcam::report::{FigureSlot, figures::smoothing_study, review as review_figures};
use teachcam::trajectory::Trajectory;

use super::Studio;
use super::robot::cutoff;
use super::security::ApiError;

/// The query of `/api/review`.
#[derive(Debug, Default, serde::Deserialize)]
pub struct ReviewQuery {
    /// The smoothing cut-off, Hz (10 when absent).
    cutoff_hz: Option<String>,
    /// The token, when given in the query (checked by the guard).
    #[serde(rename = "token")]
    _token: Option<String>,
}

/// The take as a trajectory, refused while it holds no pose, and whether it starts at the
/// source's first frame.
pub fn take(studio: &Studio) -> Result<(Trajectory, bool), ApiError> {
    let (take, from_first_frame) = {
        let live = studio.live();
        let first = live.take.samples.front().map(|s| s.frame.0);
        (live.take.trajectory(), first == Some(0))
    };
    if take.samples.iter().all(|s| s.pose.is_none()) {
        return Err(ApiError::conflict(
            "the take has no pose yet: let the source run, or record one",
        ));
    }
    Ok((take, from_first_frame))
}

/// The take, and the simulator's truth when the take is a whole pass of the recording the
/// truth belongs to (its frames start at 0).
fn take_with_truth(studio: &Studio) -> Result<(Trajectory, Option<Trajectory>), ApiError> {
    let (take, from_first_frame) = take(studio)?;
    let truth = studio
        .config()
        .truth
        .clone()
        .filter(|truth| from_first_frame && truth.len() >= take.len());
    Ok((take, truth))
}

/// The seed of the smoothing comparison's noise: the report's (`teachcam smoothing-study
/// --seed 1` gives the same numbers).
const STUDY_SEED: u64 = 1;

/// The paper's smoothing comparison, made on first use.
fn study() -> &'static FigureSlot {
    static STUDY: OnceLock<FigureSlot> = OnceLock::new();
    STUDY.get_or_init(|| smoothing_study(STUDY_SEED))
}

/// `GET /api/review?cutoff_hz=X`: `{frames, cutoff_hz, figures}`.
pub async fn review(
    State(studio): State<Studio>,
    Query(query): Query<ReviewQuery>,
) -> Result<axum::Json<Value>, ApiError> {
    let cutoff_hz = cutoff(query.cutoff_hz.as_deref())?;
    let (take, truth) = take_with_truth(&studio)?;
    let frames = take.len();
    let figures = tokio::task::spawn_blocking(move || {
        review_figures(&take, cutoff_hz, truth.as_ref()).map(|mut figures| {
            figures.push(study().clone());
            figures
        })
    })
    .await
    .map_err(|e| ApiError::internal(e.to_string()))?
    .map_err(|e| ApiError::unprocessable(format!("smoothing the take at {cutoff_hz} Hz: {e}")))?;
    Ok(axum::Json(json!({
        "frames": frames,
        "cutoff_hz": cutoff_hz,
        "figures": figures,
    })))
}
