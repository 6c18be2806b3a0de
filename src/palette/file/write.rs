//! Saving: updating the TOML document from the model (filled in below).
