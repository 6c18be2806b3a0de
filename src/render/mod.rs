//! Spectral volume rendering with post-illumination (seed §2.2 and §5.1): a volume is raycast once per
//! view under a flat white light, with reflectance spectra assigned by a transfer function of materials;
//! each frame of a light-dial sweep then only relights the stored image with one 3×K matrix per frame.

pub mod raycast;
pub mod dial;
pub mod relight;
