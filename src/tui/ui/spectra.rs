//! The spectra of the selected light and reflectance, as a braille line chart over 400–700 nm.

use crate::spectrum::{Grid, Spectrum};
use crate::tui::app::State;
use crate::tui::ui::num;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Axis, Chart, Dataset, GraphType, Widget};

/// The colour of the light's curve and of its name in the pane's header.
const LIGHT_COLOUR: Color = Color::Yellow;
/// The colour of the reflectance's curve and of its name in the pane's header.
const REFLECTANCE_COLOUR: Color = Color::Cyan;

/// The spectra pane's header, `width` columns at most: " spectra ─ " and then the names of the curves
/// drawn, each in its curve's colour, with what it is ("light", "reflectance, designed"). The names
/// stand here rather than in a legend box inside the plot, which hid the curves it named in a small
/// pane (issue 30, defect 8). When the whole does not fit, the kinds go first, then the names are cut
/// (each keeps a share of the room), so both colours stay visible.
pub(crate) fn title(state: &State, width: u16) -> Line<'static> {
    let d = &state.solve.derived;
    let p = &state.doc.palette;
    let (light, reflectance) = state.plotted();
    let mut names: Vec<(String, &str, Color)> = Vec::new();
    if let Some(e) = light.filter(|&l| d.light_spectra.get(l).is_some()).and_then(|l| p.lights.get(l)) {
        names.push((e.name.clone(), if e.design { "light, designed" } else { "light" }, LIGHT_COLOUR));
    }
    if let Some(e) = reflectance.filter(|&r| d.reflectance_spectra.get(r).is_some()).and_then(|r| p.reflectances.get(r))
    {
        names.push((
            e.name.clone(),
            if e.design { "reflectance, designed" } else { "reflectance" },
            REFLECTANCE_COLOUR,
        ));
    }
    const HEAD: &str = " spectra ";
    const SEP: &str = "─ ";
    let room = usize::from(width).saturating_sub(HEAD.chars().count() + 1);
    let with_kind: Vec<String> = names.iter().map(|(n, k, _)| format!("{n} ({k}) ")).collect();
    let bare: Vec<String> = names.iter().map(|(n, _, _)| format!("{n} ")).collect();
    let total = |v: &[String]| v.iter().map(|t| SEP.chars().count() + t.chars().count()).sum::<usize>();
    let texts = if total(&with_kind) <= room {
        with_kind
    } else if total(&bare) <= room {
        bare
    } else {
        let share = (room / names.len().max(1)).saturating_sub(SEP.chars().count() + 1);
        names.iter().map(|(n, _, _)| format!("{} ", super::fit(n, share.max(1)))).collect()
    };
    let mut spans = vec![Span::raw(HEAD)];
    for (text, (_, _, colour)) in texts.into_iter().zip(&names) {
        spans.push(Span::raw(SEP));
        spans.push(Span::styled(text, Style::new().fg(*colour)));
    }
    Line::from(spans)
}

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
        let mut datasets = Vec::new();
        // The curves' names are in the pane's header ([`title`]), not in a legend box over the plot.
        if let Some(data) = light_points.as_deref() {
            datasets.push(
                Dataset::default()
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(LIGHT_COLOUR))
                    .data(data),
            );
        }
        if let Some(data) = refl_points.as_deref() {
            datasets.push(
                Dataset::default()
                    .marker(Marker::Braille)
                    .graph_type(GraphType::Line)
                    .style(Style::new().fg(REFLECTANCE_COLOUR))
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
        Chart::new(datasets).x_axis(x_axis).y_axis(y_axis).legend_position(None).render(area, buf);
    }
}
