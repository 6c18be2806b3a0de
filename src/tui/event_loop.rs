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
    /// The process was told to end (SIGTERM, SIGHUP): write a recovery copy of unsaved work and stop.
    Terminated,
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
    /// Write `palette` as a recovery copy beside the file (on SIGTERM/SIGHUP with unsaved changes);
    /// returns where it went.
    fn recover(&mut self, _palette: &Palette) -> Result<std::path::PathBuf, String> {
        Err("no file to write a recovery copy beside".into())
    }
    /// Read the file again; returns its palette.
    fn reload(&mut self) -> Result<Palette, String> {
        Err("there is no file to reload".into())
    }
}

/// Where the designer's version goes when the file changed on disk: `NAME.mine.toml` beside it.
pub fn mine_path(palette_path: &std::path::Path) -> std::path::PathBuf {
    let name = palette_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    palette_path.with_file_name(format!("{name}.mine.toml"))
}

/// Where the recovery copy of `palette_path` is written: `NAME.recovery.toml` beside it.
pub fn recovery_path(palette_path: &std::path::Path) -> std::path::PathBuf {
    let name = palette_path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    palette_path.with_file_name(format!("{name}.recovery.toml"))
}

/// Saves to the palette file through its document, so comments, key order and unknown keys survive
/// (atomically: a temporary file renamed over the old one; see [`PaletteFile::save`]).
///
/// When another program changed the file since it was opened or last saved, a save does not overwrite it:
/// the designer's version is saved as `NAME.mine.toml` beside it, and the user chooses: Ctrl-s again
/// overwrites the file, Ctrl-r reloads it.
#[derive(Debug)]
pub struct FileSaver {
    pub file: PaletteFile,
    /// The outside change was shown and the user may now overwrite it (the next save does).
    overwrite_armed: bool,
}

impl FileSaver {
    pub fn new(file: PaletteFile) -> FileSaver {
        FileSaver { file, overwrite_armed: false }
    }
}

impl Saver for FileSaver {
    fn save(&mut self, palette: &Palette) -> Result<String, String> {
        if !std::mem::take(&mut self.overwrite_armed) && self.file.changed_on_disk() {
            let path = self.file.path.clone().unwrap_or_default();
            let mine = mine_path(&path);
            let mut copy = self.file.clone();
            let kept = match copy.save_as(palette, &mine) {
                Ok(()) => format!("your version is saved as {}", mine.display()),
                Err(e) => format!("your version could not be saved aside ({e})"),
            };
            self.overwrite_armed = true;
            return Err(format!(
                "{} changed on disk since it was opened; {kept}. Ctrl-s again overwrites the file, Ctrl-r \
                 reloads it",
                path.display()
            ));
        }
        self.file.save(palette).map_err(|e| e.to_string())?;
        let path = self.file.path.as_ref().map_or("the palette".to_string(), |p| p.display().to_string());
        Ok(format!("saved {path}"))
    }

    fn recover(&mut self, palette: &Palette) -> Result<std::path::PathBuf, String> {
        let path = self.file.path.as_deref().ok_or("the palette has no file")?;
        let target = recovery_path(path);
        // A copy of the file's document, so comments and unknown keys are in the recovery copy too; the
        // palette file itself is not touched.
        let mut copy = self.file.clone();
        copy.save_as(palette, &target).map_err(|e| e.to_string())?;
        Ok(target)
    }

    fn reload(&mut self) -> Result<Palette, String> {
        let path = self.file.path.clone().ok_or("the palette has no file")?;
        self.file = PaletteFile::load(&path).map_err(|e| e.to_string())?;
        self.overwrite_armed = false;
        Ok(self.file.palette.clone())
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
fn apply_reply(state: &mut State, reply: Reply, worker: &mut Worker) {
    state.solve.running = worker.solving();
    state.solve.training = worker.training();
    match reply {
        Reply::Trained(t) => {
            if state.derived.basis_key.as_deref() != Some(t.key.as_str()) {
                // For spectra no longer shown (it stays in the basis memory if they come back).
                ensure_basis(state, worker);
                return;
            }
            state.solve.basis_generation = t.generation;
            match t.result {
                Ok(resolved) => {
                    state.solve.basis_poor = poor_mean(&resolved);
                    state.basis = Some((t.key, resolved));
                    state.solve.basis_error = None;
                }
                Err(e) => {
                    state.solve.basis_error = Some(e);
                    state.solve.basis_poor = None;
                }
            }
        }
        Reply::Solved(s) => {
            if s.generation != state.solve.generation {
                // Stale: a newer palette is being (or will be) solved.
                return;
            }
            state.solve.last_time = Some(s.elapsed);
            if let Some((cell, result)) = s.feasibility {
                state.feasibility = Some(crate::tui::app::FeasibilityView { generation: s.generation, cell, result });
            }
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
    ensure_basis(state, worker);
}

/// The factor model's mean ΔE00 when it is poor on its own spectra.
fn poor_mean(resolved: &crate::basis::policy::Resolved) -> Option<f64> {
    resolved.1.poor_model().map(|_| resolved.1.accuracy.factor_model.mean)
}

/// Have the basis of the spectra the matrix shows: at once from the basis memory, else asked of the worker
/// (the V7 half shows "updating" meanwhile). Nothing is asked while a solve of a palette with designed
/// spectra is under way (the shown spectra are about to change), nor for spectra whose basis is at hand.
fn ensure_basis(state: &mut State, worker: &mut Worker) {
    let Some(key) = state.derived.basis_key.clone() else { return };
    if state.basis.as_ref().is_some_and(|(k, _)| *k == key) {
        return;
    }
    if !worker.trains_bases() {
        state.solve.basis_error = Some("basis training is off".into());
        return;
    }
    if let Some(hit) = crate::basis::policy::cached(&key) {
        state.solve.basis_poor = poor_mean(&hit);
        state.basis = Some((key, hit));
        state.solve.basis_error = None;
        state.refresh();
        return;
    }
    let designs = state.palette.lights.iter().chain(&state.palette.reflectances).any(|e| e.design);
    if designs && state.solve.running.is_some() {
        return;
    }
    match crate::basis::train::TrainingSet::new(
        state.derived.light_spectra.clone(),
        state.derived.reflectance_spectra.clone(),
    ) {
        Ok(set) => {
            worker.request_basis(state.solve.generation, key, set, state.palette.settings.basis_dimension);
            state.solve.training = worker.training();
        }
        Err(e) => state.solve.basis_error = Some(format!("cannot train the basis: {e}")),
    }
}

fn submit(state: &mut State, worker: &mut Worker) {
    worker.set_feasibility(state.feasibility_cell());
    worker.submit(state.solve.generation, &state.palette);
    state.solve.running = worker.solving();
    state.solve.training = worker.training();
    state.solve.running_for = Duration::ZERO;
    ensure_basis(state, worker);
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
    if effects.reload {
        match saver.reload() {
            Ok(palette) => {
                // The palette on screen is kept in the undo history: `z` brings it back.
                let mine = std::mem::replace(&mut state.palette, palette.clone());
                state.history.undo.push(mine);
                state.history.redo.clear();
                state.history.last_edit = None;
                state.saved = palette;
                state.solve.generation += 1;
                state.clamp_selection();
                state.refresh();
                submit(state, worker);
                state.say("reloaded from disk (z undoes the reload)");
            }
            Err(e) => state.complain(format!("not reloaded: {e}")),
        }
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
                    Some(reply) => apply_reply(state, reply, &mut worker),
                    None => break,
                }
            }
        }
        while let Some(reply) = worker.try_reply() {
            apply_reply(state, reply, &mut worker);
            redraw = true;
        }
        if state.import.is_some() {
            // A replay (synchronous input) waits for the import as it waits for solves; its read is bounded.
            let wait = if events.synchronous() { Duration::from_secs(60) } else { Duration::ZERO };
            let effects = update::poll_import(state, wait);
            if effects.solve {
                solve_started = Instant::now();
            }
            run_effects(state, effects, &mut worker, saver);
            redraw |= state.import.is_none();
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
        let waiting = worker.busy() || loading || state.import.is_some();
        let timeout = if waiting { Duration::from_millis(80) } else { Duration::from_millis(500) };
        match events.next(timeout)? {
            None => {
                if waiting {
                    state.ticks += 1;
                    redraw = true;
                }
            }
            Some(Input::End) => return Ok(()),
            Some(Input::Terminated) => {
                // Best effort: the process is ending either way; the next open offers the copy.
                let copy = (state.palette != state.saved).then(|| saver.recover(&palette_to_save(state)).ok());
                state.terminated = Some(copy.flatten());
                return Ok(());
            }
            Some(Input::Resize) => {
                terminal.autoresize().map_err(backend_error)?;
                terminal.clear().map_err(backend_error)?;
                redraw = true;
            }
            Some(Input::WaitSolve) => {
                // A running import ends (its read is bounded); its solve is then waited for too.
                if state.import.is_some() {
                    let effects = update::poll_import(state, Duration::from_secs(60));
                    run_effects(state, effects, &mut worker, saver);
                }
                while worker.busy() {
                    match worker.wait_reply(Duration::from_secs(3600)) {
                        Some(reply) => apply_reply(state, reply, &mut worker),
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
