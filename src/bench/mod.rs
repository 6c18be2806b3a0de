//! The benchmark suite behind `metamer bench`: timing statistics, Markdown tables and PNG plots shared by
//! the solver, basis and renderer benchmarks. Not a domain module: it may use anything in the crate.

pub mod basis;
pub mod plot;
pub mod render;
pub mod report;
pub mod solve;
pub mod summary;

use std::path::Path;
use std::time::Instant;

/// The line every Markdown file of the benchmark ends with, so a later run knows the file is its own.
pub const MD_MARK: &str = "<!-- written by `metamer bench`: the next run replaces this file -->";
/// The text chunk every PNG plot of the benchmark carries (`Software` = `metamer bench`), for the same.
const PNG_KEY: &str = "Software";
const PNG_VALUE: &str = "metamer bench";

/// `bench --force`: write through what the writer otherwise refuses (see [`write_own`]).
static FORCE: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Set by `bench --force` before the suites run.
pub(crate) fn set_force(force: bool) {
    FORCE.store(force, std::sync::atomic::Ordering::Relaxed);
}

fn replace() -> crate::fsio::Replace {
    if FORCE.load(std::sync::atomic::Ordering::Relaxed) {
        crate::fsio::Replace::Force
    } else {
        crate::fsio::Replace::Writable
    }
}

/// Write one of the benchmark's own files into the output folder: a name the benchmark chose, so a
/// symbolic link there is refused without `--force` ([`crate::fsio::write_chosen`]), and marked as the
/// benchmark's ([`MD_MARK`], a PNG text chunk) so the next run may replace it ([`is_own`]).
pub(crate) fn write_own(path: &Path, bytes: &[u8]) -> Result<(), crate::fsio::FsError> {
    let marked: Vec<u8>;
    let bytes = if path.extension().is_some_and(|e| e == "png") {
        marked = mark_png(bytes);
        &marked
    } else if path.extension().is_some_and(|e| e == "md") && !contains(bytes, MD_MARK.as_bytes()) {
        let mut text = bytes.to_vec();
        if !text.ends_with(b"\n") {
            text.push(b'\n');
        }
        text.extend_from_slice(format!("\n{MD_MARK}\n").as_bytes());
        marked = text;
        &marked
    } else {
        bytes
    };
    crate::fsio::write_chosen(path, bytes, replace())
}

/// Did the benchmark write the file at `path` (its Markdown mark or its PNG text chunk)? A file that cannot
/// be read is not its own.
pub(crate) fn is_own(path: &Path) -> bool {
    let Ok(bytes) = crate::fsio::read(path, crate::fsio::Kind::Text) else { return false };
    if bytes.starts_with(PNG_SIGNATURE) {
        return png_text_chunk(&bytes).is_some_and(|(k, v)| k == PNG_KEY.as_bytes() && v == PNG_VALUE.as_bytes());
    }
    contains(&bytes, MD_MARK.as_bytes())
}

fn contains(hay: &[u8], needle: &[u8]) -> bool {
    hay.windows(needle.len()).any(|w| w == needle)
}

const PNG_SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";

/// `png` with a `tEXt` chunk `Software` = `metamer bench` right after its header chunk (IHDR, which the
/// format requires first). Bytes that are not a PNG are returned as they are.
fn mark_png(png: &[u8]) -> Vec<u8> {
    // Signature (8), then IHDR: length (4), type (4), 13 bytes, CRC (4).
    const AFTER_IHDR: usize = 8 + 4 + 4 + 13 + 4;
    if !png.starts_with(PNG_SIGNATURE) || png.len() < AFTER_IHDR || &png[12..16] != b"IHDR" {
        return png.to_vec();
    }
    let mut body = b"tEXt".to_vec();
    body.extend_from_slice(PNG_KEY.as_bytes());
    body.push(0);
    body.extend_from_slice(PNG_VALUE.as_bytes());
    let mut out = Vec::with_capacity(png.len() + body.len() + 8);
    out.extend_from_slice(&png[..AFTER_IHDR]);
    out.extend_from_slice(&((body.len() - 4) as u32).to_be_bytes());
    out.extend_from_slice(&body);
    out.extend_from_slice(&crc32fast::hash(&body).to_be_bytes());
    out.extend_from_slice(&png[AFTER_IHDR..]);
    out
}

/// The first `tEXt` chunk of a PNG after its header, as (keyword, text), when its CRC is right.
fn png_text_chunk(png: &[u8]) -> Option<(&[u8], &[u8])> {
    let mut at = PNG_SIGNATURE.len();
    // Look at the first few chunks only (the mark sits right after IHDR).
    for _ in 0..4 {
        let len = u32::from_be_bytes(png.get(at..at + 4)?.try_into().ok()?) as usize;
        let body = png.get(at + 4..at + 8 + len)?;
        let crc = u32::from_be_bytes(png.get(at + 8 + len..at + 12 + len)?.try_into().ok()?);
        if &body[..4] == b"tEXt" && crc32fast::hash(body) == crc {
            let data = &body[4..];
            let nul = data.iter().position(|&b| b == 0)?;
            return Some((&data[..nul], &data[nul + 1..]));
        }
        at += 12 + len;
    }
    None
}

/// Every file a suite may write into the output folder (`README.md` is the whole report's), so a run
/// can check before it writes anything that none of them is an input.
pub fn output_files(suite: report::Suite) -> &'static [&'static str] {
    match suite {
        report::Suite::Solve => &["solve.md", "solve_scaling.png", "solve_pareto.png"],
        report::Suite::Basis => &["basis.md", "basis_error.png", "basis_cost.png", "basis_pareto.png"],
        report::Suite::Render => {
            &["render.md", "render_pareto.png", "render_raycast.png", "render_relight.png", "render_pareto_quality.png"]
        }
    }
}

/// The whole report's own file in the output folder.
pub const REPORT_FILE: &str = "README.md";

/// Summary of repeated timings (seconds): the median with the spread around it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Timing {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    /// Lower and upper quartile.
    pub q1: f64,
    pub q3: f64,
    pub runs: usize,
}

impl Timing {
    /// Summarise a set of samples (seconds). `None` when there are none.
    pub(crate) fn from_samples(samples: &[f64]) -> Option<Timing> {
        let mut s: Vec<f64> = samples.iter().copied().filter(|v| v.is_finite()).collect();
        if s.is_empty() {
            return None;
        }
        s.sort_by(f64::total_cmp);
        let q = |p: f64| {
            let pos = p * (s.len() - 1) as f64;
            let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
            s[lo] + (s[hi] - s[lo]) * (pos - lo as f64)
        };
        Some(Timing { median: q(0.5), min: s[0], max: s[s.len() - 1], q1: q(0.25), q3: q(0.75), runs: s.len() })
    }

    /// "1.23 ms (1.20–1.31)" — median with the interquartile range.
    pub(crate) fn display(&self) -> String {
        format!("{} ({}–{})", format_seconds(self.median), format_seconds(self.q1), format_seconds(self.q3))
    }
}

/// The `metamer` binary to time as a whole process (the scripts comparing it with scipy and VTK run it): this
/// process when it is `metamer`, else one beside it or one level up (`target/release/deps/…` for cargo's bench
/// harness).
pub(crate) fn metamer_binary() -> Option<std::path::PathBuf> {
    let exe = std::env::current_exe().ok()?;
    let name = format!("metamer{}", std::env::consts::EXE_SUFFIX);
    if exe.file_name().is_some_and(|n| n == name.as_str()) {
        return Some(exe);
    }
    let dir = exe.parent()?;
    [dir.join(&name), dir.parent()?.join(&name)].into_iter().find(|p| p.is_file())
}

/// Time `f` `runs` times (after one warm-up call) and summarise. The closure's result is returned from the
/// last run so the work cannot be optimised away.
pub(crate) fn time_runs<T>(runs: usize, mut f: impl FnMut() -> T) -> (Timing, T) {
    let mut last = f();
    let mut samples = Vec::with_capacity(runs.max(1));
    for _ in 0..runs.max(1) {
        let t = Instant::now();
        last = f();
        samples.push(t.elapsed().as_secs_f64());
    }
    let timing =
        Timing::from_samples(&samples).unwrap_or(Timing { median: 0.0, min: 0.0, max: 0.0, q1: 0.0, q3: 0.0, runs: 0 });
    (timing, last)
}

/// Human-readable seconds with a unit that fits.
pub(crate) fn format_seconds(s: f64) -> String {
    let a = s.abs();
    if a >= 1.0 {
        format!("{s:.3} s")
    } else if a >= 1e-3 {
        format!("{:.3} ms", s * 1e3)
    } else if a >= 1e-6 {
        format!("{:.2} µs", s * 1e6)
    } else {
        format!("{:.1} ns", s * 1e9)
    }
}

/// `v` with `digits` decimals, or "n/a" when it is not finite (tables never show NaN or inf).
pub(crate) fn fixed(v: f64, digits: usize) -> String {
    if v.is_finite() { format!("{v:.digits$}") } else { "n/a".into() }
}

/// A Markdown table.
pub(crate) fn markdown_table(headers: &[&str], rows: &[Vec<String>]) -> String {
    let mut out = String::new();
    out.push_str(&format!("| {} |\n", headers.join(" | ")));
    out.push_str(&format!("|{}|\n", headers.iter().map(|_| "---").collect::<Vec<_>>().join("|")));
    for r in rows {
        out.push_str(&format!("| {} |\n", r.join(" | ")));
    }
    out
}

/// Indices of the points on the Pareto front of (cost, error), both to be minimised, sorted by cost.
pub(crate) fn pareto_front(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> =
        (0..points.len()).filter(|&i| points[i].0.is_finite() && points[i].1.is_finite()).collect();
    idx.sort_by(|&a, &b| points[a].0.total_cmp(&points[b].0).then(points[a].1.total_cmp(&points[b].1)));
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn timing_quartiles() {
        let t = Timing::from_samples(&[5.0, 1.0, 3.0, 2.0, 4.0]).unwrap();
        assert_eq!(t.median, 3.0);
        assert_eq!(t.q1, 2.0);
        assert_eq!(t.q3, 4.0);
        assert_eq!(t.min, 1.0);
        assert!(Timing::from_samples(&[]).is_none());
    }

    #[test]
    fn pareto_front_drops_dominated_points() {
        let pts = [(1.0, 5.0), (2.0, 3.0), (3.0, 4.0), (4.0, 1.0), (0.5, 9.0)];
        assert_eq!(pareto_front(&pts), vec![4, 0, 1, 3]);
    }

    #[test]
    fn table_shape() {
        let t = markdown_table(&["a", "b"], &[vec!["1".into(), "2".into()]]);
        assert_eq!(t, "| a | b |\n|---|---|\n| 1 | 2 |\n");
    }
}
