//! The one keymap: which key does what in each mode. The help popup (`?`) lists these same tables, so
//! what it shows is exactly what the keys do.

use crate::tui::action::{Action, Direction};
use crate::tui::app::Popup;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyEventKind, KeyModifiers};

/// A key with its modifiers (Shift is folded into the character for letter keys).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct Key {
    pub(crate) code: KeyCode,
    pub(crate) modifiers: KeyModifiers,
}

const fn plain(code: KeyCode) -> Key {
    Key { code, modifiers: KeyModifiers::NONE }
}

const fn ch(c: char) -> Key {
    plain(KeyCode::Char(c))
}

const fn ctrl(c: char) -> Key {
    Key { code: KeyCode::Char(c), modifiers: KeyModifiers::CONTROL }
}

/// One line of the keymap: the keys, the action and what the help says.
#[derive(Clone, Copy, Debug)]
pub struct Binding {
    pub(crate) keys: &'static [Key],
    pub(crate) action: Action,
    pub help: &'static str,
}

const fn bind(keys: &'static [Key], action: Action, help: &'static str) -> Binding {
    Binding { keys, action, help }
}

use Action as A;
use KeyCode as K;
use tui_input::InputRequest as R;

/// The main screen.
pub const MAIN: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "move up; sliders: previous slider"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "move down; sliders: next slider"),
    bind(&[plain(K::Left), ch('h')], A::Move(Direction::Left), "move left; sliders: decrease"),
    bind(&[plain(K::Right), ch('l')], A::Move(Direction::Right), "move right; sliders: increase"),
    bind(&[plain(K::PageUp), ch('+')], A::BigStep { up: true }, "slider: large step up"),
    bind(&[plain(K::PageDown), ch('-')], A::BigStep { up: false }, "slider: large step down"),
    bind(&[plain(K::Tab)], A::FocusNext, "next panel: matrix/sliders/settings"),
    bind(&[plain(K::BackTab)], A::FocusPrev, "previous panel"),
    bind(&[plain(K::Enter)], A::Activate, "edit cell / toggle or edit setting"),
    bind(&[plain(K::Esc)], A::Back, "back to the matrix; close popups"),
    bind(&[ch('#')], A::HexEntry, "type the target as #rrggbb"),
    bind(&[ch('w')], A::EditWeight, "type the weight"),
    bind(&[ch('d')], A::ToggleDesign, "design spectrum on/off"),
    bind(&[ch('u'), plain(K::Char(' '))], A::ToggleUse, "use colour on/off"),
    bind(&[ch('f')], A::AssignFree, "free-colour group (empty: none)"),
    bind(&[ch('b')], A::FreeBounds, "bounds of the free-colour group"),
    bind(&[ch('F')], A::FitColour, "fit colour (target := colour now)"),
    bind(&[ch('A')], A::FitAll, "fit all targets"),
    bind(&[ch('p')], A::Planck, "make Planck light (temperature)"),
    bind(&[ch('n')], A::NormaliseLuminance, "normalise light to luminance 1"),
    bind(&[ch('N')], A::NormaliseL2, "normalise light to L2 norm 1"),
    bind(&[ch('s')], A::Scale, "scale light or reflectance"),
    bind(&[ch('L')], A::AddLight, "add light (illuminant/Planck/CSV)"),
    bind(&[ch('R')], A::AddReflectance, "add reflectance (patch/flat/CSV)"),
    bind(&[ch('x'), plain(K::Delete)], A::Remove, "remove light or reflectance"),
    bind(&[ch('r')], A::Rename, "rename light, reflectance, group"),
    bind(&[ch('B')], A::ToggleBounds, "bounds on/off"),
    bind(&[ch('V')], A::ToggleFitInSubspace, "fit in the subspace model on/off"),
    bind(&[ch('z'), ctrl('z')], A::Undo, "undo"),
    bind(&[ch('Z'), ctrl('y')], A::Redo, "redo"),
    bind(&[ctrl('s')], A::Save, "save (atomic, keeps comments)"),
    bind(&[ctrl('w')], A::SaveAs, "save as… (type a path)"),
    bind(&[ctrl('r')], A::Reload, "reload from disk (z undoes it)"),
    bind(&[ch('!')], A::Diagnostics, "the solver's diagnostics"),
    bind(&[ch('m')], A::Feasibility, "reachable colours of a cell on/off"),
    bind(&[ch(']')], A::Dial { forward: true }, "scene preview: light dial forward"),
    bind(&[ch('[')], A::Dial { forward: false }, "scene preview: light dial back"),
    bind(&[ch('v')], A::TogglePreview, "scene preview / spectra plot"),
    bind(&[ch('g')], A::DialKeys, "preview: keys to the light dial"),
    bind(&[ch('M')], A::DialList, "mixtures and paths along the dial"),
    bind(&[ch('P')], A::PreviewFull, "preview over the whole terminal"),
    bind(&[ch('?'), plain(K::F(1))], A::Help, "this help"),
    bind(&[ch('i')], A::Legend, "legend: what the marks mean"),
    bind(&[ch('/')], A::Find { commands: false }, "search: jump to a cell or swatch"),
    bind(&[ch(':')], A::Find { commands: true }, "commands: any action by name"),
    bind(&[ch('q'), ctrl('c')], A::Quit, "quit (asks if unsaved)"),
];

const fn shift(code: KeyCode) -> Key {
    Key { code, modifiers: KeyModifiers::SHIFT }
}

/// The light dial beside the scene preview (after `g`).
pub const DIAL: &[Binding] = &[
    bind(&[plain(K::Left), ch('h')], A::DialSlide { dx: -1, dy: 0, big: false }, "slider / vertex left"),
    bind(&[plain(K::Right), ch('l')], A::DialSlide { dx: 1, dy: 0, big: false }, "slider / vertex right"),
    bind(&[plain(K::Up), ch('k')], A::DialSlide { dx: 0, dy: 1, big: false }, "slider / vertex up"),
    bind(&[plain(K::Down), ch('j')], A::DialSlide { dx: 0, dy: -1, big: false }, "slider / vertex down"),
    bind(&[shift(K::Left), ch('H')], A::DialSlide { dx: -1, dy: 0, big: true }, "large step left"),
    bind(&[shift(K::Right), ch('L')], A::DialSlide { dx: 1, dy: 0, big: true }, "large step right"),
    bind(&[shift(K::Up), ch('K')], A::DialSlide { dx: 0, dy: 1, big: true }, "large step up"),
    bind(&[shift(K::Down), ch('J')], A::DialSlide { dx: 0, dy: -1, big: true }, "large step down"),
    bind(
        &[ch('1'), ch('2'), ch('3'), ch('4'), ch('5'), ch('6'), ch('7'), ch('8'), ch('9')],
        A::DialToggle(0),
        "switch light N on/off",
    ),
    bind(&[plain(K::Tab)], A::DialSelect { forward: true }, "select: slider, vertex 1, 2, …"),
    bind(&[plain(K::BackTab)], A::DialSelect { forward: false }, "select the previous"),
    bind(&[ch('+'), plain(K::PageUp)], A::DialIntensity { up: true }, "selected light brighter (view only)"),
    bind(&[ch('-'), plain(K::PageDown)], A::DialIntensity { up: false }, "selected light dimmer (view only)"),
    bind(&[ch('a')], A::DialKeyframe, "add the dial as a keyframe"),
    bind(&[ch('m')], A::DialAddMixture, "target for the reflectance here"),
    bind(&[ch('P')], A::PreviewFull, "preview over the whole terminal"),
    bind(&[ch('f')], A::DialKeyframes, "keyframes: list, show, delete"),
    bind(&[ctrl('s')], A::DialSaveScene, "write the keyframes into the scene"),
    bind(&[ch(']')], A::Dial { forward: true }, "along the scene's sweep forward"),
    bind(&[ch('[')], A::Dial { forward: false }, "along the scene's sweep back"),
    bind(&[plain(K::Esc), ch('g')], A::DialLeave, "leave the dial"),
    bind(&[ch('?'), plain(K::F(1))], A::Help, "this help"),
    bind(&[ch('q'), ctrl('c')], A::Quit, "quit (asks if unsaved)"),
];

/// A text prompt: printable keys type.
pub(crate) const PROMPT: &[Binding] = &[
    bind(&[plain(K::Enter)], A::Submit, "accept"),
    bind(&[plain(K::Esc)], A::Back, "cancel"),
    bind(&[plain(K::Up)], A::Move(Direction::Up), "an earlier answer to this prompt"),
    bind(&[plain(K::Down)], A::Move(Direction::Down), "a later answer (then what you typed)"),
    bind(&[plain(K::Tab)], A::Complete, "complete the path (CSV, save as)"),
    bind(&[plain(K::Backspace)], A::Edit(R::DeletePrevChar), "delete back"),
    bind(&[plain(K::Delete)], A::Edit(R::DeleteNextChar), "delete forward"),
    bind(&[plain(K::Left)], A::Edit(R::GoToPrevChar), "left"),
    bind(&[plain(K::Right)], A::Edit(R::GoToNextChar), "right"),
    bind(&[plain(K::Home), ctrl('a')], A::Edit(R::GoToStart), "start of line"),
    bind(&[plain(K::End), ctrl('e')], A::Edit(R::GoToEnd), "end of line"),
    bind(&[ctrl('w')], A::Edit(R::DeletePrevWord), "delete word"),
    bind(&[ctrl('u')], A::Edit(R::DeleteLine), "clear"),
];

/// A list to pick from.
pub(crate) const PICK: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "previous"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "next"),
    bind(&[plain(K::PageUp)], A::BigStep { up: true }, "page up"),
    bind(&[plain(K::PageDown)], A::BigStep { up: false }, "page down"),
    bind(&[plain(K::Home)], A::ListEnd { last: false }, "first"),
    bind(&[plain(K::End)], A::ListEnd { last: true }, "last"),
    bind(&[plain(K::Enter)], A::Submit, "add"),
    bind(&[plain(K::Esc)], A::Back, "cancel"),
];

/// Light or reflectance of the selected cell.
pub(crate) const CHOOSE: &[Binding] = &[
    bind(&[ch('l')], A::ChooseLight, "the cell's light"),
    bind(&[ch('r')], A::ChooseReflectance, "the cell's reflectance"),
    bind(&[ch('g')], A::ChooseGroup, "the cell's free-colour group (rename)"),
    bind(&[plain(K::Esc)], A::Back, "cancel"),
];

/// Quitting with unsaved changes.
pub(crate) const CONFIRM_QUIT: &[Binding] = &[
    bind(&[ch('s')], A::SaveAndQuit, "save and quit"),
    bind(&[ch('y')], A::Discard, "quit without saving"),
    bind(&[ch('n'), plain(K::Esc)], A::Back, "stay"),
];

/// A recovery copy of unsaved work is beside the palette (on opening).
pub(crate) const RECOVERY: &[Binding] = &[
    bind(&[ch('r')], A::Restore, "restore it here (unsaved until Ctrl-s; z undoes it)"),
    bind(&[plain(K::Esc), ch('q')], A::Back, "keep the file as it is (the copy stays)"),
];

/// The palette file changed on disk since it was opened or saved.
pub(crate) const CONFLICT: &[Binding] = &[
    bind(&[ctrl('s'), ch('o')], A::Save, "overwrite the file with your version"),
    bind(&[ctrl('r'), ch('r')], A::Reload, "reload the file (z undoes it)"),
    bind(&[ctrl('w'), ch('a')], A::SaveAs, "save as… another file"),
    bind(&[plain(K::Esc)], A::Back, "keep editing"),
];

/// The help popup.
pub const HELP: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "scroll up"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "scroll down"),
    bind(&[plain(K::Esc), ch('?'), ch('q')], A::Back, "close (other keys act on the main screen)"),
];

/// The diagnostics list.
pub(crate) const DIAGNOSTICS: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "scroll up"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "scroll down"),
    bind(&[plain(K::Esc), ch('!'), ch('q')], A::Back, "close (other keys act on the main screen)"),
];

/// The search and the command palette: printable keys type.
pub(crate) const FIND: &[Binding] = &[
    bind(&[plain(K::Up)], A::Move(Direction::Up), "previous match"),
    bind(&[plain(K::Down)], A::Move(Direction::Down), "next match"),
    bind(&[plain(K::Enter)], A::Submit, "jump there / run it"),
    bind(&[plain(K::Esc)], A::Back, "cancel"),
    bind(&[plain(K::Backspace)], A::Edit(R::DeletePrevChar), "delete back"),
    bind(&[plain(K::Left)], A::Edit(R::GoToPrevChar), "left"),
    bind(&[plain(K::Right)], A::Edit(R::GoToNextChar), "right"),
    bind(&[ctrl('u')], A::Edit(R::DeleteLine), "clear"),
];

/// The legend of the marks.
pub(crate) const LEGEND: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "scroll up"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "scroll down"),
    bind(&[plain(K::Esc), ch('i'), ch('q')], A::Back, "close (other keys act on the main screen)"),
];

/// The mixtures and paths along the dial (`M`).
pub(crate) const DIAL_LIST: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "previous"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "next"),
    bind(&[ch('#'), plain(K::Enter)], A::HexEntry, "type the target as #rrggbb"),
    bind(&[ch('F')], A::FitColour, "target := its solved colour now"),
    bind(&[ch('w')], A::EditWeight, "weight"),
    bind(&[ch('u'), plain(K::Char(' '))], A::ToggleUse, "use on/off"),
    bind(&[ch('f')], A::AssignFree, "free-colour group (empty: none)"),
    bind(&[ch('n')], A::DialSamples, "a path's design samples"),
    bind(&[ch('t')], A::DialTolerance, "a path's tolerance (ΔE00)"),
    bind(&[ch('x'), plain(K::Delete)], A::Remove, "delete it"),
    bind(&[ch('z'), ctrl('z')], A::Undo, "undo"),
    bind(&[ch('Z'), ctrl('y')], A::Redo, "redo"),
    bind(&[ctrl('s')], A::Save, "save"),
    bind(&[plain(K::Esc), ch('M'), ch('q')], A::Back, "close"),
];

/// The dial's keyframes listed.
pub(crate) const KEYFRAMES: &[Binding] = &[
    bind(&[plain(K::Up), ch('k')], A::Move(Direction::Up), "previous"),
    bind(&[plain(K::Down), ch('j')], A::Move(Direction::Down), "next"),
    bind(&[plain(K::Home)], A::ListEnd { last: false }, "first"),
    bind(&[plain(K::End)], A::ListEnd { last: true }, "last"),
    bind(&[plain(K::Enter)], A::Submit, "set the dial to it"),
    bind(&[ch('d'), plain(K::Delete)], A::Remove, "delete it (not undoable)"),
    bind(&[plain(K::Esc), ch('f'), ch('q')], A::Back, "close"),
];

/// Every table with its title, in the order the help shows them.
pub const TABLES: &[(&str, &[Binding])] = &[
    ("main screen", MAIN),
    ("light dial (g)", DIAL),
    ("prompts", PROMPT),
    ("add lists", PICK),
    ("light or reflectance?", CHOOSE),
    ("quit with unsaved changes", CONFIRM_QUIT),
    ("file changed on disk", CONFLICT),
    ("recovery copy found", RECOVERY),
    ("help", HELP),
    ("diagnostics", DIAGNOSTICS),
    ("legend (i)", LEGEND),
    ("mixtures and paths (M)", DIAL_LIST),
    ("search (/) and commands (:)", FIND),
    ("keyframes (f on the dial)", KEYFRAMES),
];

/// The table in force for the open popup (`dial_keys`: the light dial has the main screen's keys).
pub(crate) fn table_for(popup: Option<&Popup>, dial_keys: bool) -> &'static [Binding] {
    match popup {
        None if dial_keys => DIAL,
        None => MAIN,
        Some(Popup::Help { .. }) => HELP,
        Some(Popup::Diagnostics { .. }) => DIAGNOSTICS,
        Some(Popup::Legend { .. }) => LEGEND,
        Some(Popup::DialList(_)) => DIAL_LIST,
        Some(Popup::Find(_)) => FIND,
        Some(Popup::Prompt(_)) => PROMPT,
        Some(Popup::Keyframes(_)) => KEYFRAMES,
        Some(Popup::ChooseSpectrum { .. }) => CHOOSE,
        Some(Popup::Pick { .. }) => PICK,
        Some(Popup::ConfirmQuit) => CONFIRM_QUIT,
        Some(Popup::Conflict { .. }) => CONFLICT,
        Some(Popup::Recovery { .. }) => RECOVERY,
    }
}

/// Fold Shift into letters (terminals report `F` as Shift+`F`) and drop key releases.
pub(crate) fn normalise(event: KeyEvent) -> Option<Key> {
    if event.kind == KeyEventKind::Release {
        return None;
    }
    let mut modifiers = event.modifiers;
    if matches!(event.code, KeyCode::Char(_) | KeyCode::BackTab) {
        modifiers.remove(KeyModifiers::SHIFT);
    }
    Some(Key { code: event.code, modifiers })
}

/// The action a key asks for with `popup` open (`dial_keys`: the light dial has the main screen's keys).
pub(crate) fn action_for(popup: Option<&Popup>, dial_keys: bool, event: KeyEvent) -> Option<Action> {
    let key = normalise(event)?;
    let table = table_for(popup, dial_keys);
    if let Some(b) = table.iter().find(|b| b.keys.contains(&key)) {
        // One binding for the number keys: the action carries the number pressed.
        return Some(match (b.action, key.code) {
            (Action::DialToggle(_), KeyCode::Char(c)) => Action::DialToggle(c.to_digit(10).unwrap_or(0) as u8),
            (a, _) => a,
        });
    }
    match (popup, key.code) {
        (Some(Popup::Prompt(_) | Popup::Find(_)), KeyCode::Char(c)) if key.modifiers.is_empty() => {
            Some(Action::Edit(tui_input::InputRequest::InsertChar(c)))
        }
        // Help and diagnostics only read: any other key closes them and acts on the main screen.
        (Some(Popup::Help { .. } | Popup::Diagnostics { .. } | Popup::Legend { .. }), _) => {
            MAIN.iter().find(|b| b.keys.contains(&key)).map(|b| b.action)
        }
        _ => None,
    }
}

/// How a key is written in the help and in replay scripts.
pub(crate) fn key_label(key: &Key) -> String {
    let base = match key.code {
        K::Char(' ') => "Space".to_string(),
        K::Char(c) => c.to_string(),
        K::Up => "↑".into(),
        K::Down => "↓".into(),
        K::Left => "←".into(),
        K::Right => "→".into(),
        K::PageUp => "PgUp".into(),
        K::PageDown => "PgDn".into(),
        K::Tab => "Tab".into(),
        K::BackTab => "Shift-Tab".into(),
        K::Enter => "Enter".into(),
        K::Esc => "Esc".into(),
        K::Backspace => "Backspace".into(),
        K::Delete => "Del".into(),
        K::F(n) => format!("F{n}"),
        other => format!("{other:?}"),
    };
    if key.modifiers.contains(KeyModifiers::CONTROL) {
        format!("Ctrl-{base}")
    } else if key.modifiers.contains(KeyModifiers::SHIFT) {
        format!("Shift-{base}")
    } else {
        base
    }
}

/// The main screen's actions as the `:` command palette offers them: what the help calls each, with its keys.
pub(crate) fn commands() -> Vec<(String, Action)> {
    MAIN.iter().map(|b| (format!("{}  ({})", b.help, keys_label(b)), b.action)).collect()
}

/// All keys of a binding, as the help shows them.
pub fn keys_label(binding: &Binding) -> String {
    if let Action::DialToggle(_) = binding.action {
        return "1…9".to_string();
    }
    binding.keys.iter().map(key_label).collect::<Vec<_>>().join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_key_is_bound_twice_in_a_table() {
        for (name, table) in TABLES {
            let mut seen = Vec::new();
            for b in *table {
                for k in b.keys {
                    assert!(!seen.contains(k), "{name}: {k:?} bound twice");
                    seen.push(*k);
                }
            }
        }
    }

    #[test]
    fn shift_is_folded_into_letters() {
        let e = KeyEvent::new(KeyCode::Char('F'), KeyModifiers::SHIFT);
        assert_eq!(normalise(e), Some(ch('F')));
        let e = KeyEvent::new(KeyCode::Char('s'), KeyModifiers::CONTROL);
        assert_eq!(normalise(e), Some(ctrl('s')));
    }
}
