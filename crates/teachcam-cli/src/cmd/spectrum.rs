//! `teachcam spectrum`: the amplitude spectrum of each trajectory component (paper Fig. 7).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use teachcam::io::trajectory::read_trajectory;
use teachcam::io::{Output, check_outputs};
use teachcam::report::spectrum::{SpectrumMethod, Window};
use teachcam::smooth::{COMPONENTS, ComponentSpectra, SmoothConfig, trajectory_spectrum};

use crate::Rejected;
use crate::plot::{Panel, Series, YScale, write_png};

/// Amplitude spectrum of each trajectory component, as CSV or PNG.
///
/// The single-sided amplitude spectrum of x, y, z (mm) and of the unrolled rotation rx, ry, rz
/// (rad) over the longest gap-free segment, to choose a low-pass cut-off. By default each
/// component is detrended (its least-squares line removed) and Hann-windowed, as the report's
/// spectrum is: a sinusoid of amplitude A reads A at its frequency, the motion sits at low
/// frequencies and falls off fast, and above it the floor is the measurement noise (white
/// noise of standard deviation σ over n samples reads about σ·√(π/n) per bin, flat). Without
/// the window (`--window none --no-detrend`: the plain FFT) a stroke that does not hold a whole
/// number of periods leaks into every bin as 1/f, and that leak can hide the noise floor.
///
/// The output is CSV (`frequency_hz,x_mm,y_mm,z_mm,rx_rad,ry_rad,rz_rad`) or, when the name
/// ends in `.png`, a plot (log amplitude over frequency, the DC bin left out).
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam spectrum raw.csv -o spectrum.png
  teachcam spectrum raw.csv -o spectrum.csv
  teachcam spectrum raw.csv -o plain.png --window none --no-detrend"#)]
pub struct Args {
    /// Trajectory CSV.
    pub input: PathBuf,
    /// Output file: `.csv` or `.png`.
    #[arg(short = 'o', long)]
    pub output: PathBuf,
    /// The window applied before the transform: `hann` (the report's) or `none`.
    #[arg(long, value_enum, default_value_t = WindowArg::Hann)]
    pub window: WindowArg,
    /// Keep the least-squares line of each component (by default it is removed first).
    #[arg(long)]
    pub no_detrend: bool,
}

/// `--window`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum WindowArg {
    /// The periodic Hann window.
    Hann,
    /// No window (rectangular).
    None,
}

impl Args {
    /// The spectrum method the flags choose.
    fn method(&self) -> SpectrumMethod {
        SpectrumMethod {
            window: match self.window {
                WindowArg::Hann => Window::Hann,
                WindowArg::None => Window::None,
            },
            detrend: !self.no_detrend,
        }
    }
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
    let method = args.method();
    let spectra = trajectory_spectrum(
        &trajectory,
        SmoothConfig::default().time_step_tolerance,
        method,
    )
    .with_context(|| format!("{}", args.input.display()))
    .rejected()?;
    let is_png = args
        .output
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"));
    if is_png {
        write_png(&args.output, &spectrum_panels(&spectra, method))?;
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
        &format!("{} frequencies, {method}", spectra.frequency_hz.len()),
    );
    Ok(())
}

/// The two panels of a spectrum figure (positions, rotations), without the DC bin.
pub fn spectrum_panels(spectra: &ComponentSpectra, method: SpectrumMethod) -> Vec<Panel<'_>> {
    let label = |c: usize| COMPONENTS[c].to_string();
    // The DC bin (the mean position) dwarfs the rest: plot from the first bin on.
    let f = &spectra.frequency_hz[1.min(spectra.frequency_hz.len())..];
    let amplitude = |c: usize| &spectra.amplitude[c][1.min(spectra.amplitude[c].len())..];
    let frames = format!(
        "frames {}..={}, {method}",
        spectra.first_frame, spectra.last_frame
    );
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
