//! What prompts remember and complete: the history of the answers given to each kind of prompt this
//! session (↑ recalls an earlier one, ↓ a later one, back to what was being typed), and Tab completion of
//! a path in the path prompts (CSV import, save as), both relative to the palette's folder. The
//! history is the interface's ([`crate::tui::model::UiState`]); the folder listing a completion needs is
//! read by the event loop ([`crate::tui::msg::Effect::Complete`]), never inside the update step, and comes
//! back as [`crate::tui::msg::Msg::Completed`]; [`complete`] is the pure part.

use crate::tui::app::{Prompt, PromptPurpose};

/// Most answers kept per kind of prompt.
const KEPT: usize = 50;

/// Where a prompt stands in its history while ↑/↓ browse it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Recall {
    /// 0: the newest answer shown, 1 the one before, …
    back: usize,
    /// What was typed before browsing (↓ past the newest answer brings it back).
    draft: String,
}

/// The answers given to each kind of prompt this session, oldest first.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct PromptHistory {
    entries: Vec<(&'static str, String)>,
}

/// The kind of a prompt whose answers share a history: the same question asked of another cell or
/// spectrum shares it (every hex target, every weight, every CSV path, …).
pub(crate) fn kind(purpose: &PromptPurpose) -> &'static str {
    match purpose {
        PromptPurpose::Hex { .. } => "hex",
        PromptPurpose::Weight { .. } => "weight",
        PromptPurpose::FreeGroup { .. } => "group",
        PromptPurpose::FreeBounds { .. } => "bounds",
        PromptPurpose::Planck { .. } | PromptPurpose::NewPlanck => "kelvin",
        PromptPurpose::Scale { .. } => "scale",
        PromptPurpose::Setting(_) => "setting",
        PromptPurpose::CsvPath(_) => "csv",
        PromptPurpose::SaveAs => "save-as",
        PromptPurpose::Rename(_) => "name",
        PromptPurpose::Dial(p) => match p.field {
            crate::tui::dial_list::DialField::Target => "hex",
            crate::tui::dial_list::DialField::Weight => "weight",
            crate::tui::dial_list::DialField::Free => "group",
            crate::tui::dial_list::DialField::Samples => "samples",
            crate::tui::dial_list::DialField::Tolerance => "tolerance",
        },
    }
}

/// True for the prompts that take a path (Tab completes it).
pub(crate) fn is_path(purpose: &PromptPurpose) -> bool {
    matches!(purpose, PromptPurpose::CsvPath(_) | PromptPurpose::SaveAs)
}

impl PromptHistory {
    /// Remember `text` as an answer to a prompt of `kind` (the newest; an equal older one is dropped).
    pub(crate) fn record(&mut self, kind: &'static str, text: &str) {
        let text = text.trim();
        if text.is_empty() {
            return;
        }
        self.entries.retain(|(k, t)| !(*k == kind && t == text));
        self.entries.push((kind, text.to_string()));
        let of_kind = self.entries.iter().filter(|(k, _)| *k == kind).count();
        if of_kind > KEPT
            && let Some(oldest) = self.entries.iter().position(|(k, _)| *k == kind)
        {
            self.entries.remove(oldest);
        }
    }

    /// The answers of `kind`, newest first.
    pub fn of(&self, kind: &str) -> Vec<&str> {
        self.entries.iter().rev().filter(|(k, _)| *k == kind).map(|(_, t)| t.as_str()).collect()
    }

    /// ↑ (`earlier`) or ↓ in `prompt`: show the next older or newer answer of its kind; ↓ past the
    /// newest brings back what was typed. False when there is nothing to show.
    pub(crate) fn browse(&self, prompt: &mut Prompt, earlier: bool) -> bool {
        let answers = self.of(kind(&prompt.purpose));
        let next = match (&prompt.recall, earlier) {
            (None, true) if !answers.is_empty() => Some(Recall { back: 0, draft: prompt.input.as_str().to_string() }),
            (Some(r), true) if r.back + 1 < answers.len() => Some(Recall { back: r.back + 1, draft: r.draft.clone() }),
            (Some(r), false) if r.back > 0 => Some(Recall { back: r.back - 1, draft: r.draft.clone() }),
            (Some(r), false) => {
                prompt.input = crate::tui::basics::PromptText::new(r.draft.clone());
                prompt.recall = None;
                return true;
            }
            _ => return false,
        };
        let Some(next) = next else { return false };
        prompt.input = crate::tui::basics::PromptText::new(answers[next.back].to_string());
        prompt.recall = Some(next);
        true
    }
}

/// What a Tab in a path prompt found: the text to put in the prompt, and the names it could go on to
/// when more than one matches.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Completion {
    /// The text typed, completed as far as every match agrees.
    pub text: String,
    /// The matching names (folders end in `/`), when more than one matches.
    pub candidates: Vec<String>,
}

/// Complete `typed` against `entries`, the names (folders ending in `/`) in the folder `typed` names
/// (the part up to its last `/`): the one match whole, or the longest start every match shares.
/// Names starting with `.` match only a typed `.`. None when nothing matches.
pub fn complete(typed: &str, entries: &[String]) -> Option<Completion> {
    let (dir, prefix) = split(typed);
    let mut matches: Vec<&String> =
        entries.iter().filter(|e| e.starts_with(prefix) && (prefix.starts_with('.') || !e.starts_with('.'))).collect();
    matches.sort();
    let first = matches.first()?;
    let common = matches.iter().fold(first.as_str(), |acc, m| {
        let n = acc.chars().zip(m.chars()).take_while(|(a, b)| a == b).map(|(a, _)| a.len_utf8()).sum();
        &acc[..n]
    });
    let candidates = if matches.len() > 1 { matches.iter().map(|m| m.to_string()).collect() } else { Vec::new() };
    Some(Completion { text: format!("{dir}{common}"), candidates })
}

/// `typed` as the folder part (up to and with its last `/`) and the start of a name.
pub fn split(typed: &str) -> (&str, &str) {
    match typed.rfind('/') {
        Some(i) => (&typed[..=i], &typed[i + 1..]),
        None => ("", typed),
    }
}

/// The names in `folder` (folders with a `/` after them), at most `limit`, sorted; empty when it cannot be
/// read. Run by the event loop (it reads the disk).
pub fn list_folder(folder: &std::path::Path, limit: usize) -> Vec<String> {
    let Ok(read) = std::fs::read_dir(folder) else { return Vec::new() };
    let mut names: Vec<String> = read
        .flatten()
        .take(limit)
        .map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            // A link to a folder counts as a folder (metadata follows it).
            if std::fs::metadata(e.path()).is_ok_and(|m| m.is_dir()) { format!("{name}/") } else { name }
        })
        .collect();
    names.sort();
    names
}

/// The folder listing for a Tab came back: complete the prompt's text when it is still the one typed
/// (a key typed meanwhile wins); more than one match is listed in the message line.
pub(crate) fn completed(ui: &mut crate::tui::model::UiState, typed: &str, entries: &[String]) {
    ui.completing = false;
    let Some(crate::tui::app::Popup::Prompt(prompt)) = ui.popup.as_mut() else { return };
    if prompt.input.as_str() != typed || !is_path(&prompt.purpose) {
        return;
    }
    let Some(c) = complete(typed, entries) else {
        return ui.complain(format!("nothing here starts with {}", split(typed).1));
    };
    prompt.input = crate::tui::basics::PromptText::new(c.text);
    prompt.recall = None;
    if !c.candidates.is_empty() {
        let shown: Vec<&str> = c.candidates.iter().take(12).map(String::as_str).collect();
        let more = c.candidates.len().saturating_sub(shown.len());
        let more = if more > 0 { format!(" and {more} more") } else { String::new() };
        ui.say(format!("{} match: {}{more}", c.candidates.len(), shown.join("  ")));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn completion_takes_the_one_match_or_what_every_match_shares() {
        let entries: Vec<String> =
            ["grey.csv", "green.csv", "sub/", ".hidden.csv", "palette.toml"].iter().map(|s| s.to_string()).collect();
        assert_eq!(complete("pa", &entries).unwrap(), Completion { text: "palette.toml".into(), candidates: vec![] });
        let c = complete("gr", &entries).unwrap();
        assert_eq!(c.text, "gre");
        assert_eq!(c.candidates, ["green.csv", "grey.csv"]);
        assert_eq!(complete("data/s", &entries).unwrap().text, "data/sub/");
        assert!(complete("x", &entries).is_none());
        assert_eq!(complete("", &entries).unwrap().candidates.len(), 4, "hidden names only for a typed dot");
        assert_eq!(complete(".h", &entries).unwrap().text, ".hidden.csv");
        assert_eq!(split("a/b/c"), ("a/b/", "c"));
    }

    #[test]
    fn history_keeps_the_newest_once_per_kind() {
        let mut h = PromptHistory::default();
        h.record("csv", "a.csv");
        h.record("hex", "#ff0000");
        h.record("csv", "b.csv");
        h.record("csv", "a.csv");
        h.record("csv", "  ");
        assert_eq!(h.of("csv"), ["a.csv", "b.csv"]);
        assert_eq!(h.of("hex"), ["#ff0000"]);
        for k in 0..60 {
            h.record("weight", &k.to_string());
        }
        assert_eq!(h.of("weight").len(), KEPT);
        assert_eq!(h.of("weight")[0], "59");
    }
}
