//! Where the light dial's vertex labels go: each label beside its vertex on the side away from the dial's
//! centre (right or left for a vertex beside the centre, above or below for one over or under it, the other
//! sides when those are taken), never over another label or any mark (vertices, the slider), and with a
//! blank cell between it and another label or a foreign mark on its row. A name that does not fit is
//! shortened with `…`; when not even one letter fits, the label is the light's number alone, and when that
//! does not fit either the vertex has no label.

use ratatui::text::Span;

/// A label placed at column `x`, row `y` (cells, relative to the dial's area).
#[derive(Clone, Debug, PartialEq, Eq)]
pub(crate) struct Placed {
    pub(crate) x: u16,
    pub(crate) y: u16,
    pub(crate) text: String,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    Right,
    Left,
    Above,
    Below,
}

/// The sides to try for a vertex at `(dx, dy)` cells from the centre (rows grow downwards; a cell is about
/// twice as high as wide), the side facing away from the centre first.
fn sides(dx: f64, dy: f64) -> [Side; 4] {
    let out_h = if dx < 0.0 { Side::Left } else { Side::Right };
    let in_h = if out_h == Side::Left { Side::Right } else { Side::Left };
    let out_v = if dy > 0.0 { Side::Below } else { Side::Above };
    let in_v = if out_v == Side::Below { Side::Above } else { Side::Below };
    if dx.abs() >= 2.0 * dy.abs() { [out_h, out_v, in_v, in_h] } else { [out_v, out_h, in_h, in_v] }
}

fn width(text: &str) -> usize {
    Span::raw(text).width()
}

/// `name` cut to at most `cols` columns, ending in `…` when cut (`None` when not even one letter fits).
pub(crate) fn shorten(name: &str, cols: usize) -> Option<String> {
    if width(name) <= cols {
        return Some(name.to_string());
    }
    let mut out = String::new();
    for c in name.chars() {
        if width(&out) + width(&c.to_string()) + 1 > cols {
            break;
        }
        out.push(c);
    }
    (!out.is_empty()).then(|| format!("{out}…"))
}

/// The label texts for light `number` called `name` on `side`, longest first: the whole name, the name
/// shortened letter by letter, the number alone. The number sits next to the vertex.
fn variants(number: usize, name: &str, side: Side) -> Vec<String> {
    let n = width(name);
    let mut out: Vec<String> = (1..=n)
        .rev()
        .filter_map(|cols| shorten(name, cols))
        .map(|s| if side == Side::Left { format!("{s} {number}") } else { format!("{number} {s}") })
        .collect();
    out.dedup();
    out.push(number.to_string());
    out
}

/// Lay out the labels of vertices at `marks[i]` (cells in a `width × height` area, light number i + 1
/// called `names[i]`) around `centre`; `others` are further marks no label may cover (the slider).
/// Vertices are labelled in order; each takes the longest text that fits on any of its sides, in the
/// order of [`sides`].
pub(crate) fn layout(
    area: (u16, u16),
    marks: &[(u16, u16)],
    others: &[(u16, u16)],
    names: &[&str],
    centre: (f64, f64),
) -> Vec<Option<Placed>> {
    let (w, h) = (usize::from(area.0), usize::from(area.1));
    // 0 free, 1 a mark, 2 a label.
    let mut grid = vec![0u8; w * h];
    for &(x, y) in marks.iter().chain(others) {
        if usize::from(x) < w && usize::from(y) < h {
            grid[usize::from(y) * w + usize::from(x)] = 1;
        }
    }
    let mut placed = Vec::with_capacity(marks.len());
    for (i, (&(mx, my), name)) in marks.iter().zip(names).enumerate() {
        let (mx, my) = (i64::from(mx), i64::from(my));
        let dx = mx as f64 - centre.0;
        let dy = my as f64 - centre.1;
        let fits = |x: i64, y: i64, len: i64, grid: &[u8]| -> bool {
            if x < 0 || y < 0 || x + len > w as i64 || y >= h as i64 {
                return false;
            }
            let at = |cx: i64| grid[y as usize * w + cx as usize];
            if (x..x + len).any(|cx| at(cx) != 0) {
                return false;
            }
            // A blank cell on either end, unless that end touches the label's own vertex.
            let own = |cx: i64| cx == mx && y == my;
            let clear = |cx: i64| cx < 0 || cx >= w as i64 || own(cx) || at(cx) == 0;
            clear(x - 1) && clear(x + len)
        };
        let mut found = None;
        let order = sides(dx, dy);
        let longest: Vec<Vec<String>> = order.iter().map(|&s| variants(i + 1, name, s)).collect();
        let rounds = longest.iter().map(Vec::len).max().unwrap_or(0);
        'outer: for k in 0..rounds {
            for (side, texts) in order.iter().zip(&longest) {
                let Some(text) = texts.get(k) else { continue };
                let len = width(text) as i64;
                let (x, y) = match side {
                    Side::Right => (mx + 1, my),
                    Side::Left => (mx - len, my),
                    Side::Above | Side::Below => {
                        let y = if *side == Side::Above { my - 1 } else { my + 1 };
                        // Centred over the vertex, moved in to fit the area.
                        let x = (mx - (len - 1) / 2).min(w as i64 - len).max(0);
                        (x, y)
                    }
                };
                if fits(x, y, len, &grid) {
                    found = Some(Placed { x: x as u16, y: y as u16, text: text.clone() });
                    break 'outer;
                }
            }
        }
        if let Some(p) = &found {
            let start = usize::from(p.y) * w + usize::from(p.x);
            grid[start..start + width(&p.text)].fill(2);
        }
        placed.push(found);
    }
    placed
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cells(p: &Placed) -> Vec<(u16, u16)> {
        (0..width(&p.text) as u16).map(|k| (p.x + k, p.y)).collect()
    }

    /// No label covers a mark or another label, or leaves the area, or touches another label on its row.
    fn check(area: (u16, u16), marks: &[(u16, u16)], others: &[(u16, u16)], placed: &[Option<Placed>]) {
        let mut seen: Vec<(u16, u16)> = Vec::new();
        for p in placed.iter().flatten() {
            for c in cells(p) {
                assert!(c.0 < area.0 && c.1 < area.1, "{p:?} leaves the {area:?} area");
                assert!(!marks.contains(&c) && !others.contains(&c), "{p:?} covers a mark at {c:?}");
                assert!(!seen.contains(&c), "{p:?} overlaps another label at {c:?}");
            }
            for q in placed.iter().flatten().filter(|q| *q != p && q.y == p.y) {
                let (a, b) = (i32::from(p.x), i32::from(p.x) + width(&p.text) as i32);
                let (c, d) = (i32::from(q.x), i32::from(q.x) + width(&q.text) as i32);
                assert!(b < c || d < a, "{p:?} and {q:?} touch");
            }
            seen.extend(cells(p));
        }
    }

    #[test]
    fn labels_face_away_from_the_centre() {
        let marks = [(14, 1), (24, 5), (8, 5), (14, 9)];
        let names = ["top", "right", "left", "bottom"];
        let placed = layout((34, 11), &marks, &[], &names, (14.0, 5.0));
        check((34, 11), &marks, &[], &placed);
        let p: Vec<Placed> = placed.into_iter().map(|p| p.expect("room for every label")).collect();
        assert_eq!((p[0].y, p[0].text.as_str()), (0, "1 top"), "above the top vertex");
        assert_eq!((p[1].x, p[1].y, p[1].text.as_str()), (25, 5, "2 right"), "right of the right vertex");
        assert_eq!((p[2].x + width(&p[2].text) as u16, p[2].text.as_str()), (8, "left 3"), "left of the left one");
        assert_eq!((p[3].y, p[3].text.as_str()), (10, "4 bottom"), "below the bottom vertex");
    }

    #[test]
    fn crowded_labels_are_shortened_then_numbers_then_dropped() {
        // Two vertices on a one-row area: five cells beside each, no room for whole names.
        let marks = [(5, 0), (10, 0)];
        let names = ["daylight", "tungsten"];
        let placed = layout((16, 1), &marks, &[], &names, (7.5, 0.0));
        check((16, 1), &marks, &[], &placed);
        assert_eq!(placed[0].as_ref().map(|p| (p.x, p.text.as_str())), Some((0, "da… 1")), "{placed:?}");
        assert_eq!(placed[1].as_ref().map(|p| (p.x, p.text.as_str())), Some((11, "2 tu…")), "{placed:?}");
        let texts: Vec<&str> = placed.iter().flatten().map(|p| p.text.as_str()).collect();
        assert_eq!(texts.len(), 2, "{placed:?}");
        assert!(texts.iter().all(|t| t.contains('…')), "{texts:?}");
        // A 1-row area with marks every other cell: only numbers fit, or nothing.
        let marks = [(0, 0), (2, 0), (4, 0)];
        let placed = layout((6, 1), &marks, &[], &["a", "b", "c"], (2.0, 0.0));
        check((6, 1), &marks, &[], &placed);
        assert!(placed.iter().flatten().all(|p| p.text.len() == 1), "{placed:?}");
        let placed = layout((3, 1), &[(0, 0), (1, 0), (2, 0)], &[], &["a", "b", "c"], (1.0, 0.0));
        assert!(placed.iter().all(Option::is_none), "{placed:?}");
    }

    #[test]
    fn shortening_counts_columns() {
        assert_eq!(shorten("daylight", 8).as_deref(), Some("daylight"));
        assert_eq!(shorten("daylight", 5).as_deref(), Some("dayl…"));
        assert_eq!(shorten("daylight", 2).as_deref(), Some("d…"));
        assert_eq!(shorten("daylight", 1), None);
        assert_eq!(variants(3, "abc", Side::Left), vec!["abc 3", "a… 3", "3"]);
        assert_eq!(variants(3, "ab", Side::Right), vec!["3 ab", "3"], "`a…` is no shorter than `ab`");
    }

    #[test]
    fn random_dials_never_overlap() {
        // A small linear congruential generator: deterministic vertex sets of 2 to 8 lights.
        let mut seed = 0x2545_f491_u64;
        let mut next = |m: u16| {
            seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
            ((seed >> 33) % u64::from(m)) as u16
        };
        let names = ["daylight", "tungsten", "split", "glow", "fluorescent", "hide", "north sky", "candle"];
        for _ in 0..500 {
            let area = (12 + next(30), 4 + next(14));
            let n = 2 + usize::from(next(7));
            let marks: Vec<(u16, u16)> = (0..n).map(|_| (next(area.0), next(area.1))).collect();
            let slider = [(next(area.0), next(area.1))];
            let placed = layout(area, &marks, &slider, &names[..n], (f64::from(area.0) / 2.0, f64::from(area.1) / 2.0));
            check(area, &marks, &slider, &placed);
        }
    }
}
