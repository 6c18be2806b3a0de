//! PNG plots of run time against error (plotters, bitmap backend, text in the embedded DejaVu Sans).
//!
//! One drawing path for every plot of `metamer bench`, so every plot follows the same rules:
//!
//! - **nothing fake**: a point that is not finite (or not positive on a log axis) is left out and counted
//!   in a note beside the chart; nothing is clamped onto the axis;
//! - **one style per series**: [`style_of`] gives series `i` of a plot its colour and marker, every
//!   series of a plot (up to [`COLOURS`]`.len()`) its own colour *and* its own marker pairing;
//! - **ticks chosen here** ([`axis_ticks`]: whole decades, else 1-2-5 steps, and a labelled tick near each
//!   end of a log axis) and bound to the axes with plotters' `with_key_points`, formatted by
//!   [`tick_label`], so no label is clipped, doubled or missing;
//! - **legend and notes in a column of their own** right of the chart, never over data;
//! - **Pareto fronts per workload**: only points measured on the same work are compared; front points are
//!   ringed, and a line joins a workload's front only when it has two points or more.

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};
use plotters::prelude::*;
use std::path::Path;

mod ticks;
pub(crate) use ticks::{Ticks, axis_ticks, range, tick_label};

/// An axis whose key points are [`Ticks`] chosen here (bold: labelled, light: grid only), over plotters'
/// own linear or log coordinate. (plotters' `WithKeyPoints` does the same but loses the label formatter.)
struct Keyed<R: Ranged<ValueType = f64>> {
    inner: R,
    ticks: Ticks,
}

impl<R: Ranged<ValueType = f64>> Ranged for Keyed<R> {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.inner.map(value, limit)
    }

    fn key_points<H: KeyPointHint>(&self, hint: H) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.ticks.light.clone() } else { self.ticks.bold.clone() }
    }

    fn range(&self) -> std::ops::Range<f64> {
        self.inner.range()
    }

    fn axis_pixel_range(&self, limit: (i32, i32)) -> std::ops::Range<i32> {
        self.inner.axis_pixel_range(limit)
    }
}

/// `r` with `ticks` as its key points.
fn keyed<R: Ranged<ValueType = f64>>(r: impl Into<R>, ticks: &Ticks) -> Keyed<R> {
    Keyed { inner: r.into(), ticks: ticks.clone() }
}

static REGISTER: std::sync::Once = std::sync::Once::new();

/// Register the font the project ships (embedded in the domain crate, `render::text::FONT`) as
/// plotters' "sans-serif", once, so plots render the same on every machine.
fn register_font() {
    REGISTER.call_once(|| {
        // A known-good TTF compiled into the binary; if registration failed, text would be missing,
        // which the plot tests catch.
        let _ = plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, crate::render::FONT);
    });
}

/// One series of points. `spread` optionally gives an x-interval per point (e.g. the interquartile range
/// of a timing on the x axis), `y_spread` a y-interval, each drawn as a bar through the point.
#[derive(Clone, Debug, Default)]
pub(crate) struct Series {
    pub(crate) label: String,
    pub(crate) points: Vec<(f64, f64)>,
    pub(crate) spread: Option<Vec<(f64, f64)>>,
    pub(crate) y_spread: Option<Vec<(f64, f64)>>,
    /// Join the points with a line (in the given order). Only for points that belong together (one
    /// quantity measured along x); never to join unrelated workloads.
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
    /// Vertical reference lines (x, legend label), drawn dashed in the colours after the series': a measured x without a y that
    /// can be drawn (e.g. the reference model's time, whose error is zero by definition).
    pub(crate) x_refs: Vec<(f64, String)>,
    /// Sentences written under the legend (what was left out and why, beyond the automatic counts).
    pub(crate) notes: Vec<String>,
    /// A linear y axis starts at 0 (so the heights of points compare as ratios); ignored on a log axis.
    pub(crate) y_from_zero: bool,
}

impl Default for XyPlot {
    fn default() -> Self {
        XyPlot {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            series: Vec::new(),
            pareto: false,
            x_refs: Vec::new(),
            notes: Vec::new(),
            y_from_zero: false,
        }
    }
}

/// Errors while drawing a plot.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    #[error("nothing to plot: no finite points")]
    Empty,
    #[error("cannot draw {path}: {reason}")]
    Draw { path: String, reason: String },
}

/// The series colours (matplotlib's tab10, then black and a dark gold): every series of a plot up to
/// this many has a colour of its own.
pub(crate) const COLOURS: [RGBColor; 12] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(127, 127, 127),
    RGBColor(188, 189, 34),
    RGBColor(23, 190, 207),
    RGBColor(0, 0, 0),
    RGBColor(150, 110, 0),
];

/// Marker shapes (circle, square, triangle, diamond, cross), cycled with the colours: 12 and 5 are
/// coprime, so 60 series pass before a (colour, marker) pair repeats.
const MARKERS: usize = 5;

/// Colour and marker shape of series `i`: the one style assignment of every bench plot.
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

/// Where a value is left out of a plot, and why.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum LeftOut {
    /// NaN or infinite ("n/a" in the tables).
    NotFinite,
    /// Zero or negative on a log axis.
    NotPositive,
}

/// Why point `p` cannot be drawn on these axes (None: it can).
pub(crate) fn left_out(p: (f64, f64), xs: Scale, ys: Scale) -> Option<LeftOut> {
    if !p.0.is_finite() || !p.1.is_finite() {
        Some(LeftOut::NotFinite)
    } else if (xs == Scale::Log && p.0 <= 0.0) || (ys == Scale::Log && p.1 <= 0.0) {
        Some(LeftOut::NotPositive)
    } else {
        None
    }
}

/// The points of a series that can be drawn on the axes (finite, positive on a log axis).
pub(crate) fn drawable(points: &[(f64, f64)], xs: Scale, ys: Scale) -> Vec<(f64, f64)> {
    points.iter().copied().filter(|p| left_out(*p, xs, ys).is_none()).collect()
}

/// The notes a plot carries about the points it left out (empty when none were).
pub(crate) fn left_out_notes(plot: &XyPlot) -> Vec<String> {
    let (xs, ys) = (plot.x_scale, plot.y_scale);
    let count = |why: LeftOut| {
        plot.series.iter().flat_map(|s| &s.points).filter(|p| left_out(**p, xs, ys) == Some(why)).count()
    };
    let n = |k: usize| if k == 1 { "1 point is".to_string() } else { format!("{k} points are") };
    let mut notes = Vec::new();
    let nf = count(LeftOut::NotFinite);
    if nf > 0 {
        notes.push(format!("{} not finite (n/a in the tables): left out, not drawn.", n(nf)));
    }
    let np = count(LeftOut::NotPositive);
    if np > 0 {
        notes.push(format!("{} zero or negative: left out of the log axis.", n(np)));
    }
    notes
}

/// Split `text` into lines of at most `max_chars` characters at spaces (a longer word stands alone).
pub(crate) fn wrap(text: &str, max_chars: usize) -> Vec<String> {
    let mut lines: Vec<String> = vec![String::new()];
    for w in text.split(' ') {
        let last = lines.last().map_or(0, |l| l.chars().count());
        if last > 0 && last + 1 + w.chars().count() > max_chars {
            lines.push(String::new());
        }
        if let Some(l) = lines.last_mut() {
            if !l.is_empty() {
                l.push(' ');
            }
            l.push_str(w);
        }
    }
    lines
}

/// A drawable point of a plot: its workload's index, (series, point) and position.
type KeyedPoint = (usize, (usize, usize), (f64, f64));

/// An optional per-point interval of a series.
type Bars = Option<Vec<(f64, f64)>>;

/// The Pareto fronts of a plot, one per workload that two series or more measured: for each such workload
/// (in first-seen order), its front's points as (series index, point index), sorted by x. Only drawable
/// points take part.
pub(crate) fn workload_fronts(plot: &XyPlot) -> Vec<(String, Vec<(usize, usize)>)> {
    let (xs, ys) = (plot.x_scale, plot.y_scale);
    let mut workloads: Vec<String> = Vec::new();
    let mut keyed: Vec<KeyedPoint> = Vec::new();
    for (i, s) in plot.series.iter().enumerate() {
        for (j, p) in s.points.iter().enumerate() {
            if left_out(*p, xs, ys).is_some() {
                continue;
            }
            let w = s.workload_of(j);
            let k = workloads.iter().position(|x| x == w).unwrap_or_else(|| {
                workloads.push(w.to_string());
                workloads.len() - 1
            });
            keyed.push((k, (i, j), *p));
        }
    }
    workloads
        .iter()
        .enumerate()
        .map(|(k, w)| {
            let members: Vec<&KeyedPoint> = keyed.iter().filter(|e| e.0 == k).collect();
            let pts: Vec<(f64, f64)> = members.iter().map(|e| e.2).collect();
            let mut series: Vec<usize> = members.iter().map(|e| e.1.0).collect();
            series.dedup();
            (w.clone(), series, super::pareto_front(&pts).into_iter().map(|i| members[i].1).collect())
        })
        // A workload that one series alone measured has nothing to compare: no front.
        .filter(|(_, series, _): &(String, Vec<usize>, Vec<(usize, usize)>)| series.len() >= 2)
        .map(|(w, _, front)| (w, front))
        .collect()
}

/// Width of the legend column right of the chart.
const LEGEND_W: u32 = 270;
/// Chart margins, label areas and caption as laid out in [`draw`] (for the axes' pixel lengths).
const MARGIN: u32 = 14;
const X_LABEL_AREA: u32 = 46;
const Y_LABEL_AREA: u32 = 78;
const CAPTION: u32 = 34;

/// Draw `plot` to a PNG of `width`×`height` pixels at `path`: the chart on the left, the legend in a
/// column of its own on the right (never over data), and under the legend the notes: the counts of the
/// points left out ([`left_out_notes`]) and the plot's own.
pub(crate) fn draw(plot: &XyPlot, path: &Path, width: u32, height: u32) -> Result<(), PlotError> {
    register_font();
    let err = |e: &dyn std::fmt::Display| PlotError::Draw { path: path.display().to_string(), reason: e.to_string() };
    let (xs, ys) = (plot.x_scale, plot.y_scale);
    let kept: Vec<Vec<(f64, f64)>> = plot.series.iter().map(|s| drawable(&s.points, xs, ys)).collect();
    let all = || kept.iter().flatten().copied();
    // Spread bars of drawable points widen the range so they are never cut off.
    let bar_ends = |pick: fn(&Series) -> &Bars| -> Vec<f64> {
        plot.series
            .iter()
            .flat_map(|s| {
                pick(s)
                    .iter()
                    .flatten()
                    .zip(&s.points)
                    .filter(|(_, p)| left_out(**p, xs, ys).is_none())
                    .flat_map(|((a, b), _)| [*a, *b])
                    .collect::<Vec<f64>>()
            })
            .collect()
    };
    let x_bars = bar_ends(|s| &s.spread);
    let y_bars = bar_ends(|s| &s.y_spread);
    let refs: Vec<f64> = plot.x_refs.iter().map(|r| r.0).collect();
    let xr = range(all().map(|p| p.0).chain(x_bars).chain(refs), xs).ok_or(PlotError::Empty)?;
    let zero = (plot.y_from_zero && ys == Scale::Linear && all().next().is_some()).then_some(0.0);
    let yr = range(all().map(|p| p.1).chain(y_bars).chain(zero), ys).ok_or(PlotError::Empty)?;
    let legend_w = LEGEND_W.min(width / 3);
    let chart_w = width - legend_w;
    let x_px = chart_w.saturating_sub(2 * MARGIN + Y_LABEL_AREA).max(50);
    let y_px = height.saturating_sub(2 * MARGIN + X_LABEL_AREA + CAPTION).max(50);
    // About 70 px per x label (up to seven characters) and 32 px per y label.
    let xt = axis_ticks(xr.0, xr.1, xs, (x_px / 70) as usize);
    let yt = axis_ticks(yr.0, yr.1, ys, (y_px / 32) as usize);
    let fronts = if plot.pareto { workload_fronts(plot) } else { Vec::new() };
    let mut notes = left_out_notes(plot);
    notes.extend(plot.notes.iter().cloned());

    // Drawn in memory, then written through the one atomic writer (never straight onto the path).
    let mut rgb = vec![0u8; width as usize * height as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (width, height)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&e))?;
        let (chart_area, legend_area) = root.split_horizontally(chart_w);
        // The title shrinks rather than run past the chart (DejaVu Sans: about 0.55 em per character).
        let chars = plot.title.chars().count().max(1) as f64;
        let title_size = (f64::from(chart_w.saturating_sub(2 * MARGIN)) / (0.56 * chars)).clamp(11.0, 18.0);
        let mut builder = ChartBuilder::on(&chart_area);
        builder
            .caption(&plot.title, ("sans-serif", title_size))
            .margin(MARGIN)
            .x_label_area_size(X_LABEL_AREA)
            .y_label_area_size(Y_LABEL_AREA);
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
                    .axis_desc_style(("sans-serif", 14))
                    .bold_line_style(RGBColor(200, 200, 200).stroke_width(1))
                    .light_line_style(RGBColor(236, 236, 236).stroke_width(1))
                    .draw()
                    .map_err(|e| err(&e))?;
                for (k, (x, _)) in plot.x_refs.iter().enumerate() {
                    if left_out((*x, yr.0), xs, ys).is_none() {
                        chart
                            .draw_series(DashedLineSeries::new(
                                vec![(*x, yr.0), (*x, yr.1)],
                                8,
                                5,
                                style_of(plot.series.len() + k).0.stroke_width(2),
                            ))
                            .map_err(|e| err(&e))?;
                    }
                }
                for (i, (s, pts)) in plot.series.iter().zip(&kept).enumerate() {
                    let (colour, shape) = style_of(i);
                    if s.line && pts.len() > 1 {
                        chart.draw_series(LineSeries::new(pts.clone(), colour.stroke_width(2))).map_err(|e| err(&e))?;
                    }
                    for (bars, horizontal) in [(&s.spread, true), (&s.y_spread, false)] {
                        for ((x, y), (a, b)) in s.points.iter().zip(bars.iter().flatten()) {
                            let ends = if horizontal {
                                [(*x, *y), (*a, *y), (*b, *y)]
                            } else {
                                [(*x, *y), (*x, *a), (*x, *b)]
                            };
                            if drawable(&ends, xs, ys).len() == 3 {
                                chart
                                    .draw_series(LineSeries::new(vec![ends[1], ends[2]], colour.stroke_width(1)))
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
                // One front per workload: fronts never join points measured on different work; front
                // points are ringed, so a front of one point is visible too.
                for (_, front) in &fronts {
                    let pts: Vec<(f64, f64)> = front.iter().map(|(i, j)| plot.series[*i].points[*j]).collect();
                    if pts.len() > 1 {
                        chart.draw_series(LineSeries::new(pts.clone(), BLACK.stroke_width(1))).map_err(|e| err(&e))?;
                    }
                    chart
                        .draw_series(
                            pts.iter().map(|p| EmptyElement::at(*p) + Circle::new((0, 0), 9, BLACK.stroke_width(1))),
                        )
                        .map_err(|e| err(&e))?;
                }
            }};
        }
        use plotters::coord::types::RangedCoordf64;
        type Log = plotters::coord::combinators::LogCoord<f64>;
        let lin = |r: (f64, f64), t: &Ticks| keyed::<RangedCoordf64>(r.0..r.1, t);
        let log = |r: (f64, f64), t: &Ticks| keyed::<Log>((r.0..r.1).log_scale(), t);
        match (xs, ys) {
            (Scale::Linear, Scale::Linear) => {
                body!(builder.build_cartesian_2d(lin(xr, &xt), lin(yr, &yt)).map_err(|e| err(&e))?)
            }
            (Scale::Log, Scale::Linear) => {
                body!(builder.build_cartesian_2d(log(xr, &xt), lin(yr, &yt)).map_err(|e| err(&e))?)
            }
            (Scale::Linear, Scale::Log) => {
                body!(builder.build_cartesian_2d(lin(xr, &xt), log(yr, &yt)).map_err(|e| err(&e))?)
            }
            (Scale::Log, Scale::Log) => {
                body!(builder.build_cartesian_2d(log(xr, &xt), log(yr, &yt)).map_err(|e| err(&e))?)
            }
        }
        // The legend column.
        let font = ("sans-serif", 14).into_font();
        let mut y = 48;
        let max_chars = ((legend_w as f64 - 40.0) / 7.5).max(8.0) as usize;
        let text = |s: &str, at: (i32, i32)| legend_area.draw(&Text::new(s.to_string(), at, font.clone()));
        for (i, (s, pts)) in plot.series.iter().zip(&kept).enumerate() {
            let (colour, shape) = style_of(i);
            if s.line {
                legend_area
                    .draw(&PathElement::new(vec![(6, y), (30, y)], colour.stroke_width(2)))
                    .map_err(|e| err(&e))?;
            }
            marker(&legend_area, (18, y), colour, shape);
            // A series none of whose points can be drawn still has its entry, saying so.
            let label = if pts.is_empty() { format!("{} (n/a: not drawn)", s.label) } else { s.label.clone() };
            let lines = wrap(&label, max_chars);
            for (j, line) in lines.iter().enumerate() {
                text(line, (38, y - 8 + 17 * j as i32)).map_err(|e| err(&e))?;
            }
            y += 22 + 17 * (lines.len() as i32 - 1);
        }
        // Reference lines continue the series' colours, so each has its own too.
        for (k, (_, label)) in plot.x_refs.iter().enumerate() {
            let colour = style_of(plot.series.len() + k).0;
            legend_area.draw(&PathElement::new(vec![(6, y), (14, y)], colour.stroke_width(2))).map_err(|e| err(&e))?;
            legend_area.draw(&PathElement::new(vec![(20, y), (28, y)], colour.stroke_width(2))).map_err(|e| err(&e))?;
            let lines = wrap(label, max_chars);
            for (j, line) in lines.iter().enumerate() {
                text(line, (38, y - 8 + 17 * j as i32)).map_err(|e| err(&e))?;
            }
            y += 22 + 17 * (lines.len() as i32 - 1);
        }
        if plot.pareto {
            legend_area.draw(&Circle::new((18, y), 9, BLACK.stroke_width(1))).map_err(|e| err(&e))?;
            let lines =
                wrap("ringed: on the Pareto front of its workload (work that two or more series measured)", max_chars);
            for (j, line) in lines.iter().enumerate() {
                text(line, (38, y - 8 + 17 * j as i32)).map_err(|e| err(&e))?;
            }
            y += 22 + 17 * (lines.len() as i32 - 1);
            if fronts.iter().any(|(_, f)| f.len() > 1) {
                legend_area
                    .draw(&PathElement::new(vec![(6, y), (30, y)], BLACK.stroke_width(1)))
                    .map_err(|e| err(&e))?;
                let lines = wrap("one workload's front (same work only)", max_chars);
                for (j, line) in lines.iter().enumerate() {
                    text(line, (38, y - 8 + 17 * j as i32)).map_err(|e| err(&e))?;
                }
                y += 22 + 17 * (lines.len() as i32 - 1);
            }
        }
        y += 8;
        let note_chars = ((legend_w as f64 - 12.0) / 7.5).max(8.0) as usize;
        for note in &notes {
            for line in wrap(note, note_chars) {
                text(&line, (6, y)).map_err(|e| err(&e))?;
                y += 17;
            }
            y += 6;
        }
        root.present().map_err(|e| err(&e))?;
    }
    let png =
        crate::render::encode_png(&rgb, width as usize, height as usize, Default::default()).map_err(|e| err(&e))?;
    crate::bench::write_own(path, &png).map_err(|e| err(&e))
}

#[cfg(test)]
mod tests;
