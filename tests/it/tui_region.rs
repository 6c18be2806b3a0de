//! The mismatch-region overlay (`m`) at 80×24 (issue 30, defect 7): a target outside the reachable
//! L* (`#00ff00`) still gets its `×` on the plot and a line saying there is no region there (the note
//! was drawn over the `×`); the overlay keeps off the selected cell's column, moving to the left side
//! when the right would cover it.

use crate::tui_support;

use metamer::tui::colour::ColourMode;
use tui_support::{demo_palette, replay, state};

/// The overlay's rows: the characters of each screen row inside its frame (found by its title).
fn overlay(text: &str) -> (usize, Vec<String>) {
    let lines: Vec<&str> = text.lines().collect();
    let top = lines.iter().position(|l| l.contains("┌ reachable")).unwrap_or_else(|| panic!("no overlay\n{text}"));
    let left = lines[top][..lines[top].find("┌ reachable").unwrap()].chars().count();
    let rows = lines[top..]
        .iter()
        .take_while(|l| !l.chars().skip(left).collect::<String>().starts_with('└'))
        .map(|l| l.chars().skip(left).take(46).collect())
        .collect();
    (left, rows)
}

#[test]
fn a_target_out_of_reach_is_marked_and_the_overlay_keeps_off_the_cell() {
    let mut s = state(demo_palette(), ColourMode::TrueColor);
    let p = &s.doc.palette;
    // tungsten × block (block is designed): from daylight × skin, one right and one down.
    assert_eq!((p.lights[1].name.as_str(), p.reflectances[1].name.as_str()), ("tungsten", "block"));
    let script = "Right\nDown\n#\nCtrl-u\n\"#00ff00\"\nEnter\nm\nwait-solve";
    let (text, buf) = replay(&mut s, script, 80, 24);
    snap!("region_out_of_reach_80x24", text);
    let (left, rows) = overlay(&text);
    let plot: String = rows.join("\n");
    assert!(plot.contains('×'), "no × on the plot:\n{text}");
    let flat = plot.replace('│', " ").split_whitespace().collect::<Vec<_>>().join(" ");
    assert!(flat.contains("no region at the target's L* (above the reachable L*): the marks only"), "{text}");
    // The × on the plot (below the title, which names the cell with a ×) is light red, on the cells.
    let top = text.lines().position(|l| l.contains("┌ reachable")).unwrap();
    let (dy, x) = rows
        .iter()
        .enumerate()
        .skip(1)
        .find_map(|(dy, r)| r.chars().position(|c| c == '×').map(|x| (dy, x)))
        .expect("a × on the plot");
    assert_eq!(buf[((left + x) as u16, (top + dy) as u16)].fg, ratatui::style::Color::LightRed);
    // The selected cell's column is not covered: its `[` marks are on screen.
    assert!(text.lines().any(|l| l.contains("[▌▀▀▀]")), "{text}");
}

#[test]
fn the_overlay_moves_left_of_a_cell_in_the_right_columns() {
    let palette = tui_support::square_palette(6);
    let mut s = state(palette, ColourMode::TrueColor);
    // The last light's column, near the right edge at 80 columns, on the second reflectance (a cell
    // with a colour criterion).
    let n = s.doc.palette.lights.len();
    let (text, _) = replay(&mut s, &format!("Right *{n}\nDown *4\nm"), 80, 24);
    assert!(text.contains("reachable · "), "{text}");
    let (left, _) = overlay(&text);
    assert!(left < 10, "the overlay is on the left: column {left}\n{text}");
    assert!(text.lines().any(|l| l.contains("[▌▀▀▀]") || l.contains("[·▀▀▀]")), "{text}");
    snap!("region_left_of_cell_80x24", text);
    // Back on the first column: the overlay is on the right again.
    let (text, _) = replay(&mut s, &format!("Left *{}\nm\nm", n - 1), 80, 24);
    let (left, _) = overlay(&text);
    assert!(left > 20, "column {left}\n{text}");
}
