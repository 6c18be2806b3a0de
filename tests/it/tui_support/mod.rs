//! Shared helpers of the designer's tests: a palette built in code and a replay runner.

use metamer::colorimetry::{Colorimetry, hex_to_linear};
use metamer::palette::{ColourCell, FreeGroup, Kind, Palette, Settings, Source, SpectrumEntry, TargetNotation};
use metamer::spectrum::{Normalize, Spectrum};
use metamer::tui::State;
use metamer::tui::colour::ColourMode;
use metamer::tui::replay::{self, MemorySaver};
use metamer::tui::worker::{BasisMode, WorkerConfig};
use nalgebra::Vector3;
use std::path::PathBuf;
use std::time::Duration;

fn light(name: &str, source: Source, design: bool) -> SpectrumEntry {
    let c = Colorimetry::default();
    let raw = match &source {
        Source::Illuminant(n) => Spectrum::illuminant(n).expect("built-in illuminant"),
        Source::Planck(t) => Spectrum::planck(*t).expect("positive temperature"),
        Source::Flat(v) => Spectrum::flat(*v),
        _ => unreachable!("test lights are built-in"),
    };
    let spectrum = raw.normalized(Normalize::Luminance, &c.luminance()).expect("normalisable");
    SpectrumEntry { design, ..SpectrumEntry::resolved(name, Kind::Light, source, Normalize::Luminance, spectrum) }
}

fn reflectance(name: &str, source: Source, design: bool) -> SpectrumEntry {
    let spectrum = match &source {
        Source::ColorChecker(n) => Spectrum::colorchecker(n).expect("built-in patch"),
        Source::Flat(v) => Spectrum::flat(*v),
        _ => unreachable!("test reflectances are built-in"),
    };
    SpectrumEntry { design, ..SpectrumEntry::resolved(name, Kind::Reflectance, source, Normalize::None, spectrum) }
}

fn cell(light: usize, reflectance: usize, hex: &str, free: Option<usize>) -> ColourCell {
    ColourCell {
        light,
        reflectance,
        target: hex_to_linear(hex).expect("valid hex"),
        notation: TargetNotation::Hex,
        weight: 1.0,
        free,
        enabled: true,
    }
}

/// A 3-light × 3-reflectance metamer palette: two designed reflectances (no designed light, so the solve
/// is linear and fast), one free group, one cell out of use.
pub fn demo_palette() -> Palette {
    let settings = Settings {
        reflectance_bounds: metamer::palette::Bounds::new(0.0, 1.0),
        light_bounds: metamer::palette::Bounds::new(0.0, f64::INFINITY),
        ..Settings::default()
    };
    let mut off = cell(2, 2, "#808080", None);
    off.enabled = false;
    Palette {
        name: "demo".into(),
        settings,
        lights: vec![
            light("daylight", Source::Illuminant("D65".into()), false),
            light("tungsten", Source::Illuminant("A".into()), false),
            light("split", Source::Planck(9000.0), false),
        ],
        reflectances: vec![
            reflectance("skin", Source::ColorChecker("dark_skin".into()), false),
            reflectance("block", Source::Flat(0.5), true),
            reflectance("tissue", Source::Flat(0.3), true),
        ],
        colours: vec![
            cell(0, 1, "#6a7b5c", None),
            cell(1, 1, "#6a7b5c", None),
            cell(0, 2, "#6a7b5c", None),
            cell(1, 2, "#a03020", Some(0)),
            cell(2, 1, "#a03020", Some(0)),
            off,
        ],
        free: vec![FreeGroup { name: "A".into(), lower: Vector3::repeat(0.02), upper: Vector3::repeat(0.8) }],
        mixtures: Vec::new(),
        paths: Vec::new(),
    }
}

/// An n-light × n-reflectance palette of built-in spectra, half the reflectances designed within [0, 1]
/// (for scrolling and size checks, and the bench).
pub fn square_palette(n: usize) -> Palette {
    let illuminants: Vec<&str> = Spectrum::illuminant_names().collect();
    let patches: Vec<&str> = Spectrum::colorchecker_names().collect();
    // Bounds keep the objective well away from zero, so screens show no rounding noise.
    let settings = Settings { reflectance_bounds: metamer::palette::Bounds::new(0.0, 1.0), ..Settings::default() };
    let mut p = Palette { name: format!("{n}x{n}"), settings, ..Palette::default() };
    for k in 0..n {
        let ill = illuminants[k % illuminants.len()];
        p.lights.push(light(&format!("{ill}_{k}"), Source::Illuminant(ill.into()), false));
        let patch = patches[k % patches.len()];
        p.reflectances.push(reflectance(patch, Source::ColorChecker(patch.into()), k % 2 == 0));
    }
    for i in 0..n {
        for j in 0..n {
            if (i + j) % 3 == 0 {
                p.colours.push(cell(j, i, "#7f6050", None));
            }
        }
    }
    p
}

/// A designer on `palette` named `palettes/demo.toml`.
pub fn state(palette: Palette, mode: ColourMode) -> State {
    State::new(PathBuf::from("palettes/demo.toml"), palette, mode)
}

/// Replay `script` on `state` at `width`×`height`; the final screen as text and buffer.
pub fn replay(state: &mut State, script: &str, width: u16, height: u16) -> (String, ratatui::buffer::Buffer) {
    replay_saving(state, script, width, height, &mut MemorySaver::default())
}

/// Like [`replay`], saving into `saver`.
pub fn replay_saving(
    state: &mut State,
    script: &str,
    width: u16,
    height: u16,
    saver: &mut MemorySaver,
) -> (String, ratatui::buffer::Buffer) {
    replay_with(state, script, width, height, saver, BasisMode::Off)
}

/// Like [`replay_saving`], training the basis as `basis` says.
pub fn replay_with(
    state: &mut State,
    script: &str,
    width: u16,
    height: u16,
    saver: &mut MemorySaver,
    basis: BasisMode,
) -> (String, ratatui::buffer::Buffer) {
    let steps = replay::parse_script(script).expect("valid script");
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis };
    let (frames, buf) = replay::run(state, steps, width, height, false, saver, worker).expect("replay runs");
    (frames.last().cloned().unwrap_or_default(), buf)
}

/// Run the designer's loop live (not synchronously) on `msgs`, all sent on its channel at the start as
/// an input thread would; returns the label of every message the loop took, in order.
pub fn run_live(
    state: &mut State,
    msgs: Vec<metamer::tui::msg::Msg>,
    saver: &mut dyn metamer::tui::event_loop::Saver,
) -> Vec<String> {
    use metamer::tui::event_loop::{self, ChannelEvents, Io};
    let mut terminal = ratatui::Terminal::new(ratatui::backend::TestBackend::new(100, 30)).expect("terminal");
    let mut events = ChannelEvents(msgs);
    let mut taken = Vec::new();
    let mut on_msg = |m: &metamer::tui::msg::Msg| taken.push(m.label());
    let worker = WorkerConfig { time_limit: Duration::from_secs(30), basis: BasisMode::Off };
    let io = Io { events: &mut events, saver, on_frame: None, on_msg: Some(&mut on_msg), worker, tick: None };
    event_loop::run_main_loop(&mut terminal, state, io).expect("the loop runs");
    taken
}

/// The key events of `script` (a replay script) as messages.
pub fn keys(script: &str) -> Vec<metamer::tui::msg::Msg> {
    replay::parse_script(script)
        .expect("valid script")
        .steps()
        .map(|s| match s {
            replay::Step::Key(k) => metamer::tui::msg::Msg::Key(k),
            replay::Step::WaitSolve => metamer::tui::msg::Msg::WaitSolve,
            replay::Step::Mouse(m) => metamer::tui::msg::Msg::Mouse(m),
        })
        .collect()
}
