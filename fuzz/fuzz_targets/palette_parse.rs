//! Any bytes into the palette parser: never a panic; whatever parses saves back byte-identical and reads
//! back to the same palette.
#![no_main]

use libfuzzer_sys::fuzz_target;
use metamer_core::palette::PaletteFile;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("/nonexistent/fuzz.toml");
    if let Ok(file) = PaletteFile::parse_bytes(data, path) {
        let (_, reread) = file.render(&file.palette, path).expect("an unchanged palette renders");
        assert_eq!(reread.text(), file.text());
        assert_eq!(reread.palette, file.palette);
        assert_eq!(file.text().as_bytes(), data, "an unchanged save is byte-identical");
    }
});
