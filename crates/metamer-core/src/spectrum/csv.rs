//! CSV import of measured spectra sampled at any wavelengths.
//!
//! The file holds two columns, wavelength in nanometres and value, separated by a comma, a semicolon or
//! whitespace. Blank lines and `#` comments (whole-line or trailing) are skipped, and the first data line may
//! be a header (it is one when its first field is not a number). Wavelengths must increase strictly and
//! cover 400–700 nm; the samples are resampled linearly onto [`Grid::STANDARD`].

use super::{Grid, SAMPLES, Samples, Spectrum};
use std::path::{Path, PathBuf};

/// Why a spectrum CSV file cannot be read.
#[derive(Debug, thiserror::Error)]
#[error("{}: {kind}", path.display())]
pub struct SpectrumCsvError {
    /// The file (as given).
    pub path: PathBuf,
    pub(crate) kind: CsvErrorKind,
}

/// The reason a spectrum CSV file was rejected.
#[derive(Debug, thiserror::Error)]
pub enum CsvErrorKind {
    #[error("{}", .0.reason())]
    Io(crate::fsio::FsError),
    #[error("not a text file (invalid UTF-8 at byte {offset})")]
    Binary { offset: usize },
    #[error("the file holds no data lines (expected two columns: wavelength in nm, value)")]
    Empty,
    #[error("line {line}, column {column}: `{text}` is not a number")]
    NotANumber { line: usize, column: usize, text: String },
    #[error("line {line}, column {column}: {what} `{text}` is not finite")]
    NotFinite { line: usize, column: usize, what: &'static str, text: String },
    #[error("line {line}: expected 2 columns (wavelength in nm, value), found {found}")]
    WrongColumns { line: usize, found: usize },
    #[error(
        "line {line}: wavelengths must increase strictly, but {wavelength} nm follows {previous} nm \
         (sort the file by wavelength and remove duplicates)"
    )]
    NotIncreasing { line: usize, previous: f64, wavelength: f64 },
    #[error("the data span {first}–{last} nm but must cover {start}–{end} nm{hint}")]
    DoesNotCover { first: f64, last: f64, start: f64, end: f64, hint: &'static str },
}

/// Read a spectrum CSV file and resample it onto the standard grid.
pub(crate) fn read_spectrum_csv(path: &Path) -> Result<Spectrum, SpectrumCsvError> {
    let wrap = |kind| SpectrumCsvError { path: path.to_path_buf(), kind };
    let bytes = crate::fsio::read(path, crate::fsio::Kind::Csv).map_err(|e| wrap(CsvErrorKind::Io(e)))?;
    parse_spectrum_csv_bytes(&bytes).map_err(wrap)
}

/// Parse the bytes of a spectrum CSV file (see the module documentation).
pub fn parse_spectrum_csv_bytes(bytes: &[u8]) -> Result<Spectrum, CsvErrorKind> {
    let text = std::str::from_utf8(bytes).map_err(|e| CsvErrorKind::Binary { offset: e.valid_up_to() })?;
    if text.contains('\0') {
        return Err(CsvErrorKind::Binary { offset: text.find('\0').unwrap_or(0) });
    }
    parse_spectrum_csv(text)
}

/// Parse the text of a spectrum CSV file (see the module documentation).
pub fn parse_spectrum_csv(text: &str) -> Result<Spectrum, CsvErrorKind> {
    let points = read_points(text)?;
    resample(&points, &Grid::STANDARD)
}

/// One field of a data line: its text and its 1-based character column.
fn fields(line: &str) -> Vec<(usize, &str)> {
    let mut out = Vec::new();
    let mut start = None;
    for (i, c) in line.char_indices() {
        let separator = c == ',' || c == ';' || c.is_whitespace();
        match (separator, start) {
            (true, Some(s)) => {
                out.push((s, &line[s..i]));
                start = None;
            }
            (false, None) => start = Some(i),
            _ => {}
        }
    }
    if let Some(s) = start {
        out.push((s, &line[s..]));
    }
    out.into_iter().map(|(byte, f)| (line[..byte].chars().count() + 1, f)).collect()
}

/// The (wavelength, value) points of the file, checked for numbers, finiteness and strict increase.
fn read_points(text: &str) -> Result<Vec<(f64, f64)>, CsvErrorKind> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut points: Vec<(f64, f64)> = Vec::new();
    let mut seen_data_line = false;
    for (index, raw) in text.lines().enumerate() {
        let line_no = index + 1;
        let line = raw.split('#').next().unwrap_or("");
        let cols = fields(line);
        if cols.is_empty() {
            continue;
        }
        let first_is_number = cols[0].1.parse::<f64>().is_ok();
        if !seen_data_line && !first_is_number {
            // A header line such as `wavelength,value`.
            seen_data_line = true;
            continue;
        }
        seen_data_line = true;
        if cols.len() != 2 {
            return Err(CsvErrorKind::WrongColumns { line: line_no, found: cols.len() });
        }
        let number = |(column, text): (usize, &str), what: &'static str| -> Result<f64, CsvErrorKind> {
            let v = text.parse::<f64>().map_err(|_| CsvErrorKind::NotANumber {
                line: line_no,
                column,
                text: text.to_string(),
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(CsvErrorKind::NotFinite { line: line_no, column, what, text: text.to_string() })
            }
        };
        let wavelength = number(cols[0], "wavelength")?;
        let value = number(cols[1], "value")?;
        if let Some(&(previous, _)) = points.last()
            && wavelength <= previous
        {
            return Err(CsvErrorKind::NotIncreasing { line: line_no, previous, wavelength });
        }
        points.push((wavelength, value));
    }
    if points.is_empty() {
        return Err(CsvErrorKind::Empty);
    }
    Ok(points)
}

/// Linear interpolation of strictly increasing points at every wavelength of `grid`.
fn resample(points: &[(f64, f64)], grid: &Grid) -> Result<Spectrum, CsvErrorKind> {
    let (first, last) = match (points.first(), points.last()) {
        (Some(f), Some(l)) => (f.0, l.0),
        _ => return Err(CsvErrorKind::Empty),
    };
    let (start, end) = (grid.start_nm, grid.end_nm());
    if first > start || last < end {
        let hint = if last < 10.0 { " (wavelengths must be in nanometres, not micrometres)" } else { "" };
        return Err(CsvErrorKind::DoesNotCover { first, last, start, end, hint });
    }
    let mut samples = Samples::zeros();
    let mut k = 0;
    for i in 0..SAMPLES.min(grid.count) {
        let w = grid.wavelength(i);
        // Advance to the segment [k, k+1] holding w; the coverage check guarantees it exists.
        while k + 1 < points.len() && points[k + 1].0 < w {
            k += 1;
        }
        let (w0, v0) = points[k];
        samples[i] = match points.get(k + 1) {
            Some(&(w1, v1)) if w > w0 => v0 + (v1 - v0) * (w - w0) / (w1 - w0),
            _ => v0,
        };
    }
    Ok(Spectrum(samples))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid_csv(f: impl Fn(f64) -> f64, step: f64, from: f64, to: f64) -> String {
        let mut s = String::from("wavelength_nm,value\n");
        let mut w = from;
        while w <= to + 1e-9 {
            s.push_str(&format!("{w},{}\n", f(w)));
            w += step;
        }
        s
    }

    #[test]
    fn linear_data_resamples_exactly() {
        // A linear function is reproduced by linear interpolation up to rounding (tolerance 1e-12).
        let text = grid_csv(|w| 0.001 * w - 0.2, 3.7, 380.0, 720.0);
        let s = parse_spectrum_csv(&text).unwrap();
        for (i, w) in Grid::STANDARD.wavelengths().into_iter().enumerate() {
            assert!((s.0[i] - (0.001 * w - 0.2)).abs() < 1e-12, "at {w} nm");
        }
    }

    #[test]
    fn exact_grid_is_kept() {
        let text = grid_csv(|w| (w / 50.0).sin(), 10.0, 400.0, 700.0);
        let s = parse_spectrum_csv(&text).unwrap();
        for (i, w) in Grid::STANDARD.wavelengths().into_iter().enumerate() {
            assert!((s.0[i] - (w / 50.0).sin()).abs() < 1e-12);
        }
    }

    #[test]
    fn separators_comments_and_header() {
        let text = "# measured\nnm; value\n390;0.5 # trailing\n\n550\t0.7\n710 , 0.9\n";
        let s = parse_spectrum_csv(text).unwrap();
        assert!((s.0[0] - (0.5 + 0.2 * 10.0 / 160.0)).abs() < 1e-12);
        assert!((s.0[15] - 0.7).abs() < 1e-12);
    }

    #[test]
    fn errors_name_line_and_column() {
        let e = parse_spectrum_csv("400,0.1\n500,abc\n700,0.3\n").unwrap_err();
        assert!(matches!(e, CsvErrorKind::NotANumber { line: 2, column: 5, .. }), "{e}");
        let e = parse_spectrum_csv("400,0.1\n600,0.2\n500,0.3\n700,0.1\n").unwrap_err();
        assert!(matches!(e, CsvErrorKind::NotIncreasing { line: 3, .. }), "{e}");
        let e = parse_spectrum_csv("400,0.1\n650,0.2\n").unwrap_err();
        assert!(e.to_string().contains("400–700"), "{e}");
        let e = parse_spectrum_csv("0.4,0.1\n0.7,0.2\n").unwrap_err();
        assert!(e.to_string().contains("nanometres"), "{e}");
        assert!(matches!(parse_spectrum_csv("# nothing\n\n"), Err(CsvErrorKind::Empty)));
        assert!(matches!(parse_spectrum_csv_bytes(&[0xff, 0xfe, 0x00]), Err(CsvErrorKind::Binary { .. })));
        let e = parse_spectrum_csv("400,0.1,3\n").unwrap_err();
        assert!(matches!(e, CsvErrorKind::WrongColumns { line: 1, found: 3 }));
        let e = parse_spectrum_csv("400,inf\n700,1\n").unwrap_err();
        assert!(matches!(e, CsvErrorKind::NotFinite { line: 1, .. }));
    }
}
