//! Value parsers of flags, so that clap refuses a bad value as a usage error (exit 2) naming the
//! flag and what it accepts, before any file is read (ARCHITECTURE.md, "Outputs and exit codes").
//!
//! Each parser returns the parsed value or one lowercase line saying what was expected; clap
//! prefixes it with the flag (`error: invalid value '0' for '--fps <FPS>': ...`).

use std::ops::Range;

pub mod detection;

/// A finite number.
fn number(text: &str) -> Result<f64, String> {
    let value: f64 = text
        .trim()
        .parse()
        .map_err(|_| format!("'{text}' is not a number"))?;
    if value.is_finite() {
        Ok(value)
    } else {
        Err(format!("'{text}' is not a finite number"))
    }
}

/// A finite number above zero.
pub fn positive(text: &str) -> Result<f64, String> {
    let value = number(text)?;
    if value > 0.0 {
        Ok(value)
    } else {
        Err(format!("{value} must be above 0"))
    }
}

/// `--time-scale`: "auto", or a factor of 1 or more (a program is never faster than the
/// demonstration).
pub fn time_scale(text: &str) -> Result<teachcam::robot::check::TimeScale, String> {
    if text.eq_ignore_ascii_case("auto") {
        return Ok(teachcam::robot::check::TimeScale::Auto);
    }
    let value = number(text)
        .map_err(|e| format!("{e} (or auto: the smallest factor within the joint limits)"))?;
    if value >= 1.0 {
        Ok(teachcam::robot::check::TimeScale::Fixed(value))
    } else {
        Err(format!(
            "{value} must be 1 or more (1 keeps the demonstration's timing), or auto"
        ))
    }
}

/// A finite number, zero or above.
pub fn non_negative(text: &str) -> Result<f64, String> {
    let value = number(text)?;
    if value >= 0.0 {
        Ok(value)
    } else {
        Err(format!("{value} must be 0 or above"))
    }
}

/// A number in (0, 1].
pub fn fraction(text: &str) -> Result<f64, String> {
    let value = number(text)?;
    if value > 0.0 && value <= 1.0 {
        Ok(value)
    } else {
        Err(format!("{value} must be in (0, 1]"))
    }
}

/// A number in [0, 1].
pub fn unit_interval(text: &str) -> Result<f64, String> {
    let value = number(text)?;
    if (0.0..=1.0).contains(&value) {
        Ok(value)
    } else {
        Err(format!("{value} must be in [0, 1]"))
    }
}

/// A low-pass cut-off: `auto` or a frequency above zero, Hz (kept as the text; its upper
/// bound, the record's Nyquist frequency, is checked against the data).
pub fn cutoff(text: &str) -> Result<String, String> {
    if text == "auto" {
        return Ok(text.to_string());
    }
    positive(text)
        .map(|_| text.to_string())
        .map_err(|e| format!("{e} (or `auto`)"))
}

/// Most Monte Carlo trials one run may ask for: each trial runs the whole tracking chain; 10,000
/// (the default) took 0.84 s on the paper's rig here (0.27 s of CPU), so the limit is a minute
/// or two, and the σ it gives is already known to 0.07 % (1/√(2n)); a typo of a few more zeros
/// would run for hours.
pub const MAX_TRIALS: usize = 1_000_000;

/// A number of Monte Carlo trials: 1 to [`MAX_TRIALS`].
pub fn trials(text: &str) -> Result<usize, String> {
    let n = count(text)?;
    if n <= MAX_TRIALS {
        Ok(n)
    } else {
        Err(format!(
            "{n} is more than {MAX_TRIALS} (enough for σ within 0.07 %; more would run for hours)"
        ))
    }
}

/// A frame rate in Hz: finite, above zero and within the sampling rates every file holds
/// (`teachcam::trajectory::check_sample_rate_hz`, the check `recording.json` and trajectories
/// get too).
pub fn fps(text: &str) -> Result<f64, String> {
    let value = positive(text)?;
    teachcam::trajectory::check_sample_rate_hz("the frame rate", value).map_err(|e| e.to_string())
}

/// A whole number of at least 1.
pub fn count(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(0) => Err("must be at least 1".into()),
        Ok(n) => Ok(n),
        Err(_) => Err(format!("'{text}' is not a whole number")),
    }
}

/// A point `x,y,z` of three finite numbers (millimetres).
pub fn point(text: &str) -> Result<[f64; 3], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| number(v.trim()))
        .collect::<Result<_, _>>()?;
    <[f64; 3]>::try_from(values)
        .map_err(|v| format!("'{text}' has {} numbers, expected x,y,z", v.len()))
}

/// Six joint angles `j1,...,j6`, degrees.
pub fn joints(text: &str) -> Result<[f64; 6], String> {
    let values: Vec<f64> = text
        .split(',')
        .map(|v| number(v.trim()))
        .collect::<Result<_, _>>()?;
    <[f64; 6]>::try_from(values).map_err(|v| {
        format!(
            "'{text}' has {} numbers, expected six joint angles j1,...,j6 in degrees",
            v.len()
        )
    })
}

/// A pose `x,y,z,qw,qx,qy,qz` (millimetres, unit quaternion), checked and kept as the text.
pub fn pose(text: &str) -> Result<String, String> {
    teachcam::geometry::parse_pose(text)
        .map(|_| text.to_string())
        .map_err(|e| e.to_string())
}

/// `START..END` or `START..` (to the end), 0-based frames.
pub fn parse_frames(text: &str) -> Result<Range<usize>, String> {
    let (a, b) = text
        .split_once("..")
        .ok_or_else(|| format!("{text:?} is not START..END"))?;
    let start = a
        .trim()
        .parse()
        .map_err(|_| format!("{a:?} is not a frame number"))?;
    let end = if b.trim().is_empty() {
        usize::MAX
    } else {
        b.trim()
            .parse()
            .map_err(|_| format!("{b:?} is not a frame number"))?
    };
    if end <= start {
        return Err(format!("{text:?} is empty"));
    }
    Ok(start..end)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parsers_refuse_what_the_flags_cannot_mean() {
        assert!(positive("0").is_err());
        assert!(positive("nan").is_err());
        assert!(positive("inf").is_err());
        assert!(positive("1e-3").is_ok());
        assert!(non_negative("-1").is_err());
        assert!(non_negative("0").is_ok());
        assert!(fraction("1.5").is_err());
        assert!(fraction("1").is_ok());
        assert!(count("0").is_err());
        assert!(count("-3").is_err());
        assert_eq!(count("12"), Ok(12));
        assert!(trials("2000000").is_err());
        assert!(cutoff("auto").is_ok());
        assert!(cutoff("0").is_err());
        assert!(unit_interval("1.01").is_err());
        assert!(pose("0,0,190").is_err());
        assert!(pose("0,0,190,1,0,0,0").is_ok());
        assert!(pose("0,0,190,2,0,0,0").is_err(), "not a unit quaternion");
    }
}
