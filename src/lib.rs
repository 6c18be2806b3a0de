//! metamer, the application: the command line (`cli`), the terminal designer (`tui`) and the benchmark
//! suite (`bench`) over the domain crate `metamer-core` (crates/metamer-core).
//!
//! After Bergner, Möller & Drew, "A Spectral Engine for Visualization" (SFU TR 2004-06). The domain
//! modules are re-exported under their own names so `metamer::palette::…` and `crate::palette::…` name
//! the same items; the domain crate cannot see anything here (see docs/ARCHITECTURE.md).

pub use metamer_core::{basis, colorimetry, design, fsio, memory, palette, render, spectrum, volume};

pub mod bench;
pub mod cli;
pub mod tui;
