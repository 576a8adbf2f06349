//! The report's summary: typed values, each with its text for people ("3 cameras",
//! "0.0171 mm", "passed"), never a raw number dump.

use serde::Serialize;

use super::figures::{aligned, rms};
use super::{ReportInputs, short};
use crate::trajectory::{Status, Trajectory};

/// A typed value of the summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "kind", content = "value", rename_all = "snake_case")]
pub enum SummaryValue {
    /// How many of something (`noun` is its plural: "cameras").
    Count {
        /// How many.
        n: u64,
        /// What, plural.
        noun: String,
    },
    /// A length, mm.
    LengthMm(f64),
    /// A length in pixels.
    Pixels(f64),
    /// A duration, s.
    Seconds(f64),
    /// A frequency, Hz.
    Hertz(f64),
    /// A fraction, shown as a percentage.
    Fraction(f64),
    /// A check's outcome.
    Passed(bool),
    /// Words.
    Text(String),
}

impl std::fmt::Display for SummaryValue {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Count { n, noun } => write!(f, "{n} {noun}"),
            Self::LengthMm(v) => write!(f, "{} mm", significant(*v)),
            Self::Pixels(v) => write!(f, "{} px", significant(*v)),
            Self::Seconds(v) => write!(f, "{} s", significant(*v)),
            Self::Hertz(v) => write!(f, "{} Hz", short(*v)),
            Self::Fraction(v) => write!(f, "{:.0} %", 100.0 * v),
            Self::Passed(true) => f.write_str("passed"),
            Self::Passed(false) => f.write_str("FAILED"),
            Self::Text(t) => f.write_str(t),
        }
    }
}

/// Three significant digits, plain decimals (`0.0171`, `12.3`, `580`).
fn significant(v: f64) -> String {
    if v == 0.0 || !v.is_finite() {
        return format!("{v}");
    }
    let digits = (2 - v.abs().log10().floor() as i32).clamp(0, 9) as usize;
    format!("{v:.digits$}")
}

/// One line of the summary.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SummaryItem {
    /// A stable machine name (`raw_tip_error_rms_mm`), unique in a summary.
    pub key: String,
    /// What it is, for people.
    pub label: String,
    /// The value.
    pub value: SummaryValue,
    /// The value as people read it.
    pub text: String,
}

impl SummaryItem {
    /// An item; its text is the value's.
    #[must_use]
    pub fn new(key: &str, label: &str, value: SummaryValue) -> Self {
        Self {
            key: key.to_string(),
            label: label.to_string(),
            text: value.to_string(),
            value,
        }
    }
}

fn count(n: usize, noun: &str) -> SummaryValue {
    SummaryValue::Count {
        n: n as u64,
        noun: noun.to_string(),
    }
}

/// Tip distances between `measured` and `truth` at `raw`'s frames.
fn tip_errors(raw: &Trajectory, truth: &Trajectory, measured: &Trajectory) -> Vec<f64> {
    aligned(raw, truth)
        .iter()
        .zip(aligned(raw, measured))
        .filter_map(|(t, m)| Some((t.as_ref()?.pose?.tip_in_world - m?.pose?.tip_in_world).norm()))
        .collect()
}

/// The summary the report computes from its inputs (keys as the demo's run.json names them,
/// so that its numbers are not repeated).
pub(crate) fn run_summary(
    inputs: &ReportInputs,
    smoothed: Option<&Trajectory>,
) -> Vec<SummaryItem> {
    let raw = inputs.raw;
    let mut items = vec![SummaryItem::new(
        "frames",
        "frames",
        count(raw.len(), "frames"),
    )];
    let posed = raw.samples.iter().filter(|s| s.pose.is_some()).count();
    items.push(SummaryItem::new(
        "frames_tracked",
        "frames with a pose",
        SummaryValue::Text(format!(
            "{posed} of {} ({})",
            raw.len(),
            Status::ALL
                .iter()
                .map(|a| format!(
                    "{} {a}",
                    raw.samples.iter().filter(|s| s.status == *a).count()
                ))
                .collect::<Vec<_>>()
                .join(", ")
        )),
    ));
    if let Some(rate) = raw.sample_rate_hz() {
        items.push(SummaryItem::new(
            "frame_rate_hz",
            "frame rate",
            SummaryValue::Hertz(rate),
        ));
    }
    if let (Some(first), Some(last)) = (raw.samples.first(), raw.samples.last()) {
        items.push(SummaryItem::new(
            "duration_s",
            "duration",
            SummaryValue::Seconds(last.time_s - first.time_s),
        ));
    }
    if let Ok(rig) = &inputs.rig {
        let names: Vec<&str> = rig.cameras.iter().map(|c| c.name.as_str()).collect();
        items.push(SummaryItem::new(
            "cameras",
            "cameras",
            SummaryValue::Text(format!("{} cameras ({})", rig.len(), names.join(", "))),
        ));
    }
    if let Ok(tool) = &inputs.tool {
        items.push(SummaryItem::new(
            "tool",
            "tool",
            SummaryValue::Text(format!(
                "{}: {} markers of {} mm",
                tool.name,
                tool.markers_in_tool.len(),
                short(tool.marker_diameter_mm)
            )),
        ));
    }
    let stds: Vec<f64> = raw.samples.iter().filter_map(|s| s.tip_std_mm).collect();
    if let Some(r) = rms(stds.iter().copied()) {
        items.push(SummaryItem::new(
            "predicted_tip_std_rms_mm",
            "predicted tip uncertainty (RMS of tip_std_mm)",
            SummaryValue::LengthMm(r),
        ));
    }
    if let Ok(truth) = &inputs.truth {
        let raw_errors = tip_errors(raw, truth, raw);
        if let Some(r) = rms(raw_errors.iter().copied()) {
            items.push(SummaryItem::new(
                "raw_tip_error_rms_mm",
                "raw tip error against the truth (RMS)",
                SummaryValue::LengthMm(r),
            ));
            items.push(SummaryItem::new(
                "raw_tip_error_max_mm",
                "raw tip error against the truth (largest)",
                SummaryValue::LengthMm(raw_errors.iter().copied().fold(0.0, f64::max)),
            ));
        }
        if let Some(r) = smoothed.and_then(|s| rms(tip_errors(raw, truth, s))) {
            items.push(SummaryItem::new(
                "smoothed_tip_error_rms_mm",
                "smoothed tip error against the truth (RMS)",
                SummaryValue::LengthMm(r),
            ));
        }
    }
    items
}

/// Summary items from a JSON object of named numbers (the demo's `run.json` `summary`),
/// typed by the house naming rule: `_mm` lengths, `_px` pixels, `_s`/`_seconds` durations,
/// `_hz` frequencies, `_fraction` percentages, booleans passed/failed, integers counts;
/// `[name, seconds]` pairs (stage times) each an item. Lists of file names are left out
/// (the header lists the inputs). A label is the key's words without its unit.
#[must_use]
pub fn summary_from_json(value: &serde_json::Value) -> Vec<SummaryItem> {
    let Some(object) = value.as_object() else {
        return Vec::new();
    };
    let mut items = Vec::new();
    for (key, v) in object {
        let (stem, unit) = ["_mm", "_px", "_seconds", "_s", "_hz", "_fraction"]
            .iter()
            .find_map(|u| key.strip_suffix(u).map(|s| (s, *u)))
            .unwrap_or((key.as_str(), ""));
        let label = stem.replace('_', " ").replace(" rms", " (RMS)");
        let typed = match (v, unit) {
            (serde_json::Value::Bool(b), _) => Some(SummaryValue::Passed(*b)),
            (serde_json::Value::Number(n), "") => n
                .as_u64()
                .map(|n| count(n as usize, &label))
                .or_else(|| n.as_f64().map(|f| SummaryValue::Text(significant(f)))),
            (serde_json::Value::Number(n), unit) => n.as_f64().map(|f| match unit {
                "_mm" => SummaryValue::LengthMm(f),
                "_px" => SummaryValue::Pixels(f),
                "_hz" => SummaryValue::Hertz(f),
                "_fraction" => SummaryValue::Fraction(f),
                _ => SummaryValue::Seconds(f),
            }),
            (serde_json::Value::String(s), _) => Some(SummaryValue::Text(s.clone())),
            (serde_json::Value::Array(list), _) => {
                for pair in list {
                    if let Some(
                        [
                            serde_json::Value::String(name),
                            serde_json::Value::Number(s),
                        ],
                    ) = pair.as_array().map(Vec::as_slice)
                        && let Some(s) = s.as_f64()
                    {
                        items.push(SummaryItem::new(
                            &format!("{key}/{name}"),
                            &format!("{label}: {name}"),
                            SummaryValue::Seconds(s),
                        ));
                    }
                }
                None
            }
            _ => None,
        };
        if let Some(typed) = typed {
            items.push(SummaryItem::new(key, &label, typed));
        }
    }
    items
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_read_as_people_write_them() {
        assert_eq!(count(3, "cameras").to_string(), "3 cameras");
        assert_eq!(SummaryValue::LengthMm(0.017_123).to_string(), "0.0171 mm");
        assert_eq!(SummaryValue::LengthMm(580.0).to_string(), "580 mm");
        assert_eq!(SummaryValue::Fraction(0.614).to_string(), "61 %");
        assert_eq!(SummaryValue::Passed(true).to_string(), "passed");
        assert_eq!(SummaryValue::Hertz(30.0).to_string(), "30 Hz");
    }

    #[test]
    fn json_summaries_are_typed_by_their_names() {
        let items = summary_from_json(&serde_json::json!({
            "cameras": 3,
            "raw_tip_error_rms_mm": 0.0171,
            "robot_check_passed": true,
            "robot_peak_speed_fraction": 0.61,
            "stage_seconds": [["simulate", 4.2]],
            "files": ["a", "b"],
        }));
        let text = |key: &str| items.iter().find(|i| i.key == key).map(|i| i.text.clone());
        assert_eq!(text("cameras").as_deref(), Some("3 cameras"));
        assert_eq!(text("raw_tip_error_rms_mm").as_deref(), Some("0.0171 mm"));
        assert_eq!(text("robot_check_passed").as_deref(), Some("passed"));
        assert_eq!(text("robot_peak_speed_fraction").as_deref(), Some("61 %"));
        assert_eq!(text("stage_seconds/simulate").as_deref(), Some("4.20 s"));
        assert_eq!(text("files"), None);
        assert!(!items.iter().any(|i| i.text.contains("3.0000")));
    }
}
