//! The designer as a daily tool (issue 30): rename, the legend of the marks, search and the command
//! palette, a free cell's colour. Screens at 80×24 (insta snapshots under `snapshots/`), updates
//! checked on the state, colours on cell styles where they matter.

use crate::tui_support;

use metamer::palette::Kind;
use metamer::tui::colour::ColourMode;
use metamer::tui::replay::MemorySaver;
use tui_support::{demo_palette, replay, state};

/// `r` on a cell asks light / reflectance / group; the prompt has the old name typed; the new name shows
/// in the matrix, the message says what happened, a taken name is refused in the prompt, undo restores it
/// and a save writes the renamed palette.
#[test]
fn rename_a_light_a_reflectance_and_a_group() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "r", 80, 24);
    snap!("rename_choose_80x24", text);
    assert!(text.contains("l  the light daylight") && text.contains("r  the reflectance skin"));
    assert!(!text.contains("g  the free-colour group"), "skin × daylight is in no group");
    let (text, _) = replay(&mut s, "l", 80, 24);
    snap!("rename_prompt_80x24", text);
    assert!(text.contains("rename light daylight") && text.contains("› daylight"));
    // A name the other side already uses on this side is refused in the prompt, the palette unchanged.
    let (text, _) = replay(&mut s, "Ctrl-u\n\"tungsten\"\nEnter", 80, 24);
    assert!(text.contains("a light named `tungsten` already exists"), "{text}");
    assert_eq!(s.doc.palette.lights[0].name, "daylight");
    let (text, _) = replay(&mut s, "Ctrl-u\n\"sun\"\nEnter", 80, 24);
    snap!("rename_done_80x24", text);
    assert_eq!(s.doc.palette.lights[0].name, "sun");
    assert!(text.contains("renamed daylight to sun (z undoes)"), "{text}");
    assert!(s.is_dirty());
    // The cell's colours did not change: the cells follow the light by index.
    assert_eq!(s.doc.palette.colours, demo_palette().colours);
    // A reflectance from its swatch (column 0): the prompt opens at once.
    replay(&mut s, "Left\nr\nCtrl-u\n\"ochre\"\nEnter", 80, 24);
    assert_eq!(s.doc.palette.reflectances[0].name, "ochre");
    // The free group of tungsten × tissue: `g` in the choice.
    let (text, _) = replay(&mut s, "Right *2\nDown *2\nr", 80, 24);
    assert!(text.contains("g  the free-colour group A"), "{text}");
    let (text, _) = replay(&mut s, "g\nCtrl-u\n\"warm\"\nEnter", 80, 24);
    assert_eq!(s.doc.palette.free[0].name, "warm");
    assert!(text.contains("renamed A to warm"), "{text}");
    // The matrix marks the group's cells with its new initial, in the group colour.
    assert!(text.lines().any(|l| l.contains("▌▀▀▀ w")), "{text}");
    // Undo steps back through the renames.
    replay(&mut s, "z", 80, 24);
    assert_eq!(s.doc.palette.free[0].name, "A");
    replay(&mut s, "z\nz", 80, 24);
    assert_eq!(
        (s.doc.palette.lights[0].name.as_str(), s.doc.palette.reflectances[0].name.as_str()),
        ("daylight", "skin")
    );
    // Redo, save: the saver gets the renamed palette.
    let mut saver = MemorySaver::default();
    tui_support::replay_saving(&mut s, "Z\nZ\nZ\nCtrl-s", 80, 24, &mut saver);
    let saved = &saver.saved[0];
    assert_eq!(saved.lights[0].name, "sun");
    assert_eq!(saved.reflectances[0].name, "ochre");
    assert_eq!(saved.free[0].name, "warm");
    assert_eq!(saved.entries(Kind::Light).len(), 3);
}

/// `i` opens the legend: every mark the matrix draws, in the matrix's own style (checked on cell styles
/// against the marks on the matrix), wrapped at 80 columns; `q` and `i` close it without quitting.
#[test]
fn the_legend_names_every_mark_in_its_style() {
    use ratatui::style::Color;
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (main, main_buf) = replay(&mut s, "", 80, 24);
    let (text, buf) = replay(&mut s, "i", 80, 24);
    snap!("legend_80x24", text);
    for (symbol, meaning) in [
        ("D", "open to design"),
        ("•", "in use"),
        ("○", "not in use"),
        ("A", "free-colour group"),
        ("[ ]", "the selection"),
        ("▀", "subspace-model"),
        ("●", "unsaved changes"),
        ("⚠N", "diagnostics"),
    ] {
        let line = text.lines().find(|l| l.contains(meaning)).unwrap_or_else(|| panic!("no '{meaning}' in\n{text}"));
        assert!(line.contains(symbol), "{line}");
    }
    // The legend's `D` and `A` have the colours the matrix draws them in.
    let style_of = |buf: &ratatui::buffer::Buffer, text: &str, line_has: &str, symbol: char, from: usize| {
        let y = text.lines().position(|l| l.contains(line_has)).expect("line");
        let x = text.lines().nth(y).unwrap().chars().skip(from).position(|c| c == symbol).expect("symbol") + from;
        buf[(x as u16, y as u16)].fg
    };
    assert_eq!(style_of(&buf, &text, "open to design", 'D', 0), Color::LightRed);
    assert_eq!(style_of(&main_buf, &main, "block", 'D', 0), Color::LightRed);
    assert_eq!(style_of(&buf, &text, "free-colour group (its", 'A', 0), Color::LightMagenta);
    assert_eq!(style_of(&main_buf, &main, "block", 'A', 20), Color::LightMagenta);
    // Nothing cut: every meaning's words are on screen.
    let flat = text.split_whitespace().collect::<Vec<_>>().join(" ");
    for m in ["the solver picks its colour", "another panel has the keys", "nearest by ΔE*ab"] {
        assert!(flat.contains(m) || text.contains(m), "'{m}' missing from\n{text}");
    }
    let (text, _) = replay(&mut s, "q", 80, 24);
    assert!(!s.ui.quit && !text.contains("what the marks mean"));
    replay(&mut s, "i\ni", 80, 24);
    assert!(s.ui.popup.is_none());
}

/// `/` lists the lights, reflectances and cells, filtered by every word typed; Enter jumps there. `:`
/// lists every main-screen action by its help text; Enter runs it (here: the legend, then rename).
#[test]
fn search_jumps_and_the_command_palette_runs_actions() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let (text, _) = replay(&mut s, "/\n\"tiss tung\"", 80, 24);
    snap!("search_80x24", text);
    assert!(text.contains("cell tungsten × tissue"), "{text}");
    assert!(!text.contains("cell daylight × skin"), "{text}");
    replay(&mut s, "Enter", 80, 24);
    assert_eq!((s.ui.selection.col, s.ui.selection.row), (2, 3));
    assert!(s.ui.popup.is_none());
    // A reflectance: the second match of "block" is its cells; the first is the swatch.
    replay(&mut s, "/\n\"block\"\nEnter", 80, 24);
    assert_eq!((s.ui.selection.col, s.ui.selection.row), (0, 2));
    // Nothing matches: Enter keeps the finder open; Esc closes it where it was.
    let (text, _) = replay(&mut s, "/\n\"zzz\"\nEnter", 80, 24);
    assert!(text.contains("nothing matches") && s.ui.popup.is_some(), "{text}");
    replay(&mut s, "Esc", 80, 24);
    assert!(s.ui.popup.is_none());
    assert_eq!((s.ui.selection.col, s.ui.selection.row), (0, 2));
    // The command palette: every main action is listed by name.
    let (text, _) = replay(&mut s, ":\n\"legend\"", 80, 24);
    snap!("commands_80x24", text);
    assert!(text.contains("legend: what the marks mean  (i)"), "{text}");
    let (text, _) = replay(&mut s, "Enter", 80, 24);
    assert!(text.contains("what the marks mean"), "{text}");
    replay(&mut s, "Esc\n:\n\"rename\"\nEnter\nCtrl-u\n\"stone\"\nEnter", 80, 24);
    assert_eq!(s.doc.palette.reflectances[1].name, "stone");
    // Up and Down choose among the matches.
    // "undo" matches undo and reload ("z undoes it"): Down chooses reload, Up undo again.
    let (text, _) = replay(&mut s, ":\n\"undo\"\nDown", 80, 24);
    assert!(text.contains("2 of 2"), "{text}");
    replay(&mut s, "Up\nEnter", 80, 24);
    assert_eq!(s.doc.palette.reflectances[1].name, "block", "undone");
}

/// A free cell has no target of its own: at 80×24 its detail line names its group and shows the
/// group's solved colour (the colour its `▌` has in the matrix), not the stale R, G, B it kept.
#[test]
fn a_free_cell_shows_its_groups_colour_labelled_not_its_old_target() {
    use ratatui::style::Color;
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    // tungsten × tissue, in group A.
    let (text, buf) = replay(&mut s, "Right\nDown *2", 80, 24);
    snap!("free_cell_80x24", text);
    let p = &s.doc.palette;
    let light = p.lights.iter().position(|l| l.name == "tungsten").expect("tungsten");
    let reflectance = p.reflectances.iter().position(|r| r.name == "tissue").expect("tissue");
    let rgb = |c: &nalgebra::Vector3<f64>| {
        let [r, g, b] = metamer::colorimetry::linear_to_srgb8(c);
        Color::Rgb(r, g, b)
    };
    let cell = s.doc.palette.cell(light, reflectance).expect("a cell");
    assert_eq!(cell.free.map(|g| s.doc.palette.free[g].name.as_str()), Some("A"));
    let y = text.lines().position(|l| l.contains("free (group A)")).unwrap_or_else(|| panic!("no label in\n{text}"));
    let line = text.lines().nth(y).unwrap();
    assert!(!line.contains("R 0.") && !line.contains("G 0."), "stale target sliders: {line}");
    let label = line.find("free (group A)").map_or(0, |b| line[..b].chars().count());
    let x = line.chars().skip(label).position(|c| c == '█').expect("a swatch") + label;
    let x = x as u16;
    let swatch = buf[(x, y as u16)].fg;
    let view = s.solve.derived.cell(light, reflectance).expect("a view");
    let desired = view.desired.expect("the group's solved colour");
    assert_eq!(swatch, rgb(&desired));
    assert_ne!(swatch, rgb(&cell.target), "the stale target");
    // The stale target's R, G, B bars are greyed, not in the channels' colours.
    let ry = text.lines().position(|l| l.contains("│ R ")).expect("R slider");
    let rline = text.lines().nth(ry).unwrap();
    let rfrom = rline.find("│ R ").map_or(0, |b| rline[..b].chars().count());
    let rx = (rline.chars().skip(rfrom).position(|c| c == '█').expect("R bar") + rfrom) as u16;
    assert_eq!(buf[(rx, ry as u16)].fg, Color::DarkGray);
    // The matrix's `▌` of that (selected) cell has the same colour.
    let (my, mline) = text.lines().enumerate().find(|(_, l)| l.contains("[▌▀▀▀]A")).expect("the cell's row");
    let mx = mline.find("[▌▀▀▀]A").map(|b| mline[..b].chars().count() + 1).expect("the cell") as u16;
    assert_eq!(buf[(mx, my as u16)].fg, swatch);
}
