//! `metamer design`: the terminal palette designer (seed §4, Fig. 1) as a ratatui application.
//!
//! Architecture (ratatui's Elm architecture): the [`app::State`] is the whole model; a key becomes an
//! [`action::Action`] through the one [`keymap`]; [`update::update`] changes the state and returns the
//! side effects to run (start a solve, save); the [`ui`] draws the state without changing it. The
//! [`event_loop::run_main_loop`] is generic over the ratatui backend, so the real terminal and the
//! off-screen `TestBackend` (tests, `--replay`) run exactly the same code. Solves run on a worker
//! thread ([`worker`]) and stale ones are cancelled.

pub mod action;
pub mod app;
pub mod colour;
pub mod derived;
pub mod dial_keys;
pub mod edits;
pub mod event_loop;
pub mod graphics;
pub mod keymap;
pub mod preview;
pub mod replay;
pub mod terminal;
pub mod ui;
pub mod update;
pub mod worker;

pub use app::State;
pub use event_loop::run_main_loop;
