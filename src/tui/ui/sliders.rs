//! The sliders of the selected cell (R, G, B in display sRGB, the weight) with its hex target and the
//! CIEDE2000 errors of the full and subspace models; for a selected light or reflectance, its details.

use crate::colorimetry::{linear_to_hex, srgb_encode};
use crate::palette::{Kind, Source};
use crate::tui::app::{Focus, Slider, State, Target};
use crate::tui::ui::{design_style, fit, num, put, selected_style, swatch};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::widgets::Widget;

/// The full sliders panel.
pub(crate) struct Sliders<'a>(pub &'a State);

/// The one-line sliders of narrow screens.
pub(crate) struct CompactSliders<'a>(pub &'a State);

/// Values of the selected cell's sliders: display sRGB target (0–1) and weight.
pub(crate) fn slider_values(state: &State, light: usize, reflectance: usize) -> [f64; 4] {
    let cell = state.doc.palette.cell(light, reflectance);
    let target = cell.map(|c| c.target).or_else(|| state.solve.derived.cell(light, reflectance).map(|c| c.full));
    let t = target.unwrap_or_default();
    let enc = |v: f64| srgb_encode(v).clamp(0.0, 1.0);
    [enc(t[0]), enc(t[1]), enc(t[2]), cell.map_or(0.0, |c| c.weight)]
}

fn bar(width: usize, fraction: f64) -> (String, String) {
    let eighths = (fraction.clamp(0.0, 1.0) * width as f64 * 2.0).round() as usize;
    let mut filled = "█".repeat(eighths / 2);
    if eighths % 2 == 1 {
        filled.push('▌');
    }
    let used = filled.chars().count();
    (filled, "·".repeat(width.saturating_sub(used)))
}

fn source_text(source: &Source) -> String {
    match source {
        Source::Illuminant(n) => format!("illuminant {n}"),
        Source::ColorChecker(n) => format!("ColorChecker {n}"),
        Source::Planck(t) => format!("Planck {} K", num(*t)),
        Source::Flat(v) => format!("flat {}", num(*v)),
        Source::Samples(_) => "31 samples".into(),
        Source::Csv(p) => format!("CSV {p}"),
    }
}

impl Widget for Sliders<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let p = &state.doc.palette;
        let w = usize::from(area.width);
        let x0 = 1u16;
        match state.target() {
            Target::Cell { light, reflectance } => {
                let (lname, rname) = (&p.lights[light].name, &p.reflectances[reflectance].name);
                let cell = p.cell(light, reflectance);
                let title = crate::design::cell_name(lname, rname);
                put(buf, area, x0, 0, &fit(&title, w.saturating_sub(10)), Style::new().add_modifier(Modifier::BOLD));
                if let Some(g) = cell.and_then(|c| c.free).and_then(|g| p.free.get(g)) {
                    let free = format!("free {}", g.name);
                    put(
                        buf,
                        area,
                        area.width.saturating_sub(free.chars().count() as u16 + 1),
                        0,
                        &free,
                        Style::new().fg(Color::LightMagenta).add_modifier(Modifier::BOLD),
                    );
                } else if cell.is_some_and(|c| !c.enabled) {
                    put(buf, area, area.width.saturating_sub(8), 0, "not used", Style::new().fg(Color::DarkGray));
                } else if cell.is_none() {
                    put(buf, area, area.width.saturating_sub(8), 0, "no goal", Style::new().fg(Color::DarkGray));
                }
                let values = slider_values(state, light, reflectance);
                let bar_width = w.saturating_sub(12).max(4);
                // A free cell's R, G, B are the target it keeps for leaving its group, not one in use:
                // greyed (its colour is the group's, on the line below).
                let in_group = cell.is_some_and(|c| c.free.is_some());
                for (k, slider) in Slider::ALL.iter().enumerate() {
                    let y = 1 + k as u16;
                    let focused = state.ui.focus == Focus::Sliders && state.ui.slider == k;
                    let (label, colour, fraction, value) = match slider {
                        Slider::Red => ("R", Color::Red, values[0], format!("{:.2}", values[0])),
                        Slider::Green => ("G", Color::Green, values[1], format!("{:.2}", values[1])),
                        Slider::Blue => ("B", Color::Blue, values[2], format!("{:.2}", values[2])),
                        Slider::Weight => ("w", Color::White, values[3] / values[3].max(10.0), num(values[3])),
                    };
                    let label_style = if focused { selected_style() } else { Style::new() };
                    put(buf, area, 0, y, if focused { "›" } else { " " }, selected_style());
                    put(buf, area, x0, y, label, label_style);
                    let (filled, rest) = bar(bar_width, fraction);
                    let colour = if in_group && k < 3 { Color::DarkGray } else { colour };
                    let x = put(buf, area, x0 + 2, y, &filled, Style::new().fg(colour));
                    put(buf, area, x, y, &rest, Style::new().fg(Color::DarkGray));
                    put(buf, area, x0 + 3 + bar_width as u16, y, &value, label_style);
                }
                let view = state.solve.derived.cell(light, reflectance);
                let hex = view.and_then(|c| c.desired).map_or("—".to_string(), |d| linear_to_hex(&d));
                let de = |v: Option<f64>| v.map_or("–".to_string(), |d| format!("{d:.1}"));
                let m = p.settings.basis_dimension;
                // Never a stale V7 number: while the basis of the shown spectra is being trained, say so.
                let updating = state.solve.derived.subspace_pending && state.solve.basis_error.is_none();
                let v7 = if updating { "updating".to_string() } else { de(view.and_then(|c| c.delta_e_subspace)) };
                let line = format!("{hex}  full ΔE {}  V{m} ΔE {v7}", de(view.and_then(|c| c.delta_e_full)));
                put(buf, area, x0, 5, &line, Style::new());
                if let Some(mean) = state.solve.basis_poor() {
                    let warn = Style::new().fg(Color::Yellow);
                    let text = format!("⚠ V{m} model poor: ΔE00 {mean:.2} > {}", crate::basis::POOR_MODEL_MEAN_DE00);
                    put(buf, area, x0, 8, &fit(&text, w.saturating_sub(2)), warn);
                    let fix = format!("fix: raise m, subspace error, fit V{m}");
                    put(buf, area, x0, 9, &fit(&fix, w.saturating_sub(2)), warn);
                }
                let cell_index = state.doc.cell_index(light, reflectance);
                if let Some(d) = state.diagnostics().iter().find(|d| d.cell.is_some() && d.cell == cell_index) {
                    let text = format!("⚠ {}", d.message);
                    put(buf, area, x0, 7, &fit(&text, w.saturating_sub(2)), Style::new().fg(Color::Yellow));
                }
                if let Some(v) = view {
                    let mode = state.ui.colour_mode;
                    let free = cell.and_then(|c| c.free).and_then(|g| p.free.get(g));
                    let mut x = match free {
                        Some(g) => put(buf, area, x0, 6, &format!("free (group {}) ", g.name), free_style()),
                        None => put(buf, area, x0, 6, "target ", Style::new().fg(Color::Gray)),
                    };
                    x = match &v.desired {
                        Some(d) => put(buf, area, x, 6, "██", swatch(mode, d)),
                        None => put(buf, area, x, 6, "··", Style::new().fg(Color::DarkGray)),
                    };
                    x = put(buf, area, x, 6, "  full ", Style::new().fg(Color::Gray));
                    x = put(buf, area, x, 6, "██", swatch(mode, &v.full));
                    x = put(buf, area, x, 6, &format!("  V{m} "), Style::new().fg(Color::Gray));
                    match &v.subspace {
                        Some(s) => put(buf, area, x, 6, "██", swatch(mode, s)),
                        None if updating => put(buf, area, x, 6, "…", Style::new().fg(Color::Yellow)),
                        None => put(buf, area, x, 6, "n/a", Style::new().fg(Color::DarkGray)),
                    };
                }
            }
            Target::Light(i) | Target::Reflectance(i) => {
                let kind = if matches!(state.target(), Target::Light(_)) { Kind::Light } else { Kind::Reflectance };
                let Some(e) = p.entries(kind).get(i) else { return };
                let title = format!("{} ({})", e.name, kind.as_str());
                put(buf, area, x0, 0, &fit(&title, w.saturating_sub(2)), Style::new().add_modifier(Modifier::BOLD));
                put(buf, area, x0, 1, &fit(&source_text(&e.source), w.saturating_sub(2)), Style::new());
                if kind == Kind::Light {
                    put(
                        buf,
                        area,
                        x0,
                        2,
                        &format!("normalise {} · scale {}", e.normalize.as_str(), num(e.scale)),
                        Style::new(),
                    );
                } else {
                    put(buf, area, x0, 2, &format!("scale {}", num(e.scale)), Style::new());
                }
                if e.design {
                    let b = p.bounds_of(e);
                    put(
                        buf,
                        area,
                        x0,
                        3,
                        &format!("designed · bounds {} … {}", num(b.lower), num(b.upper)),
                        design_style(),
                    );
                } else {
                    put(buf, area, x0, 3, "fixed (d or Enter: design it)", Style::new().fg(Color::Gray));
                }
                let keys: &[&str] = if kind == Kind::Light {
                    &["p Planck · n/N normalise", "s scale · x remove · d design"]
                } else {
                    &["s scale · x remove · d design"]
                };
                for (k, line) in keys.iter().enumerate() {
                    put(buf, area, x0, 5 + k as u16, &fit(line, w.saturating_sub(2)), Style::new().fg(Color::Gray));
                }
            }
            Target::Nothing => {}
        }
    }
}

impl Widget for CompactSliders<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let Target::Cell { light, reflectance } = state.target() else {
            let text = match state.target() {
                Target::Light(l) => format!("light {}", state.doc.palette.lights[l].name),
                Target::Reflectance(r) => format!("reflectance {}", state.doc.palette.reflectances[r].name),
                _ => String::new(),
            };
            put(buf, area, 0, 0, &text, Style::new().add_modifier(Modifier::BOLD));
            return;
        };
        let view = state.solve.derived.cell(light, reflectance);
        let p = &state.doc.palette;
        // A free cell has no target of its own (its R, G, B would be the stale one it had before): its
        // group's solved colour, labelled.
        if let Some(g) = p.cell(light, reflectance).and_then(|c| c.free).and_then(|g| p.free.get(g)) {
            let mut x = put(buf, area, 0, 0, &format!("free (group {}) ", g.name), free_style());
            x = match view.and_then(|c| c.desired) {
                Some(d) => {
                    let x = put(buf, area, x, 0, "██", swatch(state.ui.colour_mode, &d));
                    put(buf, area, x, 0, &format!(" {}", linear_to_hex(&d)), Style::new())
                }
                None => put(buf, area, x, 0, "not solved yet", Style::new().fg(Color::DarkGray)),
            };
            let de = view.and_then(|c| c.delta_e_full).map_or("–".to_string(), |d| format!("{d:.1}"));
            x = put(buf, area, x, 0, &format!("  ΔE {de}  "), Style::new());
            let name = crate::design::cell_name(&p.lights[light].name, &p.reflectances[reflectance].name);
            let room = usize::from(area.width.saturating_sub(x));
            put(buf, area, x, 0, &fit(&name, room), Style::new().fg(Color::Gray));
            return;
        }
        let mut x = 0;
        for (k, text) in compact_texts(state, light, reflectance).iter().enumerate() {
            let focused = state.ui.focus == Focus::Sliders && state.ui.slider == k;
            let style = if focused { selected_style().add_modifier(Modifier::REVERSED) } else { Style::new() };
            x = put(buf, area, x, 0, text, style);
            x = put(buf, area, x, 0, "  ", Style::new());
        }
        let hex = view.and_then(|c| c.desired).map_or("—".to_string(), |d| linear_to_hex(&d));
        let de = view.and_then(|c| c.delta_e_full).map_or("–".to_string(), |d| format!("{d:.1}"));
        x = put(buf, area, x, 0, &format!("{hex}  ΔE {de}  "), Style::new());
        let name = crate::design::cell_name(
            &state.doc.palette.lights[light].name,
            &state.doc.palette.reflectances[reflectance].name,
        );
        let room = usize::from(area.width.saturating_sub(x));
        put(buf, area, x, 0, &fit(&name, room), Style::new().fg(Color::Gray));
    }
}

/// The one-line sliders' texts (`R 0.95`, `G 0.95`, `B 0.95`, `w 1`), drawn two columns apart from the
/// line's start (a click on one focuses that slider: `ui/hit.rs`).
pub(crate) fn compact_texts(state: &State, light: usize, reflectance: usize) -> [String; 4] {
    let v = slider_values(state, light, reflectance);
    [format!("R {:.2}", v[0]), format!("G {:.2}", v[1]), format!("B {:.2}", v[2]), format!("w {}", num(v[3]))]
}

/// How a free cell's group is named beside its colour.
fn free_style() -> Style {
    Style::new().fg(Color::LightMagenta).add_modifier(Modifier::BOLD)
}
