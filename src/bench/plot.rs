//! PNG plots of run time against error (plotters, bitmap backend, text in the embedded DejaVu Sans).

use plotters::prelude::*;
// The embedded DejaVu Sans, shared with the contact sheets' labels.
use std::path::Path;

static REGISTER: std::sync::Once = std::sync::Once::new();

/// Register the font the project ships (embedded in the domain crate, `render::text::FONT`) as
/// plotters' "sans-serif", once, so plots render the same on every machine.
fn register_font() {
    REGISTER.call_once(|| {
        // A known-good TTF compiled into the binary; if registration failed, text would be missing,
        // which the plot tests catch.
        let _ =
            plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, crate::render::text::FONT);
    });
}

/// One series of points; `spread` optionally gives an x-interval (e.g. interquartile range of a timing)
/// drawn as a horizontal bar through each point.
#[derive(Clone, Debug, Default)]
pub(crate) struct Series {
    pub(crate) label: String,
    pub(crate) points: Vec<(f64, f64)>,
    pub(crate) spread: Option<Vec<(f64, f64)>>,
    /// Join the points with a line (in the given order).
    pub(crate) line: bool,
    /// The workload the points were measured on: Pareto fronts join only points of the same workload
    /// (None: a workload of its own).
    pub(crate) workload: Option<String>,
    /// Per point, its workload when the points of one series were measured on different work
    /// (overrides `workload`; empty = not given).
    pub(crate) point_workloads: Vec<String>,
}

impl Series {
    /// The workload of point `j`.
    fn workload_of(&self, j: usize) -> &str {
        self.point_workloads.get(j).or(self.workload.as_ref()).map_or(self.label.as_str(), String::as_str)
    }
}

/// Axis scaling.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Scale {
    Linear,
    Log,
}

/// A scatter/line plot description.
#[derive(Clone, Debug)]
pub(crate) struct XyPlot {
    pub(crate) title: String,
    pub(crate) x_label: String,
    pub(crate) y_label: String,
    pub(crate) x_scale: Scale,
    pub(crate) y_scale: Scale,
    pub(crate) series: Vec<Series>,
    /// Mark the Pareto front (minimise both x and y) of each workload's points.
    pub(crate) pareto: bool,
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

/// Marker shapes, cycled with the colours (8 colours × 5 shapes: 40 series before a pair repeats).
const MARKERS: usize = 5;

/// Colour and marker shape of series `i`.
pub(crate) fn style_of(i: usize) -> (RGBColor, usize) {
    (COLOURS[i % COLOURS.len()], i % MARKERS)
}

/// Draw marker `shape` of `colour` centred at pixel `c` on `area` (the legend's; the chart draws the
/// same shapes in data coordinates).
fn marker<DB: DrawingBackend>(
    area: &DrawingArea<DB, plotters::coord::Shift>,
    c: (i32, i32),
    colour: RGBColor,
    shape: usize,
) {
    let (x, y) = c;
    let r = 5;
    let style = colour.filled();
    let _ = match shape {
        0 => area.draw(&Circle::new(c, r, style)),
        1 => area.draw(&Rectangle::new([(x - r + 1, y - r + 1), (x + r - 1, y + r - 1)], style)),
        2 => area.draw(&Polygon::new(vec![(x, y - r - 1), (x - r, y + r - 1), (x + r, y + r - 1)], style)),
        3 => area.draw(&Polygon::new(vec![(x, y - r - 1), (x + r + 1, y), (x, y + r + 1), (x - r - 1, y)], style)),
        _ => {
            let _ = area.draw(&PathElement::new(vec![(x - r, y - r), (x + r, y + r)], colour.stroke_width(3)));
            area.draw(&PathElement::new(vec![(x - r, y + r), (x + r, y - r)], colour.stroke_width(3)))
        }
    };
}

/// A tick label with at most three significant digits and no float noise (`0.001`, `2.5`, `1e-5`,
/// `3.2e6`), short enough never to be clipped.
pub(crate) fn tick_label(v: f64) -> String {
    if v == 0.0 {
        return "0".into();
    }
    if !v.is_finite() {
        return String::new();
    }
    let a = v.abs();
    if (1e-3..1e5).contains(&a) {
        let digits = (2 - a.log10().floor() as i32).clamp(0, 6) as usize;
        let s = format!("{v:.digits$}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.').to_string() } else { s };
        if s == "-0" { "0".into() } else { s }
    } else {
        let s = format!("{v:.1e}");
        // 1.0e-5 → 1e-5
        s.replace(".0e", "e")
    }
}

/// The points of a series that can be drawn on the axes (finite, positive on a log axis).
fn drawable(points: &[(f64, f64)], xs: Scale, ys: Scale) -> Vec<(f64, f64)> {
    let ok = |v: f64, s: Scale| v.is_finite() && (s == Scale::Linear || v > 0.0);
    points.iter().copied().filter(|p| ok(p.0, xs) && ok(p.1, ys)).collect()
}

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

/// Width of the legend column right of the chart.
const LEGEND_W: u32 = 260;

/// Draw `plot` to a PNG of `width`×`height` pixels at `path`: the chart on the left, the legend in a
/// column of its own on the right (never over data), and a note under the legend counting the points
/// left out because they are not finite (or not positive on a log axis).
pub(crate) fn draw(plot: &XyPlot, path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    register_font();
    let err = |e: &dyn std::fmt::Display| PlotError::Draw { path: path.display().to_string(), reason: e.to_string() };
    let (xs, ys) = (plot.x_scale, plot.y_scale);
    let kept: Vec<Vec<(f64, f64)>> = plot.series.iter().map(|s| drawable(&s.points, xs, ys)).collect();
    let dropped: usize = plot.series.iter().zip(&kept).map(|(s, k)| s.points.len() - k.len()).sum();
    let all = || kept.iter().flatten().copied();
    let spreads = || {
        plot.series.iter().flat_map(|s| {
            s.spread
                .iter()
                .flatten()
                .zip(&s.points)
                .filter(|(_, p)| p.0.is_finite() && p.1.is_finite())
                .flat_map(|((a, b), _)| [*a, *b])
        })
    };
    let xr = range(all().map(|p| p.0).chain(spreads()), xs).ok_or(PlotError::Empty)?;
    let yr = range(all().map(|p| p.1), ys).ok_or(PlotError::Empty)?;

    // Drawn in memory, then written through the one atomic writer (never straight onto the path).
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let legend_w = LEGEND_W.min(width / 3);
        let (chart_area, legend_area) = root.split_horizontally(width - legend_w);
        let mut builder = ChartBuilder::on(&chart_area);
        builder.caption(&plot.title, ("sans-serif", 18)).margin(14).x_label_area_size(46).y_label_area_size(78);
        let fmt = |v: &f64| tick_label(*v);

        macro_rules! body {
            ($chart:expr) => {{
                let mut chart = $chart;
                chart
                    .configure_mesh()
                    .x_desc(plot.x_label.as_str())
                    .y_desc(plot.y_label.as_str())
                    .x_label_formatter(&fmt)
                    .y_label_formatter(&fmt)
                    .label_style(("sans-serif", 14))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (i, (s, pts)) in plot.series.iter().zip(&kept).enumerate() {
                    let (colour, shape) = style_of(i);
                    if s.line && pts.len() > 1 {
                        chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(|e| err(&e))?;
                    }
                    if let Some(spread) = &s.spread {
                        for ((x, y), (a, b)) in s.points.iter().zip(spread) {
                            if drawable(&[(*x, *y), (*a, *y), (*b, *y)], xs, ys).len() == 3 {
                                chart
                                    .draw_series(LineSeries::new(vec![(*a, *y), (*b, *y)], colour.stroke_width(1)))
                                    .map_err(|e| err(&e))?;
                            }
                        }
                    }
                    let st = colour.filled();
                    let at = |p: &(f64, f64)| EmptyElement::at(*p);
                    match shape {
                        0 => chart.draw_series(pts.iter().map(|p| at(p) + Circle::new((0, 0), 5, st))).map(|_| ()),
                        1 => chart
                            .draw_series(pts.iter().map(|p| at(p) + Rectangle::new([(-4, -4), (4, 4)], st)))
                            .map(|_| ()),
                        2 => chart
                            .draw_series(pts.iter().map(|p| at(p) + TriangleMarker::new((0, 0), 6, st)))
                            .map(|_| ()),
                        3 => chart
                            .draw_series(
                                pts.iter().map(|p| at(p) + Polygon::new(vec![(0, -6), (6, 0), (0, 6), (-6, 0)], st)),
                            )
                            .map(|_| ()),
                        _ => chart
                            .draw_series(pts.iter().map(|p| at(p) + Cross::new((0, 0), 5, colour.stroke_width(3))))
                            .map(|_| ()),
                    }
                    .map_err(|e| err(&e))?;
                }
                if plot.pareto {
                    // One front per workload: fronts never join points measured on different work.
                    let mut keyed: Vec<(&str, (f64, f64))> = Vec::new();
                    for s in &plot.series {
                        for (j, p) in s.points.iter().enumerate() {
                            if drawable(&[*p], xs, ys).len() == 1 {
                                keyed.push((s.workload_of(j), *p));
                            }
                        }
                    }
                    let mut workloads: Vec<&str> = keyed.iter().map(|(w, _)| *w).collect();
                    workloads.sort_unstable();
                    workloads.dedup();
                    for w in workloads {
                        let pts: Vec<(f64, f64)> = keyed.iter().filter(|(k, _)| *k == w).map(|(_, p)| *p).collect();
                        let front: Vec<(f64, f64)> = super::pareto_front(&pts).into_iter().map(|i| pts[i]).collect();
                        if front.len() > 1 {
                            chart.draw_series(LineSeries::new(front, BLACK.stroke_width(1))).map_err(|e| err(&e))?;
                        }
                    }
                }
            }};
        }
        match (xs, ys) {
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
                body!(
                    builder
                        .build_cartesian_2d((xr.0..xr.1).log_scale(), (yr.0..yr.1).log_scale())
                        .map_err(|e| err(&e))?
                )
            }
        }
        // The legend column.
        let font = ("sans-serif", 14).into_font();
        let mut y = 48;
        let max_chars = ((legend_w as f64 - 40.0) / 7.5).max(8.0) as usize;
        for (i, s) in plot.series.iter().enumerate() {
            let (colour, shape) = style_of(i);
            if s.line {
                legend_area
                    .draw(&PathElement::new(vec![(6, y), (30, y)], colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
            }
            marker(&legend_area, (18, y), colour, shape);
            // Long labels wrap onto further lines (up to three) rather than losing their distinguishing end.
            let words: Vec<&str> = s.label.split(' ').collect();
            let mut lines: Vec<String> = vec![String::new()];
            for w in words {
                let last = lines.last_mut().map_or(0, |l| l.chars().count());
                if last > 0 && last + 1 + w.chars().count() > max_chars && lines.len() < 3 {
                    lines.push(String::new());
                }
                if let Some(l) = lines.last_mut() {
                    if !l.is_empty() {
                        l.push(' ');
                    }
                    l.push_str(w);
                }
            }
            for (j, line) in lines.iter().enumerate() {
                legend_area
                    .draw(&Text::new(line.clone(), (38, y - 8 + 17 * j as i32), font.clone()))
                    .map_err(|e| err(&e))?;
            }
            y += 22 + 17 * (lines.len() as i32 - 1);
        }
        if plot.pareto {
            legend_area.draw(&PathElement::new(vec![(6, y), (30, y)], BLACK.stroke_width(1))).map_err(|e| err(&e))?;
            legend_area
                .draw(&Text::new("Pareto front per workload", (38, y - 8), font.clone()))
                .map_err(|e| err(&e))?;
            y += 22;
        }
        if dropped > 0 {
            let note = format!("{dropped} point{} not finite:", if dropped == 1 { " is" } else { "s are" });
            legend_area.draw(&Text::new(note, (6, y + 6), font.clone())).map_err(|e| err(&e))?;
            legend_area
                .draw(&Text::new("left out (n/a in the tables)", (6, y + 24), font.clone()))
                .map_err(|e| err(&e))?;
        }
        root.present().map_err(|e| err(&e))?;
    }
    let png = crate::render::sweep::encode_png(&rgb, width as usize, height as usize).map_err(|e| err(&e))?;
    crate::fsio::write_atomic(path, &png).map_err(|e| err(&e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tick_labels_are_short_and_exact() {
        assert_eq!(tick_label(0.001), "0.001");
        assert_eq!(tick_label(0.00999999), "0.01");
        assert_eq!(tick_label(2.5), "2.5");
        assert_eq!(tick_label(30.0), "30");
        assert_eq!(tick_label(1e-5), "1e-5");
        assert_eq!(tick_label(3.2e6), "3.2e6");
        assert_eq!(tick_label(0.0), "0");
        assert!((1..200).map(|i| tick_label(i as f64 * 1.1e-4)).all(|s| s.len() <= 7));
    }

    #[test]
    fn every_series_gets_its_own_colour_and_marker() {
        let styles: Vec<(RGBColor, usize)> = (0..40).map(style_of).collect();
        for i in 0..40 {
            for j in 0..i {
                assert!(styles[i] != styles[j], "series {i} and {j} look alike");
            }
        }
    }

    #[test]
    fn non_finite_points_are_left_out_with_a_note() {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("a.png"), dir.path().join("b.png"));
        let series = |pts: Vec<(f64, f64)>| Series { label: "s".into(), points: pts, ..Series::default() };
        let plot = |pts| XyPlot {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            series: vec![series(pts)],
            pareto: false,
        };
        draw(&plot(vec![(1.0, 1.0), (2.0, 3.0)]), &a, 640, 400).unwrap();
        draw(&plot(vec![(1.0, 1.0), (2.0, 3.0), (3.0, f64::NAN), (4.0, 0.0)]), &b, 640, 400).unwrap();
        // Same axes and points; the second image differs only by the note in the legend column.
        let (ia, ib) = (image::open(&a).unwrap().to_rgb8(), image::open(&b).unwrap().to_rgb8());
        let split = 640 - LEGEND_W.min(640 / 3);
        let diff = |x0: u32, x1: u32| {
            (0..400)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|(x, y)| ia.get_pixel(*x, *y) != ib.get_pixel(*x, *y))
                .count()
        };
        assert_eq!(diff(0, split), 0, "a non-finite point changed the chart");
        assert!(diff(split, 640) > 50, "no note about the left-out points");
    }

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
                workload: None,
                point_workloads: vec![],
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
