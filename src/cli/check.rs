//! `metamer check PALETTE...`: validate palette files and print each design matrix — lights as columns
//! (each on flat white across the top), reflectances as rows (each under a flat white light down the side),
//! every cell's current colour and its target — with truecolor swatches when stdout is a terminal.

use crate::colorimetry::{Colorimetry, linear_to_hex};
use crate::palette::PaletteFile;
use crate::palette::{Palette, Source, SpectrumEntry};
use crate::spectrum::Spectrum;
use anyhow::bail;
use clap::ColorChoice;
use nalgebra::Vector3;
use std::fmt::Write as _;
use std::io::IsTerminal;
use std::path::PathBuf;

#[derive(Debug, clap::Args)]
#[command(
    about = "Validate palettes and print their design matrices",
    long_about = "Validate palette files (docs/formats/palette.md) and print each design matrix: lights as columns (each \
                  light on a flat white reflectance across the top), reflectances as rows (each under a flat white \
                  light down the side), and in every cell the colour the current spectra produce with its target \
                  below it. Exits non-zero when any file is invalid, after printing why.",
    after_help = "Swatches use 24-bit colour when stdout is a terminal; with NO_COLOR set or output to a file or pipe \
                  only the hex values are printed."
)]
pub struct Args {
    /// Palette files to check.
    #[arg(required = true, value_name = "PALETTE")]
    pub palettes: Vec<PathBuf>,
    /// When to print colour swatches (auto: when stdout is a terminal and NO_COLOR is not set).
    #[arg(long, value_enum, default_value_t = ColorChoice::Auto, value_name = "WHEN")]
    pub(crate) color: ColorChoice,
}

/// Whether to print truecolor swatches for `--color` (clap's own auto / always / never).
fn swatches(choice: ColorChoice) -> bool {
    match choice {
        ColorChoice::Always => true,
        ColorChoice::Never => false,
        ColorChoice::Auto => {
            std::io::stdout().is_terminal() && std::env::var_os("NO_COLOR").is_none_or(|v| v.is_empty())
        }
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    let colour = swatches(args.color);
    let colorimetry = Colorimetry::default();
    let mut failed = Vec::new();
    let mut printed = false;
    for path in &args.palettes {
        match PaletteFile::load(path) {
            Ok(file) => {
                if printed {
                    super::out::println("")?;
                }
                printed = true;
                for w in &file.warnings {
                    eprintln!("warning: {}", crate::fsio::escape_lines(w));
                }
                let matrix = render_matrix(&file.palette, &colorimetry, colour);
                super::out::print(&format!("{matrix}ok: {}: {}\n", crate::fsio::show(path), summary(&file.palette)))?;
            }
            Err(e) => {
                eprintln!("error: {}", crate::fsio::escape_lines(&e.to_string()));
                failed.push(path.display().to_string());
            }
        }
    }
    match failed.len() {
        0 => Ok(()),
        1 if args.palettes.len() == 1 => bail!("{} is not a valid palette", failed[0]),
        n => bail!("{n} of {} palettes are invalid: {}", args.palettes.len(), failed.join(", ")),
    }
}

/// One line describing a palette's size.
pub(crate) fn summary(p: &Palette) -> String {
    let designed = |es: &[SpectrumEntry]| es.iter().filter(|e| e.design).count();
    let in_groups = p.colours.iter().filter(|c| c.free.is_some()).count();
    let off = p.colours.iter().filter(|c| !c.enabled).count();
    format!(
        "\"{}\": {} ({} designed), {} ({} designed), {} ({} in free groups, {} off), {}; m = {}, \
         smoothness = {}, subspace_error = {}",
        crate::fsio::escape(&p.name),
        count(p.lights.len(), "light"),
        designed(&p.lights),
        count(p.reflectances.len(), "reflectance"),
        designed(&p.reflectances),
        count(p.colours.len(), "colour cell"),
        in_groups,
        off,
        count(p.free.len(), "free group"),
        p.settings.basis_dimension,
        p.settings.smoothness,
        p.settings.subspace_error,
    )
}

fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

/// Visible width of the light columns and of the name column.
const COLUMN: usize = 22;
const SIDE: usize = 28;

/// A piece of a table cell: text with its visible width (escape codes take no room).
struct Cell {
    text: String,
    width: usize,
}

impl Cell {
    fn new() -> Cell {
        Cell { text: String::new(), width: 0 }
    }

    fn push(&mut self, s: &str) -> &mut Cell {
        self.text.push_str(s);
        self.width += s.chars().count();
        self
    }

    /// A two-column swatch (background colour) when colour is on; nothing otherwise.
    fn swatch(&mut self, rgb: &Vector3<f64>, colour: bool) -> &mut Cell {
        if colour {
            let [r, g, b] = crate::colorimetry::linear_to_srgb8(rgb);
            let _ = write!(self.text, "\x1b[48;2;{r};{g};{b}m  \x1b[0m ");
            self.width += 3;
        }
        self
    }

    /// Swatch, hex value, and `!` when the colour lies outside the display gamut (clamped for showing).
    fn colour(&mut self, rgb: &Vector3<f64>, colour: bool) -> &mut Cell {
        self.swatch(rgb, colour);
        self.push(&linear_to_hex(rgb));
        let outside = rgb.iter().any(|v| !(-1e-9..=1.0 + 1e-9).contains(v));
        self.push(if outside { "!" } else { " " })
    }

    fn padded(&self, width: usize) -> String {
        format!("{}{}", self.text, " ".repeat(width.saturating_sub(self.width)))
    }
}

fn truncate(s: &str, width: usize) -> String {
    if s.chars().count() <= width {
        s.to_string()
    } else {
        let mut t: String = s.chars().take(width.saturating_sub(1)).collect();
        t.push('…');
        t
    }
}

fn source_label(e: &SpectrumEntry) -> String {
    match &e.source {
        Source::Illuminant(n) => n.clone(),
        Source::ColorChecker(n) => n.clone(),
        Source::Planck(k) => format!("planck {k} K"),
        Source::Flat(v) => format!("flat {v}"),
        Source::Samples(_) => "samples".to_string(),
        Source::Csv(p) => format!("csv {p}"),
    }
}

fn name_label(e: &SpectrumEntry) -> String {
    format!("{}{}", crate::fsio::escape(&e.name), if e.design { " *" } else { "" })
}

/// The design matrix of a palette as text (with ANSI truecolor swatches when `colour`).
pub(crate) fn render_matrix(p: &Palette, colorimetry: &Colorimetry, colour: bool) -> String {
    let white = Spectrum::flat(1.0);
    let mut out = String::new();
    let row = |out: &mut String, side: Cell, cells: Vec<Cell>| {
        let mut line = side.padded(SIDE);
        for c in &cells {
            line.push_str("│ ");
            line.push_str(&c.padded(COLUMN - 2));
        }
        out.push_str(line.trim_end());
        out.push('\n');
    };
    // Header: light names, their sources, and each light on flat white.
    let header = |f: &dyn Fn(&SpectrumEntry) -> String| {
        p.lights
            .iter()
            .map(|e| {
                let mut c = Cell::new();
                c.push(&truncate(&f(e), COLUMN - 3));
                c
            })
            .collect::<Vec<_>>()
    };
    let mut title = Cell::new();
    title.push("lights →");
    row(&mut out, title, header(&name_label));
    let mut sub = Cell::new();
    sub.push("reflectances ↓");
    row(&mut out, sub, header(&source_label));
    let mut on_white = Cell::new();
    on_white.push("(on flat white)");
    let light_colours = p
        .lights
        .iter()
        .map(|e| {
            let mut c = Cell::new();
            // A light on white is as bright as Y = 1 and often beyond the gamut in one channel:
            // shown scaled to its brightest channel, so the hue is what the swatch tells.
            let rgb = colorimetry.rgb(&e.spectrum, &white);
            let peak = rgb.max();
            c.colour(&if peak > 0.0 { rgb / peak } else { rgb }, colour);
            c
        })
        .collect();
    row(&mut out, on_white, light_colours);
    out.push_str(&"─".repeat(SIDE));
    for _ in &p.lights {
        out.push_str(&format!("┼{}", "─".repeat(COLUMN - 1)));
    }
    out.push('\n');

    // The cells by place (reflectance, light) and which reflectances have any: one pass over the cells (a
    // palette names each place once), not a search of them for every entry of the matrix, which was
    // quadratic in a batch's size (`check` of 1200 reflectances under 3 lights took 23 ms, now 14).
    let lights = p.lights.len();
    let mut by_place: Vec<Option<&crate::palette::ColourCell>> = vec![None; lights * p.reflectances.len()];
    let mut has_cells = vec![false; p.reflectances.len()];
    for cell in &p.colours {
        if let Some(any) = has_cells.get_mut(cell.reflectance) {
            *any = true;
            if cell.light < lights {
                by_place[cell.reflectance * lights + cell.light].get_or_insert(cell);
            }
        }
    }
    for (r, refl) in p.reflectances.iter().enumerate() {
        // Line 1: name, the reflectance under flat white, and every cell's current colour.
        let mut side = Cell::new();
        let name = truncate(&name_label(refl), SIDE - 13);
        side.push(&format!("{name:<width$}", width = SIDE - 12));
        side.colour(&colorimetry.rgb(&white, &refl.spectrum), colour);
        let current = (0..p.lights.len())
            .map(|l| {
                let mut c = Cell::new();
                c.colour(&colorimetry.rgb(&p.lights[l].spectrum, &refl.spectrum), colour);
                c
            })
            .collect();
        row(&mut out, side, current);
        // Line 2: the target of every cell that has one, with its free group, weight and state.
        if has_cells[r] {
            let targets = (0..lights)
                .map(|l| {
                    let mut c = Cell::new();
                    let Some(cell) = by_place[r * lights + l] else { return c };
                    c.push("→ ");
                    match cell.free.and_then(|g| p.free.get(g)) {
                        Some(g) => {
                            c.push(&format!("free {}", truncate(&crate::fsio::escape(&g.name), 6)));
                        }
                        None => {
                            c.colour(&cell.target, colour);
                        }
                    }
                    if !cell.enabled {
                        c.push(" off");
                    } else if cell.weight != 1.0 {
                        c.push(&format!(" w{}", cell.weight));
                    }
                    if !p.lights[l].design && !refl.design {
                        c.push(" =");
                    }
                    c
                })
                .collect();
            let mut side = Cell::new();
            side.push("  target");
            row(&mut out, side, targets);
        }
    }
    out.push_str(
        "* designed   → target   free G: free-colour group G   off: not in use   wN: weight N\n\
         !: outside the sRGB gamut (shown clamped)   =: both sides fixed, nothing to design\n\
         lights on flat white are shown scaled to their brightest channel\n",
    );
    for g in &p.free {
        let side = |v: &Vector3<f64>| format!("[{}, {}, {}]", v[0], v[1], v[2]);
        let _ = writeln!(
            out,
            "free group {}: linear sRGB from {} to {}",
            crate::fsio::escape(&g.name),
            side(&g.lower),
            side(&g.upper)
        );
    }
    let designed_lights = p.lights.iter().filter(|e| e.design).count();
    let designed_refl = p.reflectances.iter().filter(|e| e.design).count();
    if designed_lights + designed_refl == 0 {
        out.push_str("note: no spectrum is marked `design = true`, so there is nothing to design\n");
    }
    out
}
