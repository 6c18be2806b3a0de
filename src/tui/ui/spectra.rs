//! The spectra of the selected light and reflectance, as a braille line chart over 400–700 nm.

use crate::spectrum::{Grid, Spectrum};
use crate::tui::app::State;
use crate::tui::ui::num;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::Span;
use ratatui::widgets::{Axis, Chart, Dataset, GraphType, LegendPosition, Widget};

/// The spectrum plot of a state.
pub(crate) struct SpectraPlot<'a>(pub &'a State);

fn points(s: &Spectrum) -> Vec<(f64, f64)> {
    s.as_slice().iter().enumerate().map(|(i, v)| (Grid::STANDARD.wavelength(i), *v)).collect()
}

impl Widget for SpectraPlot<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let d = &state.solve.derived;
        let (light, reflectance) = state.plotted();
        let light_points = light.and_then(|l| d.light_spectra.get(l)).map(points);
        let refl_points = reflectance.and_then(|r| d.reflectance_spectra.get(r)).map(points);
        let label =
            |name: &str, kind: &str, design: bool| format!("{name} ({kind}{})", if design { ", designed" } else { "" });
        let mut datasets = Vec::new();
        if let (Some(l), Some(data)) = (light, light_points.as_deref()) {
            let e = &state.doc.palette.lights[l];
            datasets.push(
                Dataset::default()
                    .name(label(&e.name, "light", e.design))
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(Color::Yellow))
                    .data(data),
            );
        }
        if let (Some(r), Some(data)) = (reflectance, refl_points.as_deref()) {
            let e = &state.doc.palette.reflectances[r];
            datasets.push(
                Dataset::default()
                    .name(label(&e.name, "reflectance", e.design))
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(Color::Cyan))
                    .data(data),
            );
        }
        let all = light_points.iter().chain(refl_points.iter()).flatten().map(|(_, v)| *v);
        let (lo, hi) =
            all.fold((0.0f64, 1.0f64), |(lo, hi), v| if v.is_finite() { (lo.min(v), hi.max(v)) } else { (lo, hi) });
        let grid = Grid::STANDARD;
        let x_axis = Axis::default()
            .bounds([grid.start_nm, grid.end_nm()])
            .style(Style::new().fg(Color::Gray))
            .labels(["400", "550", "700 nm"].map(Span::raw));
        let y_axis = Axis::default()
            .bounds([lo, hi])
            .style(Style::new().fg(Color::Gray))
            .labels([num(lo), num(hi)].map(Span::raw));
        Chart::new(datasets)
            .x_axis(x_axis)
            .y_axis(y_axis)
            .legend_position(Some(LegendPosition::TopRight))
            .hidden_legend_constraints((
                ratatui::layout::Constraint::Percentage(60),
                ratatui::layout::Constraint::Percentage(100),
            ))
            .render(area, buf);
    }
}
