//! The dial's keyframes written into a scene file: appended to its `[[dial.keyframes]]` (the format of
//! `docs/formats/dial.md`), everything else of the file kept as the user wrote it. Run by the event loop
//! ([`crate::tui::msg::Effect::SaveKeyframes`]), never inside the update step.

use crate::render::DialState;
use std::path::Path;
use toml_edit::{Array, ArrayOfTables, DocumentMut, InlineTable, Item, Table, value};

/// One keyframe as a TOML table: the slider point and, explicitly, every light's state (so it does not
/// depend on the keyframes before it).
fn keyframe_table(k: &DialState) -> Table {
    let names = |on: bool| -> Array { k.lights.iter().filter(|l| l.on == on).map(|l| l.name.as_str()).collect() };
    let point = |p: [f64; 2]| -> Array { [round(p[0]), round(p[1])].into_iter().collect() };
    let mut t = Table::new();
    t["at"] = value(point(k.slider));
    t["off"] = value(names(false));
    t["on"] = value(names(true));
    let mut moves = InlineTable::new();
    let mut intensity = InlineTable::new();
    for l in &k.lights {
        moves.insert(&l.name, point(l.position).into());
        intensity.insert(&l.name, round(l.intensity).into());
    }
    t["move"] = value(moves);
    t["intensity"] = value(intensity);
    t
}

/// Six decimals: what a user would type, and stable across saves.
fn round(v: f64) -> f64 {
    (v * 1e6).round() / 1e6
}

/// Append `keyframes` to the scene file's `[[dial.keyframes]]`, keeping everything else of the file as
/// the user wrote it: every other key, comment and the order, the palette and volume paths, and keyframes
/// already there. A dial has either a `path` or keyframes, so a `path = [...]` sweep is taken out of
/// `[dial]` but kept, with the comments above it, as a comment over the saved keyframes (put it back to
/// sweep the path again). The write is atomic and keeps a symbolic link and the file's permissions
/// ([`crate::fsio::write_atomic`]).
pub fn save_keyframes(path: &Path, keyframes: &[DialState]) -> Result<String, String> {
    let show = crate::fsio::show(path);
    let text = crate::fsio::read_to_string(path, crate::fsio::Kind::Scene).map_err(|e| e.to_string())?;
    let mut doc: DocumentMut = text.parse().map_err(|e| format!("{show}: not TOML: {e}"))?;
    let dial = doc.entry("dial").or_insert(Item::Table(Table::new()));
    if let Some(inline) = dial.as_inline_table() {
        // `dial = { path = [...] }` becomes a `[dial]` table (keyframes are tables).
        *dial = Item::Table(inline.clone().into_table());
    }
    let Some(dial) = dial.as_table_mut() else {
        return Err(format!("{show}: dial: is not a table"));
    };
    // The path as written (with a trailing comment), and the comment lines above it.
    let old_path = dial.remove_entry("path").map(|(key, item)| {
        let above = key.leaf_decor().prefix().and_then(|p| p.as_str()).unwrap_or("").trim_start_matches('\n');
        let above: String =
            above.lines().filter(|l| l.trim_start().starts_with('#')).map(|l| format!("{}\n", l.trim())).collect();
        (above, item.to_string().trim().to_string())
    });
    let frames = dial.entry("keyframes").or_insert(Item::ArrayOfTables(ArrayOfTables::new()));
    let Some(frames) = frames.as_array_of_tables_mut() else {
        return Err(format!("{show}: dial.keyframes: is not an array of tables"));
    };
    let first = frames.len();
    for k in keyframes {
        frames.push(keyframe_table(k));
    }
    if let (Some((above, value)), Some(t)) = (&old_path, frames.get_mut(first)) {
        // A path written over several lines is commented out line by line.
        let value: String = value.lines().map(|l| format!("\n# {}", l.trim_end())).collect();
        let value = value.trim_start_matches("\n# ");
        t.decor_mut().set_prefix(format!(
            "\n# Keyframes saved from the designer replace the dial's sweep, which was:\n{above}# path = {value}\n"
        ));
    }
    let total = frames.len();
    // The one atomic writer: the scene keeps its mode (and owner where permitted); a FIFO is refused.
    crate::fsio::write_atomic(path, doc.to_string().as_bytes()).map_err(|e| e.to_string())?;
    let note = if old_path.is_some() { " (the dial's path is kept as a comment)" } else { "" };
    Ok(format!("saved {} keyframes into {show}: {total} in all{note}", keyframes.len()))
}
