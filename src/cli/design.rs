//! `metamer design PALETTE.toml`: the terminal palette designer, or with `--replay` a headless run of a
//! key script that writes the screen as text.

use crate::basis::sidecar_path;
use crate::palette::PaletteFile;
use crate::render::{Scene, builtin_scene};
use crate::tui::colour::ColourMode;
use crate::tui::event_loop::{self, FileSaver, Io};
use crate::tui::graphics::{Graphics, PreviewMode};
use crate::tui::terminal::{TerminalEvents, TerminalGuard};
use crate::tui::worker::{BasisMode, WorkerConfig};
use crate::tui::{State, replay};
use anyhow::{Context, bail};
use std::path::PathBuf;
use std::time::Duration;

const AFTER_HELP: &str = "\
Keys: arrows move, Enter edits the cell's sliders, Tab switches panel, ? lists every key, Esc closes popups,
Ctrl-s saves (atomically, keeping comments and unknown keys), q quits (asking first when unsaved).

Replay scripts (--replay KEYS.txt), one step per line:
  # a comment                  (a line that is exactly # is the # key)
  Down                         a named key: Up Down Left Right Enter Esc Tab BackTab Backspace Delete
                               Home End PageUp PageDown Space Hash F1..F12
  Right *3                     any step repeated 3 times
  Ctrl-s                       with modifiers Ctrl- Alt- Shift-
  q                            a single character is that key
  \"#ff8800\"                    text in double quotes types each character (\\\" and \\\\ escape)
  wait-solve                   wait for the running solve
  click 12 5 / drag 20 5       the left mouse button pressed / moved held / released at column, row
  release 20 5                 (0-based screen cells)
Every solve is waited for after each key, and times are hidden, so screens are reproducible.
A script runs at most 1000000 steps (repeats and typed texts counted); a longer one is refused before it runs.
Ctrl-s in a script saves the palette file for real.";

#[derive(Debug, clap::Args)]
#[command(after_help = AFTER_HELP)]
pub struct Args {
    /// The palette file to design.
    pub input: PathBuf,
    /// Run this key script headless (no terminal needed) instead of opening the designer.
    #[arg(long, value_name = "KEYS.txt")]
    pub(crate) replay: Option<PathBuf>,
    /// With --replay: write the final screen here as text (default: standard output).
    #[arg(long, value_name = "OUT.txt", requires = "replay")]
    pub(crate) screen: Option<PathBuf>,
    /// With --replay: the screen size, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", default_value = "100x30", value_parser = parse_size, requires = "replay")]
    pub(crate) size: (u16, u16),
    /// With --replay: write every frame, not only the last.
    #[arg(long, requires = "replay")]
    pub(crate) every_frame: bool,
    /// Colours: `truecolor` or `256` (default: truecolor when COLORTERM says truecolor or 24bit).
    #[arg(long, value_name = "MODE", value_parser = parse_colours)]
    pub(crate) colours: Option<ColourMode>,
    /// Cap on one solve, in seconds.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0)]
    pub(crate) time_limit: f64,
    /// Do not train the spectral factor basis: no subspace colours (palettes that fit in the subspace then
    /// cannot be solved).
    #[arg(long)]
    pub(crate) no_basis: bool,
    /// Train the basis without reading or writing its sidecar cache (PALETTE.basis.json).
    #[arg(long, conflicts_with = "no_basis")]
    pub(crate) no_basis_cache: bool,
    /// Show a preview of this scene (docs/formats/scene.md; `builtin` = the embedded generated engine), raycast
    /// once at the panel's size and relit live with the designed spectra as the light dial moves (`v`
    /// switches between preview and spectra).
    #[arg(long, value_name = "SCENE.toml")]
    pub(crate) scene: Option<PathBuf>,
    /// With --scene: the volume file to preview, instead of the scene's `volume` key (which is otherwise
    /// looked for beside the scene file, then by file name in the folder named by METAMER_DATA or its
    /// volumes/), as for `metamer render --volume`.
    #[arg(long, value_name = "PATH", requires = "scene")]
    pub(crate) volume: Option<PathBuf>,
    /// How the preview is drawn: `auto` (ask the terminal for kitty / sixel / iTerm2 graphics, else half
    /// blocks), `halfblocks`, `kitty`, `sixel` or `iterm2`. Replays draw half blocks unless told otherwise.
    #[arg(long, value_name = "MODE", default_value = "auto", value_parser = parse_preview)]
    pub(crate) preview: PreviewMode,
}

fn parse_preview(text: &str) -> Result<PreviewMode, String> {
    PreviewMode::parse(text).ok_or(format!("'{text}' is not auto, halfblocks, kitty, sixel or iterm2"))
}

fn parse_size(text: &str) -> Result<(u16, u16), String> {
    let (w, h) = text.split_once(['x', 'X']).ok_or(format!("'{text}' is not WIDTHxHEIGHT"))?;
    let w: u16 = w.trim().parse().map_err(|_| format!("'{w}' is not a width"))?;
    let h: u16 = h.trim().parse().map_err(|_| format!("'{h}' is not a height"))?;
    if !(20..=1000).contains(&w) || !(8..=1000).contains(&h) {
        return Err(format!("{w}x{h} is outside 20x8 … 1000x1000"));
    }
    Ok((w, h))
}

fn parse_colours(text: &str) -> Result<ColourMode, String> {
    match text {
        "truecolor" | "24bit" => Ok(ColourMode::TrueColor),
        "256" => Ok(ColourMode::Indexed256),
        _ => Err(format!("'{text}' is not truecolor or 256")),
    }
}

pub fn run(args: Args) -> anyhow::Result<()> {
    if !(args.time_limit.is_finite() && args.time_limit > 0.0) {
        bail!("--time-limit must be a positive number of seconds, not {}", args.time_limit);
    }
    let file = PaletteFile::load(&args.input)?;
    let colours = args.colours.unwrap_or_else(ColourMode::detect);
    let warnings = file.warnings.join("; ");
    let mut state = State::with_file(file, colours);
    if !warnings.is_empty() {
        state.say(warnings);
    }
    let recovery = crate::tui::event_loop::recovery_path(&args.input);
    if recovery.is_file() {
        state.ui.popup = Some(crate::tui::app::Popup::Recovery { path: recovery });
    }
    // Every file the scene reads (its palette, CSV sources, volume and the volume's data file) is an input.
    let mut scene_reads = Vec::new();
    if let Some(scene) = &args.scene {
        // The scene and its volume are read here; the raycast runs off the UI thread at the panel's size.
        let scene = if scene.as_os_str() == "builtin" {
            if args.volume.is_some() {
                bail!("--volume needs a scene file (it replaces the scene's `volume`), not the built-in scene");
            }
            builtin_scene(160)
        } else {
            let (scene, read) = crate::fsio::record_reads(|| Scene::load_with_volume(scene, args.volume.as_deref()));
            scene_reads = read;
            scene
        };
        state.set_preview_scene(scene.context("--scene")?);
    }
    let mut saver = FileSaver;
    let worker = WorkerConfig {
        time_limit: Duration::try_from_secs_f64(args.time_limit).unwrap_or(Duration::MAX),
        basis: if args.no_basis {
            BasisMode::Off
        } else {
            BasisMode::Train { sidecar: (!args.no_basis_cache).then(|| sidecar_path(&args.input)) }
        },
    };
    match &args.replay {
        Some(script_path) => {
            // The screen must not be the palette, its CSV sources, its sidecar, the scene or the script.
            let mut files = crate::fsio::Outputs::new();
            state.doc.file.record_inputs("palette", &mut files);
            files.input("basis sidecar", &sidecar_path(&args.input)).input("key script", script_path);
            if let Some(scene) = &args.scene {
                files.input("scene", scene);
            }
            files.inputs_read(&scene_reads);
            if let Some(screen) = &args.screen {
                files.output("screen", screen)?;
            }
            let text = crate::fsio::read_to_string(script_path, crate::fsio::Kind::KeyScript)?;
            let steps = replay::parse_script(&text).with_context(|| format!("{}", script_path.display()))?;
            if args.preview != PreviewMode::Auto {
                state.preview.graphics = Graphics::forced(args.preview, (10, 20));
            }
            let (w, h) = args.size;
            let (frames, _) = replay::run(&mut state, steps, w, h, args.every_frame, &mut saver, worker)
                .with_context(|| format!("replaying {}", script_path.display()))?;
            let out = if args.every_frame {
                frames.iter().enumerate().map(|(k, f)| format!("── frame {k} ──\n{f}")).collect::<String>()
            } else {
                frames.concat()
            };
            match &args.screen {
                Some(path) => crate::fsio::write_atomic(path, out.as_bytes()).context("cannot write the screen")?,
                None => super::out::print(&out)?,
            }
            Ok(())
        }
        None => {
            let mut guard = TerminalGuard::enter()
                .context("metamer design needs a terminal (use --replay KEYS.txt for headless runs)")?;
            // The terminal is asked for its graphics once the first screen is drawn, by the input thread.
            let probe = (state.preview.has_scene() && args.preview != PreviewMode::Halfblocks).then_some(args.preview);
            state.preview.probing = probe.is_some();
            let mut events = TerminalEvents::new(probe).context("cannot listen for SIGTERM, SIGHUP and SIGINT")?;
            event_loop::run_main_loop(
                &mut guard.terminal,
                &mut state,
                Io {
                    events: &mut events,
                    saver: &mut saver,
                    on_frame: None,
                    on_msg: None,
                    worker,
                    tick: Some(Duration::from_millis(80)),
                },
            )
            .context("the terminal failed")?;
            // The input thread stops before the terminal is restored (it reads no key meant for the shell).
            drop(events);
            drop(guard);
            match &state.ui.terminated {
                Some(Some(copy)) => bail!("ended by a signal; unsaved work was written to {}", copy.display()),
                Some(None) => bail!("ended by a signal"),
                None => Ok(()),
            }
        }
    }
}
