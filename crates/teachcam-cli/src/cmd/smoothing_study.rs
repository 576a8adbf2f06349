//! `teachcam smoothing-study`: the paper's comparison of smoothing methods (Figs. 4–8).

use std::fmt::Write as _;
use std::path::PathBuf;

use anyhow::{Context, Result};
use rand::SeedableRng;
use teachcam::smooth::study::{StudyConfig, StudyResult, run_study};

use crate::plot::{Panel, Series, YScale, write_png};

/// Rerun the paper's comparison of smoothing methods (Figs. 4-8).
///
/// The paper's trajectory model: a sum of sinusoids plus white Gaussian noise, and the noise alone. Prints, per method, the RMS error
/// against the clean signal, the fraction of each sinusoid's amplitude kept and of the noise
/// kept; writes `study.csv` (every signal) and `study.png` (one panel per method, as the
/// paper's figures) into the output folder.
#[derive(Debug, clap::Args)]
#[command(after_help = r#"Examples:
  teachcam smoothing-study --out study --seed 1"#)]
pub struct Args {
    /// Output folder (created if missing).
    #[arg(long, default_value = "smoothing-study")]
    pub out: PathBuf,
    /// Seed of the noise.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Standard deviation of the white noise, mm.
    #[arg(long, default_value_t = 1.0, value_parser = crate::flags::positive)]
    pub noise_mm: f64,
}

/// Runs the study and writes `study.csv` and `study.png` into `args.out`; prints nothing.
pub fn write_study(args: &Args) -> Result<(StudyConfig, StudyResult)> {
    let config = StudyConfig {
        noise_std_mm: args.noise_mm,
        ..StudyConfig::default()
    };
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(args.seed);
    let result = run_study(&config, &mut rng)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;

    let mut csv = String::from("time_s,clean_mm,noisy_mm,noise_mm");
    for m in &result.methods {
        let _ = write!(csv, ",{0}_mm,{0}_on_noise_mm", m.name);
    }
    csv.push('\n');
    for i in 0..result.time_s.len() {
        let _ = write!(
            csv,
            "{:.6},{:.9},{:.9},{:.9}",
            result.time_s[i], result.clean[i], result.noisy[i], result.noise[i]
        );
        for m in &result.methods {
            let _ = write!(csv, ",{:.9},{:.9}", m.smoothed[i], m.smoothed_noise[i]);
        }
        csv.push('\n');
    }
    teachcam::io::write_atomically(&args.out.join("study.csv"), csv.as_bytes())?;

    let mut panels = Vec::new();
    for m in &result.methods {
        panels.push(Panel {
            title: format!(
                "{}: sinusoids + noise (RMS error {:.3} mm)",
                m.name, m.rms_error_mm
            ),
            x_label: "time (s)".into(),
            y_label: "mm".into(),
            y_scale: YScale::Linear,
            series: vec![
                Series {
                    label: "noisy".into(),
                    x: &result.time_s,
                    y: &result.noisy,
                },
                Series {
                    label: "clean".into(),
                    x: &result.time_s,
                    y: &result.clean,
                },
                Series {
                    label: m.name.clone(),
                    x: &result.time_s,
                    y: &m.smoothed,
                },
            ],
        });
        panels.push(Panel {
            title: format!("{}: white noise alone (kept {:.3})", m.name, m.noise_kept),
            x_label: "time (s)".into(),
            y_label: "mm".into(),
            y_scale: YScale::Linear,
            series: vec![
                Series {
                    label: "noise".into(),
                    x: &result.time_s,
                    y: &result.noise,
                },
                Series {
                    label: m.name.clone(),
                    x: &result.time_s,
                    y: &m.smoothed_noise,
                },
            ],
        });
    }
    write_png(&args.out.join("study.png"), &panels)?;
    Ok((config, result))
}

/// Run the command.
pub fn run(args: &Args) -> Result<()> {
    let (config, result) = write_study(args)?;
    println!(
        "signal: {} at {} Hz, noise {} mm; raw RMS error {:.3} mm",
        config
            .sinusoids
            .iter()
            .map(|s| format!("{} mm @ {} Hz", s.amplitude_mm, s.frequency_hz))
            .collect::<Vec<_>>()
            .join(" + "),
        config.sample_rate_hz,
        config.noise_std_mm,
        result.raw_rms_error_mm
    );
    println!("method    rms_error_mm  amplitude_kept (per sinusoid)  noise_kept");
    for m in &result.methods {
        let kept: Vec<String> = m.amplitude_kept.iter().map(|a| format!("{a:.3}")).collect();
        println!(
            "{:<9} {:>12.3}  {:<29}  {:.3}",
            m.name,
            m.rms_error_mm,
            kept.join(" "),
            m.noise_kept
        );
    }

    println!(
        "wrote {} and {}",
        args.out.join("study.csv").display(),
        args.out.join("study.png").display()
    );
    Ok(())
}
