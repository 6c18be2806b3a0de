//! The one-pass read gives the tree the `toml` crate gives for the same text (keys, values, spans) and the
//! budget's counts, or leaves the text to the events' path; and the palette every path reads is the same,
//! or the error is.

use super::super::events::tests::{samples, toml_tree_read};
use super::super::numbers::tests::both;
use super::super::{PaletteError, PaletteFile, budget, numbers};
use super::*;
use std::path::Path;

/// Whether the one-pass read took `text`; when it did, its tree is the `toml` crate's tree of the same text
/// with the arrays read by hand empty, its arrays are those the hand reader finds in the whole text, and its
/// counts are the budget scan's.
fn same_tree(text: &str) -> bool {
    let Some(lines) = parse(text) else { return false };
    let arrays = numbers::arrays_in(text, 0..text.len());
    assert_eq!(arrays.len(), lines.read.len(), "the arrays read are those of the whole text: {text:?}");
    assert_eq!(lines.counts, budget::count(text), "the budget's counts of {text:?}");
    assert_eq!(format!("{:?}", lines.tree.into_tree()), toml_tree_read(text, arrays), "the tree of {text:?}");
    true
}

/// A palette of every shape this path reads, each spelled in several ways.
fn plain() -> String {
    let s = samples(crate::spectrum::SAMPLES);
    format!(
        "# a palette\nname = \"värid ☃\" # trailing comment\n\n[settings]\nsmoothness = 1e-3\nreflectance_bounds = \
         [0, 1.0]\nfit_in_subspace = false\nbasis_dimension = 8\n\n[[lights]]\n  name = 'D65'\n\tilluminant=\"D65\"\
         \n[[lights]]  # c\nname = \"lamp\"\nplanck = 2856\nscale = +1.5\nnormalize = \"l2\"\n\n[[free]]\nname = \
         \"g\"\nlower = [0, -0.0, 1e2]\n\n[[reflectances]]\nname = \"leaf\"\nsamples = [\n    {s},\n]\ndesign = \
         true\nbounds = [0.0, 0.9]\ndial = [0.5, 0.25]\n[[reflectances]]\nname = \"\"\nflat = 0.5\n\
         [[colours]]\nlight = \"D65\"\nreflectance = \"leaf\"\ntarget = [0.1, 0.2, 0.3] # linear\nweight = 2\n\
         [[colours]]\nlight = \"lamp\"\nreflectance = \"leaf\"\ntarget = \"#808080\"\nuse = false\n[[colours]]\n\
         light = \"lamp\"\nreflectance = \"petal\"\nfree = \"g\""
    )
}

#[test]
fn the_tree_is_the_toml_crates_for_every_shape_taken() {
    let text = plain();
    assert!(same_tree(&text));
    assert!(same_tree(&format!("{text}\n")));
    // The palette reads as the other paths read it (here: refused, `petal` is no reflectance).
    let (read, _) = both(&text, Path::new("plain.toml"));
    assert!(read.contains("reflectances[1].name: the name must not be empty"), "{read}");
    let fixed = text.replace("name = \"\"\nflat", "name = \"petal\"\nflat");
    assert!(same_tree(&fixed));
    let (read, used) = both(&fixed, Path::new("plain.toml"));
    assert!(!read.starts_with("error"), "{read}");
    assert_eq!(used, Some(2), "the samples and one target read by hand");
}

#[test]
fn a_long_batch_is_read_in_pieces_in_one_pass() {
    let col = crate::colorimetry::Colorimetry::default();
    let p = crate::palette::random::reachable_batch_palette(600, 3, &col);
    let text = PaletteFile::from_palette(&p).text();
    assert!(cuts(&text).len() > 1, "{} bytes", text.len());
    assert!(same_tree(&text));
    let (read, used) = both(&text, Path::new("batch.toml"));
    assert!(!read.starts_with("error"), "{read}");
    assert_eq!(used, Some(parse(&text).unwrap().read.len()));
}

/// Lines this path leaves to the events' path and the `toml` crate: the same palette or error either way.
#[test]
fn shapes_it_leaves_to_the_other_paths() {
    let base = plain();
    let cases = [
        "a.b = 1\n",
        "[a.b]\nx = 1\n",
        "[ spaced ]\nx = 1\n",
        "[[lights.x]]\nname = \"a\"\n",
        "name = \"again\"\n",
        "[settings]\nsmoothness = 1\n",
        "lights = []\n",
        "[lights]\nname = \"x\"\n",
        "\"quoted\" = 1\n",
        "= 1\n",
        "x = \n",
        "x = 1 2\n",
        "x = \"unterminated\n",
        "x = 'unterminated\n",
        "x = \"\"\"multi\"\"\"\n",
        "x = '''multi'''\n",
        "x = 1e999\n",
        "x = inf\n",
        "x = 99999999999999999999\n",
        "x = 0x1F\n",
        "x = 1_000\n",
        "x = 1979-05-27\n",
        "x = \"escaped \\\" quote\"\n",
        "x = \"bad \\q escape\"\n",
        "x = [1, 2\n",
        "x = [1, [2]]\n",
        "x = {a = 1}\n",
        "x = truth\n",
        "x = 1\nx = 2\n",
        "x = \"\u{1}\"\n",
        "x = 1 # control \u{7f}\n",
        "# control \u{1} in a comment\n",
        "x = 1\r\n",
    ];
    for case in cases {
        let first = format!("{case}{base}");
        assert!(!same_tree(&first), "{case:?}");
        both(&first, Path::new("p.toml"));
        // At the end, in the last `[[colours]]` table (where some are valid keys): the same tree if taken.
        let last = format!("{base}\n{case}");
        same_tree(&last);
        both(&last, Path::new("p.toml"));
    }
}

/// `[[name]]` tables are read into flat lists: one with more keys than are compared one by one is checked
/// for a key given twice through a set of its keys; its unknown keys are named in the tree's (sorted)
/// order; an error in a flat table names its line; all as the `toml` crate's tree reads them.
#[test]
fn flat_tables_with_many_keys_read_as_the_tree() {
    let base = plain().replace("name = \"\"\nflat", "name = \"petal\"\nflat");
    let keys: Vec<String> = ["zeta", "k9", "k10", "alpha", "k1", "mid", "k2", "k3", "k4", "k5", "k6", "k7"]
        .iter()
        .enumerate()
        .map(|(i, k)| format!("{k} = {i}\n"))
        .collect();
    let many = format!("{base}\n{}", keys.concat());
    assert!(same_tree(&many));
    let (read, _) = both(&many, Path::new("p.toml"));
    let order: Vec<usize> = ["colours[2].alpha", "colours[2].k1", "colours[2].k10", "colours[2].zeta"]
        .iter()
        .map(|k| read.find(k).unwrap_or_else(|| panic!("{k} in {read}")))
        .collect();
    assert!(order.is_sorted(), "{read}");
    // The same key again, before and after the set takes over.
    for at in [3, 11] {
        let twice = format!("{base}\n{}{}", keys[..at].concat(), keys[1].replace("= 1", "= 2"));
        assert!(!same_tree(&twice), "{at}");
        let (read, _) = both(&twice, Path::new("p.toml"));
        assert!(read.starts_with("error: p.toml: TOML syntax error"), "{read}");
    }
    // A refused value in a flat table: its line.
    let wrong = many.replace("mid = 5", "weight = -1");
    assert!(same_tree(&wrong));
    let (read, _) = both(&wrong, Path::new("p.toml"));
    let line = wrong[..wrong.find("weight = -1").unwrap()].matches('\n').count() + 1;
    assert!(read.contains(&format!("p.toml:{line}: colours[2].weight: weights must not be negative")), "{read}");
    // Key paths find the same spans in the flat lists as in the tree.
    let flat = parse(&wrong).expect("read in one pass").tree;
    let tree = super::super::doc::Doc::tree(toml::de::DeTable::parse(&wrong).unwrap());
    for key in [
        "colours[2].weight",
        "colours[2]",
        "colours[9].light",
        "colours",
        "colours[0].target",
        "colours[1].nothing",
        "colours.x",
        "colours[x]",
        "lights[1].name",
        "settings.smoothness",
        "settings.nothing.x",
        "name",
        "nothing",
    ] {
        assert_eq!(flat.span_of_key(key), tree.span_of_key(key), "{key}");
    }
    assert_eq!(flat.span_of_key("colours[2].weight").map(|s| &wrong[s]), Some("-1"));
}

/// A text of many tables in few bytes is refused for its parse budget as before, and the one-pass read
/// stops building it once the pieces' total is over the budget.
#[test]
fn the_budget_is_kept() {
    let text = "[[a]]\n".repeat(100_000);
    assert!(budget::count(&text).cost() > budget::budget(text.len()));
    assert!(parse(&text).is_none());
    let spent = AtomicU64::new(0);
    let limit = 4 * FLUSH;
    assert!(piece(&text, 0..text.len(), &spent, limit).is_none(), "stopped at the limit");
    assert!(spent.load(Ordering::Relaxed) <= limit + 2 * FLUSH, "{}", spent.load(Ordering::Relaxed));
    match PaletteFile::parse(&text, Path::new("many.toml")) {
        Err(PaletteError::TooComplex { tables, .. }) => assert_eq!(tables, 100_000),
        other => panic!("{:?}", other.map(|f| f.palette.name)),
    }
}

mod prop {
    use super::*;
    use proptest::prelude::*;

    /// Lines a palette may hold, valid and not, in any order: duplicate keys, wrong types, unknown keys,
    /// comments, unicode, huge numbers, arrays of the wrong length, shapes only the other paths take.
    fn line() -> impl Strategy<Value = String> {
        let s31 = samples(31);
        let s3 = samples(3);
        proptest::sample::select(vec![
            "name = \"p\"".to_string(),
            "name = \"ünï ☃\"".to_string(),
            "name = 'lit \\ eral'".to_string(),
            "name = \"\"".to_string(),
            "name = \"a\\u00e9\"".to_string(),
            "name = 3".to_string(),
            "# [[lights]] a = comment, {".to_string(),
            "".to_string(),
            "   ".to_string(),
            "[settings]".to_string(),
            "smoothness = 0.001".to_string(),
            "smoothness = -1E-3 # c".to_string(),
            "smoothness = 1e999".to_string(),
            "smoothness = nan".to_string(),
            "reflectance_bounds = [0.0, 1.0] # c".to_string(),
            "reflectance_bounds = [0.0,1.0,]".to_string(),
            "basis_dimension = 8".to_string(),
            "basis_dimension = 99999999999999999999".to_string(),
            "[[lights]]".to_string(),
            "[[lights]] # c".to_string(),
            "[[ lights ]]".to_string(),
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
            "design = false # no".to_string(),
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
            "inline = {a = 1}".to_string(),
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
            final_newline in any::<bool>(),
        ) {
            let mut text = lines.join(if crlf { "\r\n" } else { "\n" });
            if final_newline {
                text.push('\n');
            }
            same_tree(&text);
            both(&text, Path::new("p.toml"));
        }
    }
}
