//! The colour pipeline against published references:
//! - tests/data/colorchecker_linear_srgb.csv (copied from ../shared/reference, DESIGN_SPEC §1 exactly) to 1e-9;
//! - tests/data/ciede2000_sharma2005.txt (Sharma, Wu & Dalal 2005, Table 1) to 1e-4.

use metamer::colorimetry::{Colorimetry, delta_e00};
use metamer::spectrum::{Normalize, Spectrum};

fn data_lines(text: &str) -> impl Iterator<Item = &str> {
    text.lines().filter(|l| !l.trim().is_empty() && !l.starts_with('#'))
}

#[test]
fn colorchecker_linear_srgb_matches_reference_to_1e_9() {
    let c = Colorimetry::default();
    let text = include_str!("../data/colorchecker_linear_srgb.csv");
    let mut checked = 0;
    for line in data_lines(text).skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 8, "{line}");
        let refl = Spectrum::colorchecker(f[0]).expect("patch name");
        let light = Spectrum::illuminant(f[1])
            .expect("illuminant name")
            .normalized(Normalize::Luminance, &c.luminance())
            .expect("normalisable");
        let want: Vec<f64> = f[2..].iter().map(|v| v.parse().expect("number")).collect();
        let rgb = c.rgb(&light, &refl);
        let xyz = c.xyz(&light, &refl);
        for k in 0..3 {
            assert!((rgb[k] - want[k]).abs() < 1e-9, "{} {} rgb[{k}] {} vs {}", f[0], f[1], rgb[k], want[k]);
            assert!((xyz[k] - want[3 + k]).abs() < 1e-9, "{} {} xyz[{k}] {} vs {}", f[0], f[1], xyz[k], want[3 + k]);
        }
        checked += 1;
    }
    assert_eq!(checked, 96);
}

#[test]
fn ciede2000_matches_sharma_pairs_to_1e_4() {
    let text = include_str!("../data/ciede2000_sharma2005.txt");
    let mut checked = 0;
    for line in data_lines(text) {
        let v: Vec<f64> = line.split_whitespace().map(|x| x.parse().expect("number")).collect();
        assert_eq!(v.len(), 7, "{line}");
        let d = delta_e00([v[0], v[1], v[2]], [v[3], v[4], v[5]]);
        assert!((d - v[6]).abs() < 1e-4, "pair {checked}: {d} vs {}", v[6]);
        // symmetric
        let d2 = delta_e00([v[3], v[4], v[5]], [v[0], v[1], v[2]]);
        assert!((d2 - v[6]).abs() < 1e-4);
        checked += 1;
    }
    assert_eq!(checked, 34);
}
