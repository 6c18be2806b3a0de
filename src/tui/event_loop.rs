//! The event loop, generic over the ratatui backend: the real terminal and the off-screen `TestBackend`
//! (tests, `--replay`) run the same code. Each turn applies finished solves, draws, then waits for one
//! input (a key, a resize, the end of a script) — but never for a solve, unless the input source asks
//! for synchronous solving (replay, for reproducible screens).

use crate::palette::Palette;
use crate::palette::file::PaletteFile;
use crate::tui::app::State;
use crate::tui::preview::{Loaded, MAX_PREVIEW_EDGE, Preview, PreviewLoader};
use crate::tui::update::{self, Effects};
use crate::tui::worker::{Reply, Worker, WorkerConfig};
use crate::tui::{keymap, ui};
use ratatui::Terminal;
use ratatui::backend::Backend;
use ratatui::buffer::Buffer;
use ratatui::crossterm::event::{KeyCode, KeyEvent, KeyModifiers};
use ratatui::layout::Rect;
use std::io;
use std::time::{Duration, Instant};

/// One input to the designer.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Input {
    Key(KeyEvent),
    /// The terminal changed size.
    Resize,
    /// Wait until the running solve has finished (replay scripts).
    WaitSolve,
    /// No more input: stop.
    End,
}

/// Where inputs come from.
pub trait Events {
    /// The next input, waiting at most `timeout`; `None` when nothing came.
    fn next(&mut self, timeout: Duration) -> io::Result<Option<Input>>;
    /// True when every solve must finish before the next input is read and before drawing (replay).
    fn synchronous(&self) -> bool {
        false
    }
}

/// Writes the palette to its file.
pub trait Saver {
    /// Save `palette`; the text says where it went, the error why it failed.
    fn save(&mut self, palette: &Palette) -> Result<String, String>;
}

/// Saves to the palette file through its document, so comments, key order and unknown keys survive
/// (atomically: a temporary file renamed over the old one; see [`PaletteFile::save`]).
#[derive(Debug)]
pub struct FileSaver {
    pub file: PaletteFile,
}

impl Saver for FileSaver {
    fn save(&mut self, palette: &Palette) -> Result<String, String> {
        self.file.save(palette).map_err(|e| e.to_string())?;
        let path = self.file.path.as_ref().map_or("the palette".to_string(), |p| p.display().to_string());
        Ok(format!("saved {path}"))
    }
}

/// What the loop needs besides the terminal and the state.
pub struct Io<'a> {
    pub events: &'a mut dyn Events,
    pub saver: &'a mut dyn Saver,
    /// Called with every drawn frame.
    pub on_frame: Option<&'a mut dyn FnMut(&Buffer)>,
    /// Solve time cap and basis training.
    pub worker: WorkerConfig,
}

fn backend_error(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(e.to_string())
}

/// Apply a worker reply to the state.
fn apply_reply(state: &mut State, reply: Reply, worker: &Worker) {
    state.solve.running = worker.solving();
    state.solve.training = worker.training();
    match reply {
        Reply::Trained(t) => {
            if t.generation < state.solve.basis_generation {
                return;
            }
            state.solve.basis_generation = t.generation;
            match t.result {
                Ok(basis) => {
                    state.basis = Some(basis);
                    state.solve.basis_error = None;
                }
                Err(e) => state.solve.basis_error = Some(e),
            }
        }
        Reply::Solved(s) => {
            if s.generation != state.solve.generation {
                // Stale: a newer palette is being (or will be) solved.
                return;
            }
            if let Some(b) = s.basis {
                state.basis = Some(b);
                state.solve.basis_generation = state.solve.basis_generation.max(s.generation);
            }
            state.solve.last_time = Some(s.elapsed);
            match s.result {
                Ok(solution) => {
                    state.solve.solution = Some((s.generation, solution));
                    state.solve.error = None;
                }
                Err(e) => state.solve.error = Some(e),
            }
        }
    }
    state.refresh();
}

fn submit(state: &mut State, worker: &mut Worker) {
    worker.submit(state.solve.generation, &state.palette);
    state.solve.running = worker.solving();
    state.solve.training = worker.training();
    state.solve.running_for = Duration::ZERO;
}

/// The palette to write: designed spectra replaced by the current solution's (stored as samples, DESIGN_SPEC §3).
pub fn palette_to_save(state: &State) -> Palette {
    let mut palette = state.palette.clone();
    if let Some(solution) = state.solve.current() {
        let solved = |own: &mut Vec<crate::palette::SpectrumEntry>, theirs: &[crate::palette::SpectrumEntry]| {
            for (e, s) in own.iter_mut().zip(theirs) {
                if e.design && e.name == s.name {
                    // Samples, never normalised or scaled again (DESIGN_SPEC §1, §3).
                    *e = s.clone();
                }
            }
        };
        solved(&mut palette.lights, &solution.palette.lights);
        solved(&mut palette.reflectances, &solution.palette.reflectances);
    }
    palette
}

fn run_effects(state: &mut State, effects: Effects, worker: &mut Worker, saver: &mut dyn Saver) {
    if effects.solve {
        submit(state, worker);
    }
    if effects.save {
        let palette = palette_to_save(state);
        match saver.save(&palette) {
            Ok(text) => {
                let solved = state.solve.current().is_some();
                let changed = palette != state.palette;
                state.saved = palette.clone();
                state.palette = palette;
                if changed {
                    // The palette now starts from its solution. Solve it again so the title shows exactly
                    // what the saved file solves to (the same optimum for designs with one side designed;
                    // a joint design may improve a little from its new start). The last solution stays on
                    // screen meanwhile.
                    state.solve.generation += 1;
                    state.refresh();
                    if !effects.quit_after_save {
                        submit(state, worker);
                    }
                }
                if solved {
                    state.say(text);
                } else {
                    state.say(format!("{text} (not solved yet: designed spectra kept as they were)"));
                }
                if effects.quit_after_save {
                    state.quit = true;
                }
            }
            Err(e) => state.complain(format!("not saved: {e}")),
        }
    }
}

/// Take a finished preview raycast into the state.
fn apply_loaded(state: &mut State, loaded: Loaded, loader: &PreviewLoader) {
    let same_scene = state.preview.as_ref().is_some_and(|p| std::sync::Arc::ptr_eq(&p.scene, &loaded.scene));
    match &mut state.preview {
        Some(p) if same_scene => {
            p.set_weights(loaded.weights);
            state.relight();
        }
        _ => {
            let preview = Preview::new(loaded.scene, loaded.model, loaded.weights, &state.colorimetry);
            let show = state.show_preview;
            state.set_preview(preview);
            state.show_preview = show;
        }
    }
    state.preview_loading = loader.pending.map(|((w, h), _)| format!("raycasting {w}×{h} pixels…"));
}

/// Keep the scene preview at the panel's pixel size: take finished raycasts and start one when the scene
/// is new or the panel changed size (synchronous inputs wait for it). True when the screen changed.
fn sync_preview<B: Backend>(
    terminal: &Terminal<B>,
    state: &mut State,
    loader: &mut Option<PreviewLoader>,
    synchronous: bool,
) -> io::Result<bool> {
    if !state.has_scene() {
        return Ok(false);
    }
    let mut changed = false;
    if let Some(l) = loader.as_mut() {
        while let Some(done) = l.reply(Duration::ZERO) {
            apply_loaded(state, done, l);
            changed = true;
        }
    }
    let size = terminal.size().map_err(backend_error)?;
    let Some(areas) = ui::preview_areas(state, Rect::new(0, 0, size.width, size.height)) else {
        return Ok(changed);
    };
    let side = state.graphics.pixels_for(areas.image, MAX_PREVIEW_EDGE).max(2);
    let want = (side, side);
    let have = state.preview.as_ref().map(Preview::size);
    let pending = loader.as_ref().and_then(|l| l.pending.map(|p| p.0));
    if have != Some(want) && pending != Some(want) {
        let scene = state.preview.as_ref().map(|p| p.scene.clone()).or_else(|| state.preview_scene.clone());
        if let Some(scene) = scene {
            if loader.is_none() {
                *loader = Some(PreviewLoader::start()?);
            }
            if let Some(l) = loader.as_mut() {
                let model = state.preview.as_ref().map(|p| p.model.clone());
                l.submit(scene, model, want, &state.colorimetry);
                state.preview_loading = Some(format!("raycasting {side}×{side} pixels…"));
                changed = true;
            }
        }
    }
    if synchronous && let Some(l) = loader.as_mut() {
        while l.pending.is_some() {
            match l.reply(Duration::from_secs(3600)) {
                Some(done) => apply_loaded(state, done, l),
                None => break,
            }
        }
    }
    Ok(changed)
}

/// Run the designer until it quits or the input ends.
pub fn run_main_loop<B: Backend>(terminal: &mut Terminal<B>, state: &mut State, io: Io<'_>) -> io::Result<()> {
    let Io { events, saver, mut on_frame, worker } = io;
    let mut worker = Worker::start(worker)?;
    submit(state, &mut worker);
    let mut solve_started = Instant::now();
    let mut redraw = true;
    let mut loader: Option<PreviewLoader> = None;
    loop {
        redraw |= sync_preview(terminal, state, &mut loader, events.synchronous())?;
        if events.synchronous() {
            while worker.busy() {
                match worker.wait_reply(Duration::from_secs(3600)) {
                    Some(reply) => apply_reply(state, reply, &worker),
                    None => break,
                }
            }
        }
        while let Some(reply) = worker.try_reply() {
            apply_reply(state, reply, &worker);
            redraw = true;
        }
        if state.solve.running.is_some() || state.solve.training {
            state.solve.running_for = solve_started.elapsed();
        }
        if redraw {
            let frame = terminal.draw(|f| f.render_widget(&*state, f.area())).map_err(backend_error)?;
            if let Some(cb) = on_frame.as_mut() {
                cb(frame.buffer);
            }
            redraw = false;
        }
        if state.quit {
            return Ok(());
        }
        let loading = loader.as_ref().is_some_and(|l| l.pending.is_some());
        let timeout = if worker.busy() || loading { Duration::from_millis(80) } else { Duration::from_millis(500) };
        match events.next(timeout)? {
            None => {
                if worker.busy() || loading {
                    state.ticks += 1;
                    redraw = true;
                }
            }
            Some(Input::End) => return Ok(()),
            Some(Input::Resize) => {
                terminal.autoresize().map_err(backend_error)?;
                terminal.clear().map_err(backend_error)?;
                redraw = true;
            }
            Some(Input::WaitSolve) => {
                while worker.busy() {
                    match worker.wait_reply(Duration::from_secs(3600)) {
                        Some(reply) => apply_reply(state, reply, &worker),
                        None => break,
                    }
                }
                redraw = true;
            }
            Some(Input::Key(key)) => {
                redraw = true;
                // Esc followed at once by a key reaches us as Alt+key (the terminal cannot tell them
                // apart); nothing is bound to Alt, so take it as Esc, then the key.
                let keys = match keymap::action_for(state, key) {
                    None if key.modifiers.contains(KeyModifiers::ALT) => {
                        let mut plain = key;
                        plain.modifiers.remove(KeyModifiers::ALT);
                        vec![KeyEvent::new(KeyCode::Esc, KeyModifiers::NONE), plain]
                    }
                    _ => vec![key],
                };
                for key in keys {
                    if let Some(action) = keymap::action_for(state, key) {
                        let effects = update::update(state, action);
                        if effects.solve {
                            solve_started = Instant::now();
                        }
                        run_effects(state, effects, &mut worker, saver);
                    }
                }
            }
        }
    }
}

/// The screen of a buffer as text (re-exported for callers of the loop).
pub fn screen_text(buf: &Buffer) -> String {
    ui::buffer_text(buf)
}
