//! `teachcam spectrum`: the amplitude spectrum of each trajectory component (paper Fig. 7).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use teachcam::io::trajectory::read_trajectory;
use teachcam::io::{Output, check_outputs};
use teachcam::smooth::{COMPONENTS, ComponentSpectra, SmoothConfig, trajectory_spectrum};

use crate::Rejected;
use crate::plot::{Panel, Series, YScale, write_png};

/// Amplitude spectrum of each trajectory component, as CSV or PNG.
///
/// Amplitude spectrum of x, y, z (mm) and of the unrolled rotation rx, ry, rz (rad) over the
/// longest gap-free segment, to choose a low-pass cut-off: the motion sits at low
/// frequencies, the measurement noise spreads flat up to Nyquist.
///
/// The output is CSV (`frequency_hz,x_mm,y_mm,z_mm,rx_rad,ry_rad,rz_rad`) or, when the name
/// ends in `.png`, a plot.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam spectrum raw.csv -o spectrum.png
  teachcam spectrum raw.csv -o spectrum.csv"#)]
pub struct Args {
    /// Trajectory CSV.
    pub input: PathBuf,
    /// Output file: `.csv` or `.png`.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let output = Output {
        path: &args.output,
        format: "a spectrum (CSV or PNG)",
        extensions: &["csv", "png"],
    };
    check_outputs(&[output], &[&args.input])?;
    let trajectory = read_trajectory(&args.input).rejected()?;
    let spectra = trajectory_spectrum(&trajectory, SmoothConfig::default().time_step_tolerance)
        .with_context(|| format!("{}", args.input.display()))
        .rejected()?;
    let is_png = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        write_png(&args.output, &spectrum_panels(&spectra))?;
    } else {
        let mut text = String::from("frequency_hz");
        for c in COMPONENTS {
            text.push(',');
            text.push_str(c);
        }
        text.push('\n');
        for (k, f) in spectra.frequency_hz.iter().enumerate() {
            let _ = write!(text, "{f:.6}");
            for a in &spectra.amplitude {
                let _ = write!(text, ",{:.9e}", a[k]);
            }
            text.push('\n');
        }
        teachcam::io::write_atomically(&args.output, text.as_bytes())?;
    }
    crate::announce::wrote(
        std::slice::from_ref(&args.output),
        &format!("{} frequencies", spectra.frequency_hz.len()),
    );
    Ok(())
}

/// The two panels of a spectrum figure (positions, rotations), without the DC bin.
pub fn spectrum_panels(spectra: &ComponentSpectra) -> Vec<Panel<'_>> {
    let label = |c: usize| COMPONENTS[c].to_string();
    // The DC bin (the mean position) dwarfs the rest: plot from the first bin on.
    let f = &spectra.frequency_hz[1.min(spectra.frequency_hz.len())..];
    let amplitude = |c: usize| &spectra.amplitude[c][1.min(spectra.amplitude[c].len())..];
    let frames = format!("frames {}..={}", spectra.first_frame, spectra.last_frame);
    let panels = vec![
        Panel {
            title: format!("position amplitude spectrum, {frames}"),
            x_label: "frequency (Hz)".into(),
            y_label: "amplitude (mm)".into(),
            y_scale: YScale::Log,
            series: (0..3)
                .map(|c| Series {
                    label: label(c),
                    x: f,
                    y: amplitude(c),
                })
                .collect(),
        },
        Panel {
            title: format!("rotation amplitude spectrum, {frames}"),
            x_label: "frequency (Hz)".into(),
            y_label: "amplitude (rad)".into(),
            y_scale: YScale::Log,
            series: (3..6)
                .map(|c| Series {
                    label: label(c),
                    x: f,
                    y: amplitude(c),
                })
                .collect(),
        },
    ];
    panels
}
