//! SVG plots (no system fonts needed).

use std::path::Path;

use plotters::prelude::*;

/// Colours for [`Series`].
pub use plotters::style::RGBColor;
/// Reference, observed, sensor colours.
pub const COLORS: [RGBColor; 3] = [RGBColor(0, 0, 0), RGBColor(31, 119, 180), RGBColor(214, 39, 40)];

/// One named series of (x, y) points.
pub struct Series<'a> {
    /// Legend.
    pub name: &'a str,
    /// Points.
    pub points: Vec<(f64, f64)>,
    /// Colour.
    pub color: RGBColor,
}

/// Why a plot was not drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// No series has two finite points with different x.
    #[error("nothing to plot in {}", path.display())]
    Empty {
        /// The SVG file.
        path: std::path::PathBuf,
    },
    /// The SVG could not be drawn or written.
    #[error("cannot draw {}", path.display())]
    Draw {
        /// The SVG file.
        path: std::path::PathBuf,
        /// plotters' reason.
        source: DrawingAreaErrorKind<std::io::Error>,
    },
}

/// Draws series into an SVG file.
///
/// ```
/// use jointctl_experiments::plot::{COLORS, PlotError, Series, lines};
/// let path = std::env::temp_dir().join(format!("doc-plot-{}.svg", std::process::id()));
/// let s = Series { name: "observed", points: vec![(0.0, 0.0), (1.0, 2.0)], color: COLORS[1] };
/// lines(&path, "q4, 113.78 Nm/rad, step", "t [s]", "torque [Nm]", &[s]).unwrap();
/// let empty = Series { name: "none", points: vec![], color: COLORS[0] };
/// assert!(matches!(lines(&path, "t", "x", "y", &[empty]), Err(PlotError::Empty { .. })));
/// # std::fs::remove_file(&path).unwrap();
/// ```
pub fn lines(path: &Path, title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Result<(), PlotError> {
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for s in series {
        for &(x, y) in &s.points {
            if x.is_finite() && y.is_finite() {
                (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
            }
        }
    }
    if !(x0 < x1) {
        return Err(PlotError::Empty { path: path.to_path_buf() });
    }
    let pad = ((y1 - y0) * 0.1).max(1e-6);
    // Headroom for the legend (upper left, about 7 % of the height per entry), so that it never
    // covers data.
    let legend = (0.07 * series.len() as f64 + 0.05).min(0.6);
    let top = y1 + pad + (y1 - y0 + 2.0 * pad) * legend / (1.0 - legend);
    let root = SVGBackend::new(path, (900, 420)).into_drawing_area();
    let e = |source: DrawingAreaErrorKind<std::io::Error>| PlotError::Draw { path: path.to_path_buf(), source };
    root.fill(&WHITE).map_err(e)?;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 18))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(56)
        .build_cartesian_2d(x0..x1, (y0 - pad)..top)
        .map_err(e)?;
    chart.configure_mesh().x_desc(x_label).y_desc(y_label).draw().map_err(e)?;
    for s in series {
        let color = s.color;
        chart
            .draw_series(LineSeries::new(s.points.iter().copied().filter(|(x, y)| x.is_finite() && y.is_finite()), color.stroke_width(2)))
            .map_err(e)?
            .label(s.name)
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2)));
    }
    chart.configure_series_labels().background_style(WHITE.mix(0.8)).border_style(BLACK).draw().map_err(e)?;
    root.present().map_err(e)?;
    Ok(())
}
