//! The event loop, generic over the ratatui backend: the real terminal and the off-screen `TestBackend`
//! (tests, `--replay`) run the same code.
//!
//! One channel carries every [`Msg`]: keys and resizes from the input thread, worker replies, finished
//! raycasts and imports, the outcome of file operations, ticks and signals. Each turn the loop draws (when
//! the screen may have changed), then BLOCKS on the channel for the next message, hands it to
//! [`update::update`] — the only place the state changes — and runs the [`Effect`]s it returns; their
//! results come back as messages. A synchronous source (a replay script) hands over its next step only
//! once nothing is under way ([`State::busy`]), so its screens are reproducible.

use crate::palette::Palette;
use crate::palette::PaletteFile;
use crate::tui::app::State;
use crate::tui::edits::FileError;
use crate::tui::msg::{Effect, FileOutcome, Msg, Saved, SavedScene};
use crate::tui::preview::PreviewLoader;
use crate::tui::update;
use crate::tui::worker::{BasisMode, Reply, Solved, Trained, Worker, WorkerConfig};
use ratatui::Terminal;
use ratatui::backend::Backend;
use ratatui::buffer::Buffer;
use std::io;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender};
use std::time::{Duration, Instant};

/// Where inputs come from.
pub trait Events {
    /// Start sending inputs on the loop's channel (from threads of the source's own). Scripts send nothing
    /// here: they hand over steps through [`Events::next_step`].
    fn start(&mut self, _tx: &Sender<Msg>) -> io::Result<()> {
        Ok(())
    }
    /// A synchronous source's next step ([`Msg::End`] when there is none), asked for only when nothing is
    /// under way.
    fn next_step(&mut self) -> Msg {
        Msg::End
    }
    /// True when every solve (raycast, import, save) must finish before the next step is taken and before
    /// drawing (replay).
    fn synchronous(&self) -> bool {
        false
    }
}

/// A live source for tests: sends these messages on the loop's channel when started, from the caller's
/// thread, as an input thread would.
pub struct ChannelEvents(pub Vec<Msg>);

impl Events for ChannelEvents {
    fn start(&mut self, tx: &Sender<Msg>) -> io::Result<()> {
        for msg in self.0.drain(..) {
            tx.send(msg).map_err(|_| io::Error::other("the loop's channel is closed"))?;
        }
        Ok(())
    }
}

/// Writes the palette to its file. The state owns the file (path, palette, document); each call gets a copy
/// and a save returns the file as written. Every outcome is typed; the update step says what it means.
pub trait Saver {
    /// Save `palette` into `file` (`overwrite`: even when another program changed it on disk).
    fn save(&mut self, file: &PaletteFile, palette: &Palette, overwrite: bool) -> Result<Saved, FileError>;
    /// Save `palette` into `file` at `path`, which becomes the palette file. Another file at `path` is
    /// replaced only when `replace` (the user was asked: [`FileError::Exists`]).
    fn save_as(
        &mut self,
        _file: &PaletteFile,
        _palette: &Palette,
        _path: &Path,
        _replace: bool,
    ) -> Result<Saved, FileError> {
        Err(FileError::NoFile)
    }
    /// Write `palette` as a recovery copy beside `file` (on SIGTERM, SIGHUP or SIGINT with unsaved changes); returns
    /// where it went.
    fn recover(&mut self, _file: &PaletteFile, _palette: &Palette) -> Result<PathBuf, FileError> {
        Err(FileError::NoFile)
    }
    /// Read the palette of the recovery copy at `path`.
    fn restore(&mut self, _path: &Path) -> Result<Palette, FileError> {
        Err(FileError::NoFile)
    }
    /// Read `file` again.
    fn reload(&mut self, _file: &PaletteFile) -> Result<PaletteFile, FileError> {
        Err(FileError::NoFile)
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
/// When another program changed the file since it was opened or last saved, a save does not overwrite it
/// (unless told to): the designer's version is saved as `NAME.mine.toml` beside it, and the user chooses
/// (the update step opens the conflict popup): overwrite, reload, or save as another file.
#[derive(Debug, Default)]
pub struct FileSaver;

fn failed(e: impl std::fmt::Display) -> FileError {
    FileError::Failed(e.to_string())
}

impl Saver for FileSaver {
    fn save(&mut self, file: &PaletteFile, palette: &Palette, overwrite: bool) -> Result<Saved, FileError> {
        let path = file.path.clone().ok_or(FileError::NoFile)?;
        if !overwrite && file.changed_on_disk() {
            let mine = mine_path(&path);
            let aside = file.clone().save_as(palette, &mine).map(|()| mine).map_err(|e| e.to_string());
            return Err(FileError::Conflict { path, aside });
        }
        let mut file = file.clone();
        if overwrite {
            // The user saw the outside change and chose to overwrite it: the one writer is told so (it
            // refuses a file changed since it was read otherwise); a read-only file is still refused.
            let staged = file.stage_save_as(palette, &path, crate::fsio::Replace::Changed).map_err(failed)?;
            file.commit(staged).map_err(failed)?;
        } else {
            file.save(palette).map_err(failed)?;
        }
        Ok(Saved { text: format!("saved {}", path.display()), file })
    }

    fn save_as(
        &mut self,
        file: &PaletteFile,
        palette: &Palette,
        path: &Path,
        replace: bool,
    ) -> Result<Saved, FileError> {
        if path.as_os_str().is_empty() {
            return Err(FileError::NoPath);
        }
        // Never onto what the palette reads (its CSV spectra); onto the palette file itself it is a save.
        let mut files = crate::fsio::Outputs::new();
        file.record_inputs("palette", &mut files);
        // Nor onto any other file the designer read: its `--scene` file and the scene's volume, the running
        // key script, a CSV imported, a basis sidecar (other palettes it read are not inputs of this one).
        let others = |k: crate::fsio::Kind| !matches!(k, crate::fsio::Kind::Palette | crate::fsio::Kind::Text);
        files.inputs_read(&crate::fsio::read_by_this_process(others));
        if let Some(own) = &file.path {
            // Its basis sidecar is the tool's cache, read on the next open: not a place for a palette.
            files.input("basis sidecar", &crate::basis::sidecar_path(own));
        }
        match file.path.clone() {
            Some(own) => files.output_except("palette", path, &own).map(|_| ()),
            None => files.output("palette", path).map(|_| ()),
        }
        .map_err(failed)?;
        // Nothing the user made is replaced unasked: another regular file there is refused once, with the
        // question; asked again (the same path), it is replaced.
        let own = file.path.as_deref().is_some_and(|own| crate::fsio::same_file(own, path));
        if !replace && !own && path.is_file() {
            return Err(FileError::Exists(path.to_path_buf()));
        }
        let mut file = file.clone();
        file.save_as(palette, path).map_err(failed)?;
        Ok(Saved { text: format!("saved as {}", crate::fsio::show(path)), file })
    }

    fn recover(&mut self, file: &PaletteFile, palette: &Palette) -> Result<PathBuf, FileError> {
        let path = file.path.as_deref().ok_or(FileError::NoFile)?;
        let target = recovery_path(path);
        // A copy of the file's document, so comments and unknown keys are in the recovery copy too; the
        // palette file itself is not touched.
        file.clone().save_as(palette, &target).map_err(failed)?;
        Ok(target)
    }

    fn reload(&mut self, file: &PaletteFile) -> Result<PaletteFile, FileError> {
        let path = file.path.clone().ok_or(FileError::NoFile)?;
        PaletteFile::load(&path).map_err(failed)
    }

    fn restore(&mut self, path: &Path) -> Result<Palette, FileError> {
        PaletteFile::load(path).map(|f| f.palette).map_err(failed)
    }
}

/// What the loop needs besides the terminal and the state.
pub struct Io<'a> {
    pub events: &'a mut dyn Events,
    pub saver: &'a mut dyn Saver,
    /// Called with every drawn frame.
    pub on_frame: Option<&'a mut dyn FnMut(&Buffer)>,
    /// Called with every message the loop takes, before it is handled (tests, logs).
    pub on_msg: Option<&'a mut dyn FnMut(&Msg)>,
    /// Solve time cap and basis training.
    pub worker: WorkerConfig,
    /// The spinner's period: a timer sends [`Msg::Tick`] this often while something is under way (live
    /// sources only; `None`: no ticks).
    pub tick: Option<Duration>,
}

fn backend_error(e: impl std::fmt::Display) -> io::Error {
    io::Error::other(e.to_string())
}

/// Sends [`Msg::Tick`] every period while told that something is under way; blocks otherwise.
struct Ticker {
    busy: Sender<bool>,
    last: bool,
}

impl Ticker {
    fn start(tx: Sender<Msg>, period: Duration) -> io::Result<Ticker> {
        let (busy, control): (Sender<bool>, Receiver<bool>) = mpsc::channel();
        std::thread::Builder::new().name("metamer-tick".into()).spawn(move || {
            let mut on = false;
            loop {
                let next = if on {
                    control.recv_timeout(period)
                } else {
                    control.recv().map_err(|_| RecvTimeoutError::Disconnected)
                };
                match next {
                    Ok(b) => on = b,
                    Err(RecvTimeoutError::Timeout) => {
                        if tx.send(Msg::Tick(Instant::now())).is_err() {
                            return;
                        }
                    }
                    Err(RecvTimeoutError::Disconnected) => return,
                }
            }
        })?;
        Ok(Ticker { busy, last: false })
    }

    fn set(&mut self, busy: bool) {
        if busy != self.last {
            self.last = busy;
            let _ = self.busy.send(busy);
        }
    }
}

/// Runs the effects the update step asks for; every result comes back on the loop's channel.
struct Runner<'a> {
    tx: Sender<Msg>,
    worker: Worker,
    loader: Option<PreviewLoader>,
    saver: &'a mut dyn Saver,
}

impl Runner<'_> {
    fn send(&self, msg: Msg) {
        // The receiver lives as long as the loop: a send cannot fail while anyone would read it.
        let _ = self.tx.send(msg);
    }

    fn run(&mut self, effect: Effect) -> io::Result<()> {
        match effect {
            Effect::Solve { ticket, generation, palette, feasibility } => {
                self.send(Msg::SolveStarted { ticket, at: Instant::now() });
                if !self.worker.submit_ticket(ticket, generation, palette, feasibility) {
                    let result = Err(crate::design::DesignError::Invalid("the solver thread stopped".into()));
                    let solved = Solved { ticket, generation, result, elapsed: Duration::ZERO, feasibility: None };
                    self.send(Msg::Worker(Reply::Solved(solved)));
                }
            }
            Effect::TrainBasis { generation, key, set, m } => {
                if !self.worker.train(generation, key.clone(), set, m) {
                    let result = Err("the basis thread stopped".to_string());
                    self.send(Msg::Worker(Reply::Trained(Trained { generation, key, result })));
                }
            }
            Effect::Raycast { scene, model, size, colorimetry } => {
                if self.loader.is_none() {
                    let tx = self.tx.clone();
                    self.loader = Some(PreviewLoader::start(move |loaded| tx.send(Msg::Preview(loaded)).is_ok())?);
                }
                if let Some(loader) = self.loader.as_mut()
                    && !loader.submit(scene, model, size, &colorimetry)
                {
                    return Err(io::Error::other("the preview thread stopped"));
                }
            }
            Effect::Import { id, kind, name, path, base_dir, mut palette, colorimetry } => {
                let tx = self.tx.clone();
                let spawned = std::thread::Builder::new().name("csv import".into()).spawn(move || {
                    let source = crate::palette::Source::Csv(path);
                    let result = crate::tui::edits::add(&mut palette, kind, &name, source, &base_dir, &colorimetry)
                        .map(|()| palette);
                    let _ = tx.send(Msg::Imported { id, result });
                });
                if let Err(e) = spawned {
                    let reason = crate::tui::edits::EditError::Reader(e.to_string());
                    self.send(Msg::Imported { id, result: Err(reason) });
                }
            }
            Effect::Save { file, palette, before, quit_after, overwrite } => {
                let result = self.saver.save(&file, &palette, overwrite);
                self.send(Msg::File(FileOutcome::Saved { before, result, quit_after, save_as: None }));
            }
            Effect::SaveAs { file, palette, before, path, replace } => {
                let result = self.saver.save_as(&file, &palette, &path, replace);
                let outcome = FileOutcome::Saved { before, result, quit_after: false, save_as: Some(path) };
                self.send(Msg::File(outcome));
            }
            Effect::Reload { file } => {
                let result = self.saver.reload(&file);
                self.send(Msg::File(FileOutcome::Reloaded(result)));
            }
            Effect::Restore { path } => {
                let result = self.saver.restore(&path);
                self.send(Msg::File(FileOutcome::Restored { path, result }));
            }
            Effect::Recover { file, palette } => {
                let result = self.saver.recover(&file, &palette);
                self.send(Msg::File(FileOutcome::Recovered(result)));
            }
            Effect::Complete { folder, typed } => {
                let entries = crate::tui::prompt_memory::list_folder(&folder, 5000);
                self.send(Msg::Completed { typed, entries });
            }
            Effect::SaveKeyframes { path, keyframes } => {
                let result = crate::tui::keyframes::save_keyframes(&path, &keyframes).map(|text| SavedScene {
                    text,
                    count: keyframes.len(),
                    reloaded: crate::render::Scene::load(&path).map_err(|e| e.to_string()),
                });
                self.send(Msg::SceneSaved(result));
            }
        }
        Ok(())
    }
}

/// Run the designer until it quits or the input ends.
pub fn run_main_loop<B: Backend>(terminal: &mut Terminal<B>, state: &mut State, io: Io<'_>) -> io::Result<()> {
    let Io { events, saver, mut on_frame, mut on_msg, worker, tick } = io;
    let (tx, rx) = mpsc::channel::<Msg>();
    let trains_bases = worker.basis != BasisMode::Off;
    let worker = {
        let tx = tx.clone();
        Worker::start_delivering(worker, move |reply| tx.send(Msg::Worker(reply)).is_ok())?
    };
    let synchronous = events.synchronous();
    let mut ticker = match tick {
        Some(period) if !synchronous => Some(Ticker::start(tx.clone(), period)?),
        _ => None,
    };
    let mut runner = Runner { tx, worker, loader: None, saver };
    // The source starts once the first screen is drawn (a terminal is asked for its graphics then; keys
    // typed before are read after, none lost).
    let mut started = false;
    let size = terminal.size().map_err(backend_error)?;
    let mut next = Some(Msg::Start { width: size.width, height: size.height, trains_bases });
    loop {
        let msg = match next.take() {
            Some(msg) => msg,
            None => {
                // The screen after the last message; a synchronous source neither draws nor takes its next
                // step while work is under way.
                let waiting = synchronous && state.busy();
                if !waiting {
                    let frame = terminal.draw(|f| f.render_widget(&*state, f.area())).map_err(backend_error)?;
                    if let Some(cb) = on_frame.as_mut() {
                        cb(frame.buffer);
                    }
                    if state.ui.quit {
                        return Ok(());
                    }
                }
                if !started {
                    started = true;
                    events.start(&runner.tx)?;
                }
                if let Some(t) = ticker.as_mut() {
                    t.set(state.busy());
                }
                if synchronous && !waiting {
                    events.next_step()
                } else {
                    // Blocks until something happens; the runner holds a sender, so this never ends early.
                    rx.recv().unwrap_or(Msg::End)
                }
            }
        };
        if let Some(cb) = on_msg.as_mut() {
            cb(&msg);
        }
        let msg = match msg {
            Msg::End => return Ok(()),
            Msg::Resize { .. } => {
                terminal.autoresize().map_err(backend_error)?;
                terminal.clear().map_err(backend_error)?;
                let size = terminal.size().map_err(backend_error)?;
                Msg::Resize { width: size.width, height: size.height }
            }
            other => other,
        };
        for effect in update::update(state, msg) {
            runner.run(effect)?;
        }
    }
}
