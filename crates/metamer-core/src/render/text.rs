//! Text for pictures: the font the project ships (DejaVu Sans, see data/fonts/DejaVu-LICENSE.txt),
//! embedded so labels render the same on every machine, rasterised with ab_glyph into coverage masks
//! and blended onto 8-bit RGB(A) buffers. The dial overlay's names and the contact sheets' labels
//! both go through here; the application's bench plots register the same bytes with their plotting
//! library.

use ab_glyph::{Font, FontRef, PxScale, ScaleFont};

/// The embedded font (DejaVu Sans).
pub static FONT: &[u8] = include_bytes!("../../../../data/fonts/DejaVuSans.ttf");

/// The embedded font, parsed. It is a known-good TTF compiled into the binary, so parsing can fail
/// only if the file in the repository were replaced by something else; then text is left out (and
/// the label tests fail).
pub(crate) fn font() -> Option<FontRef<'static>> {
    FontRef::try_from_slice(FONT).ok()
}

/// A text line rasterised once: coverage in 0..=255, row-major.
#[derive(Clone, Debug)]
pub(crate) struct Label {
    pub(crate) width: usize,
    pub(crate) height: usize,
    pub(crate) coverage: Vec<u8>,
}

/// Rasterise `text` (control characters left out) at `px` pixels.
pub(crate) fn rasterise(font: &FontRef<'_>, text: &str, px: f32) -> Label {
    let scaled = font.as_scaled(PxScale::from(px));
    let ascent = scaled.ascent();
    let height = (scaled.ascent() - scaled.descent()).ceil().max(1.0) as usize + 1;
    let mut glyphs = Vec::new();
    let mut x = 0.0f32;
    let mut prev = None;
    for c in text.chars().filter(|c| !c.is_control()) {
        let id = scaled.glyph_id(c);
        if let Some(p) = prev {
            x += scaled.kern(p, id);
        }
        glyphs.push(id.with_scale_and_position(PxScale::from(px), ab_glyph::point(x, ascent)));
        x += scaled.h_advance(id);
        prev = Some(id);
    }
    let width = x.ceil().max(1.0) as usize + 1;
    let mut coverage = vec![0u8; width * height];
    for g in glyphs {
        if let Some(o) = font.outline_glyph(g) {
            let b = o.px_bounds();
            o.draw(|gx, gy, c| {
                let (px_, py_) = (b.min.x as i64 + gx as i64, b.min.y as i64 + gy as i64);
                if px_ >= 0 && py_ >= 0 && (px_ as usize) < width && (py_ as usize) < height {
                    let i = py_ as usize * width + px_ as usize;
                    coverage[i] = coverage[i].max((c.clamp(0.0, 1.0) * 255.0).round() as u8);
                }
            });
        }
    }
    Label { width, height, coverage }
}

/// `label` dilated by `r` pixels (each pixel the largest coverage within a disc of radius `r`), `2r`
/// larger each way: drawn under the text in the background's colour, it keeps lines off the letters.
pub(crate) fn halo(label: &Label, r: usize) -> Label {
    let (w, h) = (label.width + 2 * r, label.height + 2 * r);
    let mut coverage = vec![0u8; w * h];
    let ri = r as i64;
    let offsets: Vec<(i64, i64)> = (-ri..=ri)
        .flat_map(|dy| (-ri..=ri).map(move |dx| (dx, dy)))
        .filter(|(dx, dy)| dx * dx + dy * dy <= ri * ri + ri)
        .collect();
    for ly in 0..label.height {
        for lx in 0..label.width {
            let c = label.coverage[ly * label.width + lx];
            if c == 0 {
                continue;
            }
            for &(dx, dy) in &offsets {
                let (x, y) = ((lx as i64 + ri + dx) as usize, (ly as i64 + ri + dy) as usize);
                let i = y * w + x;
                coverage[i] = coverage[i].max(c);
            }
        }
    }
    Label { width: w, height: h, coverage }
}

/// Blend `label` in `colour` (opacity `alpha`) into an interleaved 8-bit buffer of `channels`
/// (3 or 4; only the first three are written) per pixel, `width × height`, its top-left at `(x0, y0)`;
/// what falls outside is clipped.
#[allow(clippy::too_many_arguments)]
pub(crate) fn blit(
    data: &mut [u8],
    channels: usize,
    width: usize,
    height: usize,
    label: &Label,
    (x0, y0): (i64, i64),
    colour: [u8; 3],
    alpha: f32,
) {
    let (w, h) = (width as i64, height as i64);
    for ly in 0..label.height {
        let y = y0 + ly as i64;
        if !(0..h).contains(&y) {
            continue;
        }
        for lx in 0..label.width {
            let x = x0 + lx as i64;
            let c = label.coverage[ly * label.width + lx];
            if c == 0 || !(0..w).contains(&x) {
                continue;
            }
            let a = f32::from(c) / 255.0 * alpha;
            let i = (y * w + x) as usize * channels;
            for ch in 0..3 {
                let v = f32::from(data[i + ch]) * (1.0 - a) + f32::from(colour[ch]) * a;
                data[i + ch] = v.round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_embedded_font_parses_and_text_has_ink() {
        let f = font().expect("embedded font");
        let l = rasterise(&f, "frame 12", 13.0);
        assert!(l.width > 30 && l.height >= 13, "{}×{}", l.width, l.height);
        assert!(l.coverage.iter().filter(|&&c| c > 128).count() > 20);
        let blank = rasterise(&f, "\u{1b}\u{7}", 13.0);
        assert!(blank.coverage.iter().all(|&c| c == 0), "control characters draw nothing");
    }

    #[test]
    fn a_halo_grows_the_ink_and_keeps_it_centred() {
        let f = font().expect("embedded font");
        let l = rasterise(&f, "ab", 16.0);
        let h = halo(&l, 2);
        assert_eq!((h.width, h.height), (l.width + 4, l.height + 4));
        let ink = |l: &Label| l.coverage.iter().filter(|&&c| c > 128).count();
        assert!(ink(&h) > ink(&l) * 3 / 2, "{} vs {}", ink(&h), ink(&l));
        // Every inked pixel of the label is inked in the halo at the same place (shifted by r).
        for y in 0..l.height {
            for x in 0..l.width {
                assert!(h.coverage[(y + 2) * h.width + x + 2] >= l.coverage[y * l.width + x]);
            }
        }
    }

    #[test]
    fn blit_clips_and_blends() {
        let f = font().expect("embedded font");
        let l = rasterise(&f, "W", 20.0);
        let (w, h) = (8, 8);
        let mut rgb = vec![0u8; w * h * 3];
        blit(&mut rgb, 3, w, h, &l, (-3, -3), [255, 255, 255], 1.0);
        assert!(rgb.iter().any(|&v| v > 0), "the visible part is drawn");
        let mut rgba = vec![7u8; w * h * 4];
        blit(&mut rgba, 4, w, h, &l, (0, 0), [255, 0, 0], 1.0);
        assert!(rgba.chunks(4).all(|p| p[3] == 7), "alpha channel untouched");
    }
}
