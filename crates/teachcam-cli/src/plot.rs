//! Line plots as PNG files, for every command that draws (`spectrum`, `smoothing-study`,
//! reports): panels stacked vertically, each with its own series, axes and legend (beside the
//! axes, so that it never hides a line).
//!
//! Drawn with `plotters` into a memory buffer (bitmap backend, no system fonts: DejaVu Sans is
//! bundled, see `assets/DejaVuSans-LICENSE.txt`) and encoded with `image`, then written whole
//! through [`teachcam::io::write_atomically`].

use std::path::Path;
use std::sync::OnceLock;

use anyhow::{Context, Result, anyhow};
use plotters::prelude::*;
use plotters::style::{FontStyle, register_font};

/// One line of a panel.
#[derive(Debug, Clone)]
pub struct Series<'a> {
    /// Legend text.
    pub label: String,
    /// Abscissae.
    pub x: &'a [f64],
    /// Ordinates, one per abscissa.
    pub y: &'a [f64],
}

/// Scale of a panel's vertical axis.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum YScale {
    /// Linear.
    #[default]
    Linear,
    /// Base-10 logarithmic (non-positive values are left out).
    Log,
}

/// One panel: a title, axis labels and its lines.
#[derive(Debug, Clone)]
pub struct Panel<'a> {
    /// Title above the panel.
    pub title: String,
    /// Label of the horizontal axis, with its unit.
    pub x_label: String,
    /// Label of the vertical axis, with its unit.
    pub y_label: String,
    /// Vertical scale.
    pub y_scale: YScale,
    /// The lines, drawn in order.
    pub series: Vec<Series<'a>>,
}

const PANEL_HEIGHT_PX: u32 = 300;
const WIDTH_PX: u32 = 1000;
/// The strip right of each panel's axes that holds its legend.
const LEGEND_WIDTH_PX: u32 = 230;

fn font() -> Result<()> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        register_font(
            "sans-serif",
            FontStyle::Normal,
            include_bytes!("../assets/DejaVuSans.ttf"),
        )
        .is_ok()
    });
    if ok {
        Ok(())
    } else {
        Err(anyhow!("the bundled font could not be loaded"))
    }
}

/// Draws `panels` stacked vertically into a PNG file at `path`, written whole or not at all.
pub fn write_png(path: &Path, panels: &[Panel]) -> Result<()> {
    let png = png_bytes(panels).with_context(|| format!("drawing {}", path.display()))?;
    teachcam::io::write_atomically(path, &png)?;
    Ok(())
}

/// Draws `panels` stacked vertically and returns the PNG file's bytes.
pub fn png_bytes(panels: &[Panel]) -> Result<Vec<u8>> {
    font()?;
    let height = PANEL_HEIGHT_PX * panels.len().max(1) as u32;
    let mut buffer = vec![255u8; (WIDTH_PX * height * 3) as usize];
    draw(&mut buffer, height, panels).map_err(|e| anyhow!("{e}"))?;
    let image = image::RgbImage::from_raw(WIDTH_PX, height, buffer)
        .ok_or_else(|| anyhow!("plot buffer has the wrong size"))?;
    let mut png = std::io::Cursor::new(Vec::new());
    image.write_to(&mut png, image::ImageFormat::Png)?;
    Ok(png.into_inner())
}

/// A tick label: plain decimals for ordinary magnitudes, `1e-5` style otherwise.
fn tick(v: f64) -> String {
    let magnitude = v.abs();
    if v == 0.0 || (1e-2..1e5).contains(&magnitude) {
        let text = format!("{v:.3}");
        text.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        format!("{v:.0e}")
    }
}

fn draw(
    buffer: &mut [u8],
    height: u32,
    panels: &[Panel],
) -> Result<(), Box<dyn std::error::Error>> {
    let root = BitMapBackend::with_buffer(buffer, (WIDTH_PX, height)).into_drawing_area();
    root.fill(&WHITE)?;
    let areas = root.split_evenly((panels.len().max(1), 1));
    for (panel, area) in panels.iter().zip(areas) {
        let (area, legend) = area.split_horizontally(WIDTH_PX - LEGEND_WIDTH_PX);
        let points = |s: &Series| -> Vec<(f64, f64)> {
            s.x.iter()
                .zip(s.y)
                .filter(|(x, y)| {
                    x.is_finite() && y.is_finite() && (panel.y_scale == YScale::Linear || **y > 0.0)
                })
                .map(|(x, y)| (*x, *y))
                .collect()
        };
        let all: Vec<(f64, f64)> = panel.series.iter().flat_map(points).collect();
        let (mut x0, mut x1, mut y0, mut y1) = all.iter().fold(
            (
                f64::INFINITY,
                f64::NEG_INFINITY,
                f64::INFINITY,
                f64::NEG_INFINITY,
            ),
            |(a, b, c, d), (x, y)| (a.min(*x), b.max(*x), c.min(*y), d.max(*y)),
        );
        if !(x0.is_finite() && y0.is_finite()) {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.1, 1.0);
        }
        if x1 <= x0 {
            x1 = x0 + 1.0;
        }
        if y1 <= y0 {
            y1 = y0 + y0.abs().max(1.0) * 0.1;
        }
        let mut builder = ChartBuilder::on(&area);
        builder
            .caption(&panel.title, ("sans-serif", 18))
            .margin(8)
            .x_label_area_size(36)
            .y_label_area_size(70);
        let colors = [BLUE, RED, GREEN, MAGENTA, CYAN, BLACK];
        macro_rules! lines {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(panel.x_label.as_str())
                    .y_desc(panel.y_label.as_str())
                    .label_style(("sans-serif", 13))
                    .y_label_formatter(&|v: &f64| tick(*v))
                    .draw()?;
                for (k, s) in panel.series.iter().enumerate() {
                    let color = colors[k % colors.len()];
                    chart.draw_series(LineSeries::new(points(s), color.stroke_width(1)))?;
                    let y = 40 + 20 * k as i32;
                    legend.draw(&PathElement::new(
                        vec![(4, y), (26, y)],
                        color.stroke_width(2),
                    ))?;
                    legend.draw(&Text::new(
                        s.label.as_str(),
                        (32, y - 7),
                        ("sans-serif", 13),
                    ))?;
                }
            }};
        }
        match panel.y_scale {
            YScale::Linear => {
                let pad = 0.05 * (y1 - y0);
                lines!(builder.build_cartesian_2d(x0..x1, (y0 - pad)..(y1 + pad))?);
            }
            YScale::Log => {
                lines!(builder.build_cartesian_2d(x0..x1, (y0..y1 * 1.5).log_scale())?);
            }
        }
    }
    root.present()?;
    Ok(())
}
