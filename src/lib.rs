//! metamer: design palettes of light spectra and surface reflectances that produce chosen colours in
//! chosen light/surface combinations, and render spectral volumes relit in real time.
//!
//! After Bergner, Möller & Drew, "A Spectral Engine for Visualization" (SFU TR 2004-06).
//! Domain modules (`spectrum`, `colorimetry`, `palette`, `basis`, `design`, `volume`, `render`) know
//! nothing of the command line or the terminal UI.

pub mod basis;
pub mod bench;
pub mod cli;
pub mod colorimetry;
pub mod design;
pub mod fsio;
pub mod palette;
pub mod render;
pub mod spectrum;
pub mod tui;
pub mod volume;
