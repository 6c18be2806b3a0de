//! The light dial drawn into a frame, as in the seed's Figs. 6 and 7: an opaque dark panel, the dial's
//! outline (the polygon through the vertices in angular order), the slider's trail, each light's vertex
//! as a disc in its own colour (its colour on a white reflectance) — a ring when the light is off — the
//! slider as a white reticle with a dark outline (a hollow ring with four ticks outward, a shape no vertex
//! has), and the
//! lights' names drawn last, each on a halo of the panel's colour so no line runs through a name.
//!
//! Layout: the text size follows the frame (about 1/36 of its shorter side, 9–20 px); the dial's
//! vertices span about 1/6 of the shorter side; every name sits outside its vertex (and clear of the
//! slider's reticle when the slider is on that vertex), on the side away from the dial's centre unless
//! another vertex or name is there. The panel is the box of everything any state of the sweep draws
//! (every keyframe's vertices, names and slider) plus a margin, so nothing is clipped and the drawing
//! does not jump between frames. A panel that would be more than 45 % of the frame's width or height is
//! drawn smaller; frames under 96 pixels, or where even 6 px text does not fit, get no dial.
//!
//! Placement: one corner per sweep. [`DialOverlay::choose_corner`] picks the corner whose panel covers
//! the least of the raycast image (the sum of each covered pixel's largest channel, so faint smoke counts
//! little and a dense surface much); ties go lower right (the seed's place), lower left, upper right,
//! upper left. The raycast is the same for every frame, so every frame — and every run over a part of
//! the sweep — puts the dial in the same corner.
//!
//! Shapes are antialiased with tiny-skia; names are rasterised once with the font the project ships
//! (DejaVu Sans, see data/fonts/DejaVu-LICENSE.txt), so a frame costs only the panel's pixels. Drawing
//! is deterministic: the same state gives the same bytes.

use super::dial::{Dial, DialState, Sweep};
use super::raycast::ChannelImage;
use super::text::{self, Label};
use crate::colorimetry::Colorimetry;
use crate::spectrum::Spectrum;
use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// Frames smaller than this (pixels, the shorter side) get no dial: it would not be legible.
pub(crate) const MIN_FRAME: usize = 96;

/// The largest share of the frame's width or height the panel may take.
const MAX_SHARE: f32 = 0.45;

/// The smallest text the dial is drawn with; below it the frame gets no dial.
const MIN_TEXT_PX: f32 = 6.0;

/// The panel's fill (opaque) and border.
const PANEL: [u8; 3] = [18, 18, 22];
const BORDER: [u8; 3] = [150, 150, 160];

/// Which corner of the frame holds the dial.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Corner {
    /// The lower right corner (`lower-right`), the seed's placement and the first tried.
    LowerRight,
    /// The lower left corner (`lower-left`).
    LowerLeft,
    /// The upper right corner (`upper-right`).
    UpperRight,
    /// The upper left corner (`upper-left`).
    UpperLeft,
}

impl Corner {
    /// Every corner, in the order ties are broken (the seed's lower right first).
    pub const ALL: [Corner; 4] = [Corner::LowerRight, Corner::LowerLeft, Corner::UpperRight, Corner::UpperLeft];

    /// The name on the command line: `lower-right`, `lower-left`, `upper-right`, `upper-left`.
    pub fn as_str(self) -> &'static str {
        match self {
            Corner::LowerRight => "lower-right",
            Corner::LowerLeft => "lower-left",
            Corner::UpperRight => "upper-right",
            Corner::UpperLeft => "upper-left",
        }
    }

    /// The corner called `name` (see [`Corner::as_str`]).
    pub fn parse(name: &str) -> Option<Corner> {
        Corner::ALL.into_iter().find(|c| c.as_str() == name)
    }
}

/// The dial's layout at one frame size.
#[derive(Clone, Debug)]
struct Geometry {
    /// Text size and vertex radius, pixels.
    px: f32,
    rv: f32,
    /// Dial coordinates → panel pixels: `x = origin.0 + (p.x − centre.x)·scale`, y flipped.
    scale: f64,
    centre: [f64; 2],
    origin: (f32, f32),
    /// Panel width and height, pixels.
    panel: (usize, usize),
    /// Gap between the panel and the frame's edge.
    margin: usize,
    labels: Vec<Label>,
    /// Each label dilated by `halo` pixels (drawn first, in the panel's colour).
    halos: Vec<Label>,
    halo: usize,
}

impl Geometry {
    fn map(&self, p: [f64; 2]) -> (f32, f32) {
        (
            self.origin.0 + ((p[0] - self.centre[0]) * self.scale) as f32,
            self.origin.1 - ((p[1] - self.centre[1]) * self.scale) as f32,
        )
    }

    /// Radius of the slider's ring, and how far its ticks reach.
    fn reticle(&self) -> (f32, f32) {
        (self.rv * 1.45, self.rv * 2.05)
    }

    /// Width of the reticle's white stroke (its black outline is 2 px wider).
    fn reticle_stroke(&self) -> f32 {
        (self.rv * 0.34).max(1.2)
    }

    /// How far the slider's white strokes reach from its centre (the ticks' ends). A name's halo, in
    /// the panel's near-black, may cover the black outline beyond, not the white.
    fn marker_reach(&self) -> f32 {
        self.reticle().1 + self.reticle_stroke() / 2.0
    }

    /// The box of the slider's white strokes at `state`'s slider, grown by the names' halo (panel
    /// pixels).
    fn marker_box(&self, state: &DialState) -> Rect {
        let (sx, sy) = self.map(state.slider);
        let r = self.marker_reach() + self.halo as f32;
        [sx - r, sy - r, sx + r, sy + r]
    }

    /// How far a name keeps from its vertex's centre: its halo clear of the reticle's white with the
    /// slider on the vertex.
    fn clearance(&self) -> f32 {
        self.marker_reach() + self.halo as f32
    }
}

/// Everything about a sweep's dial drawing that does not change between frames.
#[derive(Clone, Debug)]
pub struct DialOverlay {
    /// Each light's colour (8-bit sRGB) on a white reflectance, brightest channel at full scale.
    colours: Vec<[u8; 3]>,
    names: Vec<String>,
    /// The states whose drawings the panel must hold (see [`sweep_states`]).
    states: Vec<DialState>,
    /// The dial-coordinate box every state of the sweep fits in (so the drawing does not jump).
    bounds: [[f64; 2]; 2],
    width: usize,
    height: usize,
    corner: Corner,
    /// None: the frame is too small for a legible dial.
    geometry: Option<Geometry>,
}

/// A light's colour on a white reflectance as 8-bit sRGB, scaled so its brightest channel is 1.
pub(crate) fn light_colour(colorimetry: &Colorimetry, light: &Spectrum) -> [u8; 3] {
    let rgb = colorimetry.rgb(light, &Spectrum::flat(1.0));
    let peak = rgb.max();
    if !(peak.is_finite() && peak > 1e-12) {
        return [128, 128, 128];
    }
    let enc = |v: f64| {
        let v = (v / peak).clamp(0.0, 1.0);
        let s = if v <= 0.003_130_8 { 12.92 * v } else { 1.055 * v.powf(1.0 / 2.4) - 0.055 };
        (s * 255.0).round() as u8
    };
    [enc(rgb[0]), enc(rgb[1]), enc(rgb[2])]
}

fn union(a: [[f64; 2]; 2], b: [[f64; 2]; 2]) -> [[f64; 2]; 2] {
    [[a[0][0].min(b[0][0]), a[0][1].min(b[0][1])], [a[1][0].max(b[1][0]), a[1][1].max(b[1][1])]]
}

fn rgba(c: [u8; 3], a: u8) -> Color {
    Color::from_rgba8(c[0], c[1], c[2], a)
}

/// An axis-aligned box `[x0, y0, x1, y1]`.
type Rect = [f32; 4];

fn overlap(a: Rect, b: Rect) -> f32 {
    let w = (a[2].min(b[2]) - a[0].max(b[0])).max(0.0);
    let h = (a[3].min(b[3]) - a[1].max(b[1])).max(0.0);
    w * h
}

/// Where names must not go: the slider's drawing (a name there would hide it), and, once the panel
/// is laid out, the outside of the panel.
#[derive(Clone, Copy, Debug)]
struct Keep {
    /// The slider's box (see [`Geometry::marker_box`]).
    marker: Rect,
    /// The box names must stay inside (names' halos included), when known.
    within: Option<Rect>,
}

/// Top-left corners of the names of vertices at `points` (pixels), each `clearance` from its vertex:
/// the first of four places (outward from `centre` first) that overlaps least, in this order of
/// weight, the outside of `keep.within`, the slider's box, the other vertices' discs (radius `disc`)
/// and the names already placed. `halo` grows each name's box.
fn place_labels(
    points: &[(f32, f32)],
    sizes: &[(f32, f32)],
    centre: (f32, f32),
    clearance: f32,
    disc: f32,
    halo: f32,
    keep: Keep,
) -> Vec<(f32, f32)> {
    let mut placed: Vec<Rect> = Vec::with_capacity(points.len());
    let mut out = Vec::with_capacity(points.len());
    for (i, (&(x, y), &(w, h))) in points.iter().zip(sizes).enumerate() {
        let (dx, dy) = (x - centre.0, y - centre.1);
        let right = (x + clearance, y - h / 2.0);
        let left = (x - clearance - w, y - h / 2.0);
        let above = (x - w / 2.0, y - clearance - h);
        let below = (x - w / 2.0, y + clearance);
        let (side, other_side) = if dx >= 0.0 { (right, left) } else { (left, right) };
        let (vert, other_vert) = if dy > 0.0 { (below, above) } else { (above, below) };
        let candidates = if dy.abs() > dx.abs() {
            [vert, side, other_side, other_vert]
        } else {
            [side, vert, other_vert, other_side]
        };
        let score = |(lx, ly): (f32, f32)| {
            let r = [lx, ly, lx + w, ly + h];
            let discs: f32 = points
                .iter()
                .enumerate()
                .filter(|&(j, _)| j != i)
                .map(|(_, &(px, py))| overlap(r, [px - disc, py - disc, px + disc, py + disc]))
                .sum();
            let haloed = [lx - halo, ly - halo, lx + w + halo, ly + h + halo];
            let outside = keep.within.map_or(0.0, |b| {
                let area = (haloed[2] - haloed[0]) * (haloed[3] - haloed[1]);
                area - overlap(haloed, b)
            });
            let marker = if w > 0.0 { overlap(haloed, keep.marker) } else { 0.0 };
            outside * 1e6 + marker * 1e3 + discs + placed.iter().map(|&p| overlap(r, p)).sum::<f32>()
        };
        let mut best = candidates[0];
        let mut best_score = score(best);
        for &c in &candidates[1..] {
            let s = score(c);
            if s < best_score - 0.5 {
                best = c;
                best_score = s;
            }
        }
        placed.push([best.0, best.1, best.0 + w, best.1 + h]);
        out.push(best);
    }
    out
}

/// Points along a sweep, besides its keyframes, whose drawings the panel holds (so a name that moves
/// off the slider's way finds room in the panel).
const SWEEP_SAMPLES: usize = 32;

/// The states whose drawings a sweep's panel must hold: the dial at rest, every keyframe and
/// [`SWEEP_SAMPLES`] points along the sweep.
fn sweep_states(dial: &Dial) -> Vec<DialState> {
    let mut states = vec![dial.base.clone()];
    if let Sweep::Keyframes(k) = &dial.sweep {
        states.extend(k.iter().cloned());
    }
    states.extend((0..=SWEEP_SAMPLES).map(|k| dial.frame_state(k, SWEEP_SAMPLES + 1)));
    states
}

/// The centroid of a state's vertices (what names are placed away from).
fn centroid(state: &DialState) -> [f64; 2] {
    let n = state.lights.len().max(1) as f64;
    [
        state.lights.iter().map(|l| l.position[0]).sum::<f64>() / n,
        state.lights.iter().map(|l| l.position[1]).sum::<f64>() / n,
    ]
}

/// The names' top-left corners (panel pixels) in `state`.
fn label_positions(g: &Geometry, state: &DialState) -> Vec<(f32, f32)> {
    let points: Vec<(f32, f32)> = state.lights.iter().map(|l| g.map(l.position)).collect();
    let sizes: Vec<(f32, f32)> = state
        .lights
        .iter()
        .enumerate()
        .map(|(i, _)| g.labels.get(i).map_or((0.0, 0.0), |l| (l.width as f32, l.height as f32)))
        .collect();
    let within = (g.panel.0 > 0).then_some([1.0, 1.0, g.panel.0 as f32 - 1.0, g.panel.1 as f32 - 1.0]);
    let keep = Keep { marker: g.marker_box(state), within };
    place_labels(&points, &sizes, g.map(centroid(state)), g.clearance(), g.rv * 1.3, g.halo as f32, keep)
}

/// The layout at text size `px`: the panel is the box of every state's drawing plus a margin.
fn layout(states: &[DialState], bounds: [[f64; 2]; 2], names: &[String], px: f32, margin: usize) -> Geometry {
    let labels: Vec<Label> = match text::font() {
        Some(f) => names.iter().map(|n| text::rasterise(&f, n, px)).collect(),
        None => names.iter().map(|_| Label { width: 0, height: 0, coverage: Vec::new() }).collect(),
    };
    let halo = ((px / 8.0).round() as usize).max(1);
    let halos = labels.iter().map(|l| text::halo(l, halo)).collect();
    let [[bx0, by0], [bx1, by1]] = bounds;
    let span = (bx1 - bx0).max(by1 - by0).max(1e-9);
    let mut g = Geometry {
        px,
        rv: (px * 0.36).max(2.5),
        scale: f64::from(px * 6.0) / span,
        centre: [(bx0 + bx1) / 2.0, (by0 + by1) / 2.0],
        origin: (0.0, 0.0),
        panel: (0, 0),
        margin,
        labels,
        halos,
        halo,
    };
    // The box of everything drawn, with the dial's centre at the origin.
    let mut b: Rect = [f32::INFINITY, f32::INFINITY, f32::NEG_INFINITY, f32::NEG_INFINITY];
    let mut grow = |r: Rect| b = [b[0].min(r[0]), b[1].min(r[1]), b[2].max(r[2]), b[3].max(r[3])];
    let reach = (g.marker_reach() + 1.0).max(g.reticle().1 + g.rv * 0.3);
    let h = g.halo as f32;
    for state in states {
        let mut centres: Vec<(f32, f32)> = state.lights.iter().map(|l| g.map(l.position)).collect();
        centres.push(g.map(state.slider));
        for (x, y) in centres {
            grow([x - reach, y - reach, x + reach, y + reach]);
        }
        for (i, (lx, ly)) in label_positions(&g, state).into_iter().enumerate() {
            if let Some(l) = g.labels.get(i).filter(|l| l.width > 0) {
                grow([lx - h, ly - h, lx + l.width as f32 + h, ly + l.height as f32 + h]);
            }
        }
    }
    let pad = (px * 0.6).max(3.0);
    g.origin = ((pad - b[0]).round(), (pad - b[1]).round());
    g.panel = ((b[2] - b[0] + 2.0 * pad).ceil() as usize + 1, (b[3] - b[1] + 2.0 * pad).ceil() as usize + 1);
    g
}

/// The layout for a `width × height` frame: text 1/36 of the shorter side (9–20 px), shrunk until the
/// panel takes at most [`MAX_SHARE`] of the frame; None when that needs text under [`MIN_TEXT_PX`].
fn geometry(
    states: &[DialState],
    bounds: [[f64; 2]; 2],
    names: &[String],
    width: usize,
    height: usize,
) -> Option<Geometry> {
    let m = width.min(height);
    if m < MIN_FRAME {
        return None;
    }
    let margin = (m / 64).max(2);
    let mut px = (m as f32 / 36.0).clamp(9.0, 20.0);
    for _ in 0..16 {
        let g = layout(states, bounds, names, px, margin);
        let (mw, mh) = (MAX_SHARE * width as f32, MAX_SHARE * height as f32);
        let (pw, ph) = (g.panel.0 as f32, g.panel.1 as f32);
        if pw <= mw && ph <= mh {
            return Some(g);
        }
        px *= ((mw / pw).min(mh / ph) * 0.98).min(0.95);
        if px < MIN_TEXT_PX {
            return None;
        }
    }
    None
}

impl DialOverlay {
    /// The overlay of `dial` for frames of `width × height` pixels, in the lower right (see
    /// [`DialOverlay::choose_corner`]).
    pub fn new(dial: &Dial, colorimetry: &Colorimetry, width: usize, height: usize) -> DialOverlay {
        let lights = &dial.base.lights;
        let colours = lights.iter().map(|l| light_colour(colorimetry, &l.spectrum)).collect();
        let names: Vec<String> = lights.iter().map(|l| l.name.clone()).collect();
        let states = sweep_states(dial);
        let bounds = states.iter().map(DialState::bounds).fold(dial.base.bounds(), union);
        let geometry = geometry(&states, bounds, &names, width, height);
        DialOverlay { colours, names, states, bounds, width, height, corner: Corner::LowerRight, geometry }
    }

    /// The same dial laid out for frames of another size (a contact sheet's tiles), in the same corner.
    pub fn for_size(&self, width: usize, height: usize) -> DialOverlay {
        let geometry = geometry(&self.states, self.bounds, &self.names, width, height);
        DialOverlay { width, height, geometry, ..self.clone() }
    }

    /// The corner the dial is drawn in.
    pub fn corner(&self) -> Corner {
        self.corner
    }

    /// Draw the dial in `corner`.
    pub fn set_corner(&mut self, corner: Corner) {
        self.corner = corner;
    }

    /// Put the dial in the corner where its panel hides least of `image` (the view's raycast; any
    /// size, mapped onto the frame's): the sum over the panel of each pixel's largest absolute channel.
    /// Ties go in the order of [`Corner::ALL`]. Returns the corner chosen.
    pub fn choose_corner(&mut self, image: &ChannelImage) -> Corner {
        let k = image.channels;
        if k == 0 || image.width == 0 || image.height == 0 || image.data.len() < image.width * image.height * k {
            return self.corner;
        }
        let mut best: Option<(f64, Corner)> = None;
        for c in Corner::ALL {
            let Some([x0, y0, w, h]) = self.rect_at(c, self.width, self.height) else { continue };
            let sx = |x: usize| (x * image.width).div_ceil(self.width.max(1)).min(image.width);
            let sy = |y: usize| (y * image.height).div_ceil(self.height.max(1)).min(image.height);
            let mut score = 0.0f64;
            for y in sy(y0)..sy(y0 + h) {
                let row = &image.data[(y * image.width + sx(x0)) * k..(y * image.width + sx(x0 + w)) * k];
                score +=
                    row.chunks_exact(k).map(|p| f64::from(p.iter().fold(0.0f32, |a, v| a.max(v.abs())))).sum::<f64>();
            }
            if best.is_none_or(|(s, _)| score < s) {
                best = Some((score, c));
            }
        }
        if let Some((_, c)) = best {
            self.corner = c;
        }
        self.corner
    }

    /// The panel `[x, y, width, height]` in a frame of the overlay's size, or None when no dial fits.
    pub fn panel_rect(&self) -> Option<[usize; 4]> {
        self.rect_at(self.corner, self.width, self.height)
    }

    fn rect_at(&self, corner: Corner, width: usize, height: usize) -> Option<[usize; 4]> {
        let g = self.geometry.as_ref()?;
        let ((pw, ph), m) = (g.panel, g.margin);
        if width.min(height) < MIN_FRAME || pw + 2 * m > width || ph + 2 * m > height {
            return None;
        }
        let x = if matches!(corner, Corner::LowerRight | Corner::UpperRight) { width - pw - m } else { m };
        let y = if matches!(corner, Corner::LowerRight | Corner::LowerLeft) { height - ph - m } else { m };
        Some([x, y, pw, ph])
    }

    /// Draw frame `k` of `n` of `dial` into `rgb` (8-bit RGB, `width × height`).
    pub fn draw_frame(&self, rgb: &mut [u8], width: usize, height: usize, dial: &Dial, k: usize, n: usize) {
        let t = Dial::position(k, n);
        self.draw(rgb, width, height, &dial.state_at(t), &dial.trail(t));
    }

    /// Draw `state` with the slider's `trail` into `rgb` (8-bit RGB, `width × height`).
    pub fn draw(&self, rgb: &mut [u8], width: usize, height: usize, state: &DialState, trail: &[[f64; 2]]) {
        let (Some(g), Some([x0, y0, pw, ph])) = (&self.geometry, self.rect_at(self.corner, width, height)) else {
            return;
        };
        if rgb.len() < width * height * 3 {
            return;
        }
        let Some(mut pm) = Pixmap::new(pw as u32, ph as u32) else { return };
        // The frame's pixels under the panel (they show only outside its rounded corners).
        for (row, chunk) in pm.data_mut().chunks_exact_mut(pw * 4).enumerate() {
            let src = &rgb[((y0 + row) * width + x0) * 3..((y0 + row) * width + x0 + pw) * 3];
            for (d, s) in chunk.chunks_exact_mut(4).zip(src.chunks_exact(3)) {
                d[..3].copy_from_slice(s);
                d[3] = 255;
            }
        }
        draw_panel(&mut pm, g, &self.colours, state, trail);
        // Back into the frame.
        for (row, chunk) in pm.data().chunks_exact(pw * 4).enumerate() {
            let dst = &mut rgb[((y0 + row) * width + x0) * 3..((y0 + row) * width + x0 + pw) * 3];
            for (d, s) in dst.chunks_exact_mut(3).zip(chunk.chunks_exact(4)) {
                d.copy_from_slice(&s[..3]);
            }
        }
    }
}

fn line(w: f32) -> Stroke {
    Stroke { width: w, line_cap: LineCap::Round, line_join: LineJoin::Round, ..Stroke::default() }
}

/// The panel, outline, trail, vertices, slider and names, into the panel's pixmap.
fn draw_panel(pm: &mut Pixmap, g: &Geometry, colours: &[[u8; 3]], state: &DialState, trail: &[[f64; 2]]) {
    let (w, h) = (pm.width() as f32, pm.height() as f32);
    let id = Transform::identity();
    let mut paint = Paint { anti_alias: true, ..Paint::default() };
    if let Some(path) = rounded_rect(0.5, 0.5, w - 1.0, h - 1.0, (g.px * 0.5).max(3.0)) {
        paint.set_color(rgba(PANEL, 255));
        pm.fill_path(&path, &paint, FillRule::Winding, id, None);
        paint.set_color(rgba(BORDER, 255));
        pm.stroke_path(&path, &paint, &line(1.0), id, None);
    }
    // Outline: the vertices in angular order around their centroid.
    let lights = &state.lights;
    if lights.len() >= 2 {
        let [mx, my] = centroid(state);
        let mut order: Vec<usize> = (0..lights.len()).collect();
        let angle = |i: usize| (lights[i].position[1] - my).atan2(lights[i].position[0] - mx);
        order.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)));
        let mut pb = PathBuilder::new();
        for (j, &i) in order.iter().enumerate() {
            let (x, y) = g.map(lights[i].position);
            if j == 0 { pb.move_to(x, y) } else { pb.line_to(x, y) }
        }
        if lights.len() > 2 {
            pb.close();
        }
        if let Some(path) = pb.finish() {
            paint.set_color(Color::from_rgba8(150, 150, 162, 255));
            pm.stroke_path(&path, &paint, &line((g.px / 14.0).max(1.0)), id, None);
        }
    }
    // Trail.
    if trail.len() >= 2 {
        let mut pb = PathBuilder::new();
        for (j, p) in trail.iter().enumerate() {
            let (x, y) = g.map(*p);
            if j == 0 { pb.move_to(x, y) } else { pb.line_to(x, y) }
        }
        if let Some(path) = pb.finish() {
            paint.set_color(Color::from_rgba8(235, 175, 45, 220));
            pm.stroke_path(&path, &paint, &line((g.px / 8.0).max(1.5)), id, None);
        }
    }
    // Vertices.
    let rv = g.rv;
    for (i, l) in lights.iter().enumerate() {
        let (x, y) = g.map(l.position);
        let colour = colours.get(i).copied().unwrap_or([128; 3]);
        let Some(circle) = PathBuilder::from_circle(x, y, rv) else { continue };
        if l.on {
            paint.set_color(rgba(colour, 255));
            pm.fill_path(&circle, &paint, FillRule::Winding, id, None);
            paint.set_color(Color::from_rgba8(235, 235, 235, 255));
            pm.stroke_path(&circle, &paint, &line((rv / 4.0).max(1.0)), id, None);
        } else {
            paint.set_color(Color::from_rgba8(0, 0, 0, 255));
            pm.stroke_path(&circle, &paint, &line((rv / 2.0).max(1.5)), id, None);
            paint.set_color(rgba(colour, 255));
            pm.stroke_path(&circle, &paint, &line((rv / 3.5).max(1.0)), id, None);
        }
    }
    // Slider: a white reticle (ring and four ticks) outlined in black, a shape no vertex has.
    let (sx, sy) = g.map(state.slider);
    let (ring, reach) = g.reticle();
    let mut pb = PathBuilder::new();
    pb.push_circle(sx, sy, ring);
    for (ux, uy) in [(1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] {
        pb.move_to(sx + ux * ring, sy + uy * ring);
        pb.line_to(sx + ux * reach, sy + uy * reach);
    }
    if let Some(path) = pb.finish() {
        let width = g.reticle_stroke();
        paint.set_color(Color::from_rgba8(0, 0, 0, 255));
        pm.stroke_path(&path, &paint, &line(width + 2.0), id, None);
        paint.set_color(Color::from_rgba8(255, 255, 255, 255));
        pm.stroke_path(&path, &paint, &line(width), id, None);
    }
    // Names last, each on a halo of the panel's colour.
    let (pw, ph) = (pm.width() as usize, pm.height() as usize);
    let r = g.halo as i64;
    for (i, (lx, ly)) in label_positions(g, state).into_iter().enumerate() {
        let (Some(label), Some(halo)) = (g.labels.get(i), g.halos.get(i)) else { continue };
        if label.width == 0 {
            continue;
        }
        let (lx, ly) = (lx.round() as i64, ly.round() as i64);
        let alpha = if lights.get(i).is_some_and(|l| l.on) { 1.0 } else { 0.6 };
        text::blit(pm.data_mut(), 4, pw, ph, halo, (lx - r, ly - r), PANEL, 1.0);
        text::blit(pm.data_mut(), 4, pw, ph, label, (lx, ly), [255, 255, 255], alpha);
    }
}

fn rounded_rect(x: f32, y: f32, w: f32, h: f32, r: f32) -> Option<tiny_skia::Path> {
    let mut pb = PathBuilder::new();
    pb.move_to(x + r, y);
    pb.line_to(x + w - r, y);
    pb.quad_to(x + w, y, x + w, y + r);
    pb.line_to(x + w, y + h - r);
    pb.quad_to(x + w, y + h, x + w - r, y + h);
    pb.line_to(x + r, y + h);
    pb.quad_to(x, y + h, x, y + h - r);
    pb.line_to(x, y + r);
    pb.quad_to(x, y, x + r, y);
    pb.close();
    pb.finish()
}

#[cfg(test)]
mod tests;
