//! The settings row: bounds on/off with lower/upper for reflectances and lights, smoothness weight,
//! subspace-error weight, fit in the subspace model ("use V7") and the basis dimension.

use crate::tui::app::{Focus, SettingField, State};
use crate::tui::ui::{num, put};
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style};
use ratatui::widgets::Widget;

/// The settings row of a state.
pub(crate) struct SettingsRow<'a>(pub &'a State);

/// The text of each field, in [`SettingField::ALL`] order; `short` abbreviates for narrow screens.
pub(crate) fn field_texts(state: &State, short: bool) -> Vec<String> {
    let s = &state.doc.palette.settings;
    let check = |on: bool| if on { "[x]" } else { "[ ]" };
    let label = |long: &'static str, abbreviated: &'static str| if short { abbreviated } else { long };
    SettingField::ALL
        .iter()
        .map(|f| match f {
            SettingField::Bounds => format!("{} bounds", check(state.doc.palette.settings.bounded())),
            SettingField::ReflectanceLower => format!("{} {}", label("refl", "R"), num(s.reflectance_bounds.lower)),
            SettingField::ReflectanceUpper => format!("… {}", num(s.reflectance_bounds.upper)),
            SettingField::LightLower => format!("{} {}", label("light", "L"), num(s.light_bounds.lower)),
            SettingField::LightUpper => format!("… {}", num(s.light_bounds.upper)),
            SettingField::Smoothness => format!("{} {}", label("smoothness", "ω_D"), num(s.smoothness)),
            SettingField::SubspaceError => format!("{} {}", label("subspace error", "ω_F"), num(s.subspace_error)),
            SettingField::FitInSubspace => {
                format!("{} {}V{}", check(s.fit_in_subspace), label("fit in ", ""), s.basis_dimension)
            }
            SettingField::BasisDimension => format!("m {}", s.basis_dimension),
        })
        .collect()
}

fn width_of(texts: &[String]) -> usize {
    texts.iter().map(|t| t.chars().count() + 2).sum()
}

impl Widget for SettingsRow<'_> {
    fn render(self, area: Rect, buf: &mut Buffer) {
        let state = self.0;
        let mut texts = field_texts(state, false);
        if width_of(&texts) + 1 > usize::from(area.width) {
            texts = field_texts(state, true);
        }
        let total = width_of(&texts);
        let gap = if total + 1 < usize::from(area.width) { "  " } else { " " };
        let mut x = 1u16;
        for (k, text) in texts.iter().enumerate() {
            let focused = state.ui.focus == Focus::Settings && state.ui.setting == k;
            let style = if focused {
                Style::new().fg(Color::Black).bg(Color::LightGreen).add_modifier(Modifier::BOLD)
            } else {
                Style::new()
            };
            x = put(buf, area, x, 0, text, style);
            let sep = if matches!(SettingField::ALL[k], SettingField::ReflectanceLower | SettingField::LightLower) {
                " "
            } else {
                gap
            };
            x = put(buf, area, x, 0, sep, Style::new());
        }
    }
}
