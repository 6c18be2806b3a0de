//! Solving and basis training off the UI thread.
//!
//! Two threads: the solver and the basis trainer. Each takes requests over a channel and always works on
//! the newest one (older queued requests are dropped unread); a running solve is cancelled through
//! [`SolveOptions::cancel`] when a newer palette arrives. Every request carries the palette's generation
//! so the UI can drop replies to palettes that have since changed.
//!
//! Every basis comes from the one basis policy, [`crate::basis::basis_for`] (memory shared by every thread,
//! then the sidecar cache when configured), keyed by the exact spectra and m, so it is retrained only when
//! a spectrum or the dimension changes. The solver thread asks for the basis of the palette it solves when
//! the palette's criteria need one; the basis thread trains the basis of the spectra the matrix *shows*
//! (the solved ones), which the UI requests with [`Worker::request_basis`] after each solve.

use crate::basis::Basis;
use crate::basis::TrainingSet;
use crate::basis::palette_uses_basis;
use crate::basis::{self, Resolved};
use crate::colorimetry::Colorimetry;
use crate::design::feasibility::{self, Panel, RegionCache};
use crate::design::{self, DesignError, Solution, SolveOptions};
use crate::palette::Palette;
use crate::tui::model::BasisKey;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::time::{Duration, Instant};

/// Whether and how the worker trains the palette's basis.
#[derive(Clone, Debug, PartialEq)]
pub enum BasisMode {
    /// Never train: no subspace colours, and palettes that need a basis report so.
    Off,
    /// Train when the spectra or the dimension change, reading and writing this sidecar cache if given.
    Train { sidecar: Option<PathBuf> },
}

/// How the worker runs.
#[derive(Clone, Debug)]
pub struct WorkerConfig {
    /// Cap on one solve.
    pub time_limit: Duration,
    pub basis: BasisMode,
}

/// A finished solve.
#[derive(Debug)]
pub struct Solved {
    /// The request this answers ([`Worker::submit_ticket`]; [`Worker::submit`] uses the generation).
    pub ticket: u64,
    pub generation: u64,
    pub result: Result<Arc<Solution>, DesignError>,
    /// Wall-clock time of the solve (and of any basis training it waited for).
    pub elapsed: Duration,
    /// The mismatch region asked for with the request (cell, panel or why not), computed after the solve.
    pub feasibility: Option<(usize, Result<Arc<Panel>, String>)>,
}

/// A finished basis training (or cache hit).
#[derive(Debug)]
pub struct Trained {
    pub generation: u64,
    /// The key of the spectra it is for.
    pub key: BasisKey,
    pub result: Result<Resolved, String>,
}

/// Something the worker finished.
#[derive(Debug)]
pub enum Reply {
    Solved(Solved),
    Trained(Trained),
}

struct Request {
    ticket: u64,
    generation: u64,
    palette: Palette,
    cancel: Arc<AtomicBool>,
    /// The cell whose mismatch region to compute after the solve.
    feasibility: Option<usize>,
}

/// Where the worker threads hand their replies.
type Deliver = Arc<dyn Fn(Reply) -> bool + Send + Sync>;

/// A request for the basis of some spectra.
struct BasisRequest {
    generation: u64,
    key: BasisKey,
    set: TrainingSet,
    m: usize,
}

/// The newest request queued behind `first`.
fn newest<R>(first: R, requests: &Receiver<R>) -> Option<R> {
    let mut request = first;
    loop {
        match requests.try_recv() {
            Ok(newer) => request = newer,
            Err(TryRecvError::Empty) => return Some(request),
            Err(TryRecvError::Disconnected) => return None,
        }
    }
}

/// The mismatch-region panel of `cell` at a solution.
fn feasibility_panel(
    solution: &Solution,
    basis: Option<&Basis>,
    colorimetry: &Colorimetry,
    cell: usize,
    regions: &RegionCache,
) -> Result<Arc<Panel>, String> {
    let values = design::Values {
        lights: solution.palette.lights.iter().map(|e| e.spectrum).collect(),
        reflectances: solution.palette.reflectances.iter().map(|e| e.spectrum).collect(),
        free: solution.free.clone(),
    };
    let tolerance = feasibility::DEFAULT_TOLERANCE;
    feasibility::panel(&solution.palette, basis, colorimetry, &values, cell, tolerance, regions)
        .map(Arc::new)
        .map_err(|e| e.to_string())
}

fn serve_solves(requests: Receiver<Request>, deliver: Deliver, config: WorkerConfig) {
    let colorimetry = Colorimetry::default();
    let mut regions = RegionCache::default();
    while let Ok(first) = requests.recv() {
        let Some(request) = newest(first, &requests) else { return };
        let started = Instant::now();
        // A panic in the engine becomes an error reply (the UI shows it) instead of a silent dead thread
        // and "solving…" forever.
        let work = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let cancelled = request.cancel.load(Ordering::Relaxed);
            let basis = match (&config.basis, palette_uses_basis(&request.palette)) {
                (BasisMode::Train { sidecar }, true) if !cancelled => {
                    Some(basis::basis_for_palette(&request.palette, sidecar.as_deref()).map_err(|e| e.to_string()))
                }
                _ => None,
            };
            let result = match &basis {
                _ if cancelled || request.cancel.load(Ordering::Relaxed) => Err(DesignError::Cancelled),
                Some(Err(e)) => Err(DesignError::Invalid(e.clone())),
                _ => {
                    let options = SolveOptions { time_limit: config.time_limit, cancel: Some(request.cancel.clone()) };
                    let b = basis.as_ref().and_then(|b| b.as_ref().ok()).map(|b| &b.0);
                    design::solve(&request.palette, b, &colorimetry, &options).map(Arc::new)
                }
            };
            (result, basis.and_then(Result::ok))
        }));
        let (result, basis) = work.unwrap_or_else(|panic| (Err(DesignError::Invalid(panic_message(&panic))), None));
        let elapsed = started.elapsed();
        let feasibility = match (&result, request.feasibility) {
            (Ok(solution), Some(cell)) if !request.cancel.load(Ordering::Relaxed) => {
                if regions.len() > 64 {
                    regions = RegionCache::default();
                }
                let b = basis.as_ref().map(|b| &b.0);
                let panel = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    feasibility_panel(solution, b, &colorimetry, cell, &regions)
                }))
                .unwrap_or_else(|panic| Err(panic_message(&panic)));
                Some((cell, panel))
            }
            _ => None,
        };
        let reply = Solved { ticket: request.ticket, generation: request.generation, result, elapsed, feasibility };
        if !deliver(Reply::Solved(reply)) {
            return;
        }
    }
}

fn serve_bases(requests: Receiver<BasisRequest>, deliver: Deliver, sidecar: Option<PathBuf>) {
    while let Ok(first) = requests.recv() {
        let Some(request) = newest(first, &requests) else { return };
        let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            basis::basis_for(&request.set, request.m, sidecar.as_deref())
                .map_err(|e| format!("cannot train the basis: {e}"))
        }))
        .unwrap_or_else(|panic| Err(panic_message(&panic)));
        let reply = Trained { generation: request.generation, key: request.key, result };
        if !deliver(Reply::Trained(reply)) {
            return;
        }
    }
}

/// The message of a caught panic, for the status line.
pub(crate) fn panic_message(panic: &Box<dyn std::any::Any + Send>) -> String {
    let what = panic
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| panic.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "unknown cause".into());
    format!("internal error in the worker (please report it): {what}")
}

/// Handle on the worker threads.
#[derive(Debug)]
pub struct Worker {
    solves: Option<Sender<Request>>,
    bases: Option<Sender<BasisRequest>>,
    /// The replies, when this worker keeps them ([`Worker::start`]); else they went to the deliverer.
    replies: Option<Receiver<Reply>>,
    /// Cancel flag of the newest solve request.
    cancel: Option<Arc<AtomicBool>>,
    /// The newest generations submitted and not yet answered.
    pending_solve: Option<u64>,
    pending_basis: Option<u64>,
    /// Key of the newest basis asked for, to skip asking again for the same spectra.
    basis_asked: Option<BasisKey>,
    /// The cell whose mismatch region every solve also computes.
    feasibility: Option<usize>,
}

impl Worker {
    /// Start the worker threads; the replies are kept for [`Worker::wait_reply`].
    pub fn start(config: WorkerConfig) -> std::io::Result<Worker> {
        let (reply_tx, reply_rx) = mpsc::channel();
        let mut worker = Worker::start_delivering(config, move |reply| reply_tx.send(reply).is_ok())?;
        worker.replies = Some(reply_rx);
        Ok(worker)
    }

    /// Start the worker threads; every reply is handed to `deliver` (the designer's loop sends it on its
    /// one channel), which returns false when nobody listens any more (the threads then end).
    pub(crate) fn start_delivering(
        config: WorkerConfig,
        deliver: impl Fn(Reply) -> bool + Send + Sync + 'static,
    ) -> std::io::Result<Worker> {
        let deliver: Deliver = Arc::new(deliver);
        let (solve_tx, solve_rx) = mpsc::channel();
        {
            let (deliver, config) = (deliver.clone(), config.clone());
            std::thread::Builder::new()
                .name("metamer-solve".into())
                .spawn(move || serve_solves(solve_rx, deliver, config))?;
        }
        let bases = match config.basis {
            BasisMode::Off => None,
            BasisMode::Train { sidecar } => {
                let (basis_tx, basis_rx) = mpsc::channel();
                std::thread::Builder::new()
                    .name("metamer-basis".into())
                    .spawn(move || serve_bases(basis_rx, deliver, sidecar))?;
                Some(basis_tx)
            }
        };
        Ok(Worker {
            solves: Some(solve_tx),
            bases,
            replies: None,
            cancel: None,
            pending_solve: None,
            pending_basis: None,
            basis_asked: None,
            feasibility: None,
        })
    }

    /// Solve `palette` (generation `generation`, ticket = generation), cancelling whatever solve runs now.
    pub fn submit(&mut self, generation: u64, palette: &Palette) {
        self.submit_ticket(generation, generation, palette.clone(), self.feasibility);
    }

    /// Solve `palette` as request `ticket` (its reply carries it), also computing the mismatch region of
    /// `feasibility`, cancelling whatever solve runs now. False when the solver thread is gone.
    pub fn submit_ticket(
        &mut self,
        ticket: u64,
        generation: u64,
        palette: Palette,
        feasibility: Option<usize>,
    ) -> bool {
        if let Some(old) = self.cancel.take() {
            old.store(true, Ordering::Relaxed);
        }
        let cancel = Arc::new(AtomicBool::new(false));
        self.cancel = Some(cancel.clone());
        let request = Request { ticket, generation, palette, cancel, feasibility };
        let sent = self.solves.as_ref().is_some_and(|tx| tx.send(request).is_ok());
        self.pending_solve = sent.then_some(generation);
        sent
    }

    /// Have the basis of dimension m for these spectra (key `key`) trained or loaded, unless it was the
    /// last one asked for. The reply is a [`Reply::Trained`] with the key.
    pub fn request_basis(&mut self, generation: u64, key: BasisKey, set: TrainingSet, m: usize) {
        if self.basis_asked.as_ref() == Some(&key) {
            return;
        }
        self.train(generation, key, set, m);
    }

    /// Have the basis of these spectra trained or loaded (the caller decides that it is new). False when
    /// the basis thread is off or gone.
    pub(crate) fn train(&mut self, generation: u64, key: BasisKey, set: TrainingSet, m: usize) -> bool {
        if let Some(tx) = &self.bases {
            let request = BasisRequest { generation, key: key.clone(), set, m };
            if tx.send(request).is_ok() {
                self.pending_basis = Some(generation);
                self.basis_asked = Some(key);
                return true;
            }
        }
        false
    }

    /// True while a basis is being trained.
    pub fn training(&self) -> bool {
        self.pending_basis.is_some()
    }

    /// True while anything is under way.
    pub fn busy(&self) -> bool {
        self.pending_solve.is_some() || self.pending_basis.is_some()
    }

    fn note(&mut self, reply: &Reply) {
        match reply {
            Reply::Solved(s) if self.pending_solve == Some(s.generation) => self.pending_solve = None,
            Reply::Trained(t) if self.basis_asked.as_ref() == Some(&t.key) => self.pending_basis = None,
            _ => {}
        }
    }

    /// Wait up to `timeout` for a reply (a worker started with [`Worker::start`]).
    pub fn wait_reply(&mut self, timeout: Duration) -> Option<Reply> {
        match self.replies.as_ref()?.recv_timeout(timeout) {
            Ok(reply) => {
                self.note(&reply);
                Some(reply)
            }
            Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => None,
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        if let Some(c) = self.cancel.take() {
            c.store(true, Ordering::Relaxed);
        }
        // Closing the request channels ends the threads once their current work returns; the UI does not
        // wait for that, so quitting never hangs on a long training or a solver that checks its flag late.
        self.solves = None;
        self.bases = None;
    }
}
