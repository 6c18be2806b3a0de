//! `metamer design`: the terminal palette designer (seed §4, Fig. 1) as a ratatui application.
//!
//! Architecture (the Elm architecture): the [`app::State`] is the whole model, as four sub-models
//! ([`model`]: document, solve, preview, interface), each the one owner of its part. Everything that happens —
//! a key, a resize, a worker reply, a finished raycast, import or save, a tick, a signal — is a
//! [`msg::Msg`] on the event loop's one channel; [`update::update`] is the only place the state changes
//! and returns the side effects to run as data ([`msg::Effect`]: solve, train a basis, raycast, import,
//! save, save as, reload, recover, save keyframes: every file, thread and clock), whose results come back as
//! messages. A key becomes an
//! [`action::Action`] through the one [`keymap`]; the [`ui`] draws the state without changing it. The
//! [`event_loop::run_main_loop`] blocks on the channel (no polling) and is generic over the ratatui
//! backend, so the real terminal and the off-screen `TestBackend` (tests, `--replay`) run exactly the
//! same code. Solves run on a worker thread ([`worker`]) and stale ones are cancelled.

pub mod action;
pub mod app;
pub mod basics;
pub mod colour;
pub mod derived;
pub mod dial_list;
pub mod dial_results;
pub mod edits;
pub mod event_loop;
pub mod finder;
pub mod graphics;
pub mod keyframe_list;
pub mod keyframes;
pub mod keymap;
pub mod model;
pub mod mouse;
pub mod msg;
pub mod preview;
pub(crate) mod probe;
pub mod prompt_memory;
pub mod rename;
pub mod replay;
pub mod terminal;
pub mod ui;
pub mod update;
pub mod worker;

pub use app::State;
pub use event_loop::run_main_loop;
