//! The colours the designer draws, checked on buffer cells (text snapshots drop styles).

use crate::tui_support;

use metamer::colorimetry::{Colorimetry, linear_to_srgb8};
use metamer::spectrum::Spectrum;
use metamer::tui::colour::{ColourMode, nearest_xterm256};
use metamer::tui::ui::matrix::geometry;
use metamer::tui::ui::{areas, buffer_text};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier};
use tui_support::{demo_palette, replay, state};

fn rgb(c: [u8; 3]) -> Color {
    Color::Rgb(c[0], c[1], c[2])
}

/// Screen position of the top-left character of the cell (light j, reflectance i), when no scrolling.
fn cell_origin(s: &metamer::tui::State, buf: &Buffer, j: usize, i: usize) -> (u16, u16) {
    let inner = Rect { x: 1, y: 1, width: buf.area.width - 2, height: buf.area.height - 2 };
    let a = areas(s, inner);
    let g = geometry(s, a.matrix);
    let x = g.column_x(j).expect("column shown");
    (a.matrix.x + x as u16 + 1, a.matrix.y + (2 + g.row_height * i) as u16)
}

#[test]
fn cells_show_desired_full_and_model_colours() {
    let p = demo_palette();
    let c = Colorimetry::default();
    let mut s = state(p.clone(), ColourMode::TrueColor);
    let (_, buf) = replay(&mut s, "", 100, 30);
    // Cell daylight × block has target #6a7b5c and is in use.
    let (x, y) = cell_origin(&s, &buf, 0, 1);
    let desired = &buf[(x, y)];
    assert_eq!(desired.symbol(), "▌");
    assert_eq!(desired.fg, Color::Rgb(0x6a, 0x7b, 0x5c));
    let model = &buf[(x + 1, y)];
    assert_eq!(model.symbol(), "▀");
    // `block` is designed: the achieved colour is that of its solved spectrum.
    let solved = &s.solve.current().expect("the demo palette solves").palette;
    assert_ne!(solved.reflectances[1].spectrum, p.reflectances[1].spectrum);
    let full = linear_to_srgb8(&c.rgb(&p.lights[0].spectrum, &solved.reflectances[1].spectrum));
    assert_eq!(model.fg, rgb(full), "top half: full 31-sample colour");
    // Without a basis the subspace half repeats the full colour.
    assert_eq!(model.bg, rgb(full));
    assert!(!model.modifier.contains(Modifier::DIM));
    // Light swatch: the light on flat white.
    let swatch = linear_to_srgb8(&c.rgb(&p.lights[1].spectrum, &Spectrum::flat(1.0)));
    let (lx, _) = cell_origin(&s, &buf, 1, 0);
    assert_eq!(buf[(lx, 2)].fg, rgb(swatch));
}

#[test]
fn unused_cells_are_dimmed_and_designed_spectra_marked() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, buf) = replay(&mut s, "", 100, 30);
    // split × tissue has `use = false`; skin × daylight has no criterion at all.
    for (j, i) in [(2, 2), (0, 0)] {
        let (x, y) = cell_origin(&s, &buf, j, i);
        assert!(buf[(x + 1, y)].modifier.contains(Modifier::DIM), "cell ({j}, {i}) should be dimmed");
    }
    let (x, y) = cell_origin(&s, &buf, 2, 2);
    assert_eq!(buf[(x + 5, y)].symbol(), "○");
    // `D` beside the designed reflectances, in the design colour; none beside the fixed light `split`.
    let (x, _) = cell_origin(&s, &buf, 2, 0);
    assert_eq!(buf[(x + 5, 2)].symbol(), " ");
    assert!(text.contains("block   ██ D"));
    assert!(text.contains("tissue  ██ D"));
    let line = text.lines().position(|l| l.contains("block   ██ D")).expect("block's row on screen");
    let column = text.lines().nth(line).and_then(|l| l.chars().position(|c| c == 'D')).expect("a D marker");
    assert_eq!(buf[(column as u16, line as u16)].fg, Color::LightRed);
}

#[test]
fn the_256_colour_mode_uses_the_nearest_palette_entry() {
    let mut s = state(demo_palette(), ColourMode::Indexed256);
    let (_, buf) = replay(&mut s, "", 100, 30);
    let (x, y) = cell_origin(&s, &buf, 0, 1);
    assert_eq!(buf[(x, y)].fg, Color::Indexed(nearest_xterm256([0x6a, 0x7b, 0x5c])));
}

/// Issue 30, defect 11: without `COLORTERM` two targets a viewer tells apart (a brick red and a mauve) got the
/// same entry (131) by sRGB distance; nearest in CIELAB their swatches differ.
#[test]
fn the_256_colour_mode_keeps_distinct_targets_apart() {
    use metamer::colorimetry::hex_to_linear;
    let mut p = demo_palette();
    let (brick, mauve) = ("#b45c3d", "#a05571");
    for (c, hex) in p.colours.iter_mut().filter(|c| c.free.is_none()).take(2).zip([brick, mauve]) {
        c.target = hex_to_linear(hex).expect("a hex colour");
    }
    let cells: Vec<(usize, usize)> =
        p.colours.iter().filter(|c| c.free.is_none()).take(2).map(|c| (c.light, c.reflectance)).collect();
    let mut s = state(p, ColourMode::Indexed256);
    let (_, buf) = replay(&mut s, "", 100, 30);
    let fg = |(j, i): (usize, usize)| {
        let (x, y) = cell_origin(&s, &buf, j, i);
        buf[(x, y)].fg
    };
    let (a, b) = (fg(cells[0]), fg(cells[1]));
    assert_eq!(a, Color::Indexed(nearest_xterm256([0xb4, 0x5c, 0x3d])));
    assert_eq!(b, Color::Indexed(nearest_xterm256([0xa0, 0x55, 0x71])));
    assert_ne!(a, b, "two distinct targets share one terminal colour");
}

#[test]
fn selection_brackets_follow_the_arrows() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (_, buf) = replay(&mut s, "Right\nDown", 100, 30);
    let (x, y) = cell_origin(&s, &buf, 1, 1);
    assert_eq!(buf[(x - 1, y)].symbol(), "[");
    assert_eq!(buf[(x + 4, y + 1)].symbol(), "]");
    assert_eq!(buf[(x - 1, y)].fg, Color::LightGreen);
    let text = buffer_text(&buf);
    assert!(text.contains("tungsten × block"));
}

#[test]
fn subspace_halves_show_the_trained_basis_colour() {
    use metamer::tui::replay::MemorySaver;
    use metamer::tui::worker::BasisMode;
    let p = demo_palette();
    let mut s = state(p.clone(), ColourMode::TrueColor);
    let (text, buf) =
        tui_support::replay_with(&mut s, "", 100, 30, &mut MemorySaver::default(), BasisMode::Train { sidecar: None });
    let shown = s.solve.basis.clone().expect("the replay waits for the basis");
    assert_eq!(Some(&shown.key), s.solve.derived.basis_key.as_ref(), "the basis is the shown spectra's");
    let basis = shown.basis();
    assert_eq!(basis.dimension(), p.settings.basis_dimension);
    let solved = &s.solve.current().expect("solved").palette;
    // skin (fixed) under tungsten: bottom half = factor-model colour, top half = full colour.
    let (x, y) = cell_origin(&s, &buf, 1, 0);
    let (e, r) = (&solved.lights[1].spectrum, &solved.reflectances[0].spectrum);
    assert_eq!(buf[(x + 1, y)].bg, rgb(linear_to_srgb8(&basis.rgb_factor(e, r))));
    assert_eq!(buf[(x + 1, y)].fg, rgb(linear_to_srgb8(&Colorimetry::default().rgb(e, r))));
    assert!(text.contains("V7 ΔE"), "{text}");
    assert!(!text.contains("V7 n/a"), "{text}");
}

/// The spectra pane names its curves in its header, each name in its curve's colour, and draws no legend
/// box over the plot (issue 30, defect 8: the box hid a tungsten light's peak), at both sizes.
#[test]
fn the_spectra_pane_names_its_curves_in_the_header_in_their_colours() {
    for (w, h) in [(100u16, 30u16), (80, 24)] {
        let p = demo_palette();
        let mut s = state(p.clone(), ColourMode::TrueColor);
        let (_, buf) = replay(&mut s, "", w, h);
        let row_text = |y: u16| (0..w).map(|x| buf[(x, y)].symbol().to_string()).collect::<String>();
        let y = (0..h).find(|&y| row_text(y).contains(" spectra ─ ")).expect("the spectra header");
        // The text drawn in each colour on the header row. (Below it, `└` is the axes' corner; a legend box would
        // bring the other three.)
        let in_colour = |colour: Color| {
            (0..w).filter(|&x| buf[(x, y)].fg == colour).map(|x| buf[(x, y)].symbol().to_string()).collect::<String>()
        };
        let light = in_colour(Color::Yellow);
        let refl = in_colour(Color::Cyan);
        assert!(
            p.lights.iter().any(|l| light.trim() == format!("{} (light)", l.name)),
            "{light:?} in {:?}",
            row_text(y)
        );
        assert!(
            p.reflectances.iter().any(|r| refl.trim() == format!("{} (reflectance{})", r.name, if r.design { ", designed" } else { "" })),
            "{refl:?} in {:?}",
            row_text(y)
        );
        for y in y + 1..h - 1 {
            for x in 1..w - 1 {
                let c = buf[(x, y)].symbol();
                assert!(!"┌┐┘".contains(c), "a box corner {c:?} at ({x}, {y}) under the spectra header");
            }
        }
    }
}

/// After editing a setting the settings row keeps the focus and says so: its header names its keys in
/// the focus colour; ↓ (there is no row below) says which keys work, ↑ goes back to the matrix (issue 30,
/// defect 6: the focus was hard to see and ↑ did nothing).
#[test]
fn the_focused_settings_row_shows_its_keys_and_up_leaves_it() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let header = " settings · ←/→ field · enter edit · ↑ back ";
    let (text, buf) = replay(&mut s, "Tab\nTab\nRight *5\nEnter\nCtrl-u\n\"0.01\"\nEnter", 80, 24);
    assert_eq!(s.doc.palette.settings.smoothness, 0.01);
    let y = (0..24).find(|&y| (0..80).map(|x| buf[(x, y)].symbol()).collect::<String>().contains(header));
    let y = y.unwrap_or_else(|| panic!("no focused settings header in\n{text}"));
    let row: String = (0..80).map(|x| buf[(x, y)].symbol()).collect();
    let x0 = row[..row.find(header).unwrap_or(0)].chars().count() as u16;
    assert!((x0..x0 + 10).all(|x| buf[(x + 1, y)].fg == Color::LightGreen), "{row}");
    let (text, _) = replay(&mut s, "Down", 80, 24);
    assert!(text.contains("settings is the last row"), "{text}");
    let (text, _) = replay(&mut s, "Up", 80, 24);
    assert!(!text.contains(header) && text.contains(" settings "), "{text}");
    // Back in the matrix, the arrows move the selection again.
    let before = s.ui.selection.row;
    replay(&mut s, "Down", 80, 24);
    assert_eq!(s.ui.selection.row, before + 1, "↓ in the matrix moves the selection");
}
