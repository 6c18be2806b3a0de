//! metamer-core: the domain of metamer — spectra, colorimetry, palettes, the sharpened factor-model
//! basis, the design solver, volumes and the spectral renderer.
//!
//! After Bergner, Möller & Drew, "A Spectral Engine for Visualization" (SFU TR 2004-06). This crate
//! knows nothing of the terminal UI, the command line or the benchmark plots: those live in the
//! application crate at the repository root, and this crate's dependencies (no ratatui, crossterm,
//! clap, indicatif or plotters) make any import back up a build error. See docs/ARCHITECTURE.md.

#![warn(missing_docs)]

pub mod basis;
pub mod colorimetry;
pub mod design;
pub mod fsio;
pub mod memory;
pub(crate) mod optimize;
pub mod palette;
pub(crate) mod region;
pub mod render;
pub mod spectrum;
pub mod volume;
