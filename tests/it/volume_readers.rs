//! Volume readers on small synthetic files of every encoding (written here), their failure modes, and
//! the real volumes in `../shared/volumes` when present.

use base64::Engine;
use base64::engine::general_purpose::STANDARD;
use flate2::Compression;
use flate2::write::{GzEncoder, ZlibEncoder};
use metamer::volume::{Endian, ScalarType, Volume, VolumeError, raw};
use std::io::Write;

fn values(n: usize) -> Vec<f32> {
    (0..n).map(|i| ((i * 37) % 251) as f32 - 20.0).collect()
}

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

fn encode_i16(v: &[f32], endian: Endian) -> Vec<u8> {
    v.iter()
        .flat_map(|x| match endian {
            Endian::Little => (*x as i16).to_le_bytes(),
            Endian::Big => (*x as i16).to_be_bytes(),
        })
        .collect()
}

fn message(e: VolumeError) -> String {
    e.to_string()
}

const DIMS: [usize; 3] = [5, 4, 3];

#[test]
fn nrrd_attached_raw_big_endian() {
    let dir = tempfile::tempdir().unwrap();
    let v = values(60);
    let mut file = b"NRRD0004\n# a comment\ntype: short\ndimension: 3\nsizes: 5 4 3\nspacings: 0.5 1 2\nencoding: raw\nendian: big\n\n".to_vec();
    file.extend(encode_i16(&v, Endian::Big));
    let p = dir.path().join("a.nrrd");
    std::fs::write(&p, &file).unwrap();
    let vol = Volume::open(&p).unwrap();
    assert_eq!(vol.dims, DIMS);
    assert_eq!(vol.spacing, [0.5, 1.0, 2.0]);
    assert_eq!(vol.voxels.to_f32_vec(), v);
    assert_eq!(vol.at(1, 0, 0), v[1]);
    assert_eq!(vol.at(0, 1, 0), v[5]);
}

#[test]
fn nrrd_detached_gzip_with_skips() {
    let dir = tempfile::tempdir().unwrap();
    let v = values(60);
    // Two junk lines, then (after decompression) 3 junk bytes before the data.
    let mut payload = vec![9u8, 9, 9];
    payload.extend(encode_i16(&v, Endian::Little));
    let mut stored = b"junk line one\njunk two\n".to_vec();
    stored.extend(gzip(&payload));
    std::fs::write(dir.path().join("d.raw.gz"), &stored).unwrap();
    let header = "NRRD0004\ntype: int16\ndimension: 3\nsizes: 5 4 3\nspace directions: (2,0,0) (0,3,0) (0,0,4)\nencoding: gzip\nendian: little\nline skip: 2\nbyte skip: 3\ndata file: d.raw.gz\n";
    let p = dir.path().join("d.nhdr");
    std::fs::write(&p, header).unwrap();
    let vol = Volume::open(&p).unwrap();
    assert_eq!(vol.spacing, [2.0, 3.0, 4.0]);
    assert_eq!(vol.voxels.to_f32_vec(), v);
}

#[test]
fn nrrd_every_type_and_byte_skip_minus_one() {
    let dir = tempfile::tempdir().unwrap();
    let v: Vec<f32> = (0..60).map(|i| i as f32 * 2.0).collect();
    type Enc = fn(f32) -> Vec<u8>;
    let cases: [(&str, Enc); 8] = [
        ("uchar", |x| vec![x as u8]),
        ("int8", |x| vec![(x as i8).to_ne_bytes()[0]]),
        ("ushort", |x| (x as u16).to_le_bytes().to_vec()),
        ("short", |x| (x as i16).to_le_bytes().to_vec()),
        ("uint", |x| (x as u32).to_le_bytes().to_vec()),
        ("int", |x| (x as i32).to_le_bytes().to_vec()),
        ("float", |x| x.to_le_bytes().to_vec()),
        ("double", |x| f64::from(x).to_le_bytes().to_vec()),
    ];
    for (ty, enc) in cases {
        let data: Vec<u8> = v.iter().flat_map(|x| enc(*x)).collect();
        let mut stored = b"some preamble of any length".to_vec();
        stored.extend(&data);
        std::fs::write(dir.path().join("t.raw"), &stored).unwrap();
        let p = dir.path().join("t.nhdr");
        let header = format!(
            "NRRD0005\ntype: {ty}\ndimension: 3\nsizes: 5 4 3\nencoding: raw\nendian: little\nbyte skip: -1\ndata file: t.raw\n"
        );
        std::fs::write(&p, header).unwrap();
        let vol = Volume::open(&p).unwrap_or_else(|e| panic!("{ty}: {e}"));
        assert_eq!(vol.voxels.to_f32_vec(), v, "{ty}");
    }
}

#[test]
fn nrrd_text_encoding() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("t.nrrd");
    std::fs::write(&p, "NRRD0004\ntype: float\nsizes: 2 2\nencoding: text\n\n1 2\n3.5 -4\n").unwrap();
    let vol = Volume::open(&p).unwrap();
    assert_eq!(vol.dims, [2, 2, 1]);
    assert_eq!(vol.voxels.to_f32_vec(), vec![1.0, 2.0, 3.5, -4.0]);
}

#[test]
fn nrrd_bad_inputs_are_errors_naming_file_and_reason() {
    let dir = tempfile::tempdir().unwrap();
    let write = |name: &str, bytes: &[u8]| {
        let p = dir.path().join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    };
    let head = "NRRD0004\ntype: uchar\ndimension: 3\nsizes: 5 4 3\nencoding: raw\n\n";
    // Truncated attached data.
    let mut short = head.as_bytes().to_vec();
    short.extend([1u8; 59]);
    let e = message(Volume::open(&write("short.nrrd", &short)).unwrap_err());
    assert!(e.contains("short.nrrd") && e.contains("truncated"), "{e}");
    // Too much data.
    let mut long = head.as_bytes().to_vec();
    long.extend([1u8; 61]);
    let e = message(Volume::open(&write("long.nrrd", &long)).unwrap_err());
    assert!(e.contains("61") && e.contains("60"), "{e}");
    // Truncated gzip stream.
    let gz = gzip(&[7u8; 60]);
    write("cut.raw.gz", &gz[..gz.len() / 2]);
    let e = message(
        Volume::open(&write(
            "cut.nhdr",
            b"NRRD0004\ntype: uchar\nsizes: 5 4 3\nencoding: gzip\ndata file: cut.raw.gz\n",
        ))
        .unwrap_err(),
    );
    assert!(e.contains("cut.raw.gz") && e.contains("gzip"), "{e}");
    // Missing data file.
    let e = message(
        Volume::open(&write(
            "gone.nhdr",
            b"NRRD0004\ntype: uchar\nsizes: 5 4 3\nencoding: raw\ndata file: nowhere.raw\n",
        ))
        .unwrap_err(),
    );
    assert!(e.contains("nowhere.raw"), "{e}");
    // Header problems.
    for (name, text, needle) in [
        ("nomagic.nrrd", "PNG\n", "magic"),
        ("type.nrrd", "NRRD0004\ntype: quaternion\nsizes: 1\nencoding: raw\n\n", "type"),
        ("endian.nrrd", "NRRD0004\ntype: short\nsizes: 1\nencoding: raw\n\n", "endian"),
        ("dim.nrrd", "NRRD0004\ntype: uchar\ndimension: 2\nsizes: 1 2 3\nencoding: raw\n\n", "dimension"),
        ("zero.nrrd", "NRRD0004\ntype: uchar\nsizes: 0 2 3\nencoding: raw\n\n", "zero"),
        ("enc.nrrd", "NRRD0004\ntype: uchar\nsizes: 1\nencoding: bzip2\n\n", "bzip2"),
        ("huge.nrrd", "NRRD0004\ntype: uchar\nsizes: 100000 100000 100000\nencoding: raw\n\n", "too large"),
        ("spacing.nrrd", "NRRD0004\ntype: uchar\nsizes: 1 1 1\nspacings: 1 -2 1\nencoding: raw\n\n\x01", "spacing"),
        ("sizes.nrrd", "NRRD0004\ntype: uchar\nencoding: raw\n\n", "sizes"),
        ("empty.nrrd", "", "magic"),
    ] {
        let e = message(Volume::open(&write(name, text.as_bytes())).unwrap_err());
        assert!(e.contains(name) && e.contains(needle), "{name}: {e}");
    }
    // Binary garbage.
    let e = message(Volume::open(&write("bin.nrrd", &[0xff, 0xfe, 0, 1, 2, 3])).unwrap_err());
    assert!(e.contains("bin.nrrd"), "{e}");
}

/// A VTK XML image-data file holding `v` as one UInt16 (or other) array, in the requested layout.
fn vti(v: &[f32], layout: &str, header64: bool, compressed: bool, big: bool) -> Vec<u8> {
    let word = |n: usize| -> Vec<u8> {
        match (header64, big) {
            (false, false) => (n as u32).to_le_bytes().to_vec(),
            (false, true) => (n as u32).to_be_bytes().to_vec(),
            (true, false) => (n as u64).to_le_bytes().to_vec(),
            (true, true) => (n as u64).to_be_bytes().to_vec(),
        }
    };
    let data: Vec<u8> =
        v.iter().flat_map(|x| if big { (*x as u16).to_be_bytes() } else { (*x as u16).to_le_bytes() }).collect();
    let (header, body): (Vec<u8>, Vec<u8>) = if compressed {
        // Blocks of 50 bytes, the last one shorter.
        let blocks: Vec<&[u8]> = data.chunks(50).collect();
        let packed: Vec<Vec<u8>> = blocks.iter().map(|b| zlib(b)).collect();
        let mut h = word(blocks.len());
        h.extend(word(50));
        h.extend(word(blocks.last().unwrap().len() % 50));
        for p in &packed {
            h.extend(word(p.len()));
        }
        (h, packed.concat())
    } else {
        (word(data.len()), data.clone())
    };
    let attrs = format!(
        r#"type="ImageData" version="1.0" byte_order="{}" header_type="{}"{}"#,
        if big { "BigEndian" } else { "LittleEndian" },
        if header64 { "UInt64" } else { "UInt32" },
        if compressed { r#" compressor="vtkZLibDataCompressor""# } else { "" }
    );
    let open = format!(
        "<?xml version=\"1.0\"?>\n<VTKFile {attrs}>\n<ImageData WholeExtent=\"0 4 0 3 0 2\" Origin=\"0 0 0\" Spacing=\"1 1 1.5\">\n<Piece Extent=\"0 4 0 3 0 2\">\n<PointData Scalars=\"labels\">\n<DataArray type=\"Float32\" Name=\"other\" format=\"ascii\">1</DataArray>\n"
    );
    let close = "</PointData>\n<CellData>\n</CellData>\n</Piece>\n</ImageData>\n";
    let mut out = open.into_bytes();
    match layout {
        "binary" => {
            let text = format!("{}{}", STANDARD.encode(&header), STANDARD.encode(&body));
            out.extend(
                format!("<DataArray type=\"UInt16\" Name=\"labels\" format=\"binary\">\n  {text}\n</DataArray>\n")
                    .bytes(),
            );
            out.extend(close.bytes());
            out.extend(b"</VTKFile>\n");
        }
        "binary-one-run" => {
            let text = STANDARD.encode([header.clone(), body.clone()].concat());
            out.extend(
                format!("<DataArray type=\"UInt16\" Name=\"labels\" format=\"binary\">{text}</DataArray>\n").bytes(),
            );
            out.extend(close.bytes());
            out.extend(b"</VTKFile>\n");
        }
        "ascii" => {
            let text: Vec<String> = v.iter().map(|x| x.to_string()).collect();
            out.extend(
                format!("<DataArray type=\"UInt16\" Name=\"labels\" format=\"ascii\">{}</DataArray>\n", text.join(" "))
                    .bytes(),
            );
            out.extend(close.bytes());
            out.extend(b"</VTKFile>\n");
        }
        "appended-raw" | "appended-base64" => {
            // A decoy array first, so the offset is non-zero.
            let decoy = [word(2), vec![0u8, 0]].concat();
            let (dec, arr, enc) = if layout == "appended-raw" {
                (decoy.clone(), [header.clone(), body.clone()].concat(), "raw")
            } else {
                (
                    STANDARD.encode(&decoy).into_bytes(),
                    [STANDARD.encode(&header), STANDARD.encode(&body)].concat().into_bytes(),
                    "base64",
                )
            };
            out.extend(
                format!("<DataArray type=\"UInt16\" Name=\"labels\" format=\"appended\" offset=\"{}\"/>\n", dec.len())
                    .bytes(),
            );
            out.extend(close.bytes());
            out.extend(format!("<AppendedData encoding=\"{enc}\">\n   _").bytes());
            out.extend(dec);
            out.extend(arr);
            out.extend(b"\n</AppendedData>\n</VTKFile>\n");
        }
        _ => unreachable!(),
    }
    out
}

#[test]
fn vti_every_layout() {
    let dir = tempfile::tempdir().unwrap();
    let v: Vec<f32> = (0..60).map(|i| ((i * 7) % 30) as f32).collect();
    for layout in ["binary", "binary-one-run", "ascii", "appended-raw", "appended-base64"] {
        for header64 in [false, true] {
            for compressed in [false, true] {
                for big in [false, true] {
                    if layout == "binary-one-run" && compressed {
                        continue;
                    }
                    let p = dir.path().join("v.vti");
                    std::fs::write(&p, vti(&v, layout, header64, compressed, big)).unwrap();
                    let what = format!("{layout} header64={header64} compressed={compressed} big={big}");
                    let vol = Volume::open(&p).unwrap_or_else(|e| panic!("{what}: {e}"));
                    assert_eq!(vol.dims, DIMS, "{what}");
                    assert_eq!(vol.spacing, [1.0, 1.0, 1.5], "{what}");
                    assert_eq!(vol.voxels.to_f32_vec(), v, "{what}");
                }
            }
        }
    }
}

#[test]
fn vti_truncated_and_malformed_are_errors() {
    let dir = tempfile::tempdir().unwrap();
    let v: Vec<f32> = (0..60).map(|i| (i % 30) as f32).collect();
    let full = vti(&v, "binary", false, true, false);
    let text = String::from_utf8(full.clone()).unwrap();
    let start = text.find("format=\"binary\">").unwrap() + 20;
    // Cut the base64 payload short (keeping the XML closed), and cut the file itself.
    let cases: Vec<(&str, Vec<u8>)> = vec![
        ("short_payload.vti", [&text[..start + 40], &text[text.find("</DataArray>").unwrap()..]].concat().into_bytes()),
        ("cut.vti", full[..full.len() / 2].to_vec()),
        ("empty.vti", vec![]),
        ("notvtk.vti", b"<html></html>".to_vec()),
        ("poly.vti", b"<VTKFile type=\"PolyData\"></VTKFile>".to_vec()),
        ("garbage.vti", vec![0xff, 0x00, 0x13, 0x37]),
    ];
    for (name, bytes) in cases {
        let p = dir.path().join(name);
        std::fs::write(&p, &bytes).unwrap();
        let e = message(Volume::open(&p).unwrap_err());
        assert!(e.contains(name), "{name}: {e}");
    }
    // A payload whose blocks inflate to less than the header claims.
    let appended = vti(&v, "appended-raw", false, true, false);
    let p = dir.path().join("raw_cut.vti");
    let cut_at = appended.len() - 40;
    std::fs::write(&p, [&appended[..cut_at], b"\n</AppendedData>\n</VTKFile>\n"].concat()).unwrap();
    let e = message(Volume::open(&p).unwrap_err());
    assert!(e.contains("raw_cut.vti") && (e.contains("truncated") || e.contains("inflate")), "{e}");
}

#[test]
fn raw_reader_checks_size() {
    let dir = tempfile::tempdir().unwrap();
    let v = values(60);
    let p = dir.path().join("v.raw");
    std::fs::write(&p, encode_i16(&v, Endian::Big)).unwrap();
    let vol = raw::read(&p, DIMS, ScalarType::I16, Endian::Big, [1.0; 3]).unwrap();
    assert_eq!(vol.voxels.to_f32_vec(), v);
    let pz = dir.path().join("v.raw.gz");
    std::fs::write(&pz, gzip(&encode_i16(&v, Endian::Little))).unwrap();
    assert_eq!(raw::read(&pz, DIMS, ScalarType::I16, Endian::Little, [1.0; 3]).unwrap().voxels.to_f32_vec(), v);
    let e = message(raw::read(&p, [5, 4, 4], ScalarType::I16, Endian::Big, [1.0; 3]).unwrap_err());
    assert!(e.contains("v.raw") && e.contains("truncated"), "{e}");
    let e = message(raw::read(&p, [5, 4, 2], ScalarType::I16, Endian::Big, [1.0; 3]).unwrap_err());
    assert!(e.contains("v.raw") && e.contains("need"), "{e}");
}
