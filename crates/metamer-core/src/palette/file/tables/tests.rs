//! Tests of saving by tables: the same text as the whole-document save.

use super::super::PaletteFile;
use super::Tables;
use crate::palette::{Palette, Source};
use crate::spectrum::{Normalize, SAMPLES, Spectrum};
use std::path::{Path, PathBuf};

/// What a solve does to the designed spectra (and, here, to every other spectrum in `every`).
fn solved(p: &Palette, every: usize) -> Palette {
    let mut p = p.clone();
    let mut k = 0;
    for e in p.lights.iter_mut().chain(p.reflectances.iter_mut()) {
        k += 1;
        if e.design || k % every == 0 {
            let s = Spectrum(crate::spectrum::Samples::from_fn(|i, _| {
                0.01 + (i as f64 * 0.37 + k as f64).sin().abs() / (1.0 + i as f64) * 0.9
            }));
            e.spectrum = s;
            e.source = Source::Samples(s.to_vec());
            e.normalize = Normalize::None;
            e.scale = 1.0;
        }
    }
    p
}

/// The texts the tests save into: the example palettes, the fuzz findings and some awkward layouts.
fn texts() -> Vec<(PathBuf, String)> {
    // The repository root: this crate lives in crates/metamer-core.
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let mut out = Vec::new();
    for dir in [root.join("palettes"), root.join("tests/data/fuzz")] {
        for entry in std::fs::read_dir(&dir).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "toml") {
                out.push((path.clone(), std::fs::read_to_string(&path).unwrap_or_default()));
            }
        }
    }
    assert!(out.len() >= 3, "the example palettes were not found under {}", root.display());
    let samples = (0..SAMPLES).map(|i| format!("{}", 0.5 + i as f64 / 100.0)).collect::<Vec<_>>().join(", ");
    let awkward = [
        // Comments after values, a quoted source key, scale and normalize keys, CRLF and a BOM.
        format!(
            "\u{feff}name = \"a\"\r\n\r\n[[lights]]\r\nname = \"e\" # the light\r\n\"samples\" = [{samples}] # measured\r\nnormalize = \"luminance\"\r\nscale = 2.0\r\ndesign = true\r\n\r\n[[reflectances]]\r\nname = \"r\"\r\nflat = 0.5   # grey\r\ndesign = true\r\n\r\n[[colours]]\r\nlight = \"e\"\r\nreflectance = \"r\"\r\ntarget = \"#808080\"\r\n"
        ),
        // Inline tables, no final newline.
        format!(
            "lights = [{{ name = \"e\", illuminant = \"D65\", normalize = \"none\", design = true }}]\nreflectances = [\n  {{ name = \"r\", samples = [{samples}], design = true }},\n  {{ name = \"s\", colorchecker = \"dark_skin\" }},\n]\ncolours = [{{ light = \"e\", reflectance = \"r\", target = [0.1, 0.2, 0.3] }}]"
        ),
    ];
    for (i, text) in awkward.into_iter().enumerate() {
        out.push((PathBuf::from(format!("awkward{i}.toml")), text));
    }
    out
}

#[test]
fn saving_by_tables_writes_what_the_whole_document_writes() {
    let mut by_tables = 0;
    for (path, text) in texts() {
        let Ok(file) = PaletteFile::parse(&text, &path) else { continue };
        for every in [1, 2, 1000] {
            let p = solved(&file.palette, every);
            let Some(s) = file.save_by_tables(&p, &path, true) else { continue };
            by_tables += 1;
            let (document, reread) = file.render(&p, &path).unwrap();
            assert_eq!(s.text(), file.text_of(&document), "{} (every {every})", path.display());
            assert_eq!(s.palette(&file.palette), reread.palette, "{}", path.display());
            assert_eq!(Some(&s.tables), reread.tables.as_ref(), "{}", path.display());
        }
    }
    assert!(by_tables >= 8, "only {by_tables} palettes were saved by tables");
}

/// Other changes to the spectra than a solve's: each light's scale doubled with its source kept (written as
/// its own source, with the entry's normalisation and scale), and the reflectances' samples edited without
/// their source (written as samples).
fn rescaled_and_edited(p: &Palette) -> Palette {
    let mut p = p.clone();
    for e in &mut p.lights {
        e.scale *= 2.0;
        e.spectrum = Spectrum(e.spectrum.0 * 2.0);
    }
    for e in &mut p.reflectances {
        e.spectrum = Spectrum(e.spectrum.0 * 0.5);
    }
    p
}

/// A batch as `metamer solve` saves it: designed reflectances given by samples, keys after them (the
/// solve's save rewrites only the samples' value).
fn batch_text() -> (PathBuf, String) {
    let samples = (0..SAMPLES).map(|i| format!("{}", 0.5 + i as f64 / 100.0)).collect::<Vec<_>>().join(", ");
    (
        PathBuf::from("batch.toml"),
        format!(
            "name = \"b\"\n\n[[lights]]\nname = \"e\"\nsamples = [{samples}]\nnormalize = \"none\"\n\n[[reflectances]]\nname = \"r\"\nsamples = [\n    {samples},\n]\ndesign = true\n\n[[reflectances]]\nname = \"s\"\nsamples = [{samples}]\ndesign = true\nbounds = [0.0, 1.0]\n\n[[colours]]\nlight = \"e\"\nreflectance = \"r\"\ntarget = [0.1, 0.2, 0.3]\n"
        ),
    )
}

#[test]
fn a_save_without_its_entries_writes_the_same_text() {
    // A save made for a command that ends once it is in place (`PaletteFile::prepare_save_to_end`) builds
    // no entry; the one made with them builds what reading its text gives, also where it takes the
    // spectrum the writer resolved (the entry's own source, normalisation and scale) instead of resolving
    // the written source again.
    let mut compared = 0;
    for (path, text) in texts().into_iter().chain([batch_text()]) {
        let Ok(file) = PaletteFile::parse(&text, &path) else { continue };
        for p in [solved(&file.palette, 1), solved(&file.palette, 2), rescaled_and_edited(&file.palette)] {
            let with = file.save_by_tables(&p, &path, true);
            let without = file.save_by_tables(&p, &path, false);
            assert_eq!(with.is_some(), without.is_some(), "{}", path.display());
            let (Some(with), Some(without)) = (with, without) else { continue };
            compared += 1;
            assert_eq!(with.pieces, without.pieces, "{}", path.display());
            assert_eq!(with.tables, without.tables, "{}", path.display());
            assert!(without.entries.is_empty(), "{}", path.display());
            let changed = |o: &[crate::palette::SpectrumEntry], n: &[crate::palette::SpectrumEntry]| {
                o.iter().zip(n).filter(|(o, n)| o != n).count()
            };
            let changed =
                changed(&file.palette.lights, &p.lights) + changed(&file.palette.reflectances, &p.reflectances);
            assert_eq!(with.entries.len(), changed, "{}", path.display());
            let reread = PaletteFile::parse(&with.text(), &path).unwrap();
            assert_eq!(with.palette(&file.palette), reread.palette, "{}", path.display());
        }
    }
    assert!(compared >= 12, "only {compared} saves were compared");
}

#[test]
fn changes_beyond_spectra_go_through_the_whole_document() {
    let (path, text) = texts().remove(texts().len() - 2);
    let file = PaletteFile::parse(&text, &path).unwrap();
    let p = solved(&file.palette, 1);
    assert!(file.save_by_tables(&p, &path, true).is_some());
    let mut renamed = p.clone();
    renamed.reflectances[0].name = "renamed".into();
    assert!(file.save_by_tables(&renamed, &path, true).is_none());
    let mut reweighted = p.clone();
    reweighted.colours[0].weight = 3.0;
    assert!(file.save_by_tables(&reweighted, &path, true).is_none());
    // Inline arrays of tables have no table text of their own.
    let text = "lights = [{ name = \"e\", illuminant = \"D65\", design = true }]\nreflectances = [{ name = \"r\", flat = 0.5 }]\n";
    let file = PaletteFile::parse(text, &path).unwrap();
    assert!(file.tables.is_none());
    assert!(file.save_by_tables(&solved(&file.palette, 1000), &path, true).is_none());
    // A table whose text holds a sub-table header is written through the whole document.
    let text = "[[lights]]\nname = \"e\"\nilluminant = \"D65\"\ndesign = true\n[lights.note]\nx = 1\n\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n";
    let file = PaletteFile::parse(text, &path).unwrap();
    assert!(file.save_by_tables(&solved(&file.palette, 1000), &path, true).is_none());
}

#[test]
fn repeated_saves_by_tables_keep_their_places() {
    let (path, text) = texts().remove(texts().len() - 2);
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("p.toml");
    let mut file = PaletteFile::parse(&text, &path).unwrap();
    for every in [1, 2, 3] {
        let p = solved(&file.palette, every);
        assert!(file.save_by_tables(&p, &target, true).is_some());
        file.save_as(&p, &target).unwrap();
        let reread = PaletteFile::load(&target).unwrap();
        assert_eq!(reread.palette, file.palette);
        assert_eq!(reread.tables, file.tables);
    }
}

/// A designed light saved as samples gains `normalize = "none"`, a key its table lacked: the table's
/// document adds it where the whole document would.
#[test]
fn a_key_the_table_lacks_is_added_in_place() {
    let path = Path::new("added.toml");
    let text = "[[lights]]\nname = \"e\"\nilluminant = \"D65\"\ndesign = true\n# the reflectance\n\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n";
    let file = PaletteFile::parse(text, path).unwrap();
    let p = solved(&file.palette, 1000);
    let s = file.save_by_tables(&p, path, true).expect("only a spectrum changed");
    let (document, _) = file.render(&p, path).unwrap();
    let text = s.text();
    assert_eq!(text, file.text_of(&document));
    assert!(text.contains("normalize = \"none\""), "{text}");
    assert!(text.ends_with("# the reflectance\n\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n"), "{text}");
}

/// Every table runs from its header to the next top-level header.
#[test]
fn tables_run_from_header_to_header() {
    let text = "name = \"t\"\n[[lights]]\nname = \"e\"\nflat = 1\n[settings]\nsmoothness = 0\n[[reflectances]]\nname = \"r\"\nflat = 0.5\n";
    let root = toml::de::DeTable::parse(text).unwrap();
    let t = Tables::of(&super::super::doc::Doc::tree(root), text).unwrap();
    assert_eq!(&text[t.lights[0].range.clone()], "[[lights]]\nname = \"e\"\nflat = 1\n");
    assert_eq!(&text[t.reflectances[0].range.clone()], "[[reflectances]]\nname = \"r\"\nflat = 0.5\n");
    let value = t.reflectances[0].source_value.clone().unwrap();
    assert_eq!(&text[t.reflectances[0].range.clone()][value], "0.5");
}
