//! Saving: the TOML document is updated from the model so that only what changed is rewritten. Comments,
//! key order, formatting and unknown keys of everything else stay as the user wrote them.
//!
//! Entries of the model are paired with the document's tables first by name, then (for a renamed entry) by
//! position; unpaired tables are removed and new entries appended after the last table of their list.

use super::write_dial;
use crate::colorimetry::linear_to_hex;
use crate::palette::source::spectra_agree;
use crate::palette::{
    Bounds, ColourCell, FreeGroup, Kind, MixSpec, Palette, Route, Settings, Source, SpectrumEntry, TargetNotation,
};
use crate::spectrum::{Normalize, Samples, Spectrum};
use nalgebra::Vector3;
use std::borrow::Cow;
use std::collections::HashMap;
use std::path::{Component, Path, PathBuf};
use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, TableLike, Value};

/// What the update needs besides the two palettes.
pub(super) struct SaveContext<'a> {
    /// Folder the document's relative CSV paths are relative to now (`None` for a new document).
    pub(crate) old_base: Option<&'a Path>,
    /// Folder of the file being written.
    pub(crate) new_base: &'a Path,
    /// Raw samples of CSV sources already read, by path as written.
    pub(crate) csv_raw: &'a HashMap<String, Spectrum>,
    pub(crate) luminance: Samples,
}

impl SaveContext<'_> {
    /// The samples `source` resolves to as an entry of `kind` with `normalize` and `scale`, as the reader
    /// resolves them: a CSV source from its samples already read (else its file, relative to the folder the
    /// document was read from). `None` when the source does not resolve.
    pub(super) fn resolve(&self, source: &Source, kind: Kind, normalize: Normalize, scale: f64) -> Option<Spectrum> {
        let raw = match source {
            Source::Csv(file) => self.csv_raw.get(file).copied().or_else(|| source.raw_spectrum(self.old_base).ok()),
            other => other.raw_spectrum(None).ok(),
        }?;
        crate::palette::source::finish(&raw, kind, normalize, scale, &self.luminance).ok()
    }
}

/// Why the document cannot take the model.
#[derive(Debug)]
pub(super) struct StructureError(pub String);

type Res = Result<(), StructureError>;

/// Update `doc` (which says `old`) so that it says `new`.
pub(super) fn update_document(doc: &mut DocumentMut, old: &Palette, new: &Palette, ctx: &SaveContext) -> Res {
    let root = doc.as_table_mut();
    if old.name != new.name {
        put(root, "name", Value::from(new.name.as_str()));
    }
    sync_settings(root, &old.settings, &new.settings);

    let light_map = pair_by_name(&old.lights, &new.lights, |e| &e.name);
    let refl_map = pair_by_name(&old.reflectances, &new.reflectances, |e| &e.name);
    let free_map = pair_by_name(&old.free, &new.free, |g| &g.name);

    for (list, map, olds, news) in [
        ("lights", &light_map, &old.lights, &new.lights),
        ("reflectances", &refl_map, &old.reflectances, &new.reflectances),
    ] {
        sync_list(root, list, order(map, olds.len()), |t, o, n| {
            sync_spectrum(t, o.map(|o| &olds[o]), &news[n], ctx);
        })?;
    }

    // Colour cells pair through the light and reflectance pairing.
    let old_cells: HashMap<(usize, usize), usize> =
        old.colours.iter().enumerate().map(|(i, c)| ((c.light, c.reflectance), i)).collect();
    let cell_map: Vec<Option<usize>> = new
        .colours
        .iter()
        .map(|c| {
            let l = light_map.get(c.light).copied().flatten()?;
            let r = refl_map.get(c.reflectance).copied().flatten()?;
            old_cells.get(&(l, r)).copied()
        })
        .collect();
    sync_list(root, "colours", order(&cell_map, old.colours.len()), |t, o, n| {
        sync_colour(t, o.map(|o| (&old.colours[o], old)), &new.colours[n], new);
    })?;
    sync_list(root, "free", order(&free_map, old.free.len()), |t, o, n| {
        sync_free(t, o.map(|o| &old.free[o]), &new.free[n]);
    })?;
    let pairing = write_dial::Pairing { lights: &light_map, reflectances: &refl_map };
    let mix_map = write_dial::pair_mixtures(&old.mixtures, &new.mixtures, &pairing);
    let path_map = write_dial::pair_paths(&old.paths, &new.paths, &pairing);
    let maps = IndexMaps::new(old, new, [&light_map, &refl_map, &free_map], [&mix_map, &path_map]);
    // Names first, in the tables as read; then the tables follow the model's entries.
    for list in ["mixtures", "paths"] {
        follow_names(root, list, &maps);
    }
    sync_list(root, "mixtures", order(&mix_map, old.mixtures.len()), |t, o, n| {
        write_dial::sync_mixture(t, o.map(|o| (&old.mixtures[o], old)), &new.mixtures[n], new);
    })?;
    sync_list(root, "paths", order(&path_map, old.paths.len()), |t, o, n| {
        write_dial::sync_path(t, o.map(|o| (&old.paths[o], old)), &new.paths[n], new);
    })?;
    Ok(())
}

/// Where each old light, reflectance and free group went in the new palette (`None`: removed), for the
/// names `[[mixtures]]` and `[[paths]]` write (the model refers by index). What a paired mixture or path
/// uses is mapped through that pairing ([`write_dial`]: by reflectance and position, which no edit
/// changes); any other entry through the name pairing.
struct IndexMaps<'a> {
    old: &'a Palette,
    new: &'a Palette,
    lights: Vec<Option<usize>>,
    reflectances: Vec<Option<usize>>,
    free: Vec<Option<usize>>,
}

impl<'a> IndexMaps<'a> {
    fn new(
        old: &'a Palette,
        new: &'a Palette,
        pairings: [&[Option<usize>]; 3],
        [mix_map, path_map]: [&[Option<usize>]; 2],
    ) -> IndexMaps<'a> {
        let invert = |pairing: &[Option<usize>], old_len: usize| {
            let mut back = vec![None; old_len];
            for (n, o) in pairing.iter().enumerate() {
                if let Some(slot) = o.and_then(|o| back.get_mut(o)) {
                    *slot = Some(n);
                }
            }
            back
        };
        let mut maps = IndexMaps {
            old,
            new,
            lights: invert(pairings[0], old.lights.len()),
            reflectances: invert(pairings[1], old.reflectances.len()),
            free: invert(pairings[2], old.free.len()),
        };
        let same = |a: &[usize], b: &[usize]| a.len() == b.len();
        let mut lights: Vec<(usize, usize)> = Vec::new();
        let mut pairs: Vec<(usize, usize)> = Vec::new();
        let mut groups: Vec<(usize, usize)> = Vec::new();
        {
            let paired = mix_map.iter().enumerate().filter_map(|(n, o)| Some((&old.mixtures[(*o)?], &new.mixtures[n])));
            for (o, n) in paired {
                pairs.push((o.reflectance, n.reflectance));
                groups.extend(o.free.zip(n.free));
                let ol: Vec<usize> = o.mix.iter().map(|m| m.0).collect();
                let nl: Vec<usize> = n.mix.iter().map(|m| m.0).collect();
                if same(&ol, &nl) && o.spec == MixSpec::Weights {
                    lights.extend(ol.into_iter().zip(nl));
                }
                if let (MixSpec::Dial { off: a, .. }, MixSpec::Dial { off: b, .. }) = (&o.spec, &n.spec)
                    && same(a, b)
                {
                    lights.extend(a.iter().copied().zip(b.iter().copied()));
                }
            }
        }
        {
            let paired = path_map.iter().enumerate().filter_map(|(n, o)| Some((&old.paths[(*o)?], &new.paths[n])));
            for (o, n) in paired {
                pairs.push((o.reflectance, n.reflectance));
                groups.extend(o.free.zip(n.free));
                match (&o.route, &n.route) {
                    (Route::Lights(a), Route::Lights(b)) | (Route::Dial { off: a, .. }, Route::Dial { off: b, .. })
                        if same(a, b) =>
                    {
                        lights.extend(a.iter().copied().zip(b.iter().copied()))
                    }
                    _ => {}
                }
            }
        }
        for (map, exact) in [(&mut maps.lights, lights), (&mut maps.reflectances, pairs), (&mut maps.free, groups)] {
            for (o, n) in exact {
                if let Some(slot) = map.get_mut(o) {
                    *slot = Some(n);
                }
            }
        }
        maps
    }

    /// The name the new palette gives the entry the old one called `name` on that side, when it differs.
    fn renamed(&self, side: Side, name: &str) -> Option<String> {
        let (old, new, map): (Vec<&String>, Vec<&String>, &[Option<usize>]) = match side {
            Side::Light => (names(&self.old.lights), names(&self.new.lights), &self.lights),
            Side::Reflectance => (names(&self.old.reflectances), names(&self.new.reflectances), &self.reflectances),
            Side::Free => (
                self.old.free.iter().map(|g| &g.name).collect(),
                self.new.free.iter().map(|g| &g.name).collect(),
                &self.free,
            ),
        };
        let o = old.iter().position(|n| *n == name)?;
        let now = new.get((*map.get(o)?)?)?;
        (*now != name).then(|| now.to_string())
    }
}

fn names(entries: &[SpectrumEntry]) -> Vec<&String> {
    entries.iter().map(|e| &e.name).collect()
}

#[derive(Clone, Copy)]
enum Side {
    Light,
    Reflectance,
    Free,
}

/// Rewrite the names a `[[mixtures]]` or `[[paths]]` list uses that were renamed (`reflectance`, `free`,
/// the lights of `off`, `lights`, `through` and the keys of `mix`), each in place with its formatting.
fn follow_names(root: &mut Table, list: &str, maps: &IndexMaps) {
    let rename_value = |v: &mut Value, side: Side| {
        if let Some(now) = v.as_str().and_then(|name| maps.renamed(side, name)) {
            let decor = v.decor().clone();
            *v = Value::from(now);
            *v.decor_mut() = decor;
        }
    };
    let follow = |t: &mut dyn TableLike| {
        for (key, side) in [("reflectance", Side::Reflectance), ("free", Side::Free)] {
            if let Some(v) = t.get_mut(key).and_then(Item::as_value_mut) {
                rename_value(v, side);
            }
        }
        for key in ["off", "lights", "through"] {
            if let Some(arr) = t.get_mut(key).and_then(Item::as_value_mut).and_then(Value::as_array_mut) {
                arr.iter_mut().for_each(|v| rename_value(v, Side::Light));
            }
        }
        if let Some(mix) = t.get_mut("mix").and_then(Item::as_table_like_mut)
            && mix.iter().any(|(k, _)| maps.renamed(Side::Light, k).is_some())
        {
            let entries: Vec<(toml_edit::Key, Item)> = mix
                .iter()
                .map(|(k, item)| {
                    let key = mix.key(k).cloned().unwrap_or_else(|| toml_edit::Key::new(k));
                    let key = match maps.renamed(Side::Light, k) {
                        Some(now) => toml_edit::Key::new(now).with_leaf_decor(key.leaf_decor().clone()),
                        None => key,
                    };
                    (key, item.clone())
                })
                .collect();
            mix.clear();
            for (key, item) in entries {
                mix.entry_format(&key).or_insert(item);
            }
        }
    };
    match root.get_mut(list) {
        Some(Item::ArrayOfTables(aot)) => aot.iter_mut().for_each(|t| follow(t)),
        Some(Item::Value(Value::Array(arr))) => {
            arr.iter_mut().filter_map(Value::as_inline_table_mut).for_each(|t| follow(t))
        }
        _ => {}
    }
}

/// For each new item the old item it continues: same name first, else the unpaired old item at its index.
fn pair_by_name<T>(old: &[T], new: &[T], name: impl Fn(&T) -> &String) -> Vec<Option<usize>> {
    let mut taken = vec![false; old.len()];
    let mut map: Vec<Option<usize>> = new
        .iter()
        .map(|n| {
            let o = old.iter().position(|o| name(o) == name(n))?;
            (!taken[o]).then(|| {
                taken[o] = true;
                o
            })
        })
        .collect();
    for (i, slot) in map.iter_mut().enumerate() {
        if slot.is_none() && i < old.len() && !taken[i] && !new.iter().any(|n| name(n) == name(&old[i])) {
            taken[i] = true;
            *slot = Some(i);
        }
    }
    map
}

/// The document order of the updated list: kept tables in their old order, then new ones in model order.
fn order(map: &[Option<usize>], old_len: usize) -> Vec<(Option<usize>, usize)> {
    let mut by_old: Vec<Option<usize>> = vec![None; old_len];
    let mut placed = vec![false; map.len()];
    for (n, o) in map.iter().enumerate() {
        if let Some(o) = o
            && let Some(slot @ None) = by_old.get_mut(*o)
        {
            *slot = Some(n);
            placed[n] = true;
        }
    }
    let mut out: Vec<(Option<usize>, usize)> =
        by_old.iter().enumerate().filter_map(|(o, n)| n.map(|n| (Some(o), n))).collect();
    // New items, and any that claimed an old table another item already continues, get a new table.
    out.extend((0..map.len()).filter(|&n| !placed[n]).map(|n| (None, n)));
    out
}

/// Rebuild the array (of tables, or inline) under `key`: each (old table, new item) pair is synced in place.
fn sync_list(
    root: &mut Table,
    key: &str,
    pairs: Vec<(Option<usize>, usize)>,
    mut sync: impl FnMut(&mut dyn TableLike, Option<usize>, usize),
) -> Res {
    if !root.contains_key(key) {
        if pairs.is_empty() {
            return Ok(());
        }
        root.insert(key, Item::ArrayOfTables(ArrayOfTables::new()));
    }
    match root.get_mut(key) {
        Some(Item::ArrayOfTables(aot)) => {
            let old: Vec<Table> = aot.iter().cloned().collect();
            aot.clear();
            for (o, n) in pairs {
                let mut t = o.and_then(|o| old.get(o).cloned()).unwrap_or_default();
                sync(&mut t, o, n);
                aot.push(t);
            }
        }
        Some(Item::Value(Value::Array(arr))) => {
            let old: Vec<Value> = arr.iter().cloned().collect();
            arr.clear();
            for (o, n) in pairs {
                let mut v =
                    o.and_then(|o| old.get(o).cloned()).unwrap_or_else(|| Value::InlineTable(InlineTable::new()));
                if let Value::InlineTable(t) = &mut v {
                    sync(t, o, n);
                }
                arr.push_formatted(v);
            }
        }
        _ => return Err(StructureError(format!("`{key}` is not an array of tables"))),
    }
    let now_empty = match root.get(key) {
        Some(Item::ArrayOfTables(a)) => a.is_empty(),
        Some(Item::Value(Value::Array(a))) => a.is_empty(),
        _ => false,
    };
    if now_empty {
        root.remove(key);
    }
    Ok(())
}

/// Set `key` to `v`, keeping the key's place, its comments and the old value's trailing comment.
pub(super) fn put(t: &mut dyn TableLike, key: &str, mut v: Value) {
    match t.get_mut(key) {
        Some(Item::Value(old)) => {
            *v.decor_mut() = old.decor().clone();
            *old = v;
        }
        Some(item) => *item = Item::Value(v),
        None => {
            t.insert(key, Item::Value(v));
        }
    }
}

/// Write a value when it changed; a value equal to its default is only written where the key already is.
pub(super) fn sync_value<T: PartialEq>(
    t: &mut dyn TableLike,
    key: &str,
    old: Option<T>,
    new: T,
    default: T,
    v: impl Fn(T) -> Value,
) {
    if old.as_ref() == Some(&new) || (!t.contains_key(key) && new == default) {
        return;
    }
    put(t, key, v(new));
}

pub(super) fn float_array(values: &[f64]) -> Value {
    let mut a = Array::new();
    for &x in values {
        a.push(x);
    }
    Value::Array(a)
}

/// Samples written eight to a line, like a table: `[`, each line of eight indented by four spaces, a
/// trailing comma and `]` on its own line. The numbers are written as `toml_writer` (the formatter
/// `toml_edit` itself prints floats with) writes them ([`super::float_text::push_f64`]), straight into
/// one string.
pub(super) fn samples_text(values: &[f64]) -> String {
    let mut w = String::with_capacity(samples_text_bytes(values.len()));
    push_samples_text(&mut w, values, "\n");
    w
}

/// About how many bytes [`samples_text`] of `n` values takes: a float between 1e-5 and 1e17 in size takes at
/// most 24 (`{}` writes no exponent, so far smaller or larger ones take more and the text then grows).
pub(super) fn samples_text_bytes(n: usize) -> usize {
    24 * n + 4
}

/// [`samples_text`] appended to `w`, each line feed written as `newline` (`"\r\n"` for a CRLF file: the
/// text `samples_text(values).replace('\n', "\r\n")` without a string of its own).
pub(super) fn push_samples_text(w: &mut String, values: &[f64], newline: &str) {
    w.push('[');
    for (i, &x) in values.iter().enumerate() {
        match (i > 0, i % 8 == 0) {
            (false, _) => {
                w.push_str(newline);
                w.push_str("    ");
            }
            (true, true) => {
                w.push(',');
                w.push_str(newline);
                w.push_str("    ");
            }
            (true, false) => w.push_str(", "),
        }
        super::float_text::push_f64(w, x);
    }
    if !values.is_empty() {
        w.push(',');
    }
    w.push_str(newline);
    w.push(']');
}

/// The samples as a document value: [`samples_text`] read by `toml_edit`, which keeps the text as it is.
fn samples_array(values: &[f64]) -> Value {
    samples_text(values).parse().expect("toml_writer writes every f64 as a TOML float, so the array parses")
}

fn bounds_value(b: Bounds) -> Value {
    float_array(&[b.lower, b.upper])
}

fn sync_optional_bounds(t: &mut dyn TableLike, key: &str, old: Option<Option<Bounds>>, new: Option<Bounds>) {
    if old == Some(new) {
        return;
    }
    match new {
        Some(b) => put(t, key, bounds_value(b)),
        None => {
            t.remove(key);
        }
    }
}

fn sync_settings(root: &mut Table, old: &Settings, new: &Settings) {
    if old == new {
        return;
    }
    if !root.contains_key("settings") {
        let mut table = Table::new();
        table.set_position(Some(0));
        root.insert("settings", Item::Table(table));
    }
    let Some(t) = root.get_mut("settings").and_then(Item::as_table_like_mut) else { return };
    let d = Settings::default();
    sync_value(t, "basis_dimension", Some(old.basis_dimension), new.basis_dimension, d.basis_dimension, |m| {
        Value::from(m as i64)
    });
    sync_value(t, "smoothness", Some(old.smoothness), new.smoothness, d.smoothness, Value::from);
    sync_value(t, "subspace_error", Some(old.subspace_error), new.subspace_error, d.subspace_error, Value::from);
    sync_value(t, "fit_in_subspace", Some(old.fit_in_subspace), new.fit_in_subspace, d.fit_in_subspace, Value::from);
    sync_value(
        t,
        "reflectance_bounds",
        Some(old.reflectance_bounds),
        new.reflectance_bounds,
        d.reflectance_bounds,
        bounds_value,
    );
    sync_value(t, "light_bounds", Some(old.light_bounds), new.light_bounds, d.light_bounds, bounds_value);
}

/// How a spectrum is written ([`written_source`]).
pub(super) struct Written<'e> {
    /// The entry's own source (borrowed, or rebased for another folder), or its samples.
    pub(super) source: Cow<'e, Source>,
    pub(super) normalize: Normalize,
    pub(super) scale: f64,
    /// What the entry's own source resolved to (with the entry's kind, normalisation and scale) when it is
    /// written as it is: a save that needs what the new table reads as takes it rather than resolving the
    /// same source a second time (a solve's save resolved each changed spectrum twice).
    pub(super) resolved: Option<Spectrum>,
}

/// How a spectrum is written: its own source when the samples are what that source resolves to, else
/// (designed or edited samples) the samples themselves, never normalised or scaled again.
pub(super) fn written_source<'e>(entry: &'e SpectrumEntry, ctx: &SaveContext) -> Written<'e> {
    match ctx.resolve(&entry.source, entry.kind, entry.normalize, entry.scale) {
        Some(r) if spectra_agree(&r, &entry.spectrum) => {
            let source = rebase_csv(&entry.source, ctx);
            // A rebased path resolves from another folder: not the resolve made here.
            let resolved = matches!(source, Cow::Borrowed(_)).then_some(r);
            Written { source, normalize: entry.normalize, scale: entry.scale, resolved }
        }
        _ => {
            let normalize = if entry.kind == Kind::Light { Normalize::None } else { entry.normalize };
            Written {
                source: Cow::Owned(Source::Samples(entry.spectrum.to_vec())),
                normalize,
                scale: 1.0,
                resolved: None,
            }
        }
    }
}

/// A relative CSV path rewritten for the folder the file is saved into (any other source as it is).
fn rebase_csv<'s>(source: &'s Source, ctx: &SaveContext) -> Cow<'s, Source> {
    let Source::Csv(file) = source else { return Cow::Borrowed(source) };
    let file_path = Path::new(file);
    let Some(old_base) = ctx.old_base else { return Cow::Borrowed(source) };
    if file_path.is_absolute() || same_dir(old_base, ctx.new_base) {
        return Cow::Borrowed(source);
    }
    let target = old_base.join(file_path);
    let rebased = match (std::fs::canonicalize(&target), std::fs::canonicalize(ctx.new_base)) {
        (Ok(t), Ok(b)) => relative_path(&t, &b).unwrap_or(t),
        _ => std::path::absolute(&target).unwrap_or(target),
    };
    Cow::Owned(Source::Csv(rebased.to_string_lossy().into_owned()))
}

pub(super) fn same_dir(a: &Path, b: &Path) -> bool {
    match (std::fs::canonicalize(a), std::fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    }
}

/// `target` relative to the folder `base` (both absolute and canonical).
fn relative_path(target: &Path, base: &Path) -> Option<PathBuf> {
    let t: Vec<Component> = target.components().collect();
    let b: Vec<Component> = base.components().collect();
    let common = t.iter().zip(&b).take_while(|(x, y)| x == y).count();
    if common == 0 {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..b.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c.as_os_str());
    }
    Some(out)
}

/// The text of a source's value as the writer writes it ([`source_value`] printed; samples without
/// building a document value).
pub(super) fn source_text(source: &Source) -> String {
    match source {
        Source::Samples(v) => samples_text(v),
        other => source_value(other).to_string(),
    }
}

/// A source's value as the writer writes it.
pub(super) fn source_value(source: &Source) -> Value {
    match source {
        Source::Illuminant(s) | Source::ColorChecker(s) | Source::Csv(s) => Value::from(s.as_str()),
        Source::Planck(x) | Source::Flat(x) => Value::from(*x),
        Source::Samples(v) => samples_array(v),
    }
}

/// Replace whatever source key the table has by `source`, at the place of the old key.
fn replace_source(t: &mut dyn TableLike, source: &Source) {
    let new_key = source.key();
    let present: Vec<&str> = Source::KEYS.iter().copied().filter(|k| t.contains_key(k)).collect();
    if present == [new_key] {
        put(t, new_key, source_value(source));
        return;
    }
    let Some(first) = present.first().copied() else {
        t.insert(new_key, Item::Value(source_value(source)));
        return;
    };
    // Rebuild the table so the new key takes the old one's place and comments.
    let keys: Vec<String> = t.iter().map(|(k, _)| k.to_string()).collect();
    let mut items = Vec::with_capacity(keys.len());
    for k in &keys {
        if let Some((key, item)) = t.get_key_value(k) {
            items.push((key.clone(), item.clone()));
        }
    }
    t.clear();
    for (key, item) in items {
        let name = key.get().to_string();
        if name == first {
            let mut v = source_value(source);
            if let Item::Value(old) = &item {
                *v.decor_mut() = old.decor().clone();
            }
            let new_key_formatted = toml_edit::Key::new(new_key).with_leaf_decor(key.leaf_decor().clone());
            t.entry_format(&new_key_formatted).or_insert(Item::Value(v));
        } else if !Source::KEYS.contains(&name.as_str()) {
            t.entry_format(&key).or_insert(item);
        }
    }
}

pub(super) fn sync_spectrum(
    t: &mut dyn TableLike,
    old: Option<&SpectrumEntry>,
    new: &SpectrumEntry,
    ctx: &SaveContext,
) {
    if old.map(|o| &o.name) != Some(&new.name) {
        put(t, "name", Value::from(new.name.as_str()));
    }
    let Written { source, normalize, scale, .. } = written_source(new, ctx);
    if old.map(|o| &o.source) != Some(&*source) {
        replace_source(t, &source);
    }
    if new.kind == Kind::Light {
        sync_value(t, "normalize", old.map(|o| o.normalize), normalize, Normalize::default(), |n| {
            Value::from(n.as_str())
        });
    }
    sync_value(t, "scale", old.map(|o| o.scale), scale, 1.0, Value::from);
    sync_value(t, "design", old.map(|o| o.design), new.design, false, Value::from);
    sync_optional_bounds(t, "bounds", old.map(|o| o.bounds), new.bounds);
    if old.map(|o| o.dial) != Some(new.dial) {
        match new.dial {
            Some(d) => put(t, "dial", float_array(&d)),
            None => {
                t.remove("dial");
            }
        }
    }
}

fn sync_free(t: &mut dyn TableLike, old: Option<&FreeGroup>, new: &FreeGroup) {
    if old.map(|o| &o.name) != Some(&new.name) {
        put(t, "name", Value::from(new.name.as_str()));
    }
    for (key, old_side, new_side, open) in [
        ("lower", old.map(|o| o.lower), new.lower, f64::NEG_INFINITY),
        ("upper", old.map(|o| o.upper), new.upper, f64::INFINITY),
    ] {
        sync_value(t, key, old_side, new_side, Vector3::repeat(open), |v| float_array(v.as_slice()));
    }
}

/// The target as written: hex when the notation is hex and the colour is inside the display gamut.
fn target_value(cell: &ColourCell) -> Value {
    target_text(&cell.target, cell.notation == TargetNotation::Hex)
}

/// A target as written: `"#rrggbb"` when `hex` and the colour is inside the display gamut, else `[r, g, b]`.
pub(super) fn target_text(target: &Vector3<f64>, hex: bool) -> Value {
    let in_gamut = target.iter().all(|v| (0.0..=1.0).contains(v));
    if hex && in_gamut { Value::from(linear_to_hex(target)) } else { float_array(target.as_slice()) }
}

fn sync_colour(t: &mut dyn TableLike, old: Option<(&ColourCell, &Palette)>, new: &ColourCell, palette: &Palette) {
    let light = palette.lights.get(new.light).map_or("", |e| e.name.as_str());
    let reflectance = palette.reflectances.get(new.reflectance).map_or("", |e| e.name.as_str());
    let old_light = old.and_then(|(c, p)| p.lights.get(c.light)).map(|e| e.name.as_str());
    let old_refl = old.and_then(|(c, p)| p.reflectances.get(c.reflectance)).map(|e| e.name.as_str());
    if old_light != Some(light) {
        put(t, "light", Value::from(light));
    }
    if old_refl != Some(reflectance) {
        put(t, "reflectance", Value::from(reflectance));
    }
    // A free cell's target is ignored by the design; it is written when the file has one or it is set.
    let target_shown = new.free.is_none() || t.contains_key("target") || new.target != Vector3::zeros();
    let target_same = old.is_some_and(|(c, _)| c.target == new.target && c.notation == new.notation);
    if target_shown && !target_same {
        put(t, "target", target_value(new));
    }
    sync_value(t, "weight", old.map(|(c, _)| c.weight), new.weight, 1.0, Value::from);
    let group = new.free.and_then(|g| palette.free.get(g)).map(|g| g.name.as_str());
    let old_group = old.map(|(c, p)| c.free.and_then(|g| p.free.get(g)).map(|g| g.name.as_str()));
    if old_group != Some(group) {
        match group {
            Some(g) => put(t, "free", Value::from(g)),
            None => {
                t.remove("free");
            }
        }
    }
    sync_value(t, "use", old.map(|(c, _)| c.enabled), new.enabled, true, Value::from);
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The samples array as `toml_edit` prints one built value by value (the oracle for [`samples_text`]).
    fn built(values: &[f64]) -> String {
        let mut a = Array::new();
        for (i, &x) in values.iter().enumerate() {
            let mut v = Value::from(x);
            v.decor_mut().set_prefix(if i % 8 == 0 { "\n    " } else { " " });
            v.decor_mut().set_suffix("");
            a.push_formatted(v);
        }
        a.set_trailing("\n");
        a.set_trailing_comma(true);
        Value::Array(a).to_string()
    }

    #[test]
    fn samples_text_is_what_toml_edit_prints() {
        let awkward = [
            0.0,
            -0.0,
            1.0,
            -3.0,
            0.1,
            1e-7,
            2.5e-300,
            1e22,
            123456789.0,
            f64::MIN_POSITIVE,
            std::f64::consts::FRAC_1_SQRT_2,
        ];
        let mut x = 0.37f64;
        let random: Vec<f64> = (0..200)
            .map(|_| {
                x = (x * 3.7 + 0.123).fract();
                (x - 0.3) * 10f64.powi((x * 12.0) as i32 - 6)
            })
            .collect();
        for values in [&awkward[..], &random[..31], &random[..], &[], &[0.5]] {
            let text = samples_text(values);
            assert_eq!(text, built(values), "{values:?}");
            // Appended to a text, and with CRLF line endings: the same text, its line feeds CRLF.
            let mut crlf = String::from("samples = ");
            push_samples_text(&mut crlf, values, "\r\n");
            assert_eq!(crlf, format!("samples = {}", text.replace('\n', "\r\n")));
            // The document value is that text, and reads back as the same numbers.
            let value = samples_array(values);
            assert_eq!(value.to_string(), text);
            let back: Vec<f64> = value.as_array().unwrap().iter().map(|v| v.as_float().unwrap()).collect();
            assert_eq!(back, values);
        }
    }
}
