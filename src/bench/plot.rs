//! PNG plots of run time against error (plotters, bitmap backend, text in the embedded DejaVu Sans).

use plotters::prelude::*;
// The embedded DejaVu Sans, shared with the contact sheets' labels.
use crate::render::sweep::register_font;
use std::path::Path;

/// One series of points; `spread` optionally gives an x-interval (e.g. interquartile range of a timing)
/// drawn as a horizontal bar through each point.
#[derive(Clone, Debug, Default)]
pub struct Series {
    pub label: String,
    pub points: Vec<(f64, f64)>,
    pub spread: Option<Vec<(f64, f64)>>,
    /// Join the points with a line (in the given order).
    pub line: bool,
}

/// Axis scaling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scale {
    Linear,
    Log,
}

/// A scatter/line plot description.
#[derive(Clone, Debug)]
pub struct XyPlot {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_scale: Scale,
    pub y_scale: Scale,
    pub series: Vec<Series>,
    /// Mark the Pareto front (minimise both x and y) over all series' points.
    pub pareto: bool,
}

/// Errors while drawing a plot.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("nothing to plot: no finite points")]
    Empty,
    #[error("cannot draw {path}: {reason}")]
    Draw { path: String, reason: String },
}

const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
];

fn range(values: impl Iterator<Item = f64>, scale: Scale) -> Option<(f64, f64)> {
    let vals: Vec<f64> = values.filter(|v| v.is_finite() && (scale == Scale::Linear || *v > 0.0)).collect();
    let lo = vals.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = vals.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if !lo.is_finite() || !hi.is_finite() {
        return None;
    }
    Some(match scale {
        Scale::Log => {
            let (l, h) = (lo.log10(), hi.log10());
            let pad = ((h - l) * 0.08).max(0.1);
            (10f64.powf(l - pad), 10f64.powf(h + pad))
        }
        Scale::Linear => {
            let pad = ((hi - lo) * 0.08).max(hi.abs().max(1e-12) * 0.05);
            (if lo >= 0.0 { (lo - pad).max(0.0) } else { lo - pad }, hi + pad)
        }
    })
}

/// Draw `plot` to a PNG of `width`×`height` pixels at `path`.
pub fn draw(plot: &XyPlot, path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    register_font();
    let err = |e: &dyn std::fmt::Display| PlotError::Draw { path: path.display().to_string(), reason: e.to_string() };
    let all = || plot.series.iter().flat_map(|s| s.points.iter().copied());
    let spreads = || plot.series.iter().flat_map(|s| s.spread.iter().flatten().flat_map(|(a, b)| [*a, *b]));
    let xr = range(all().map(|p| p.0).chain(spreads()), plot.x_scale).ok_or(PlotError::Empty)?;
    let yr = range(all().map(|p| p.1), plot.y_scale).ok_or(PlotError::Empty)?;

    let root = BitMapBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE).map_err(|e| err(&e))?;
    let mut builder = ChartBuilder::on(&root);
    builder.caption(&plot.title, ("sans-serif", 22)).margin(12).x_label_area_size(42).y_label_area_size(64);

    macro_rules! body {
        ($chart:expr) => {{
            let mut chart = $chart;
            chart
                .configure_mesh()
                .x_desc(plot.x_label.as_str())
                .y_desc(plot.y_label.as_str())
                .label_style(("sans-serif", 14))
                .draw()
                .map_err(|e| err(&e))?;
            for (i, s) in plot.series.iter().enumerate() {
                let colour = COLOURS[i % COLOURS.len()];
                let pts: Vec<(f64, f64)> =
                    s.points.iter().copied().filter(|p| p.0.is_finite() && p.1.is_finite()).collect();
                if s.line && pts.len() > 1 {
                    chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(|e| err(&e))?;
                }
                if let Some(spread) = &s.spread {
                    for ((_, y), (a, b)) in s.points.iter().zip(spread) {
                        chart
                            .draw_series(LineSeries::new(vec![(*a, *y), (*b, *y)], colour.stroke_width(1)))
                            .map_err(|e| err(&e))?;
                    }
                }
                chart
                    .draw_series(pts.iter().map(|p| Circle::new(*p, 4, colour.filled())))
                    .map_err(|e| err(&e))?
                    .label(s.label.as_str())
                    .legend(move |(x, y)| Circle::new((x + 8, y), 4, colour.filled()));
            }
            if plot.pareto {
                let pts: Vec<(f64, f64)> = all().collect();
                let front: Vec<(f64, f64)> = super::pareto_front(&pts).into_iter().map(|i| pts[i]).collect();
                if front.len() > 1 {
                    chart
                        .draw_series(LineSeries::new(front, BLACK.stroke_width(1)))
                        .map_err(|e| err(&e))?
                        .label("Pareto front")
                        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 16, y)], BLACK));
                }
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 14))
                .draw()
                .map_err(|e| err(&e))?;
        }};
    }
    match (plot.x_scale, plot.y_scale) {
        (Scale::Linear, Scale::Linear) => {
            body!(builder.build_cartesian_2d(xr.0..xr.1, yr.0..yr.1).map_err(|e| err(&e))?)
        }
        (Scale::Log, Scale::Linear) => {
            body!(builder.build_cartesian_2d((xr.0..xr.1).log_scale(), yr.0..yr.1).map_err(|e| err(&e))?)
        }
        (Scale::Linear, Scale::Log) => {
            body!(builder.build_cartesian_2d(xr.0..xr.1, (yr.0..yr.1).log_scale()).map_err(|e| err(&e))?)
        }
        (Scale::Log, Scale::Log) => {
            body!(builder.build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale()).map_err(|e| err(&e))?)
        }
    }
    root.present().map_err(|e| err(&e))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn draws_a_png_with_text_and_points() {
        let dir = tempfile::tempdir().unwrap();
        let path = std::env::var("METAMER_PLOT_DEMO")
            .map(std::path::PathBuf::from)
            .unwrap_or_else(|_| dir.path().join("p.png"));
        let plot = XyPlot {
            title: "run time against error".into(),
            x_label: "seconds".into(),
            y_label: "mean ΔE00".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Linear,
            series: vec![Series {
                label: "a".into(),
                points: vec![(1e-3, 2.0), (1e-2, 1.0), (1e-1, 1.5)],
                spread: Some(vec![(0.8e-3, 1.2e-3), (0.9e-2, 1.1e-2), (0.9e-1, 1.1e-1)]),
                line: true,
            }],
            pareto: true,
        };
        draw(&plot, &path, 640, 400).unwrap();
        let img = image::open(&path).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (640, 400));
        // Something other than white was drawn (axes, text, points).
        let dark = img.pixels().filter(|p| p.0.iter().all(|c| *c < 100)).count();
        assert!(dark > 500, "only {dark} dark pixels");
        let empty = XyPlot { series: vec![], ..plot };
        assert!(matches!(draw(&empty, &path, 640, 400), Err(PlotError::Empty)));
    }
}
