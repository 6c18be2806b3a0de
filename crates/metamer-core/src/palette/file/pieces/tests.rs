//! The parse in pieces gives the tree (spans included) and the errors of the parse of the whole text.

use super::*;

/// A long palette: `n` designed reflectances under two lights, with comments, a multi-line string and a
/// multi-line array holding lines that look like headers.
fn long_palette(n: usize) -> String {
    let samples = (0..31).map(|i| format!("{}", 0.25 + i as f64 / 64.0)).collect::<Vec<_>>().join(", ");
    let mut t = String::from("name = \"long\"\nnote = \"\"\"\n[[reflectances]]\n\"\"\"\n[settings]\n");
    t += "reflectance_bounds = [0.0, 1.0]\n\n";
    for l in ["a", "b"] {
        t += &format!("[[lights]]\nname = \"{l}\"\nsamples = [{samples}]\nnormalize = \"none\"\n\n");
    }
    for i in 0..n {
        t += &format!(
            "# reflectance {i}\n[[reflectances]]\nname = \"r{i}\"\nsamples = [\n    {samples},\n]\ndesign = true\n\n"
        );
        if i % 97 == 0 {
            t += &format!("extra = '''\n[[reflectances]]\n'''\nlist = [\n[[1]], [[2]],\n]\n# [[reflectances]] {i}\n");
        }
    }
    for i in 0..n {
        for l in ["a", "b"] {
            t += &format!("[[colours]]\nlight = \"{l}\"\nreflectance = \"r{i}\"\ntarget = [0.1, 0.2, 0.3]\n\n");
        }
    }
    t
}

fn headers(text: &str) -> Vec<usize> {
    super::super::budget::scan(text).headers
}

fn debug_of(r: Result<Spanned<DeTable<'_>>, Failure>) -> String {
    match r {
        Ok(t) => format!("{t:?}"),
        Err(Failure::Syntax(e)) => format!("syntax {:?} {}", e.span(), e.message()),
        Err(Failure::Number(span, m)) => format!("number {span:?} {m}"),
    }
}

#[test]
fn pieces_give_the_tree_of_the_whole_text() {
    let text = long_palette(1500);
    let starts = cuts(&text, 8, &headers(&text));
    assert!(starts.len() >= 6, "cut into {} pieces", starts.len());
    for &s in &starts[1..] {
        assert!(text[s..].starts_with("[[reflectances]]\nname") || text[s..].starts_with("[[colours]]\nlight"));
    }
    let joined = parse_pieces(&text, &starts).expect("the pieces parse");
    assert_eq!(format!("{joined:?}"), debug_of(parse_one(&text)));
}

#[test]
fn no_cut_before_a_header_of_another_shape() {
    let mut text = long_palette(600);
    text += "[settings2]\nx = 1\n[[colours]]\nlight = \"a\"\nreflectance = \"r0\"\n";
    let starts = cuts(&text, 8, &headers(&text));
    let last_other = text.find("[settings2]").unwrap();
    assert!(starts.len() == 2 && starts[1] > last_other, "cuts {starts:?}, [settings2] at {last_other}");
}

#[test]
fn errors_are_those_of_the_whole_text() {
    let base = long_palette(1500);
    let late = base.rfind("target = [0.1").unwrap();
    let cases = [
        // A syntax error in a late piece.
        format!("{}{}", &base[..late], base[late..].replacen("target = [0.1, 0.2, 0.3]", "target = [0.1,, 0.2]", 1)),
        // A number TOML cannot hold in a late piece.
        format!("{}weight = 1e999\n{}", &base[..late], &base[late..]),
        // `[[name]]` tables continuing a key that the first piece gives as a plain array.
        format!("colours = [1]\n{base}"),
        // A duplicate key in a late piece.
        format!("{}light = \"b\"\n{}", &base[..late], &base[late..]),
    ];
    for text in &cases {
        assert!(cuts(text, 8, &headers(text)).len() > 2);
        let pieces = debug_of(parse(text, &headers(text)));
        assert!(!pieces.starts_with("Spanned"), "{pieces}");
        assert_eq!(pieces, debug_of(parse_one(text)));
    }
}

#[test]
fn short_texts_are_one_piece() {
    assert_eq!(cuts(&long_palette(3), 1, &headers(&long_palette(3))), vec![0]);
    assert_eq!(debug_of(parse(&long_palette(3), &headers(&long_palette(3)))), debug_of(parse_one(&long_palette(3))));
}
