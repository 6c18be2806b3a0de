//! The designer's model as four sub-models, each the one owner of its part of the state:
//!
//! - [`Document`]: the palette file, the palette being edited, undo history, file work under way;
//! - [`SolveState`]: the solutions, the basis of the shown spectra (by a typed [`BasisKey`]), the colours
//!   derived from them, the mismatch region;
//! - [`PreviewState`]: the scene and its raycast, the one [`LiveDial`], keyframes, the relit frame and
//!   the terminal graphics;
//! - [`UiState`]: selection, focus, popup, message line, screen size and colours.
//!
//! [`crate::tui::State`] holds one of each; the update step changes them, the view reads them.

mod document;
mod preview_state;
mod solve_state;
mod ui_state;

pub use document::{Document, History, Import};
pub(crate) use document::{EditKey, PaletteChange};
pub use preview_state::{LiveDial, PreviewState};
pub(crate) use preview_state::{NO_SCENE, PreviewMsg, is_dial_action};
pub(crate) use solve_state::SolveMsg;
pub use solve_state::{BasisKey, ShownBasis, SolveState};
pub(crate) use ui_state::UiMsg;
pub use ui_state::UiState;
