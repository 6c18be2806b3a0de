//! A float as the writer writes it, fast. `toml_writer` (the formatter `toml_edit` prints floats with)
//! writes an `f64` with Rust's `{}` (the shortest digits that read back as the same bits, never an
//! exponent) and `.0` after a whole number; that formatting was most of writing a solved palette's
//! samples (grisu, about 1000 instructions a number). [`push_f64`] gets the same shortest digits from
//! `zmij` (Schubfach, the formatter `serde_json` uses; about 250 instructions) and lays them out as `{}`
//! does. The two algorithms agree on the digits but for one case: when two shortest candidates are
//! equally near the exact value (a tie), which they break differently. A tie needs an exact decimal
//! expansion one digit longer than the shortest, so at most 18 significant digits; such numbers (and
//! zero, NaN, the infinities) are written by `toml_writer` itself ([`short_exact`]).

use toml_writer::TomlWrite;

/// `5^k` for `k < 28` (`5^27 < 2^63`).
const POW5: [u64; 28] = {
    let mut t = [1u64; 28];
    let mut i = 1;
    while i < t.len() {
        t[i] = t[i - 1] * 5;
        i += 1;
    }
    t
};

/// True when the exact decimal value of `x` has fewer than 19 significant digits (or `x` is a whole
/// number of 2⁵³ or more): only then can two shortest candidates be equally near it. `x = m·2^e` with m
/// odd is, for `e < 0`, `m·5^(−e) / 10^(−e)`, whose significant digits are those of `m·5^(−e)` (odd, so
/// no trailing zero); a whole number below 2⁵³ is its own shortest form.
fn short_exact(x: f64) -> bool {
    let bits = x.to_bits();
    let biased = ((bits >> 52) & 0x7ff) as i32;
    let fraction = bits & ((1u64 << 52) - 1);
    let (mut m, mut e) = if biased == 0 { (fraction, -1074) } else { (fraction | (1u64 << 52), biased - 1075) };
    if m == 0 {
        return true;
    }
    let zeros = m.trailing_zeros();
    m >>= zeros;
    e += zeros as i32;
    if e >= 0 {
        return x.abs() >= 9_007_199_254_740_992.0;
    }
    POW5.get((-e) as usize).is_some_and(|p| m.checked_mul(*p).is_some_and(|v| v < 10_000_000_000_000_000_000))
}

/// Append `x` exactly as `toml_writer` writes it (`TomlWrite::value`).
pub(super) fn push_f64(out: &mut String, x: f64) {
    if !x.is_finite() || x == 0.0 || short_exact(x) {
        // Writing to a `String` cannot fail.
        let _ = out.value(x);
        return;
    }
    let mut buffer = zmij::Buffer::new();
    let text = buffer.format_finite(x);
    // Without an exponent zmij lays the digits out as `{}` does, `.0` after a whole number included.
    if !text.as_bytes().contains(&b'e') {
        out.push_str(text);
        return;
    }
    // `-`? digits (`.` digits)? `e` [+-] digits: the significant digits and where the point goes.
    let text = text.as_bytes();
    let mut digits = [0u8; 24];
    let (mut n, mut point, mut seen_point) = (0usize, 0i32, false);
    let mut i = usize::from(text.first() == Some(&b'-'));
    while let Some(&c) = text.get(i) {
        match c {
            b'.' => seen_point = true,
            b'e' => break,
            b'0' if n == 0 => point -= i32::from(seen_point),
            _ if n < digits.len() => {
                digits[n] = c;
                n += 1;
                point += i32::from(!seen_point);
            }
            _ => {}
        }
        i += 1;
    }
    let mut exponent = 0i32;
    for &c in text.get(i + 1..).unwrap_or_default() {
        if c.is_ascii_digit() {
            exponent = exponent.saturating_mul(10).saturating_add(i32::from(c - b'0'));
        }
    }
    if text.get(i + 1) == Some(&b'-') {
        exponent = -exponent;
    }
    while n > 0 && digits[n - 1] == b'0' {
        n -= 1;
    }
    let digits = &digits[..n];
    // The point's place from the first digit; laid out as `{}` does, in a line of its own (a number too
    // long for it, beyond about 1e±40, goes through `toml_writer`).
    let k = point.saturating_add(exponent);
    let mut line = [0u8; 48];
    let mut len = 0usize;
    let mut put = |c: u8| {
        if let Some(slot) = line.get_mut(len) {
            *slot = c;
        }
        len += 1;
    };
    if x < 0.0 {
        put(b'-');
    }
    let k_digits = usize::try_from(k).unwrap_or(0);
    if k <= 0 {
        put(b'0');
        put(b'.');
        (0..k.unsigned_abs()).for_each(|_| put(b'0'));
        digits.iter().for_each(|&d| put(d));
    } else if k_digits < n {
        digits[..k_digits].iter().for_each(|&d| put(d));
        put(b'.');
        digits[k_digits..].iter().for_each(|&d| put(d));
    } else {
        digits.iter().for_each(|&d| put(d));
        (n..k_digits).for_each(|_| put(b'0'));
        put(b'.');
        put(b'0');
    }
    match line.get(..len).and_then(|l| std::str::from_utf8(l).ok()) {
        Some(s) => out.push_str(s),
        None => {
            let _ = out.value(x);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn reference(x: f64) -> String {
        let mut s = String::new();
        let _ = s.value(x);
        s
    }

    fn check(x: f64) {
        let mut s = String::new();
        push_f64(&mut s, x);
        assert_eq!(s, reference(x), "{x:?} ({:#x})", x.to_bits());
    }

    #[test]
    fn special_values_and_exponent_forms() {
        for x in [
            0.0,
            -0.0,
            f64::NAN,
            -f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1.0,
            -3.0,
            100.0,
            0.1,
            0.3,
            1e-5,
            1e-6,
            1e-7,
            -2.5e-7,
            1.234_567_890_123_456_7e-10,
            1e15,
            1e16,
            1e22,
            1.5e300,
            2.5e-300,
            5e-324,
            -5e-324,
            f64::MAX,
            f64::MIN_POSITIVE,
            9_007_199_254_740_993.0,
            std::f64::consts::FRAC_1_SQRT_2,
        ] {
            check(x);
        }
    }

    /// Exact ties, which zmij and std break differently (zmij writes `…767.2`, std `…767.3`): written by
    /// `toml_writer` itself.
    #[test]
    fn ties_are_written_as_std_writes_them() {
        for x in [1_464_091_487_118_767.3, 121_405_252_038_058.63, -1_052_730_259_603_333.3, 74_426_468_191_001.63] {
            assert!(short_exact(x), "{x}");
            check(x);
        }
    }

    #[test]
    fn random_bits_and_reflectance_like_values_are_written_as_std_writes_them() {
        let mut s: u64 = 0x9E37_79B9_7F4A_7C15;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            s
        };
        for _ in 0..200_000 {
            let bits = next();
            check(f64::from_bits(bits));
            let u = (next() >> 11) as f64 / (1u64 << 53) as f64;
            check(u);
            check(u * 10f64.powi((next() % 40) as i32 - 20));
            check((next() % 2_000_000) as f64 / 1000.0);
            check((next() % (1u64 << 60)) as f64);
        }
        for e in -330..310 {
            for m in 1..10 {
                check(m as f64 * 10f64.powi(e));
            }
        }
        for e in -1074..1024 {
            let p = 2f64.powi(e);
            for x in [p, f64::from_bits(p.to_bits() - 1), f64::from_bits(p.to_bits() + 1)] {
                check(x);
                check(-x);
            }
        }
        for k in 1..120 {
            for m in (1..4000u64).step_by(7) {
                let x = m as f64 * 2f64.powi(-k);
                check(x);
                check(x * 1e10);
            }
        }
    }
}
