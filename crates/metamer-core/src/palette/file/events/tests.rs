//! The parse from events gives the tree the `toml` crate gives for the same text (keys, values, spans), or
//! leaves the text to it; and the palette both paths read is the same, or the error is.

use super::super::numbers::tests::both;
use super::super::{budget, numbers};
use super::*;
use std::path::Path;

/// Whether the events' path took `text`; when it did, its tree is the `toml` crate's tree of the same text
/// with the arrays read by hand empty.
fn same_tree(text: &str) -> bool {
    let headers = budget::scan(text).headers;
    let Some((root, read)) = parse(text, &headers) else { return false };
    let arrays = numbers::arrays_in(text, 0..text.len());
    assert_eq!(arrays.len(), read.len(), "the arrays read by pieces are those of the whole text");
    assert_eq!(format!("{:?}", root.into_tree()), toml_tree_read(text, arrays), "the tree of {text:?}");
    true
}

/// The `toml` crate's tree of `text` (debug-printed) with the hand-read `arrays` empty: the tree a faster
/// path must build (this path's and the one-pass read's tests).
pub(in super::super) fn toml_tree_read<T>(text: &str, arrays: Vec<(Range<usize>, T)>) -> String {
    let spans: Vec<Range<usize>> = arrays.into_iter().map(|(span, _)| span).collect();
    let mut expected = DeTable::parse(text).expect("a faster path took a text the toml crate refuses");
    for value in expected.get_mut().iter_mut().map(|(_, v)| v) {
        empty_read(value, &spans);
    }
    format!("{expected:?}")
}

/// `value` with the arrays at `spans` made empty.
fn empty_read(value: &mut Spanned<DeValue<'_>>, spans: &[Range<usize>]) {
    let span = value.span();
    match value.get_mut() {
        DeValue::Array(_) if spans.contains(&span) => *value.get_mut() = DeValue::Array(DeArray::new()),
        DeValue::Array(items) => items.iter_mut().for_each(|v| empty_read(v, spans)),
        DeValue::Table(t) => t.iter_mut().for_each(|(_, v)| empty_read(v, spans)),
        _ => {}
    }
}

/// `n` sample values, each written as Rust writes it.
pub(in super::super) fn samples(n: usize) -> String {
    (0..n).map(|i| format!("{}", 0.25 + i as f64 / 64.0)).collect::<Vec<_>>().join(", ")
}

/// A palette with every shape a palette uses, each spelled in several ways.
fn varied() -> String {
    let s = samples(crate::spectrum::SAMPLES);
    format!(
        "# a palette\nname = \"värid ☃\" # trailing comment\n\n[settings]\nsmoothness = 1e-3\nreflectance_bounds = \
         [0, 1.0]\nfit_in_subspace = false\nbasis_dimension = 8\n\n[[lights]]\n  name = 'D65'\n  illuminant = \
         \"D65\"\n[[lights]]\nname = \"lamp\"\nplanck = 2_856\nscale = 1.5\nnormalize = \"l2\"\n\n[[free]]\nname = \
         \"g\"\nlower = [0, 0, 0]\n\n[[reflectances]]\nname = \"leaf\\u00e9\"\nsamples = [\n    {s},\n]\ndesign = \
         true\nbounds = [0.0, 0.9]\ndial = [0.5, 0.25]\n[[reflectances]]\n\"name\" = \"\"\"petal\"\"\"\nflat = \
         0.5\nunknown = {{ a = 1, b = [1, 2] }}\n[[colours]]\nlight = \"D65\"\nreflectance = \"leaf\\u00e9\"\ntarget \
         = [0.1, 0.2, 0.3]\nweight = 2\n[[colours]]\nlight = \"lamp\"\nreflectance = \"leaf\\u00e9\"\ntarget = \
         \"#808080\"\nuse = false\n[[colours]]\nlight = \"lamp\"\nreflectance = \"petal\"\nfree = \"g\"\n"
    )
}

#[test]
fn the_tree_is_the_toml_crates_for_every_shape_taken() {
    let text = varied();
    assert!(same_tree(&text));
    assert!(same_tree(&text.replace('\n', "\r\n")), "CRLF");
    let (read, used) = both(&text, Path::new("varied.toml"));
    assert!(!read.starts_with("error"), "{read}");
    assert_eq!(used, Some(2), "the samples and one target read by hand");
}

#[test]
fn a_long_batch_in_pieces_gives_the_tree_of_the_whole_text() {
    let col = crate::colorimetry::Colorimetry::default();
    let p = crate::palette::random::reachable_batch_palette(600, 3, &col);
    let text = super::super::PaletteFile::from_palette(&p).text();
    assert!(pieces::starts(&text, &budget::scan(&text).headers).len() > 1, "{} bytes", text.len());
    assert!(same_tree(&text));
}

/// Texts the events' path leaves to the whole parse (the same palette or the same error either way).
#[test]
fn shapes_it_leaves_to_the_toml_crate() {
    let base = varied();
    let cases = [
        "a.b = 1\n",
        "[a.b]\nx = 1\n",
        "[[lights.x]]\nname = \"a\"\n",
        "name = \"again\"\n",
        "[settings]\nsmoothness = 1\n",
        "lights = []\n",
        "[lights]\nname = \"x\"\n",
        "[[settings]]\nx = 1\n",
        "= 1\n",
        "x = \n",
        "x = 1 2\n",
        "x = \"unterminated\n",
        "x = 1e999\n",
        "x = 99999999999999999999\n",
        "x = \"bad \\q escape\"\n",
        "x = [1, 2\n",
        "x = 1\nx = 2\n",
        "\"a.b\".c = 1\n",
        "x = \"\u{1}\"\n",
        "# control \u{7f} in a comment\n",
    ];
    for case in cases {
        let first = format!("{case}{base}");
        assert!(!same_tree(&first), "{case:?}");
        both(&first, Path::new("p.toml"));
        // At the end, in the last `[[colours]]` table (where some are valid keys): the same tree if taken.
        let last = format!("{base}{case}");
        same_tree(&last);
        both(&last, Path::new("p.toml"));
    }
}

/// Every shipped palette, and each with every line ending in CRLF, gives the toml crate's tree.
#[test]
fn shipped_palettes_give_the_toml_crates_tree() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../palettes");
    let mut n = 0;
    for entry in std::fs::read_dir(root).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            let text = std::fs::read_to_string(&path).unwrap();
            assert!(same_tree(&text), "{}", path.display());
            assert!(same_tree(&text.replace('\n', "\r\n")), "{}", path.display());
            n += 1;
        }
    }
    assert!(n >= 5);
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    /// Lines a palette may hold, valid and not, in any order: duplicate keys, wrong types, unknown keys,
    /// comments, unicode, huge numbers, NaN and inf, arrays of the wrong length, shapes only the toml crate
    /// takes.
    fn line() -> impl Strategy<Value = String> {
        let s31 = samples(31);
        let s3 = samples(3);
        proptest::sample::select(vec![
            "name = \"p\"".to_string(),
            "name = \"ünï ☃ \\u00e9\"".to_string(),
            "'name' = 'lit'".to_string(),
            "name = 3".to_string(),
            "# [[lights]] a comment".to_string(),
            "".to_string(),
            "[settings]".to_string(),
            "smoothness = 0.001".to_string(),
            "smoothness = 1e999".to_string(),
            "smoothness = nan".to_string(),
            "smoothness = -inf".to_string(),
            "reflectance_bounds = [0.0, 1.0] # c".to_string(),
            "basis_dimension = 99999999999999999999".to_string(),
            "[[lights]]".to_string(),
            "[[lights]] # c".to_string(),
            "name = \"D65\"".to_string(),
            "illuminant = \"D65\"".to_string(),
            "[[reflectances]]".to_string(),
            "name = \"r\"".to_string(),
            format!("samples = [{s31}]"),
            format!("samples = [\n  {s31},\n]"),
            format!("samples = [{s3}]"),
            "samples = [1_0, 2]".to_string(),
            "samples = []".to_string(),
            "design = true".to_string(),
            "design = \"yes\"".to_string(),
            "[[colours]]".to_string(),
            "light = \"D65\"".to_string(),
            "reflectance = \"r\"".to_string(),
            "target = [0.1, 0.2, 0.3]".to_string(),
            "target = [1, 2]".to_string(),
            "target = [inf, 0, 0]".to_string(),
            "target = \"#808080\"".to_string(),
            "weight = 2".to_string(),
            "weight = -1".to_string(),
            "unknown = 1".to_string(),
            "a.b = 1".to_string(),
            "[a.b]".to_string(),
            "inline = {a = 1, b = [1, 2]}".to_string(),
            "lights = []".to_string(),
            "[lights]".to_string(),
            "when = 1979-05-27T07:32:00Z".to_string(),
            "note = \"\"\"\nsamples = [1, 2, 3]\n\"\"\"".to_string(),
            "x = [".to_string(),
        ])
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(256))]
        #[test]
        fn any_mix_of_lines_reads_as_the_toml_crate_reads_it(
            lines in proptest::collection::vec(line(), 0..24),
            crlf in any::<bool>(),
        ) {
            let text = lines.join(if crlf { "\r\n" } else { "\n" });
            same_tree(&text);
            both(&text, Path::new("p.toml"));
        }
    }
}
