//! Small value types the designer's state is made of and its components share: the selection in the
//! design matrix, a prompt's line of text and what a field shows of it, and what a rename applies to.
//! They import nothing of the designer, so the state (`app.rs`), the popup components (`finder.rs`,
//! `rename.rs`) and the view can all use them without importing one another.

use crate::palette::{Kind, Palette};

/// The selection in the design matrix. Column 0 is the reflectance column down the left, row 0 the light
/// row across the top; column `j + 1` is light `j`, row `i + 1` is reflectance `i`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Selection {
    pub col: usize,
    pub row: usize,
}

/// A prompt's line and its cursor. The editing (cursor moves by grapheme, word deletes, display width) is
/// `tui_input::Input`'s; this wrapper caps the length and compares by text and cursor.
#[derive(Clone, Debug, Default)]
pub struct PromptText(tui_input::Input);

impl PromptText {
    /// The longest line a prompt takes, in characters (a path or a list of 31 numbers fits).
    pub(crate) const MAX_CHARS: usize = 400;

    /// A line with the cursor at its end.
    pub(crate) fn new(text: String) -> Self {
        PromptText(tui_input::Input::new(text))
    }

    pub(crate) fn as_str(&self) -> &str {
        self.0.value()
    }

    /// What a field `width` columns wide shows of the line, scrolled so that the cursor is in view: the
    /// characters before the cursor, the one under it (none when the cursor is past the end), and those
    /// after it. A wide character that would straddle either edge of the field is left out.
    pub(crate) fn visible(&self, width: usize) -> VisibleText {
        let cursor = self.0.visual_cursor();
        // `visual_scroll(n)` keeps the cursor's column at most `n` columns right of the first one shown, so
        // the field is asked with the room the cursor takes subtracted: the character under it (two columns
        // for a wide one) or the bar past the end, so either is inside the field.
        let mut at = 0;
        let under = self.0.value().chars().find(|c| {
            let here = at;
            at += unicode_width::UnicodeWidthChar::width(*c).unwrap_or(0);
            here == cursor
        });
        let room = under.map_or(1, |c| unicode_width::UnicodeWidthChar::width(c).unwrap_or(0).max(1));
        let scroll = self.0.visual_scroll(width.saturating_sub(room));
        let mut v = VisibleText::default();
        let mut column = 0;
        for c in self.0.value().chars() {
            let cw = unicode_width::UnicodeWidthChar::width(c).unwrap_or(0);
            if column >= scroll && column + cw <= scroll + width {
                match column.cmp(&cursor) {
                    std::cmp::Ordering::Less => v.before.push(c),
                    std::cmp::Ordering::Equal if v.under.is_none() => v.under = Some(c),
                    _ => v.after.push(c),
                }
            }
            column += cw;
        }
        v
    }

    /// Carries out one edit; true if the text changed. Typing past [`Self::MAX_CHARS`] is refused.
    pub(crate) fn edit(&mut self, request: tui_input::InputRequest) -> bool {
        if matches!(request, tui_input::InputRequest::InsertChar(_))
            && self.0.value().chars().count() >= Self::MAX_CHARS
        {
            return false;
        }
        self.0.handle(request).is_some_and(|changed| changed.value)
    }
}

/// The part of a prompt's line a field shows ([`PromptText::visible`]).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub(crate) struct VisibleText {
    pub(crate) before: String,
    pub(crate) under: Option<char>,
    pub(crate) after: String,
}

impl PartialEq for PromptText {
    fn eq(&self, other: &Self) -> bool {
        self.0.value() == other.0.value() && self.0.cursor() == other.0.cursor()
    }
}

/// What a rename applies to.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Renamed {
    /// A light or a reflectance by index.
    Spectrum(Kind, usize),
    /// A free-colour group by index.
    Group(usize),
}

impl Renamed {
    /// Its name now (`None` when it no longer exists).
    pub(crate) fn name(self, palette: &Palette) -> Option<&str> {
        match self {
            Renamed::Spectrum(kind, i) => palette.entries(kind).get(i).map(|e| e.name.as_str()),
            Renamed::Group(g) => palette.free.get(g).map(|g| g.name.as_str()),
        }
    }

    /// `light daylight`, `free-colour group A`.
    pub(crate) fn describe(self, palette: &Palette) -> String {
        let what = match self {
            Renamed::Spectrum(kind, _) => kind.as_str(),
            Renamed::Group(_) => "free-colour group",
        };
        format!("{what} {}", self.name(palette).unwrap_or("?"))
    }
}
