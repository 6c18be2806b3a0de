//! The light dial drawn into a frame, lower right, as in the seed's Figs. 6 and 7: a dark panel, the
//! dial's outline (the polygon through the vertices in angular order), the slider's trail, each light's
//! vertex as a disc in its own colour (its colour on a white reflectance) with its name — hollow when
//! the light is off — and the slider point (yellow). Shapes are antialiased with tiny-skia; names are
//! rasterised once with the font the project ships (DejaVu Sans, see data/fonts/DejaVu-LICENSE.txt), so
//! a frame costs only the panel's few thousand pixels. Drawing is deterministic: the same state gives
//! the same bytes.

use super::dial::{Dial, DialState, Sweep};
use super::text::{self, Label};
use crate::colorimetry::Colorimetry;
use crate::spectrum::Spectrum;
use tiny_skia::{Color, FillRule, LineCap, LineJoin, Paint, PathBuilder, Pixmap, Stroke, Transform};

/// Frames smaller than this (pixels, the shorter side) get no dial: it would not be legible.
pub(crate) const MIN_FRAME: usize = 96;

/// Everything about a sweep's dial drawing that does not change between frames.
#[derive(Clone, Debug)]
pub struct DialOverlay {
    /// Each light's colour (8-bit sRGB) on a white reflectance, brightest channel at full scale.
    colours: Vec<[u8; 3]>,
    labels: Vec<Label>,
    /// The dial-coordinate box every state of the sweep fits in (so the drawing does not jump).
    bounds: [[f64; 2]; 2],
    /// Panel side in pixels.
    side: usize,
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

impl DialOverlay {
    /// The overlay of `dial` for frames of `width × height` pixels.
    pub fn new(dial: &Dial, colorimetry: &Colorimetry, width: usize, height: usize) -> DialOverlay {
        let side = (width.min(height) as f64 * 0.3).round() as usize;
        let font = text::font();
        let px = (side as f32 / 10.0).clamp(9.0, 28.0);
        let lights = &dial.base.lights;
        let colours = lights.iter().map(|l| light_colour(colorimetry, &l.spectrum)).collect();
        let labels = lights
            .iter()
            .map(|l| match &font {
                Some(f) => text::rasterise(f, &l.name, px),
                None => Label { width: 0, height: 0, coverage: Vec::new() },
            })
            .collect();
        let mut bounds = dial.base.bounds();
        if let Sweep::Keyframes(k) = &dial.sweep {
            for s in k {
                bounds = union(bounds, s.bounds());
            }
        }
        DialOverlay { colours, labels, bounds, side }
    }

    /// Whether a frame of this size gets a dial.
    pub(crate) fn fits(&self, width: usize, height: usize) -> bool {
        width.min(height) >= MIN_FRAME && self.side > 0
    }

    /// Draw frame `k` of `n` of `dial` into `rgb` (8-bit RGB, `width × height`).
    pub fn draw_frame(&self, rgb: &mut [u8], width: usize, height: usize, dial: &Dial, k: usize, n: usize) {
        let t = Dial::position(k, n);
        self.draw(rgb, width, height, &dial.state_at(t), &dial.trail(t));
    }

    /// Draw `state` with the slider's `trail` into `rgb` (8-bit RGB, `width × height`).
    pub fn draw(&self, rgb: &mut [u8], width: usize, height: usize, state: &DialState, trail: &[[f64; 2]]) {
        if !self.fits(width, height) || rgb.len() < width * height * 3 {
            return;
        }
        let side = self.side;
        let margin = (width.min(height) / 64).max(2);
        let (x0, y0) = (width - side - margin, height - side - margin);
        let Some(mut pm) = Pixmap::new(side as u32, side as u32) else { return };
        // The frame's pixels under the panel, opaque.
        for (row, chunk) in pm.data_mut().chunks_exact_mut(side * 4).enumerate() {
            let src = &rgb[((y0 + row) * width + x0) * 3..((y0 + row) * width + x0 + side) * 3];
            for (d, s) in chunk.chunks_exact_mut(4).zip(src.chunks_exact(3)) {
                d[..3].copy_from_slice(s);
                d[3] = 255;
            }
        }
        let s = side as f32;
        let pad = s * 0.16;
        let [[bx0, by0], [bx1, by1]] = self.bounds;
        let span = (bx1 - bx0).max(by1 - by0).max(1e-9);
        let (cx, cy) = ((bx0 + bx1) / 2.0, (by0 + by1) / 2.0);
        let scale = f64::from(s - 2.0 * pad) / span;
        let map = |p: [f64; 2]| -> (f32, f32) {
            (s / 2.0 + ((p[0] - cx) * scale) as f32, s / 2.0 - ((p[1] - cy) * scale) as f32)
        };
        let mut paint = Paint { anti_alias: true, ..Paint::default() };
        let line =
            |w: f32| Stroke { width: w, line_cap: LineCap::Round, line_join: LineJoin::Round, ..Stroke::default() };
        // Panel.
        let r = s * 0.08;
        if let Some(path) = rounded_rect(1.0, 1.0, s - 2.0, s - 2.0, r) {
            paint.set_color(Color::from_rgba8(16, 16, 20, 170));
            pm.fill_path(&path, &paint, FillRule::Winding, Transform::identity(), None);
            paint.set_color(Color::from_rgba8(220, 220, 220, 140));
            pm.stroke_path(&path, &paint, &line(1.0), Transform::identity(), None);
        }
        // Outline: the vertices in angular order around their centroid.
        let lights = &state.lights;
        if lights.len() >= 2 {
            let n = lights.len() as f64;
            let mx = lights.iter().map(|l| l.position[0]).sum::<f64>() / n;
            let my = lights.iter().map(|l| l.position[1]).sum::<f64>() / n;
            let mut order: Vec<usize> = (0..lights.len()).collect();
            let angle = |i: usize| (lights[i].position[1] - my).atan2(lights[i].position[0] - mx);
            order.sort_by(|&a, &b| angle(a).total_cmp(&angle(b)));
            let mut pb = PathBuilder::new();
            for (j, &i) in order.iter().enumerate() {
                let (x, y) = map(lights[i].position);
                if j == 0 { pb.move_to(x, y) } else { pb.line_to(x, y) }
            }
            if lights.len() > 2 {
                pb.close();
            }
            if let Some(path) = pb.finish() {
                paint.set_color(Color::from_rgba8(200, 200, 210, 200));
                pm.stroke_path(&path, &paint, &line((s / 120.0).max(1.0)), Transform::identity(), None);
            }
        }
        // Trail.
        if trail.len() >= 2 {
            let mut pb = PathBuilder::new();
            for (j, p) in trail.iter().enumerate() {
                let (x, y) = map(*p);
                if j == 0 { pb.move_to(x, y) } else { pb.line_to(x, y) }
            }
            if let Some(path) = pb.finish() {
                paint.set_color(Color::from_rgba8(255, 220, 60, 150));
                pm.stroke_path(&path, &paint, &line((s / 60.0).max(1.5)), Transform::identity(), None);
            }
        }
        // Vertices.
        let rv = (s / 22.0).max(3.0);
        for (i, l) in lights.iter().enumerate() {
            let (x, y) = map(l.position);
            let colour = self.colours.get(i).copied().unwrap_or([128; 3]);
            let Some(circle) = PathBuilder::from_circle(x, y, rv) else { continue };
            if l.on {
                paint.set_color(rgba(colour, 255));
                pm.fill_path(&circle, &paint, FillRule::Winding, Transform::identity(), None);
                paint.set_color(Color::from_rgba8(255, 255, 255, 230));
                pm.stroke_path(&circle, &paint, &line((rv / 4.0).max(1.0)), Transform::identity(), None);
            } else {
                paint.set_color(Color::from_rgba8(0, 0, 0, 160));
                pm.stroke_path(&circle, &paint, &line((rv / 2.0).max(1.5)), Transform::identity(), None);
                paint.set_color(rgba(colour, 255));
                pm.stroke_path(&circle, &paint, &line((rv / 3.5).max(1.0)), Transform::identity(), None);
            }
        }
        // Slider.
        let (sx, sy) = map(state.slider);
        if let Some(circle) = PathBuilder::from_circle(sx, sy, rv * 0.85) {
            paint.set_color(Color::from_rgba8(255, 220, 40, 255));
            pm.fill_path(&circle, &paint, FillRule::Winding, Transform::identity(), None);
            paint.set_color(Color::from_rgba8(40, 30, 0, 255));
            pm.stroke_path(&circle, &paint, &line((rv / 4.0).max(1.0)), Transform::identity(), None);
        }
        // Names, placed outside the vertex (away from the dial's centre), kept inside the panel.
        for (i, l) in lights.iter().enumerate() {
            let Some(label) = self.labels.get(i) else { continue };
            if label.width == 0 {
                continue;
            }
            let (x, y) = map(l.position);
            let (dx, dy) = (x - s / 2.0, y - s / 2.0);
            let lx = if dx >= 0.0 { x + rv + 2.0 } else { x - rv - 2.0 - label.width as f32 };
            let ly = if dy > s * 0.1 { y + rv * 0.5 } else { y - rv * 0.5 - label.height as f32 };
            let lx = lx.clamp(3.0, (s - label.width as f32 - 3.0).max(3.0)).round() as i64;
            let ly = ly.clamp(3.0, (s - label.height as f32 - 3.0).max(3.0)).round() as i64;
            let alpha = if l.on { 1.0 } else { 0.6 };
            let (pw, ph) = (pm.width() as usize, pm.height() as usize);
            text::blit(pm.data_mut(), 4, pw, ph, label, (lx + 1, ly + 1), [0, 0, 0], alpha * 0.8);
            text::blit(pm.data_mut(), 4, pw, ph, label, (lx, ly), [255, 255, 255], alpha);
        }
        // Back into the frame.
        for (row, chunk) in pm.data().chunks_exact(side * 4).enumerate() {
            let dst = &mut rgb[((y0 + row) * width + x0) * 3..((y0 + row) * width + x0 + side) * 3];
            for (d, s) in dst.chunks_exact_mut(3).zip(chunk.chunks_exact(4)) {
                d.copy_from_slice(&s[..3]);
            }
        }
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
mod tests {
    use super::*;
    use crate::render::dial::{DialLight, DialState};

    fn dial() -> Dial {
        let mut s = DialState::new(vec![
            DialLight::new("red", Spectrum::flat(1.0), [0.0, 1.0]),
            DialLight::new("green", Spectrum::flat(1.0), [1.0, 0.0]),
            DialLight::new("blue", Spectrum::flat(1.0), [-1.0, 0.0]),
        ])
        .unwrap();
        let k0 = s.clone();
        s.set_on(1, false).unwrap();
        s.set_slider([0.2, 0.3]).unwrap();
        Dial::keyframes(k0.clone(), vec![k0, s]).unwrap()
    }

    #[test]
    fn draws_only_the_lower_right_panel_and_deterministically() {
        let (w, h) = (200, 160);
        let d = dial();
        let o = DialOverlay::new(&d, &Colorimetry::default(), w, h);
        let blank = vec![90u8; w * h * 3];
        let mut a = blank.clone();
        o.draw_frame(&mut a, w, h, &d, 1, 2);
        let mut b = blank.clone();
        o.draw_frame(&mut b, w, h, &d, 1, 2);
        assert_eq!(a, b);
        let changed: Vec<(usize, usize)> =
            (0..w * h).filter(|&i| a[i * 3..i * 3 + 3] != blank[i * 3..i * 3 + 3]).map(|i| (i % w, i / w)).collect();
        assert!(changed.len() > 500, "{} pixels changed", changed.len());
        assert!(changed.iter().all(|&(x, y)| x >= w / 2 && y >= h / 2));
        // The slider's yellow is there; a different state draws differently.
        assert!(a.chunks_exact(3).any(|p| p[0] > 240 && p[1] > 200 && p[2] < 80));
        let mut c = blank.clone();
        o.draw_frame(&mut c, w, h, &d, 0, 2);
        assert_ne!(a, c);
        // Too small a frame: nothing drawn.
        let mut tiny = vec![0u8; 64 * 64 * 3];
        let o = DialOverlay::new(&d, &Colorimetry::default(), 64, 64);
        o.draw_frame(&mut tiny, 64, 64, &d, 0, 1);
        assert!(tiny.iter().all(|&v| v == 0));
    }

    #[test]
    fn light_colour_of_a_white_light_is_white_and_of_a_dark_light_grey() {
        let col = Colorimetry::default();
        let e = Spectrum::illuminant("D65").unwrap();
        let c = light_colour(&col, &e);
        assert!(c.iter().all(|&v| v > 240), "{c:?}");
        assert_eq!(light_colour(&col, &Spectrum::flat(0.0)), [128, 128, 128]);
    }
}
