//! No key sequence panics the designer or leaves its selection outside the matrix, whatever the palette
//! (including an empty one) and screen size.

use crate::tui_support;

use metamer::palette::Palette;
use metamer::tui::colour::ColourMode;
use proptest::prelude::*;
use tui_support::{demo_palette, replay, state};

/// Keys of every mode, as replay steps.
const KEYS: &[&str] = &[
    "Up",
    "Down",
    "Left",
    "Right",
    "Enter",
    "Esc",
    "Tab",
    "BackTab",
    "PageUp",
    "PageDown",
    "Backspace",
    "#",
    "w",
    "d",
    "u",
    "f",
    "b",
    "F",
    "A",
    "p",
    "n",
    "N",
    "s",
    "L",
    "R",
    "x",
    "B",
    "V",
    "z",
    "Z",
    "!",
    "?",
    "l",
    "r",
    "y",
    "Ctrl-u",
    "\"0.5\"",
    "\"#12ab34\"",
    "\"-1\"",
    "\"G\"",
    "Space",
    "Ctrl-s",
];

proptest! {
    #![proptest_config(ProptestConfig { cases: 24, ..ProptestConfig::default() })]

    #[test]
    fn random_keys_never_panic(
        keys in prop::collection::vec(0..KEYS.len(), 1..40),
        empty in any::<bool>(),
        width in 20u16..130,
        height in 8u16..40,
    ) {
        let palette = if empty { Palette::default() } else { demo_palette() };
        let mut s = state(palette, ColourMode::Indexed256);
        let script: Vec<&str> = keys.iter().map(|k| KEYS[*k]).collect();
        let (text, _) = replay(&mut s, &script.join("\n"), width, height);
        prop_assert_eq!(text.lines().count(), usize::from(height));
        prop_assert!(s.ui.selection.col <= s.doc.palette.lights.len());
        prop_assert!(s.ui.selection.row <= s.doc.palette.reflectances.len());
        prop_assert_eq!(s.solve.derived.cells.len(), s.doc.palette.lights.len() * s.doc.palette.reflectances.len());
    }
}
