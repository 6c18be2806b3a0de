//! No input makes the palette parser or the spectrum CSV reader panic: arbitrary strings, byte soup and
//! mutated valid palettes. Whatever parses also saves back unchanged, and random edit sequences made with
//! the palette editing helpers save and load back to the same palette.

use metamer::colorimetry::Colorimetry;
use metamer::palette::PaletteFile;
use metamer::palette::{Kind, Palette, Source, TargetNotation};
use metamer::spectrum::Spectrum;
use metamer::spectrum::{parse_spectrum_csv, parse_spectrum_csv_bytes};
use nalgebra::Vector3;
use proptest::prelude::*;
use std::path::Path;

const EXAMPLE: &str = include_str!("../../palettes/metamers.toml");
const SMALL: &str = r##"name = "p"
[settings]
smoothness = 0.01
reflectance_bounds = [0.0, 1.0]
[[lights]]
name = "d"
illuminant = "D65"
[[lights]]
name = "w"
planck = 3000
normalize = "l2"
[[reflectances]]
name = "r"
flat = 0.5
design = true
bounds = [-inf, inf]
[[colours]]
light = "d"
reflectance = "r"
target = "#808080"
free = "A"
[[colours]]
light = "w"
reflectance = "r"
target = [0.1, 0.2, 0.3]
weight = 2
use = false
[[free]]
name = "A"
upper = [1, 1, 1]
"##;

fn path() -> &'static Path {
    Path::new("/nonexistent/fuzz.toml")
}

/// Things to splice into a palette: tokens the parser treats specially.
fn token() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("nan".to_string()),
        Just("-inf".to_string()),
        Just("1e400".to_string()),
        Just("-0.0".to_string()),
        Just("99999999999999999999".to_string()),
        Just("\"#zzzzzz\"".to_string()),
        Just("[[lights]]\n".to_string()),
        Just("[[colours]]\nlight = \"d\"\n".to_string()),
        Just("[settings]\n".to_string()),
        Just("= =".to_string()),
        Just("\"\\u0000\"".to_string()),
        Just("[]".to_string()),
        Just("{}".to_string()),
        Just("\n".to_string()),
        "[a-z_]{1,8} = [0-9.]{1,5}\n",
        any::<String>(),
    ]
}

#[derive(Clone, Debug)]
enum Mutation {
    Delete { at: usize, len: usize },
    Insert { at: usize, text: String },
    SwapLines { a: usize, b: usize },
    DuplicateLine { at: usize },
}

fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 1usize..40).prop_map(|(at, len)| Mutation::Delete { at, len }),
        (any::<usize>(), token()).prop_map(|(at, text)| Mutation::Insert { at, text }),
        (any::<usize>(), any::<usize>()).prop_map(|(a, b)| Mutation::SwapLines { a, b }),
        any::<usize>().prop_map(|at| Mutation::DuplicateLine { at }),
    ]
}

fn char_boundary(s: &str, at: usize) -> usize {
    let mut i = at % (s.len() + 1);
    while !s.is_char_boundary(i) {
        i -= 1;
    }
    i
}

fn apply(text: &str, m: &Mutation) -> String {
    let mut s = text.to_string();
    match m {
        Mutation::Delete { at, len } => {
            let a = char_boundary(&s, *at);
            let b = char_boundary(&s, (a + len).min(s.len()));
            s.replace_range(a..b.max(a), "");
        }
        Mutation::Insert { at, text } => {
            let a = char_boundary(&s, *at);
            s.insert_str(a, text);
        }
        Mutation::SwapLines { a, b } => {
            let mut lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let n = lines.len();
                lines.swap(a % n, b % n);
            }
            s = lines.join("\n");
        }
        Mutation::DuplicateLine { at } => {
            let mut lines: Vec<&str> = text.lines().collect();
            if !lines.is_empty() {
                let i = at % lines.len();
                lines.insert(i, lines[i]);
            }
            s = lines.join("\n");
        }
    }
    s
}

/// Parsing never panics; when it succeeds, saving the unchanged palette gives the text back.
fn check_parse(text: &str) {
    if let Ok(file) = PaletteFile::parse(text, path()) {
        let (_, reread) = file.render(&file.palette, path()).expect("an unchanged palette renders");
        assert!(reread.text() == text, "unchanged save differs:\n{text:?}\n{:?}", reread.text());
        assert_eq!(reread.palette, file.palette);
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_text_never_panics(text in any::<String>()) {
        check_parse(&text);
        let _ = parse_spectrum_csv(&text);
    }

    #[test]
    fn byte_soup_never_panics(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let _ = PaletteFile::parse_bytes(&bytes, path());
        let _ = parse_spectrum_csv_bytes(&bytes);
    }

    #[test]
    fn mutated_palettes_never_panic(
        base in prop_oneof![Just(EXAMPLE), Just(SMALL)],
        mutations in proptest::collection::vec(mutation(), 1..6),
    ) {
        let text = mutations.iter().fold(base.to_string(), |t, m| apply(&t, m));
        check_parse(&text);
    }

    #[test]
    fn mutated_csv_never_panics(mutations in proptest::collection::vec(mutation(), 1..6)) {
        let base: String = (0..=32).map(|i| format!("{}, {}\n", 390 + 10 * i, 0.01 * i as f64)).collect();
        let text = mutations.iter().fold(base, |t, m| apply(&t, m));
        if let Ok(s) = parse_spectrum_csv(&text) {
            prop_assert!(s.is_finite());
        }
    }
}

/// One edit a designer might make.
#[derive(Clone, Debug)]
enum Edit {
    AddLight(f64),
    AddReflectance(f64),
    Remove(bool, usize),
    Rename(bool, usize, u8),
    Target(usize, usize, [f64; 3], bool),
    Weight(usize, usize, f64),
    Enable(usize, usize, bool),
    AddGroup(u8),
    RemoveGroup(usize),
    Free(usize, usize, usize),
    Design(bool, usize),
    Scale(bool, usize, f64),
    Solve(bool, usize, f64),
}

fn edit() -> impl Strategy<Value = Edit> {
    let i = 0usize..4;
    prop_oneof![
        (1000.0..20000.0f64).prop_map(Edit::AddLight),
        (0.0..1.0f64).prop_map(Edit::AddReflectance),
        (any::<bool>(), i.clone()).prop_map(|(k, i)| Edit::Remove(k, i)),
        (any::<bool>(), i.clone(), any::<u8>()).prop_map(|(k, i, n)| Edit::Rename(k, i, n)),
        (i.clone(), i.clone(), [-0.5..1.5f64, 0.0..1.0, 0.0..1.0], any::<bool>())
            .prop_map(|(l, r, t, hex)| Edit::Target(l, r, t, hex)),
        (i.clone(), i.clone(), 0.0..5.0f64).prop_map(|(l, r, w)| Edit::Weight(l, r, w)),
        (i.clone(), i.clone(), any::<bool>()).prop_map(|(l, r, e)| Edit::Enable(l, r, e)),
        any::<u8>().prop_map(Edit::AddGroup),
        i.clone().prop_map(Edit::RemoveGroup),
        (i.clone(), i.clone(), i.clone()).prop_map(|(l, r, g)| Edit::Free(l, r, g)),
        (any::<bool>(), i.clone()).prop_map(|(k, i)| Edit::Design(k, i)),
        (any::<bool>(), i.clone(), 0.1..3.0f64).prop_map(|(k, i, s)| Edit::Scale(k, i, s)),
        (any::<bool>(), i, 0.0..2.0f64).prop_map(|(k, i, a)| Edit::Solve(k, i, a)),
    ]
}

fn kind(light: bool) -> Kind {
    if light { Kind::Light } else { Kind::Reflectance }
}

fn apply_edit(p: &mut Palette, e: &Edit, c: &Colorimetry) {
    // Refused edits leave the palette unchanged; only successful ones matter here.
    let _ = match e {
        Edit::AddLight(k) => {
            p.add_spectrum(Kind::Light, &format!("l{}", p.lights.len()), Source::Planck(*k), c).map(drop)
        }
        Edit::AddReflectance(v) => {
            p.add_spectrum(Kind::Reflectance, &format!("r{}", p.reflectances.len()), Source::Flat(*v), c).map(drop)
        }
        Edit::Remove(k, i) => p.remove_spectrum(kind(*k), *i).map(drop),
        Edit::Rename(k, i, n) => p.rename_spectrum(kind(*k), *i, &format!("n{n}")),
        Edit::Target(l, r, t, hex) => p.set_target(*l, *r, Vector3::from(*t)).map(|_| {
            if let Some(i) = p.cell_index(*l, *r) {
                p.colours[i].notation = if *hex { TargetNotation::Hex } else { TargetNotation::Linear };
            }
        }),
        Edit::Weight(l, r, w) => p.set_weight(*l, *r, *w),
        Edit::Enable(l, r, e) => p.set_enabled(*l, *r, *e),
        Edit::AddGroup(n) => p.add_free_group(&format!("G{n}"), Vector3::zeros(), Vector3::repeat(1.0)).map(drop),
        Edit::RemoveGroup(g) => p.remove_free_group(*g).map(drop),
        Edit::Free(l, r, g) => p.set_free(*l, *r, Some(*g)),
        Edit::Design(k, i) => p.toggle_design(kind(*k), *i).map(drop),
        Edit::Scale(k, i, s) => p.set_scale(kind(*k), *i, *s, c),
        Edit::Solve(k, i, a) => {
            // What a solver does: replace a spectrum's samples.
            if let Some(entry) = p.entries_mut(kind(*k)).get_mut(*i) {
                let v: Vec<f64> = (0..31).map(|j| a * (1.0 + (j as f64 * 0.3).sin())).collect();
                entry.spectrum = Spectrum::from_slice(&v).unwrap();
            }
            Ok(())
        }
    };
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn edited_palettes_save_and_load_back(edits in proptest::collection::vec(edit(), 1..12)) {
        let c = Colorimetry::default();
        let dir = tempfile::tempdir().unwrap();
        let file_path = dir.path().join("p.toml");
        std::fs::write(&file_path, SMALL).unwrap();
        let mut file = PaletteFile::load(&file_path).unwrap();
        let mut p = file.palette.clone();
        for e in &edits {
            apply_edit(&mut p, e, &c);
        }
        file.save(&p).unwrap();
        let reread = PaletteFile::load(&file_path).unwrap().palette;
        prop_assert_eq!(&reread.lights.iter().map(|e| &e.name).collect::<Vec<_>>(),
                        &p.lights.iter().map(|e| &e.name).collect::<Vec<_>>());
        for (a, b) in reread.lights.iter().chain(&reread.reflectances).zip(p.lights.iter().chain(&p.reflectances)) {
            prop_assert_eq!(&a.name, &b.name);
            prop_assert_eq!(a.design, b.design);
            // Samples are written with shortest round-trip formatting; normalising again may differ in
            // the last bits (1e-12 relative).
            prop_assert!((a.spectrum.0 - b.spectrum.0).amax() <= 1e-12 * b.spectrum.0.amax().max(1.0),
                "{} differs", a.name);
        }
        prop_assert_eq!(&reread.free, &p.free);
        prop_assert_eq!(reread.colours.len(), p.colours.len());
        for (a, b) in reread.colours.iter().zip(&p.colours) {
            prop_assert_eq!((a.light, a.reflectance, a.free, a.enabled), (b.light, b.reflectance, b.free, b.enabled));
            prop_assert_eq!(a.weight, b.weight);
            // Hex targets hold 8 bits per channel (≤ 4.5e-3 in linear light); others are exact.
            prop_assert!((a.target - b.target).amax() <= 4.5e-3);
        }
        // Saving what was read changes nothing.
        let before = std::fs::read_to_string(&file_path).unwrap();
        let mut again = PaletteFile::load(&file_path).unwrap();
        let same = again.palette.clone();
        again.save(&same).unwrap();
        prop_assert_eq!(std::fs::read_to_string(&file_path).unwrap(), before);
    }
}
