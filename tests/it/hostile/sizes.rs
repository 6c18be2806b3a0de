//! Sizes read from files, checked before anything large is allocated (issue 31, items 2, 3 and 8; issue 25):
//! decompression bounded by what the header and extent need, never by the payload's own claims; files far
//! larger than their header implies refused from their size; volumes too large for the machine's memory
//! refused early naming their size and the memory rendering needs; 2-D images refused by the scene.

use super::{stderr, within};
use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};
use metamer::volume::{Volume, nrrd, vti};
use std::io::Write;
use std::path::Path;
use std::process::{Command, Output};
use std::time::{Duration, Instant};

fn gzip(bytes: &[u8]) -> Vec<u8> {
    let mut e = GzEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn zlib(bytes: &[u8]) -> Vec<u8> {
    let mut e = ZlibEncoder::new(Vec::new(), Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

/// Bytes that do not compress (a xorshift stream).
fn noise(n: usize) -> Vec<u8> {
    let mut x = 0x9e37_79b9_7f4a_7c15u64;
    (0..n)
        .map(|_| {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x as u8
        })
        .collect()
}

fn nrrd_error(bytes: Vec<u8>) -> String {
    let start = Instant::now();
    let e = within(Duration::from_secs(20), move || nrrd::from_bytes(Path::new("bomb.nrrd"), &bytes))
        .err()
        .map(|e| e.to_string())
        .expect("must be refused");
    assert!(start.elapsed() < Duration::from_secs(10), "refused after {:?}: {e}", start.elapsed());
    e
}

#[test]
fn gzip_nrrd_claiming_a_gib_is_refused_without_inflating_past_its_data() {
    let head = b"NRRD0004\ntype: uint8\nsizes: 1024 1024 1024\nencoding: gzip\n\n".to_vec();
    // 64 MiB of zeros in about 64 KiB: that little gzip cannot inflate to 1 GiB, refused before allocating.
    let bomb = gzip(&vec![0u8; 64 << 20]);
    assert!(bomb.len() < 1 << 20);
    let e = nrrd_error([head.clone(), bomb].concat());
    assert!(e.contains("bomb.nrrd") && e.contains("truncated") && e.contains("can inflate to"), "{e}");
    // 1 MiB of gzip that could in principle inflate to 1 GiB: inflated into the one buffer the header needs
    // and refused when it ends short.
    let payload = gzip(&noise(1 << 20));
    let e = nrrd_error([head, payload].concat());
    assert!(e.contains("truncated") && e.contains("inflates to 1048576"), "{e}");
    // More than the header needs: inflating stops one byte past it.
    let head = b"NRRD0004\ntype: uint16\nendian: little\nsizes: 4 4 4\nencoding: gzip\n\n".to_vec();
    let e = nrrd_error([head, gzip(&vec![1u8; 64 << 20])].concat());
    assert!(e.contains("inflates to more than the 128 bytes"), "{e}");
}

/// A compressed VTI of 2×2×2 u8 voxels in appended raw data, with the given block header words (UInt32)
/// and block payloads.
fn vti_blocks(words: &[u32], blocks: &[Vec<u8>]) -> Vec<u8> {
    let mut out = br#"<?xml version="1.0"?>
<VTKFile type="ImageData" version="1.0" byte_order="LittleEndian" header_type="UInt32" compressor="vtkZLibDataCompressor">
<ImageData WholeExtent="0 1 0 1 0 1" Spacing="1 1 1"><Piece Extent="0 1 0 1 0 1"><PointData Scalars="s">
<DataArray type="UInt8" Name="s" format="appended" offset="0"/>
</PointData></Piece></ImageData>
<AppendedData encoding="raw">_"#
        .to_vec();
    out.extend(words.iter().flat_map(|w| w.to_le_bytes()));
    out.extend(blocks.concat());
    out.extend(b"\n</AppendedData>\n</VTKFile>\n");
    out
}

fn vti_error(bytes: Vec<u8>) -> String {
    let start = Instant::now();
    let e = within(Duration::from_secs(20), move || vti::from_bytes(Path::new("blocks.vti"), &bytes))
        .err()
        .map(|e| e.to_string())
        .expect("must be refused");
    assert!(start.elapsed() < Duration::from_secs(10), "refused after {:?}: {e}", start.elapsed());
    e
}

#[test]
fn vti_zlib_blocks_inflate_only_what_the_extent_needs() {
    let good = zlib(&[1, 2, 3, 4, 5, 6, 7, 8]);
    // The honest file reads.
    let v =
        vti::from_bytes(Path::new("ok.vti"), &vti_blocks(&[1, 8, 8, good.len() as u32], std::slice::from_ref(&good)))
            .unwrap();
    assert_eq!(v.voxels.to_f32_vec(), vec![1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0]);
    // A block header claiming a 4 GiB block (or an impossible total) is refused before anything inflates.
    let e = vti_error(vti_blocks(&[1, u32::MAX, 0, good.len() as u32], std::slice::from_ref(&good)));
    assert!(e.contains("blocks.vti") && e.contains("the extent needs 8 bytes"), "{e}");
    let e = vti_error(vti_blocks(&[u32::MAX, 8, 8, 12], std::slice::from_ref(&good)));
    assert!(e.contains("the extent needs 8 bytes"), "{e}");
    // A block that inflates to 64 MiB where the header (and the extent) say 8 bytes stops after 9.
    let bomb = zlib(&vec![0u8; 64 << 20]);
    let e = vti_error(vti_blocks(&[1, 8, 8, bomb.len() as u32], &[bomb]));
    assert!(e.contains("compressed block 1 inflates to more bytes, its header says 8"), "{e}");
    // Compressed sizes running past the end of the file.
    let e = vti_error(vti_blocks(&[1, 8, 8, 1 << 30], &[good]));
    assert!(e.contains("truncated"), "{e}");
}

fn sparse(path: &Path, start: &[u8], len: u64) {
    std::fs::write(path, start).unwrap();
    std::fs::OpenOptions::new().write(true).open(path).unwrap().set_len(len).unwrap();
}

#[test]
fn a_one_voxel_vti_padded_to_gigabytes_is_refused_from_its_size() {
    let dir = tempfile::tempdir().unwrap();
    let one = br#"<VTKFile type="ImageData" byte_order="LittleEndian"><ImageData WholeExtent="0 0 0 0 0 0"><Piece Extent="0 0 0 0 0 0"><PointData><DataArray type="UInt8" Name="s" format="ascii">7</DataArray></PointData></Piece></ImageData></VTKFile>
"#;
    let ok = dir.path().join("one.vti");
    std::fs::write(&ok, one).unwrap();
    assert_eq!(Volume::open(&ok).unwrap().voxels.to_f32_vec(), vec![7.0]);
    let padded = dir.path().join("padded.vti");
    sparse(&padded, one, 3_900_000_000);
    let start = Instant::now();
    let e = within(Duration::from_secs(20), move || Volume::open(&padded)).unwrap_err().to_string();
    assert!(e.contains("padded.vti") && e.contains("3900000000 bytes") && e.contains("not read"), "{e}");
    assert!(start.elapsed() < Duration::from_secs(2), "refused after {:?}", start.elapsed());
}

/// A u16 VTI of `dims` in inline base64 (`binary`): VTK's two runs (header, then data) with line breaks,
/// uncompressed or in zlib blocks of `block` bytes.
fn vti_base64(dims: [usize; 3], values: &[u16], block: Option<usize>) -> Vec<u8> {
    let data: Vec<u8> = values.iter().flat_map(|v| v.to_le_bytes()).collect();
    let (header, body): (Vec<u32>, Vec<u8>) = match block {
        None => (vec![data.len() as u32], data),
        Some(b) => {
            let packed: Vec<Vec<u8>> = data.chunks(b).map(zlib).collect();
            let mut h = vec![packed.len() as u32, b as u32, (data.len() % b) as u32];
            h.extend(packed.iter().map(|p| p.len() as u32));
            (h, packed.concat())
        }
    };
    let header: Vec<u8> = header.iter().flat_map(|w| w.to_le_bytes()).collect();
    let text = format!("{}{}", STANDARD.encode(header), STANDARD.encode(body));
    let lines: Vec<&str> = text.as_bytes().chunks(76).map(|c| std::str::from_utf8(c).unwrap()).collect();
    let compressor = if block.is_some() { r#" compressor="vtkZLibDataCompressor""# } else { "" };
    format!(
        "<VTKFile type=\"ImageData\" byte_order=\"LittleEndian\"{compressor}>\n<ImageData WholeExtent=\"0 {} 0 {} 0 {}\">\n\
         <Piece Extent=\"0 {} 0 {} 0 {}\"><PointData Scalars=\"s\">\n<DataArray type=\"UInt16\" Name=\"s\" format=\"binary\">\n{}\n\
         </DataArray></PointData></Piece></ImageData></VTKFile>\n",
        dims[0] - 1,
        dims[1] - 1,
        dims[2] - 1,
        dims[0] - 1,
        dims[1] - 1,
        dims[2] - 1,
        lines.join("\n        ")
    )
    .into_bytes()
}

#[test]
fn vti_base64_is_decoded_in_chunks_across_its_two_runs() {
    // 400 000 bytes: 533 336 characters, several of the reader's 64 Ki-character chunks.
    let dims = [200, 100, 10];
    let values: Vec<u16> = (0..200_000u32).map(|i| (i.wrapping_mul(2_654_435_761) >> 16) as u16).collect();
    let expect: Vec<f32> = values.iter().map(|v| f32::from(*v)).collect();
    for block in [None, Some(32 << 10), Some(1000)] {
        let v = vti::from_bytes(Path::new("big.vti"), &vti_base64(dims, &values, block))
            .unwrap_or_else(|e| panic!("{block:?}: {e}"));
        assert_eq!(v.dims, dims);
        assert!(v.voxels.to_f32_vec() == expect, "{block:?}: voxels differ");
    }
    // Cut inside the data: truncated, whichever chunk it falls in.
    let full = vti_base64(dims, &values, None);
    let text = String::from_utf8(full).unwrap();
    let close = text.find("\n</DataArray>").unwrap();
    let cut = format!("{}{}", &text[..close - 200_000], &text[close..]);
    let e = vti::from_bytes(Path::new("cut.vti"), cut.as_bytes()).unwrap_err().to_string();
    assert!(e.contains("cut.vti") && e.contains("truncated"), "{e}");
}

/// In `dir`: the engine palette and a scene `s.toml` over the volume `volume` (with `raw` as its `[raw]`
/// table when given).
fn scene_dir(dir: &Path, volume: &str, raw: Option<&str>) {
    let palette = std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/volumes/engine_palette.toml")).unwrap();
    std::fs::write(dir.join("p.toml"), palette).unwrap();
    let raw = raw.map(|r| format!("[raw]\n{r}\n")).unwrap_or_default();
    std::fs::write(
        dir.join("s.toml"),
        format!(
            "palette = \"p.toml\"\nvolume = \"{volume}\"\n[[materials]]\nreflectance = \"block\"\nrange = [100, 60000]\nopacity = 0.2\n{raw}"
        ),
    )
    .unwrap();
}

fn render(dir: &Path, limit_mib: Option<u64>) -> Output {
    let mut c = Command::new(env!("CARGO_BIN_EXE_metamer"));
    c.current_dir(dir).args(["render", "s.toml", "--frames", "1", "--size", "16", "-o", "out"]);
    c.env_remove(metamer::memory::LIMIT_ENV);
    if let Some(l) = limit_mib {
        c.env(metamer::memory::LIMIT_ENV, l.to_string());
    }
    c.output().expect("metamer runs")
}

#[test]
fn a_volume_too_large_for_memory_is_refused_naming_its_size_and_need() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let values: Vec<u8> = (0..64 * 64 * 64u32).flat_map(|i| ((i % 997) as u16 * 60).to_le_bytes()).collect();
    std::fs::write(d.join("v.raw"), values).unwrap();
    scene_dir(d, "v.raw", Some("dims = [64, 64, 64]\ntype = \"u16\"\nendian = \"little\""));
    let o = render(d, Some(100));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("volume v.raw is 64×64×64 u16 = 0.5 MiB; rendering it needs about 161 MiB; this machine has 100 MiB available (METAMER_MEMORY_LIMIT)"),
        "{e}"
    );
    assert!(!e.contains("panicked"), "{e}");
    // With the memory it needs, the same scene renders.
    let o = render(d, Some(4096));
    assert!(o.status.success(), "{}", stderr(&o));
    // NRRD and VTI go through the same check.
    std::fs::write(
        d.join("v.nrrd"),
        [b"NRRD0004\ntype: uint8\nsizes: 2 2 2\nencoding: raw\n\n".to_vec(), vec![7u8; 8]].concat(),
    )
    .unwrap();
    scene_dir(d, "v.nrrd", None);
    let e = stderr(&render(d, Some(10)));
    assert!(e.contains("volume v.nrrd is 2×2×2 u8 = 0.0 MiB; rendering it needs about 161 MiB"), "{e}");
    // Text data too (checked before the text is parsed; its values are kept as f32).
    std::fs::write(d.join("t.nrrd"), "NRRD0004\ntype: uint8\nsizes: 2 2 2\nencoding: text\n\n1 2 3 4 5 6 7 8\n")
        .unwrap();
    scene_dir(d, "t.nrrd", None);
    let e = stderr(&render(d, Some(10)));
    assert!(e.contains("volume t.nrrd is 2×2×2 f32 = 0.0 MiB; rendering it needs about 161 MiB"), "{e}");
}

#[test]
fn a_2d_nrrd_is_refused_by_the_scene_not_rendered_black() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(
        d.join("slice.nrrd"),
        [b"NRRD0004\ntype: uint8\ndimension: 2\nsizes: 8 8\nencoding: raw\n\n".to_vec(), vec![150u8; 64]].concat(),
    )
    .unwrap();
    scene_dir(d, "slice.nrrd", None);
    let o = render(d, None);
    assert!(!o.status.success(), "a 2-D image rendered: {}", String::from_utf8_lossy(&o.stdout));
    let e = stderr(&o);
    assert!(e.contains("slice.nrrd is 8×8×1 voxels") && e.contains("2-D image is not a volume"), "{e}");
    assert!(!d.join("out").exists(), "no frames may be written");
}

/// `render --size 4096 --mode full` (31 f32 channels: 1984 MiB) is estimated and refused up front when the
/// machine has less, before the raycast allocates it (issue 31, item 7).
#[test]
fn a_render_image_too_large_for_memory_is_refused_before_the_raycast() {
    let dir = tempfile::tempdir().unwrap();
    let start = Instant::now();
    let o = Command::new(env!("CARGO_BIN_EXE_metamer"))
        .current_dir(dir.path())
        .args([
            "render",
            "--builtin",
            "--builtin-volume-size",
            "16",
            "--size",
            "4096",
            "--mode",
            "full",
            "--frames",
            "1",
        ])
        .env(metamer::memory::LIMIT_ENV, "1000")
        .output()
        .unwrap();
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("a 4096×4096 full render (31 channels of f32: 1984 MiB)") && e.contains("1000 MiB available"),
        "{e}"
    );
    assert!(start.elapsed() < Duration::from_secs(20), "refused after {:?}", start.elapsed());
    assert!(!dir.path().join("frames").exists());
}
