//! Inputs that crashed (or, before the fix, would have crashed) the volume readers — found by the
//! `nrrd_read` / `vti_read` fuzz targets in `fuzz/` and by reviewing what they exercise. Each must now give
//! a readable error, without a panic, an arithmetic overflow or an allocation the input does not justify.

use flate2::Compression;
use flate2::write::GzEncoder;
use metamer::volume::{nrrd, vti};
use std::io::Write;
use std::path::Path;

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::best());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn nrrd_error(bytes: &[u8]) -> String {
    match nrrd::from_bytes(Path::new("fuzz.nrrd"), bytes) {
        Ok(v) => panic!("accepted: {:?}", v.dims),
        Err(e) => e.to_string(),
    }
}

fn vti_error(bytes: &[u8]) -> String {
    match vti::from_bytes(Path::new("fuzz.vti"), bytes) {
        Ok(v) => panic!("accepted: {:?}", v.dims),
        Err(e) => e.to_string(),
    }
}

/// `byte skip` near i64::MAX with gzip data: the reservation `expected + byte skip` overflowed.
#[test]
fn nrrd_gzip_with_a_huge_byte_skip() {
    let mut f = b"NRRD0004\ntype: uint8\nsizes: 2 2 2\nencoding: gzip\nbyte skip: 9223372036854775807\n\n".to_vec();
    f.extend(gzip(&[7; 8]));
    let e = nrrd_error(&f);
    assert!(e.contains("fuzz.nrrd") && e.contains("truncated"), "{e}");
}

/// A few kilobytes of gzip that inflate to 64 MiB for an 8-voxel volume: inflating stops at what the header
/// needs.
#[test]
fn nrrd_gzip_bomb_stops_at_the_header_size() {
    let mut f = b"NRRD0004\ntype: uint8\nsizes: 2 2 2\nencoding: gzip\n\n".to_vec();
    f.extend(gzip(&vec![0; 64 << 20]));
    assert!(f.len() < 1 << 20);
    let e = nrrd_error(&f);
    assert!(e.contains("inflates to more than the 8 bytes"), "{e}");
}

/// 2³² voxels of text data in a 70-byte file: the reader reserved 16 GiB before reading a value.
#[test]
fn nrrd_text_with_huge_sizes() {
    let e = nrrd_error(b"NRRD0004\ntype: float\nsizes: 65536 65536 1\nencoding: text\n\n1 2 3\n");
    assert!(e.contains("text data holds 3 values"), "{e}");
}

/// An Extent spanning the whole i64 range: `hi − lo + 1` overflowed.
#[test]
fn vti_extent_overflow() {
    let f = std::fs::read("tests/data/fuzz/vti_extent_overflow.vti").unwrap();
    let e = vti_error(&f);
    assert!(e.contains("too large") || e.contains("Extent"), "{e}");
}

/// A padded base64 header shorter than one UInt64 word: reading the word indexed past the decoded bytes.
#[test]
fn vti_base64_header_shorter_than_a_word() {
    let f = std::fs::read("tests/data/fuzz/vti_short_base64_header.vti").unwrap();
    let e = vti_error(&f);
    assert!(e.contains("truncated"), "{e}");
}

/// An ASCII array whose extent claims 2³² values: the reader reserved 16 GiB before parsing.
#[test]
fn vti_ascii_with_huge_extent() {
    let f = br#"<VTKFile type="ImageData"><ImageData WholeExtent="0 65535 0 65535 0 0" Spacing="1 1 1"><Piece Extent="0 65535 0 65535 0 0"><PointData Scalars="s"><DataArray type="Float32" Name="s" format="ascii">1 2 3</DataArray></PointData></Piece></ImageData></VTKFile>"#;
    let e = vti_error(f);
    assert!(e.contains("holds 3 values"), "{e}");
}

/// Compressed block headers claiming 2⁶⁰-byte blocks: the reservation trusted them.
#[test]
fn vti_compressed_header_with_absurd_block_size() {
    let f = std::fs::read("tests/data/fuzz/vti_absurd_block_size.vti").unwrap();
    let e = vti_error(&f);
    assert!(e.contains("fuzz.vti"), "{e}");
}
