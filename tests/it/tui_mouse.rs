//! The mouse (issue 30): a click selects a matrix cell or swatch, a click or drag on a slider's bar sets
//! the selected cell's value (one undo step per press), a click or drag on the light dial moves its
//! slider. Fed as replay steps (`click`, `drag`, `release`), which reach `update` as `Msg::Mouse`; the
//! positions are read off the drawn screen, so a click lands where the view drew the thing.

use crate::tui_support;

use metamer::tui::app::{Focus, Selection};
use metamer::tui::colour::ColourMode;
use metamer::tui::graphics::Graphics;
use tui_support::{demo_palette, replay, state};

/// Column (in characters) and row of the first place `needle` is drawn on the screen `text`.
fn find(text: &str, needle: &str) -> (u16, u16) {
    let (y, line) = text.lines().enumerate().find(|(_, l)| l.contains(needle)).unwrap_or_else(|| panic!("{needle}"));
    let x = line[..line.find(needle).unwrap()].chars().count();
    (x as u16, y as u16)
}

#[test]
fn a_click_selects_a_cell_and_a_swatch() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "", 80, 24);
    // The column of light 3 (tungsten) and the row of reflectance 3 (tissue).
    let (lx, _) = find(&text, "tungsten");
    let (_, ry) = find(&text, "tissue");
    let (text, _) = replay(&mut s, &format!("click {} {}\nrelease {} {}", lx + 2, ry, lx + 2, ry), 80, 24);
    let p = &s.doc.palette;
    let light = p.lights.iter().position(|l| l.name == "tungsten").unwrap();
    let reflectance = p.reflectances.iter().position(|r| r.name == "tissue").unwrap();
    assert_eq!(s.ui.selection, Selection { col: light + 1, row: reflectance + 1 });
    assert!(text.contains("tungsten × tissue"), "{text}");
    snap!("mouse_cell_80x24", text);
    // The second row of a two-row cell is the same cell; the name column is the reflectance's swatch; the
    // light's swatch row selects the light.
    replay(&mut s, &format!("click {} {}", lx + 2, ry + 1), 80, 24);
    assert_eq!(s.ui.selection, Selection { col: light + 1, row: reflectance + 1 });
    replay(&mut s, &format!("click 3 {ry}"), 80, 24);
    assert_eq!(s.ui.selection, Selection { col: 0, row: reflectance + 1 });
    let (_, sy) = find(&text, "████");
    replay(&mut s, &format!("click {} {sy}", lx + 2), 80, 24);
    assert_eq!(s.ui.selection, Selection { col: light + 1, row: 0 });
    // A click on nothing (the top-left corner, the border) changes nothing.
    replay(&mut s, "click 0 0\nclick 2 1", 80, 24);
    assert_eq!(s.ui.selection, Selection { col: light + 1, row: 0 });
    assert!(!s.ui.quit && s.ui.popup.is_none());
}

#[test]
fn a_drag_on_a_slider_sets_it_in_one_undo_step() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // daylight × block, a cell with a colour goal.
    let (text, _) = replay(&mut s, "Down", 80, 24);
    let before = s.doc.palette.clone();
    let undo_steps = s.doc.history.undo.len();
    // The R bar of the selected cell: from two columns right of `R` to before the value.
    let (rx, ry) = find(&text, "│ R ");
    let bar_start = rx + 4;
    let line = text.lines().nth(usize::from(ry)).unwrap();
    let bar: String =
        line.chars().skip(usize::from(bar_start)).take_while(|c| *c == '█' || *c == '▌' || *c == '·').collect();
    let bar_width = bar.chars().count() as u16;
    assert!(bar_width >= 10, "{line}");
    // Press in the middle of the bar: R is half way (display sRGB), the sliders have the focus.
    let mid = bar_start + (bar_width - 1) / 2;
    replay(&mut s, &format!("click {mid} {ry}"), 80, 24);
    let (light, reflectance) = (0, 1);
    assert!(before.cell(light, reflectance).is_some());
    let r = |s: &metamer::tui::State| {
        metamer::colorimetry::srgb_encode(s.doc.palette.cell(light, reflectance).unwrap().target[0])
    };
    let expect = f64::from((bar_width - 1) / 2) / f64::from(bar_width - 1);
    assert!((r(&s) - expect).abs() <= 0.5 / 255.0 + 1e-9, "R {} for {expect}", r(&s));
    assert_eq!((s.ui.focus, s.ui.slider), (Focus::Sliders, 0));
    // Drag to the bar's end (and past it, on another row): R is 1; G and B did not move.
    let (text, buf) = replay(
        &mut s,
        &format!("drag {} {ry}\ndrag {} {}\nrelease 70 3", bar_start + bar_width - 1, 75, ry + 2),
        80,
        24,
    );
    assert!((r(&s) - 1.0).abs() < 1e-9, "R {}", r(&s));
    let (old, new) =
        (before.cell(light, reflectance).unwrap().target, s.doc.palette.cell(light, reflectance).unwrap().target);
    assert_eq!((old[1], old[2]), (new[1], new[2]));
    assert!(s.ui.drag.is_none());
    snap!("mouse_slider_dragged_80x24", text);
    // The bar is drawn full, in red, on the cells; the focused slider is marked.
    assert!(text.lines().nth(usize::from(ry)).unwrap().contains("│›R"), "{text}");
    assert_eq!(buf[(rx + 4 + bar_width - 1, ry)].fg, ratatui::style::Color::Red);
    // Press and drag were one undo step.
    assert_eq!(s.doc.history.undo.len(), undo_steps + 1);
    replay(&mut s, "z", 80, 24);
    assert_eq!(s.doc.palette.colours, before.colours);
    // A drag with no press before it does nothing.
    replay(&mut s, &format!("drag {mid} {ry}"), 80, 24);
    assert_eq!(s.doc.palette.colours, before.colours);
}

#[test]
fn a_click_on_the_dial_moves_its_slider() {
    let palette = demo_palette();
    let scene = metamer::render::Scene::builtin(palette.clone(), 32).expect("built-in scene");
    let mut s = state(palette, ColourMode::TrueColor);
    s.preview.graphics = Graphics::halfblocks();
    s.set_preview_scene(scene);
    let (text, _) = replay(&mut s, "", 80, 24);
    let start = s.preview.dial_state().unwrap().clone();
    // Click the mark of light 2: the slider goes to (about) its vertex; the frame is relit.
    let (x2, y2) = find(&text, "●2");
    let frame = s.preview.frame.clone();
    let (text, _) = replay(&mut s, &format!("click {x2} {y2}\nrelease {x2} {y2}"), 80, 24);
    let d = s.preview.dial_state().unwrap();
    let v = d.lights[1].position;
    let [[x0, y0], [x1, y1]] = start.bounds();
    let extent = (x1 - x0).max(y1 - y0);
    let off = (d.slider[0] - v[0]).hypot(d.slider[1] - v[1]);
    assert!(off < 0.2 * extent, "slider {:?}, vertex 2 at {v:?}", d.slider);
    assert_ne!(d.slider, start.slider);
    assert_ne!(s.preview.frame, frame, "the preview relights");
    snap!("mouse_dial_80x24", text);
    // The slider mark is drawn on the cell clicked.
    let (sx, sy) = find(&text, "◆");
    assert!(sx.abs_diff(x2) <= 1 && sy == y2, "◆ at {sx},{sy}, clicked {x2},{y2}\n{text}");
    // A drag moves it further: to light 1's mark (the screen cell whose dial point, as the view lays
    // the canvas out, is nearest light 1's vertex; the view draws ● there).
    let v1 = s.preview.dial_state().unwrap().lights[0].position;
    let dist = |x: u16, y: u16| match metamer::tui::ui::hit::hit(&s, x, y) {
        Some(metamer::tui::ui::hit::Hit::Dial(p)) => (p[0] - v1[0]).hypot(p[1] - v1[1]),
        _ => f64::INFINITY,
    };
    let (x1m, y1m) = (0..80u16)
        .flat_map(|x| (0..24u16).map(move |y| (x, y)))
        .min_by(|a, b| dist(a.0, a.1).total_cmp(&dist(b.0, b.1)))
        .unwrap();
    assert_eq!(text.lines().nth(usize::from(y1m)).and_then(|l| l.chars().nth(usize::from(x1m))), Some('●'), "{text}");
    replay(&mut s, &format!("click {sx} {sy}\ndrag {x1m} {y1m}\nrelease {x1m} {y1m}"), 80, 24);
    let d = s.preview.dial_state().unwrap();
    let v = d.lights[0].position;
    assert!((d.slider[0] - v[0]).hypot(d.slider[1] - v[1]) < 0.2 * extent, "{:?} vs {v:?}", d.slider);
    // Mouse clicks do nothing while a popup is open.
    let sel = s.ui.selection;
    replay(&mut s, "?\nclick 20 5", 80, 24);
    assert_eq!(s.ui.selection, sel);
}

/// On a screen too narrow for the sliders beside the matrix (one line under it), a click on `G 0.36`
/// focuses that slider for the arrow keys.
#[test]
fn a_click_on_a_one_line_slider_focuses_it() {
    let palette = metamer::palette::PaletteFile::load(std::path::Path::new(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/palettes/metamers.toml"
    )))
    .expect("palette")
    .palette;
    let mut s = state(palette, ColourMode::TrueColor);
    // tungsten × petal (a cell with a target of its own, not in a free group).
    let (text, _) = replay(&mut s, "Down\nRight", 80, 24);
    let (gx, gy) = find(&text, "G 0.");
    assert!(!text.contains("│ G "), "one-line sliders at 80×24:\n{text}");
    let (text, buf) = replay(&mut s, &format!("click {} {gy}", gx + 2), 80, 24);
    assert_eq!((s.ui.focus, s.ui.slider), (Focus::Sliders, 1));
    assert!(text.contains("←/→ change the slider"), "{text}");
    assert!(buf[(gx, gy)].modifier.contains(ratatui::style::Modifier::REVERSED));
    let before = s.doc.palette.colours.clone();
    replay(&mut s, "Right", 80, 24);
    assert_ne!(s.doc.palette.colours, before, "the arrow keys change the clicked slider");
}

#[test]
fn mouse_steps_are_read_from_scripts() {
    use metamer::tui::replay::parse_script;
    assert!(parse_script("click 3 4\ndrag 5 4\nrelease 5 4").is_ok());
    let e = parse_script("Down\nclick 3").unwrap_err();
    assert_eq!(e.line, 2);
    assert!(e.to_string().contains("click|drag|release COLUMN ROW"), "{e}");
}
