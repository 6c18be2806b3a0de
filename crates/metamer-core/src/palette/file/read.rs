//! Reading: a parsed TOML table (`toml`'s borrowed [`DeTable`], spans kept, its `[[name]]` tables in flat
//! lists when a faster path read it, [`super::doc`]) walked into the resolved [`Palette`] model with every
//! validation of DESIGN_SPEC §3. Every error names the key path (`colours[3].light`) and the reason.

use super::PaletteError;
use super::doc::{Doc, Items, TableRef};
use crate::colorimetry::hex_to_linear;
use crate::palette::source::{SourceError, finish};
use crate::palette::{Bounds, ColourCell, FreeGroup, Kind, Palette, Settings, Source, SpectrumEntry, TargetNotation};
use crate::spectrum::{Grid, Normalize, SAMPLES, Samples, Spectrum};
use nalgebra::Vector3;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, PoisonError};
use toml::Spanned;
use toml::de::{DeTable, DeValue};

pub(super) type Table<'i> = DeTable<'i>;

/// The reader's maps of names and cells, with a fast hash (no input chooses their keys to collide: they
/// hold one file's names, which the reader checks for duplicates anyway).
type FastMap<K, V> = HashMap<K, V, foldhash::fast::RandomState>;
pub(super) type Value<'i> = DeValue<'i>;

const TOP_KEYS: &[&str] =
    &["name", "wavelengths", "settings", "lights", "reflectances", "colours", "free", "mixtures", "paths"];
const SETTINGS_KEYS: &[&str] =
    &["basis_dimension", "smoothness", "subspace_error", "fit_in_subspace", "reflectance_bounds", "light_bounds"];
const SPECTRUM_KEYS: &[&str] = &[
    "name",
    "illuminant",
    "colorchecker",
    "planck",
    "flat",
    "samples",
    "csv",
    "normalize",
    "scale",
    "design",
    "bounds",
    "dial",
];
const COLOUR_KEYS: &[&str] = &["light", "reflectance", "target", "weight", "free", "use"];
const FREE_KEYS: &[&str] = &["name", "lower", "upper"];

/// What reading a palette produces besides the model.
pub(super) struct ReadOutcome {
    pub(crate) palette: Palette,
    /// Non-fatal remarks (unknown keys kept as they are).
    pub(crate) warnings: Vec<String>,
    /// Raw (unnormalised) samples of every CSV source read, by the path as written.
    pub(crate) csv_raw: HashMap<String, Spectrum>,
}

/// A spectrum as read, and its CSV file's raw samples when it has one.
type ReadSpectrum = (SpectrumEntry, Option<(String, Spectrum)>);

/// What reading a spectrum gave besides the entry, by its index: the warnings about its keys and its CSV
/// file's raw samples.
type Aside = (usize, Vec<String>, Option<(String, Spectrum)>);

/// A colour cell's keys besides its light and reflectance.
pub(super) struct CellRest {
    pub(super) free: Option<usize>,
    pub(super) target: Vector3<f64>,
    pub(super) notation: TargetNotation,
    pub(super) weight: f64,
    pub(super) enabled: bool,
}

/// Why the reader refused a colour cell: its light or reflectance, or (with its light and reflectance) its
/// other keys.
enum RefusedCell {
    Cell(PaletteError),
    Rest((usize, usize), PaletteError),
}

/// The cells given so far, by light and reflectance: a table of every pair when there are not many more
/// pairs than cells (a batch's few lights on its many reflectances), a map otherwise.
enum Cells {
    Table(Vec<u32>, usize),
    Map(FastMap<(usize, usize), usize>),
}

impl Cells {
    fn new(lights: usize, reflectances: usize, cells: usize) -> Cells {
        match lights.checked_mul(reflectances) {
            Some(pairs) if pairs <= 4 * cells + 1024 && cells < u32::MAX as usize => {
                Cells::Table(vec![u32::MAX; pairs], reflectances)
            }
            _ => Cells::Map(FastMap::with_capacity_and_hasher(cells, Default::default())),
        }
    }

    /// Record cell `i` on `light` and `reflectance`; the cell that gave the pair first, if one did.
    fn insert(&mut self, light: usize, reflectance: usize, i: usize) -> Option<usize> {
        match self {
            Cells::Table(first, reflectances) => {
                let slot = &mut first[light * *reflectances + reflectance];
                if *slot != u32::MAX {
                    return Some(*slot as usize);
                }
                *slot = i as u32;
                None
            }
            Cells::Map(map) => map.insert((light, reflectance), i),
        }
    }
}

/// Walks a parsed table, collecting warnings and naming keys in errors.
pub(super) struct Reader<'a> {
    path: &'a Path,
    base_dir: Option<PathBuf>,
    luminance: Samples,
    pub(super) warnings: Vec<String>,
    csv_raw: HashMap<String, Spectrum>,
    /// The `samples` arrays read before the parse ([`super::numbers`]), when the text was blanked there.
    hand_read: Option<&'a super::numbers::Read>,
}

pub(super) type Res<T> = Result<T, PaletteError>;

/// An entry's place in its list (`colours[3]`), written out only when a message or warning needs it (a
/// batch of designs has thousands of entries and few messages).
pub(super) struct At<'a>(pub(super) &'a str, pub(super) usize);

impl std::fmt::Display for At<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}[{}]", self.0, self.1)
    }
}

/// Lookups by key in a parsed table.
pub(super) trait TableExt<'i> {
    fn value(&self, key: &str) -> Option<&Value<'i>>;
}

impl<'i> TableExt<'i> for Table<'i> {
    fn value(&self, key: &str) -> Option<&Value<'i>> {
        self.get(key).map(Spanned::get_ref)
    }
}

/// An integer's value (`None` for other types and for integers beyond i64, which
/// [`check_numbers`] refuses before reading).
pub(super) fn integer_of(v: &Value) -> Option<i64> {
    v.as_integer().and_then(|i| i64::from_str_radix(i.as_str(), i.radix()).ok())
}

/// A number's value, integers converted (`None` for other types).
fn number_of(v: &Value) -> Option<f64> {
    match v {
        Value::Float(f) => f.as_str().parse::<f64>().ok(),
        Value::Integer(_) => integer_of(v).map(|i| i as f64),
        _ => None,
    }
}

/// The first number in `v` that TOML cannot represent (an integer beyond i64, a float that overflows to
/// infinity without being written `inf`), with its span and the reason: the parser keeps their text and
/// leaves that check to the reader.
pub(super) fn check_numbers(v: &Spanned<Value>) -> Option<(std::ops::Range<usize>, &'static str)> {
    match v.get_ref() {
        Value::Integer(_) if integer_of(v.get_ref()).is_none() => Some((v.span(), "integer number overflowed")),
        Value::Float(f) => match f.as_str().parse::<f64>() {
            Ok(x) if x.is_finite() || f.as_str().contains("inf") || x.is_nan() => None,
            Ok(_) => Some((v.span(), "floating-point number overflowed")),
            Err(_) => Some((v.span(), "invalid float")),
        },
        Value::Array(a) => a.iter().find_map(check_numbers),
        Value::Table(t) => t.values().find_map(check_numbers),
        _ => None,
    }
}

fn type_name(v: &Value) -> &'static str {
    match v {
        Value::String(_) => "a string",
        Value::Integer(_) => "an integer",
        Value::Float(_) => "a float",
        Value::Boolean(_) => "a boolean",
        Value::Datetime(_) => "a date-time",
        Value::Array(_) => "an array",
        Value::Table(_) => "a table",
    }
}

impl<'a> Reader<'a> {
    pub(super) fn new(path: &'a Path, luminance: Samples, hand_read: Option<&'a super::numbers::Read>) -> Reader<'a> {
        let base_dir = Some(crate::fsio::folder_of(path));
        Reader { path, base_dir, luminance, warnings: Vec::new(), csv_raw: HashMap::new(), hand_read }
    }

    /// The numbers of `t`'s `samples` array when they were read before the parse (the parser then saw an
    /// empty array at its span).
    fn read_samples(&self, t: TableRef) -> Option<Vec<f64>> {
        self.hand_read_array(t.get("samples")?).map(<[f64]>::to_vec)
    }

    /// The numbers of the array `v` when they were read before the parse ([`super::numbers`]).
    fn hand_read_array(&self, v: &Spanned<Value>) -> Option<&'a [f64]> {
        match v.get_ref() {
            Value::Array(items) if items.is_empty() => self.hand_read?.take(&v.span()),
            _ => None,
        }
    }

    pub(super) fn invalid(&self, key: impl Into<String>, reason: impl Into<String>) -> PaletteError {
        PaletteError::Invalid { path: self.path.to_path_buf(), key: key.into(), reason: reason.into(), line: None }
    }

    pub(super) fn wrong_type(&self, key: &str, expected: &str, v: &Value) -> PaletteError {
        self.invalid(key, format!("expected {expected}, found {}", type_name(v)))
    }

    fn warn_unknown(&mut self, table: &Table, known: &[&str], prefix: &dyn std::fmt::Display) {
        let w = self.unknown_keys(TableRef::Tree(table), known, prefix);
        self.warnings.extend(w);
    }

    /// The warnings about the keys of `table` not in `known`.
    pub(super) fn unknown_keys(&self, table: TableRef, known: &[&str], prefix: &dyn std::fmt::Display) -> Vec<String> {
        self.unknown_of(table.iter().map(|(k, _)| k), known, prefix)
    }

    /// The warnings about the `keys` not in `known`, in the order of the keys' text (a tree's order).
    fn unknown_of<'k>(
        &self,
        keys: impl Iterator<Item = &'k str>,
        known: &[&str],
        prefix: &dyn std::fmt::Display,
    ) -> Vec<String> {
        let mut unknown: Vec<&str> = keys.filter(|k| !known.contains(k)).collect();
        unknown.sort_unstable();
        let mut out = Vec::with_capacity(unknown.len());
        for k in unknown {
            let prefix = prefix.to_string();
            let at = if prefix.is_empty() { k.to_string() } else { format!("{prefix}.{k}") };
            out.push(format!("{}: {at}: unknown key, kept as it is", self.path.display()));
        }
        out
    }

    pub(super) fn string<'v>(&self, v: &'v Value, key: &str) -> Res<&'v str> {
        self.string_lazy(v, || key.to_string())
    }

    /// [`Reader::string`] whose key is written out only for a message.
    fn string_lazy<'v>(&self, v: &'v Value, key: impl Fn() -> String) -> Res<&'v str> {
        v.as_str().ok_or_else(|| self.wrong_type(&key(), "a string", v))
    }

    fn boolean(&self, v: &Value, key: &str) -> Res<bool> {
        self.boolean_lazy(v, || key.to_string())
    }

    /// [`Reader::boolean`] whose key is written out only for a message.
    fn boolean_lazy(&self, v: &Value, key: impl Fn() -> String) -> Res<bool> {
        v.as_bool().ok_or_else(|| self.wrong_type(&key(), "true or false", v))
    }

    /// A number (integer or float), never NaN; infinities only when `allow_inf`.
    pub(super) fn number(&self, v: &Value, key: &str, allow_inf: bool) -> Res<f64> {
        let x = match number_of(v) {
            Some(x) => x,
            None => return Err(self.wrong_type(key, "a number", v)),
        };
        if x.is_nan() {
            Err(self.invalid(key, "NaN is not allowed"))
        } else if x.is_infinite() && !allow_inf {
            Err(self.invalid(key, "must be finite (inf is only allowed in bounds)"))
        } else {
            Ok(x)
        }
    }

    /// [`Reader::number`] (infinities refused) whose key is written out only for a message.
    fn number_lazy(&self, v: &Value, key: impl Fn() -> String) -> Res<f64> {
        match number_of(v) {
            Some(x) if x.is_finite() => Ok(x),
            _ => self.number(v, &key(), false),
        }
    }

    pub(super) fn numbers(&self, v: &Value, key: &str, len: Option<usize>, allow_inf: bool) -> Res<Vec<f64>> {
        let arr = v.as_array().ok_or_else(|| self.wrong_type(key, "an array of numbers", v))?;
        if let Some(n) = len
            && arr.len() != n
        {
            return Err(self.invalid(key, format!("expected {n} numbers, found {}", arr.len())));
        }
        arr.iter()
            .enumerate()
            .map(|(i, x)| match number_of(x.get_ref()) {
                // The common case without building the element's key.
                Some(v) if v.is_finite() || (allow_inf && v.is_infinite()) => Ok(v),
                _ => self.number(x.get_ref(), &format!("{key}[{i}]"), allow_inf),
            })
            .collect()
    }

    fn bounds(&self, v: &Value, key: &str) -> Res<Bounds> {
        let b = self.numbers(v, key, Some(2), true)?;
        if b[0] > b[1] {
            return Err(self.invalid(key, format!("inverted bounds: lower {} is above upper {}", b[0], b[1])));
        }
        Ok(Bounds::new(b[0], b[1]))
    }

    pub(super) fn sub_table<'v, 'i>(&self, v: &'v Value<'i>, key: &str) -> Res<&'v Table<'i>> {
        v.as_table().ok_or_else(|| self.wrong_type(key, "a table", v))
    }

    pub(super) fn array_of_tables<'v, 'i>(&self, doc: &'v Doc<'i>, key: &str) -> Res<Items<'v, 'i>> {
        if let Some(list) = doc.list(key) {
            return Ok(Items::Flat(doc, &list.items));
        }
        let tables = match doc.value(key) {
            None => Ok(Vec::new()),
            // The element's key is only built for the message.
            Some(Value::Array(items)) => items
                .iter()
                .enumerate()
                .map(|(i, item)| match item.get_ref() {
                    Value::Table(t) => Ok(t),
                    v => Err(self.wrong_type(&format!("{key}[{i}]"), "a table", v)),
                })
                .collect(),
            Some(v) => Err(self.wrong_type(key, &format!("an array of tables ([[{key}]])"), v)),
        };
        tables.map(Items::Tree)
    }

    /// Walk the whole document.
    pub(super) fn read(mut self, root: &Doc) -> Res<ReadOutcome> {
        if root.is_empty() {
            return Err(PaletteError::Empty { path: self.path.to_path_buf() });
        }
        let w = self.unknown_of(root.keys(), TOP_KEYS, &"");
        self.warnings.extend(w);
        let name = match root.value("name") {
            Some(v) => self.string(v, "name")?.to_string(),
            None => self.path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default(),
        };
        if let Some(v) = root.value("wavelengths") {
            self.wavelengths(v)?;
        }
        let settings = match root.value("settings") {
            Some(v) => self.settings(self.sub_table(v, "settings")?)?,
            None => Settings::default(),
        };
        let lights = self.spectra(root, "lights", Kind::Light)?;
        let reflectances = self.spectra(root, "reflectances", Kind::Reflectance)?;
        let free = self.free_groups(root)?;
        let colours = self.colours(root, &lights, &reflectances, &free)?;
        let mixtures = self.mixtures(root, &lights, &reflectances, &free)?;
        let paths = self.paths(root, &lights, &reflectances, &free)?;
        let palette = Palette { name, settings, lights, reflectances, colours, free, mixtures, paths };
        palette.check_scale().map_err(|e| self.invalid(e.key, e.reason))?;
        Ok(ReadOutcome { palette, warnings: self.warnings, csv_raw: self.csv_raw })
    }

    fn wavelengths(&mut self, v: &Value) -> Res<()> {
        let t = self.sub_table(v, "wavelengths")?;
        self.warn_unknown(t, &["start", "step", "count"], &"wavelengths");
        let std = Grid::STANDARD;
        let get = |k: &str| t.value(k).ok_or_else(|| self.invalid(format!("wavelengths.{k}"), "missing"));
        let start = self.number(get("start")?, "wavelengths.start", false)?;
        let step = self.number(get("step")?, "wavelengths.step", false)?;
        let count_v = get("count")?;
        let count = integer_of(count_v).ok_or_else(|| self.wrong_type("wavelengths.count", "an integer", count_v))?;
        if start != std.start_nm || step != std.step_nm || count != std.count as i64 {
            return Err(self.invalid(
                "wavelengths",
                format!(
                    "only the standard grid is supported: start = {}, step = {}, count = {} (got {start}, {step}, {count})",
                    std.start_nm, std.step_nm, std.count
                ),
            ));
        }
        Ok(())
    }

    fn settings(&mut self, t: &Table) -> Res<Settings> {
        self.warn_unknown(t, SETTINGS_KEYS, &"settings");
        let mut s = Settings::default();
        if let Some(v) = t.value("basis_dimension") {
            let key = "settings.basis_dimension";
            let m = integer_of(v).ok_or_else(|| self.wrong_type(key, "an integer", v))?;
            let Some(m) = usize::try_from(m).ok().filter(|m| crate::spectrum::BASIS_DIMENSIONS.contains(m)) else {
                return Err(self.invalid(key, format!("must be between 1 and {SAMPLES}, got {m}")));
            };
            s.basis_dimension = m;
        }
        for (k, slot) in [("smoothness", &mut s.smoothness), ("subspace_error", &mut s.subspace_error)] {
            if let Some(v) = t.value(k) {
                let key = format!("settings.{k}");
                let x = self.number(v, &key, false)?;
                if x < 0.0 {
                    return Err(self.invalid(key, format!("must not be negative, got {x}")));
                }
                *slot = x;
            }
        }
        if let Some(v) = t.value("fit_in_subspace") {
            s.fit_in_subspace = self.boolean(v, "settings.fit_in_subspace")?;
        }
        if let Some(v) = t.value("reflectance_bounds") {
            s.reflectance_bounds = self.bounds(v, "settings.reflectance_bounds")?;
        }
        if let Some(v) = t.value("light_bounds") {
            s.light_bounds = self.bounds(v, "settings.light_bounds")?;
        }
        Ok(s)
    }

    fn spectra(&mut self, root: &Doc, list: &str, kind: Kind) -> Res<Vec<SpectrumEntry>> {
        let tables = self.array_of_tables(root, list)?;
        // Entries are read in parallel straight into their places, then checked in order (the first error in
        // file order is reported); the few warnings and CSV files aside, by entry.
        let this = &*self;
        let aside: Mutex<Vec<Aside>> = Mutex::new(Vec::new());
        let mut read: Vec<Res<SpectrumEntry>> = Vec::with_capacity(tables.len());
        (0..tables.len())
            .into_par_iter()
            .map(|i| {
                let t = tables.get(i);
                let at = At(list, i);
                let warnings = this.unknown_keys(t, SPECTRUM_KEYS, &at);
                let (entry, csv) = match this.spectrum(t, &at, kind) {
                    Ok((entry, csv)) => (Ok(entry), csv),
                    Err(e) => (Err(e), None),
                };
                if !warnings.is_empty() || csv.is_some() {
                    aside.lock().unwrap_or_else(PoisonError::into_inner).push((i, warnings, csv));
                }
                entry
            })
            .collect_into_vec(&mut read);
        let refused = read.iter().position(Result::is_err).unwrap_or(read.len());
        // A name given twice before the first refused entry is reported first.
        let mut seen: FastMap<&str, usize> = FastMap::with_capacity_and_hasher(refused, Default::default());
        for (i, entry) in read[..refused].iter().enumerate() {
            if let Ok(entry) = entry
                && let Some(first) = seen.insert(&entry.name, i)
            {
                return Err(self.invalid(
                    format!("{list}[{i}].name"),
                    format!("duplicate {} name `{}` (first used by {list}[{first}])", kind.as_str(), entry.name),
                ));
            }
        }
        drop(seen);
        if refused < read.len()
            && let Err(e) = read.swap_remove(refused)
        {
            return Err(e);
        }
        let mut aside = aside.into_inner().unwrap_or_else(PoisonError::into_inner);
        aside.sort_unstable_by_key(|(i, _, _)| *i);
        for (_, warnings, csv) in aside {
            self.warnings.extend(warnings);
            if let Some((file, raw)) = csv {
                self.csv_raw.insert(file, raw);
            }
        }
        Ok(read.into_iter().filter_map(Result::ok).collect())
    }

    /// One spectrum, and its CSV file's raw samples when it has one.
    pub(super) fn spectrum(&self, t: TableRef, at: &dyn std::fmt::Display, kind: Kind) -> Res<ReadSpectrum> {
        // Keys are written out for a message only (a batch has thousands of entries).
        let name = match t.value("name") {
            Some(v) => self.string_lazy(v, || format!("{at}.name"))?.to_string(),
            None => return Err(self.invalid(format!("{at}.name"), "missing: every spectrum needs a name")),
        };
        if name.trim().is_empty() {
            return Err(self.invalid(format!("{at}.name"), "the name must not be empty"));
        }
        let present = || Source::KEYS.iter().copied().filter(|k| t.contains_key(k));
        let source_key = match (present().next(), present().nth(1)) {
            (Some(one), None) => one,
            (None, _) => {
                return Err(self.invalid(
                    at.to_string(),
                    format!("{} `{name}` has no source: give one of {}", kind.as_str(), Source::KEYS.join(", ")),
                ));
            }
            (Some(_), Some(_)) => {
                let many: Vec<&str> = present().collect();
                return Err(self.invalid(
                    at.to_string(),
                    format!("{} `{name}` has more than one source key ({}): keep one", kind.as_str(), many.join(", ")),
                ));
            }
        };
        // The key is written out when it is needed (a hand-read array does not need it).
        let key = || format!("{at}.{source_key}");
        let v = t.value(source_key).ok_or_else(|| self.invalid(key(), "missing"))?;
        let source = match source_key {
            "illuminant" => Source::Illuminant(self.string(v, &key())?.to_string()),
            "colorchecker" => Source::ColorChecker(self.string(v, &key())?.to_string()),
            "planck" => Source::Planck(self.number(v, &key(), false)?),
            "flat" => Source::Flat(self.number(v, &key(), false)?),
            "samples" => Source::Samples(match self.read_samples(t) {
                Some(x) => x,
                None => self.numbers(v, &key(), None, false)?,
            }),
            _ => Source::Csv(self.string(v, &key())?.to_string()),
        };
        let normalize = match (t.value("normalize"), kind) {
            (None, _) => Normalize::default(),
            (Some(v), Kind::Light) => {
                let s = self.string(v, &format!("{at}.normalize"))?;
                Normalize::parse(s).ok_or_else(|| {
                    self.invalid(
                        format!("{at}.normalize"),
                        format!("unknown normalisation `{s}` (valid: luminance, l2, none)"),
                    )
                })?
            }
            (Some(_), Kind::Reflectance) => {
                return Err(self.invalid(format!("{at}.normalize"), "reflectances are never normalised: remove it"));
            }
        };
        let scale = match t.value("scale") {
            Some(v) => self.number_lazy(v, || format!("{at}.scale"))?,
            None => 1.0,
        };
        let design = match t.value("design") {
            Some(v) => self.boolean_lazy(v, || format!("{at}.design"))?,
            None => false,
        };
        let bounds = t.value("bounds").map(|v| self.bounds(v, &format!("{at}.bounds"))).transpose()?;
        let dial = match t.value("dial") {
            Some(v) => {
                let d = self.numbers(v, &format!("{at}.dial"), Some(2), false)?;
                Some([d[0], d[1]])
            }
            None => None,
        };
        let raw = source.raw_spectrum(self.base_dir.as_deref()).map_err(|e| self.source_error(&key(), e))?;
        let csv = match &source {
            Source::Csv(file) => Some((file.clone(), raw)),
            _ => None,
        };
        let spectrum = finish(&raw, kind, normalize, scale, &self.luminance).map_err(|e| {
            self.invalid(if kind == Kind::Light { format!("{at}.normalize") } else { key() }, e.to_string())
        })?;
        Ok((SpectrumEntry { name, kind, source, normalize, scale, design, bounds, dial, spectrum }, csv))
    }

    fn source_error(&self, key: &str, e: SourceError) -> PaletteError {
        self.invalid(key, e.to_string())
    }

    fn free_groups(&mut self, root: &Doc) -> Res<Vec<FreeGroup>> {
        let tables = self.array_of_tables(root, "free")?;
        let mut out: Vec<FreeGroup> = Vec::new();
        for (i, t) in tables.iter().enumerate() {
            let at = format!("free[{i}]");
            let w = self.unknown_keys(t, FREE_KEYS, &at);
            self.warnings.extend(w);
            let name = match t.value("name") {
                Some(v) => self.string(v, &format!("{at}.name"))?.to_string(),
                None => return Err(self.invalid(format!("{at}.name"), "missing: every free group needs a name")),
            };
            if name.trim().is_empty() {
                return Err(self.invalid(format!("{at}.name"), "the name must not be empty"));
            }
            if let Some(first) = out.iter().position(|g| g.name == name) {
                return Err(self.invalid(
                    format!("{at}.name"),
                    format!("duplicate free group name `{name}` (first used by free[{first}])"),
                ));
            }
            let side = |k: &str, default: f64| -> Res<Vector3<f64>> {
                match t.value(k) {
                    Some(v) => {
                        let x = self.numbers(v, &format!("{at}.{k}"), Some(3), true)?;
                        Ok(Vector3::new(x[0], x[1], x[2]))
                    }
                    None => Ok(Vector3::repeat(default)),
                }
            };
            let lower = side("lower", f64::NEG_INFINITY)?;
            let upper = side("upper", f64::INFINITY)?;
            if let Some(c) = (0..3).find(|&c| lower[c] > upper[c]) {
                return Err(self.invalid(
                    format!("{at}.lower"),
                    format!("inverted bounds: lower[{c}] = {} is above upper[{c}] = {}", lower[c], upper[c]),
                ));
            }
            out.push(FreeGroup { name, lower, upper });
        }
        Ok(out)
    }

    fn colours<'v>(
        &mut self,
        root: &Doc,
        lights: &'v [SpectrumEntry],
        reflectances: &'v [SpectrumEntry],
        free: &[FreeGroup],
    ) -> Res<Vec<ColourCell>> {
        let tables = self.array_of_tables(root, "colours")?;
        // Names are unique within each list (checked when reading them).
        let index = |entries: &'v [SpectrumEntry]| -> FastMap<&'v str, usize> {
            entries.iter().enumerate().map(|(i, e)| (e.name.as_str(), i)).collect()
        };
        let (light_index, reflectance_index) = (index(lights), index(reflectances));
        // Cells are read in parallel straight into their places (a refused one as what it failed on), then
        // checked in order: the first error in file order is reported, a cell's light and reflectance (and
        // its being a duplicate) before its other keys. The few warnings aside, by cell.
        let this = &*self;
        let aside: Mutex<Vec<(usize, Vec<String>)>> = Mutex::new(Vec::new());
        let mut read: Vec<Result<ColourCell, Box<RefusedCell>>> = Vec::with_capacity(tables.len());
        (0..tables.len())
            .into_par_iter()
            .map(|i| {
                let t = tables.get(i);
                let at = At("colours", i);
                let lookup = |k: &str, entries: &[SpectrumEntry], index: &FastMap<&str, usize>, what: &str| {
                    let key = || format!("{at}.{k}");
                    let v =
                        t.value(k).ok_or_else(|| this.invalid(key(), format!("missing: a colour names its {what}")))?;
                    let name = v.as_str().ok_or_else(|| this.wrong_type(&key(), "a string", v))?;
                    index.get(name).copied().ok_or_else(|| {
                        let known = names(entries);
                        this.invalid(key(), format!("unknown {what} `{name}` (known: {known})"))
                    })
                };
                let cell = lookup("light", lights, &light_index, "light")
                    .and_then(|l| Ok((l, lookup("reflectance", reflectances, &reflectance_index, "reflectance")?)));
                let warnings = this.unknown_keys(t, COLOUR_KEYS, &at);
                if !warnings.is_empty() {
                    aside.lock().unwrap_or_else(PoisonError::into_inner).push((i, warnings));
                }
                match (cell, this.cell_rest(t, &at, free)) {
                    (Ok((light, reflectance)), Ok(CellRest { free, target, notation, weight, enabled })) => {
                        Ok(ColourCell { light, reflectance, target, notation, weight, free, enabled })
                    }
                    (Err(e), _) => Err(Box::new(RefusedCell::Cell(e))),
                    (Ok(pair), Err(e)) => Err(Box::new(RefusedCell::Rest(pair, e))),
                }
            })
            .collect_into_vec(&mut read);
        // The first cell refused or given twice, in file order.
        let mut cells = Cells::new(lights.len(), reflectances.len(), read.len());
        let mut stop = None;
        for (i, cell) in read.iter().enumerate() {
            let (light, reflectance) = match cell {
                Ok(cell) => (cell.light, cell.reflectance),
                Err(refused) => match **refused {
                    RefusedCell::Rest(pair, _) => pair,
                    RefusedCell::Cell(_) => {
                        stop = Some((i, None));
                        break;
                    }
                },
            };
            if let Some(first) = cells.insert(light, reflectance, i) {
                stop = Some((i, Some((first, light, reflectance))));
                break;
            }
            if cell.is_err() {
                stop = Some((i, None));
                break;
            }
        }
        if let Some((i, duplicate)) = stop {
            if let Some((first, light, reflectance)) = duplicate {
                return Err(self.invalid(
                    format!("colours[{i}]"),
                    format!(
                        "duplicate cell: light `{}` on reflectance `{}` is already given by colours[{first}]",
                        lights[light].name, reflectances[reflectance].name
                    ),
                ));
            }
            if let Err(refused) = read.swap_remove(i) {
                let (RefusedCell::Cell(e) | RefusedCell::Rest(_, e)) = *refused;
                return Err(e);
            }
        }
        let mut aside = aside.into_inner().unwrap_or_else(PoisonError::into_inner);
        aside.sort_unstable_by_key(|(i, _)| *i);
        self.warnings.extend(aside.into_iter().flat_map(|(_, w)| w));
        Ok(read.into_iter().filter_map(Result::ok).collect())
    }

    /// A cell's keys besides its light and reflectance.
    pub(super) fn cell_rest(&self, t: TableRef, at: &dyn std::fmt::Display, free: &[FreeGroup]) -> Res<CellRest> {
        let free_group = match t.value("free") {
            Some(v) => {
                let key = format!("{at}.free");
                let name = self.string(v, &key)?;
                Some(free.iter().position(|g| g.name == name).ok_or_else(|| {
                    let known = if free.is_empty() {
                        "none declared: add a [[free]] table".to_string()
                    } else {
                        free.iter().map(|g| g.name.as_str()).collect::<Vec<_>>().join(", ")
                    };
                    self.invalid(&key, format!("unknown free group `{name}` (known: {known})"))
                })?)
            }
            None => None,
        };
        let (target, notation) = match t.get("target") {
            // Read before the parse: finite numbers, checked for their count as `numbers` checks it.
            Some(v) => match self.hand_read_array(v) {
                Some(x) if x.len() == 3 => (Vector3::new(x[0], x[1], x[2]), TargetNotation::Linear),
                Some(x) => {
                    let reason = format!("expected 3 numbers, found {}", x.len());
                    return Err(self.invalid(format!("{at}.target"), reason));
                }
                None => self.target(v.get_ref(), &format!("{at}.target"))?,
            },
            None if free_group.is_some() => (Vector3::zeros(), TargetNotation::Hex),
            None => {
                return Err(self.invalid(
                    format!("{at}.target"),
                    "missing: a colour needs a target (\"#rrggbb\" or [r, g, b]) or a free group",
                ));
            }
        };
        let weight = match t.value("weight") {
            Some(v) => {
                let w = self.number_lazy(v, || format!("{at}.weight"))?;
                if w < 0.0 {
                    return Err(self.invalid(format!("{at}.weight"), format!("weights must not be negative, got {w}")));
                }
                w
            }
            None => 1.0,
        };
        let enabled = match t.value("use") {
            Some(v) => self.boolean_lazy(v, || format!("{at}.use"))?,
            None => true,
        };
        Ok(CellRest { free: free_group, target, notation, weight, enabled })
    }

    fn target(&self, v: &Value, key: &str) -> Res<(Vector3<f64>, TargetNotation)> {
        match v {
            Value::String(s) => hex_to_linear(s.as_ref()).map(|c| (c, TargetNotation::Hex)).ok_or_else(|| {
                self.invalid(
                    key,
                    format!("bad hex colour `{s}`: write \"#rrggbb\" (display sRGB) or [r, g, b] (linear)"),
                )
            }),
            Value::Array(_) => {
                let x = self.numbers(v, key, Some(3), false)?;
                Ok((Vector3::new(x[0], x[1], x[2]), TargetNotation::Linear))
            }
            _ => Err(self.wrong_type(key, "\"#rrggbb\" or [r, g, b]", v)),
        }
    }
}

pub(super) fn names(entries: &[SpectrumEntry]) -> String {
    if entries.is_empty() {
        return "none".to_string();
    }
    entries.iter().map(|e| e.name.as_str()).collect::<Vec<_>>().join(", ")
}

#[cfg(test)]
mod tests {
    /// A spectrum's `name`, `scale` and `design` and a cell's `weight` and `use` are read without writing
    /// their keys out, and a wrong value is refused with the message (key, line, reason) it always had.
    #[test]
    fn wrong_values_are_named_as_before() {
        let base = "name = \"p\"\n[[lights]]\nname = \"L\"\nilluminant = \"D65\"\n[[reflectances]]\nname = \"r0\"\n\
                    flat = 0.5\ndesign = true\n[[colours]]\nlight = \"L\"\nreflectance = \"r0\"\n\
                    target = [0.1, 0.2, 0.3]\n";
        let cases = [
            (
                "design = true",
                "design = \"yes\"",
                "p.toml:8: reflectances[0].design: expected true or false, found a string",
            ),
            (
                "flat = 0.5",
                "flat = 0.5\nscale = inf",
                "p.toml:8: reflectances[0].scale: must be finite (inf is only allowed in bounds)",
            ),
            (
                "flat = 0.5",
                "flat = 0.5\nscale = \"x\"",
                "p.toml:8: reflectances[0].scale: expected a number, found a string",
            ),
            ("flat = 0.5", "flat = 0.5\nscale = nan", "p.toml:8: reflectances[0].scale: NaN is not allowed"),
            ("0.3]", "0.3]\nweight = \"x\"", "p.toml:13: colours[0].weight: expected a number, found a string"),
            ("0.3]", "0.3]\nweight = -1", "p.toml:13: colours[0].weight: weights must not be negative, got -1"),
            ("0.3]", "0.3]\nweight = nan", "p.toml:13: colours[0].weight: NaN is not allowed"),
            (
                "0.3]",
                "0.3]\nweight = inf",
                "p.toml:13: colours[0].weight: must be finite (inf is only allowed in bounds)",
            ),
            ("0.3]", "0.3]\nuse = 1", "p.toml:13: colours[0].use: expected true or false, found an integer"),
            ("name = \"r0\"", "name = 3", "p.toml:6: reflectances[0].name: expected a string, found an integer"),
            ("name = \"L\"", "name = true", "p.toml:3: lights[0].name: expected a string, found a boolean"),
        ];
        let path = std::path::Path::new("p.toml");
        assert!(super::super::PaletteFile::parse(base, path).is_ok());
        for (from, to, message) in cases {
            let text = base.replacen(from, to, 1);
            let (read, _) = super::super::numbers::tests::both(&text, path);
            assert_eq!(read, format!("error: {message}"), "{to}");
        }
    }
}
