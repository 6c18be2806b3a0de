//! The scene preview panel: the relit raycast image — at real pixels through a terminal graphics
//! protocol ([`crate::tui::graphics`]) or in half blocks (two square pixels per character) — centred in
//! the panel, and a progress line while the raycast runs.

use crate::render::DialState;
use crate::spectrum::Spectrum;
use crate::tui::app::State;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::symbols::Marker;
use ratatui::text::{Line, Span};
use ratatui::widgets::Widget;
use ratatui::widgets::canvas::{Canvas, Line as CanvasLine};

mod labels;

/// The lights that light the dial now, strongest first, as `name 70% · name 30%`.
pub(crate) fn caption(dial: &DialState) -> String {
    let w = dial.weights();
    let mut lit: Vec<(usize, f64)> = w.iter().copied().enumerate().filter(|(_, v)| *v >= 0.005).collect();
    lit.sort_by(|a, b| b.1.total_cmp(&a.1));
    if lit.is_empty() {
        return "every light off".to_string();
    }
    lit.iter()
        .take(3)
        .map(|(i, v)| format!("{} {:.0}%", dial.lights[*i].name, v * 100.0))
        .collect::<Vec<_>>()
        .join(" · ")
}
/// The panel's title: where the dial is, the keys, the protocol.
pub(crate) fn title(state: &State) -> String {
    let caption = state.preview.dial_state().map_or_else(|| "no lights".to_string(), caption);
    let keys = if state.preview.keys { "Esc leave" } else { "g dial keys" };
    format!(" light dial: {caption} · {keys} · {} ", state.preview.graphics.name())
}

/// Which palette the preview shows: the scene's materials and dial lights take the designed spectra of
/// the same name, the others keep the scene palette's. `None` when all come from the designed palette.
pub(crate) fn palette_note(state: &State) -> Option<String> {
    let preview = state.preview.ready.as_ref()?;
    let p = &state.doc.palette;
    let materials = &preview.materials;
    let named = |list: &[crate::palette::SpectrumEntry], n: &str| list.iter().any(|e| e.name == n);
    let mat_in = materials.iter().filter(|(n, _)| named(&p.reflectances, n)).count();
    let lights: Vec<&str> =
        state.preview.dial_state().map(|d| d.lights.iter().map(|l| l.name.as_str()).collect()).unwrap_or_default();
    let light_in = lights.iter().filter(|n| named(&p.lights, n)).count();
    if mat_in == materials.len() && light_in == lights.len() {
        return None;
    }
    let scene_palette = preview
        .scene
        .palette_path
        .as_deref()
        .map_or("its built-in palette".to_string(), |path| format!("its palette {}", crate::fsio::show(path)));
    Some(if mat_in == 0 && light_in == 0 {
        format!(
            "the preview shows the scene's own spectra ({scene_palette}): no material or light of it is named \
             as in {}, so edits do not reach it",
            crate::fsio::show(state.path())
        )
    } else {
        format!(
            "the preview takes {mat_in} of {} materials and {light_in} of {} lights from this palette (by name); \
             the others are the scene's ({scene_palette})",
            materials.len(),
            lights.len()
        )
    })
}

/// The relit preview over the whole terminal (`P`): the image in `image`, under it one caption line with
/// the dial's position and how to return (and the message of the last key, when there is one).
pub(crate) fn full_screen(state: &State, image: Rect, area: Rect, buf: &mut Buffer) {
    PreviewPanel(state).render(image, buf);
    let caption = state.preview.dial_state().map_or_else(|| "no lights".to_string(), caption);
    let text = match &state.ui.message {
        Some(m) => m.text.clone(),
        None => format!(
            "light dial: {caption} · {} · {} · P or Esc returns",
            if state.preview.keys { "dial keys" } else { "[ ] along the sweep" },
            state.preview.graphics.name()
        ),
    };
    let y = image.bottom().min(area.bottom().saturating_sub(1));
    buf.set_stringn(
        area.x,
        y,
        crate::tui::ui::fit(&text, usize::from(area.width)),
        usize::from(area.width),
        Style::new().fg(Color::Gray),
    );
}

/// The preview image of a state (a progress line while it is raycast).
pub(crate) struct PreviewPanel<'a>(pub &'a State);

impl Widget for PreviewPanel<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        if area.width == 0 || area.height == 0 {
            return;
        }
        let loading = state.preview.loading();
        if let Some(text) = &loading {
            let style = Style::new().fg(Color::Yellow);
            buf.set_stringn(area.x, area.y, text, usize::from(area.width), style);
        }
        let Some(preview) = &state.preview.ready else { return };
        let (pw, ph) = preview.size();
        let pixels = &state.preview.frame;
        if pw == 0 || ph == 0 || pixels.len() != pw * ph * 3 {
            return;
        }
        let mut first = if loading.is_some() { 1 } else { 0 };
        // Which palette the image shows, when not (all) the designed one: wrapped above the image.
        if let Some(note) = palette_note(state) {
            for line in crate::tui::ui::wrap(&note, usize::from(area.width)).iter().take(usize::from(area.height / 2)) {
                buf.set_stringn(area.x, area.y + first, line, usize::from(area.width), Style::new().fg(Color::Yellow));
                first += 1;
            }
        }
        let area = Rect { y: area.y + first, height: area.height - first, ..area };
        if !state.preview.graphics.is_halfblocks()
            && let Some(cells) = state.preview.graphics.encoded_cells()
        {
            let x = area.x + area.width.saturating_sub(cells.width) / 2;
            let y = area.y + area.height.saturating_sub(cells.height) / 2;
            let at = Rect { x, y, width: area.width - (x - area.x), height: area.height - (y - area.y) };
            if state.preview.graphics.render(at, buf) {
                return;
            }
        }
        // Fit pw × ph into width × 2·height pixels, keeping the aspect ratio.
        let (aw, ah) = (usize::from(area.width), 2 * usize::from(area.height));
        if ah < 2 {
            return;
        }
        let scale = (aw as f64 / pw as f64).min(ah as f64 / ph as f64);
        let w = ((pw as f64 * scale).round() as usize).clamp(1, aw);
        let h = ((ph as f64 * scale).round() as usize).clamp(2, ah) & !1;
        let x0 = area.x + ((aw - w) / 2) as u16;
        let y0 = area.y + ((ah - h) / 4) as u16;
        let sample = |x: usize, y: usize| {
            let sx = (x * pw / w).min(pw - 1);
            let sy = (y * ph / h).min(ph - 1);
            let i = 3 * (sy * pw + sx);
            [pixels[i], pixels[i + 1], pixels[i + 2]]
        };
        for cy in 0..h / 2 {
            for x in 0..w {
                let top = state.ui.colour_mode.color(sample(x, 2 * cy));
                let bottom = state.ui.colour_mode.color(sample(x, 2 * cy + 1));
                if let Some(cell) = buf.cell_mut((x0 + x as u16, y0 + cy as u16)) {
                    cell.set_symbol("▀").set_style(Style::new().fg(top).bg(bottom));
                }
            }
        }
    }
}

/// A light's colour on the dial: its colour on a white reflectance, brightest channel 1.
fn light_colour(state: &State, e: &Spectrum) -> Color {
    let rgb = state.colorimetry.rgb(e, &Spectrum::flat(1.0));
    let peak = rgb.max();
    let rgb = if peak > 1e-12 { rgb / peak } else { rgb };
    state.ui.colour_mode.linear(&rgb)
}

/// Where the dial panel draws: the canvas (above) and the intensity list (below) in `area`, and the dial
/// coordinates at the canvas's edges.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct DialCanvas {
    pub(crate) canvas: Rect,
    pub(crate) list: Rect,
    pub(crate) left: f64,
    pub(crate) right: f64,
    pub(crate) bottom: f64,
    pub(crate) top: f64,
}

/// Lay the dial panel out in `area` for `dial` (the view draws it so, and a mouse click is read so).
pub(crate) fn dial_canvas(area: Rect, dial: &DialState) -> DialCanvas {
    let n = dial.lights.len();
    // The dial keeps at least half the panel (and 3 rows): with many lights on a short panel the
    // intensity list scrolls to keep the selected light in view.
    let list_rows = (n as u16 + 1).min(area.height.saturating_sub((area.height / 2).max(3)));
    let canvas = Rect { height: area.height - list_rows, ..area };
    let list = Rect { y: area.y + canvas.height, height: list_rows, ..area };
    let [[x0, y0], [x1, y1]] = dial.bounds();
    let pad = 0.25 * (x1 - x0).max(y1 - y0).max(0.5);
    let (cx, cy) = ((x0 + x1) / 2.0, (y0 + y1) / 2.0);
    let half = 0.5 * (x1 - x0).max(y1 - y0) + pad;
    // Cells are about twice as high as wide: widen the x range so the dial is not squashed.
    let aspect = f64::from(canvas.width.max(1)) / (2.0 * f64::from(canvas.height.max(1)));
    let (hx, hy) = if aspect >= 1.0 { (half * aspect, half) } else { (half, half / aspect) };
    DialCanvas { canvas, list, left: cx - hx, right: cx + hx, bottom: cy - hy, top: cy + hy }
}

impl DialCanvas {
    /// The dial point at the middle of the canvas's cell (`x`, `y`) (screen cells; a cell outside the
    /// canvas is taken at its nearest edge), as the canvas maps its braille dots (2 × 4 a cell) onto the
    /// dial's coordinates.
    pub(crate) fn point_at(&self, x: u16, y: u16) -> [f64; 2] {
        let (cw, ch) = (f64::from(self.canvas.width.max(1)), f64::from(self.canvas.height.max(1)));
        let x = x.clamp(self.canvas.x, self.canvas.right().saturating_sub(1).max(self.canvas.x));
        let y = y.clamp(self.canvas.y, self.canvas.bottom().saturating_sub(1).max(self.canvas.y));
        let px = 2.0 * f64::from(x - self.canvas.x) + 0.5;
        let py = 4.0 * f64::from(y - self.canvas.y) + 1.5;
        [
            self.left + px * (self.right - self.left) / (2.0 * cw - 1.0).max(1.0),
            self.top - py * (self.top - self.bottom) / (4.0 * ch - 1.0).max(1.0),
        ]
    }
}

/// The light dial beside the preview image (seed §5.1's 2D dial): each light's vertex in its colour with
/// its number and name (hollow when off), the outline through the vertices, the slider point; under it
/// one intensity slider per light.
pub(crate) struct DialPanel<'a>(pub &'a State);

impl Widget for DialPanel<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let (Some(dial), Some(preview)) = (state.preview.dial_state(), &state.preview.ready) else { return };
        // The designer's current spectra colour the vertices.
        let dial = preview.current_dial(&state.doc.palette, &state.solve.derived, dial);
        let n = dial.lights.len();
        // The dial keeps at least half the panel (and 3 rows): with many lights on a short panel the
        // intensity list scrolls to keep the selected light in view.
        let DialCanvas { canvas: canvas_area, list: list_area, left, right, bottom, top } = dial_canvas(area, &dial);
        let list_rows = list_area.height;
        let colours: Vec<Color> = dial.lights.iter().map(|l| light_colour(state, &l.spectrum)).collect();
        let selected = if state.preview.keys { state.preview.selected } else { None };
        let keys = state.preview.keys;
        let canvas =
            Canvas::default().marker(Marker::Braille).x_bounds([left, right]).y_bounds([bottom, top]).paint(|ctx| {
                for i in 0..n {
                    let (a, b) = (dial.lights[i].position, dial.lights[(i + 1) % n].position);
                    if n > 1 && (n > 2 || i == 0) {
                        ctx.draw(&CanvasLine::new(a[0], a[1], b[0], b[1], Color::DarkGray));
                    }
                }
            });
        canvas.render(canvas_area, buf);
        // Marks and labels go on the cells the canvas puts these points on (its braille grid, 2 × 4 dots a
        // cell), so the marks sit at the ends of the outline.
        let (cw, ch) = (f64::from(canvas_area.width), f64::from(canvas_area.height));
        let cell_of = |p: [f64; 2]| -> (f64, f64) {
            let px = ((p[0] - left) * (2.0 * cw - 1.0) / (right - left)).round();
            let py = ((top - p[1]) * (4.0 * ch - 1.0) / (top - bottom)).round();
            ((px / 2.0).floor().min(cw - 1.0).max(0.0), (py / 4.0).floor().min(ch - 1.0).max(0.0))
        };
        let cell = |p: [f64; 2]| -> (u16, u16) {
            let (x, y) = cell_of(p);
            (x as u16, y as u16)
        };
        let marks: Vec<(u16, u16)> = dial.lights.iter().map(|l| cell(l.position)).collect();
        let slider = cell(dial.slider);
        let names: Vec<&str> = dial.lights.iter().map(|l| l.name.as_str()).collect();
        let centroid = dial.lights.iter().fold([0.0, 0.0], |a, l| [a[0] + l.position[0], a[1] + l.position[1]]);
        let centroid = [centroid[0] / n.max(1) as f64, centroid[1] / n.max(1) as f64];
        let centre = {
            let px = (centroid[0] - left) * (2.0 * cw - 1.0) / (right - left);
            let py = (top - centroid[1]) * (4.0 * ch - 1.0) / (top - bottom);
            (px / 2.0 - 0.5, py / 4.0 - 0.5)
        };
        let placed = if canvas_area.is_empty() {
            Vec::new()
        } else {
            labels::layout((canvas_area.width, canvas_area.height), &marks, &[slider], &names, centre)
        };
        let style_of = |i: usize| {
            let style = Style::new().fg(colours[i]);
            if selected == Some(i) { style.add_modifier(Modifier::REVERSED) } else { style }
        };
        for (i, p) in placed.iter().enumerate() {
            if let Some(p) = p {
                buf.set_string(canvas_area.x + p.x, canvas_area.y + p.y, &p.text, style_of(i));
            }
        }
        for (i, (l, &(x, y))) in dial.lights.iter().zip(&marks).enumerate().filter(|_| !canvas_area.is_empty()) {
            let mark = if l.on { "●" } else { "○" };
            buf.set_string(canvas_area.x + x, canvas_area.y + y, mark, style_of(i));
        }
        let style = if keys && selected.is_none() {
            Style::new().fg(Color::White).add_modifier(Modifier::REVERSED | Modifier::BOLD)
        } else {
            Style::new().fg(Color::White).add_modifier(Modifier::BOLD)
        };
        if !canvas_area.is_empty() {
            buf.set_string(canvas_area.x + slider.0, canvas_area.y + slider.1, "◆", style);
        }
        // Intensity sliders: number, on/off, name, bar, value (0 … 2).
        let weights = dial.weights();
        let shown = usize::from(list_rows).min(n);
        let first = selected.map_or(0, |s| (s + 1).saturating_sub(shown)).min(n - shown);
        for (row, (i, l)) in dial.lights.iter().enumerate().skip(first).take(shown).enumerate() {
            let y = list_area.y + row as u16;
            let mark = if l.on { "●" } else { "○" };
            let name = labels::shorten(&l.name, 9).unwrap_or_default();
            let head = format!("{}{mark} {name:<9} ", i + 1);
            let bar_w = usize::from(area.width).saturating_sub(head.chars().count() + 10).max(1);
            let filled = ((l.intensity / 2.0).clamp(0.0, 1.0) * bar_w as f64).round() as usize;
            let bar: String = "█".repeat(filled) + &"·".repeat(bar_w - filled);
            let mut style = Style::new().fg(colours[i]);
            if selected == Some(i) {
                style = style.add_modifier(Modifier::REVERSED);
            }
            let line = Line::from(vec![
                Span::styled(head, style),
                Span::styled(bar, Style::new().fg(colours[i])),
                Span::raw(format!(" {:.2} {:>3.0}%", l.intensity, weights.get(i).copied().unwrap_or(0.0) * 100.0)),
            ]);
            buf.set_line(area.x, y, &line, area.width);
        }
        if usize::from(list_rows) > n {
            let y = list_area.y + n as u16;
            let more = if keys { " · f lists them" } else { "" };
            let text = format!("keyframes {} new{more}", state.preview.keyframes.len());
            buf.set_stringn(area.x, y, text, usize::from(area.width), Style::new().fg(Color::DarkGray));
        }
    }
}
