//! Solving and basis training off the UI thread.
//!
//! Two threads: the solver and the basis trainer. Each takes requests over a channel and always works on
//! the newest one (older queued requests are dropped unread); a running solve is cancelled through
//! [`SolveOptions::cancel`] when a newer palette arrives. Every request carries the palette's generation
//! so the UI can drop replies to palettes that have since changed.
//!
//! The basis (the spectral factor model, for the subspace colours of the matrix and for palettes that fit
//! in the subspace) is trained by [`crate::basis::store::for_palette`] — optionally through its sidecar
//! cache — and kept in memory by its training-set key, shared by both threads, so it is retrained only
//! when a spectrum or the dimension changes.

use crate::basis::Basis;
use crate::basis::store::{self, cache_key, palette_uses_basis};
use crate::basis::train::TrainingSet;
use crate::colorimetry::Colorimetry;
use crate::design::feasibility::{self, Panel, RegionCache};
use crate::design::{self, DesignError, Solution, SolveOptions};
use crate::palette::Palette;
use std::collections::HashMap;
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::sync::{Arc, Mutex};
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
    pub generation: u64,
    pub result: Result<Arc<Solution>, DesignError>,
    /// The basis the solve used, if it needed one.
    pub basis: Option<Arc<Basis>>,
    /// Wall-clock time of the solve (and of any basis training it waited for).
    pub elapsed: Duration,
    /// The mismatch region asked for with the request (cell, panel or why not), computed after the solve.
    pub feasibility: Option<(usize, Result<Arc<Panel>, String>)>,
}

/// A finished basis training (or cache hit).
#[derive(Debug)]
pub struct Trained {
    pub generation: u64,
    pub result: Result<Arc<Basis>, String>,
}

/// Something the worker finished.
#[derive(Debug)]
pub enum Reply {
    Solved(Solved),
    Trained(Trained),
}

struct Request {
    generation: u64,
    palette: Palette,
    cancel: Arc<AtomicBool>,
    /// The cell whose mismatch region to compute after the solve.
    feasibility: Option<usize>,
}

/// Bases by training-set key, shared by the two threads.
type BasisCache = Arc<Mutex<HashMap<String, Arc<Basis>>>>;

/// The palette's basis: from memory, else trained (through the sidecar when configured).
fn basis_for(palette: &Palette, cache: &BasisCache, sidecar: Option<&PathBuf>) -> Result<Arc<Basis>, String> {
    let m = palette.settings.basis_dimension;
    let set = TrainingSet::from_palette(palette).map_err(|e| format!("cannot train the basis: {e}"))?;
    let key = cache_key(&set, m);
    if let Some(b) = cache.lock().ok().and_then(|c| c.get(&key).cloned()) {
        return Ok(b);
    }
    let (basis, _) = store::for_palette(palette, m, sidecar.map(PathBuf::as_path)).map_err(|e| e.to_string())?;
    let basis = Arc::new(basis);
    if let Ok(mut c) = cache.lock() {
        if c.len() > 32 {
            c.clear();
        }
        c.insert(key, basis.clone());
    }
    Ok(basis)
}

/// The newest request queued behind `first`.
fn newest(first: Request, requests: &Receiver<Request>) -> Option<Request> {
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
    let values = design::system::Values {
        lights: solution.palette.lights.iter().map(|e| e.spectrum).collect(),
        reflectances: solution.palette.reflectances.iter().map(|e| e.spectrum).collect(),
        free: solution.free.clone(),
    };
    let tolerance = feasibility::DEFAULT_TOLERANCE;
    feasibility::panel(&solution.palette, basis, colorimetry, &values, cell, tolerance, regions)
        .map(Arc::new)
        .map_err(|e| e.to_string())
}

fn serve_solves(requests: Receiver<Request>, replies: Sender<Reply>, config: WorkerConfig, cache: BasisCache) {
    let colorimetry = Colorimetry::default();
    let mut regions = RegionCache::default();
    while let Ok(first) = requests.recv() {
        let Some(request) = newest(first, &requests) else { return };
        let started = Instant::now();
        let cancelled = request.cancel.load(Ordering::Relaxed);
        let basis = match (&config.basis, palette_uses_basis(&request.palette)) {
            (BasisMode::Train { sidecar }, true) if !cancelled => {
                Some(basis_for(&request.palette, &cache, sidecar.as_ref()))
            }
            _ => None,
        };
        let result = match &basis {
            _ if cancelled || request.cancel.load(Ordering::Relaxed) => Err(DesignError::Cancelled),
            Some(Err(e)) => Err(DesignError::Invalid(e.clone())),
            _ => {
                let options = SolveOptions { time_limit: config.time_limit, cancel: Some(request.cancel.clone()) };
                let b = basis.as_ref().and_then(|b| b.as_ref().ok()).map(|b| b.as_ref());
                design::solve(&request.palette, b, &colorimetry, &options).map(Arc::new)
            }
        };
        let elapsed = started.elapsed();
        let basis = basis.and_then(Result::ok);
        let feasibility = match (&result, request.feasibility) {
            (Ok(solution), Some(cell)) if !request.cancel.load(Ordering::Relaxed) => {
                if regions.len() > 64 {
                    regions = RegionCache::default();
                }
                Some((cell, feasibility_panel(solution, basis.as_deref(), &colorimetry, cell, &regions)))
            }
            _ => None,
        };
        let reply = Solved { generation: request.generation, result, basis, elapsed, feasibility };
        if replies.send(Reply::Solved(reply)).is_err() {
            return;
        }
    }
}

fn serve_bases(requests: Receiver<Request>, replies: Sender<Reply>, sidecar: Option<PathBuf>, cache: BasisCache) {
    while let Ok(first) = requests.recv() {
        let Some(request) = newest(first, &requests) else { return };
        let result = basis_for(&request.palette, &cache, sidecar.as_ref());
        if replies.send(Reply::Trained(Trained { generation: request.generation, result })).is_err() {
            return;
        }
    }
}

/// Handle on the worker threads.
#[derive(Debug)]
pub struct Worker {
    solves: Option<Sender<Request>>,
    bases: Option<Sender<Request>>,
    replies: Receiver<Reply>,
    /// Cancel flag of the newest solve request.
    cancel: Option<Arc<AtomicBool>>,
    /// The newest generations submitted and not yet answered.
    pending_solve: Option<u64>,
    pending_basis: Option<u64>,
    /// Key of the newest basis asked for, to skip asking again for the same spectra.
    basis_asked: Option<String>,
    /// The cell whose mismatch region every solve also computes.
    feasibility: Option<usize>,
}

impl Worker {
    /// Start the worker threads.
    pub fn start(config: WorkerConfig) -> std::io::Result<Worker> {
        let (reply_tx, reply_rx) = mpsc::channel();
        let cache: BasisCache = Arc::default();
        let (solve_tx, solve_rx) = mpsc::channel();
        {
            let (replies, config, cache) = (reply_tx.clone(), config.clone(), cache.clone());
            std::thread::Builder::new()
                .name("metamer-solve".into())
                .spawn(move || serve_solves(solve_rx, replies, config, cache))?;
        }
        let bases = match config.basis {
            BasisMode::Off => None,
            BasisMode::Train { sidecar } => {
                let (basis_tx, basis_rx) = mpsc::channel();
                std::thread::Builder::new()
                    .name("metamer-basis".into())
                    .spawn(move || serve_bases(basis_rx, reply_tx, sidecar, cache))?;
                Some(basis_tx)
            }
        };
        Ok(Worker {
            solves: Some(solve_tx),
            bases,
            replies: reply_rx,
            cancel: None,
            pending_solve: None,
            pending_basis: None,
            basis_asked: None,
            feasibility: None,
        })
    }

    /// Solve `palette` (generation `generation`), cancelling whatever solve runs now, and have its basis
    /// trained when its spectra or dimension changed.
    pub fn submit(&mut self, generation: u64, palette: &Palette) {
        if let Some(old) = self.cancel.take() {
            old.store(true, Ordering::Relaxed);
        }
        let cancel = Arc::new(AtomicBool::new(false));
        self.cancel = Some(cancel.clone());
        let request = Request { generation, palette: palette.clone(), cancel, feasibility: self.feasibility };
        let sent = self.solves.as_ref().is_some_and(|tx| tx.send(request).is_ok());
        self.pending_solve = sent.then_some(generation);
        if let Some(tx) = &self.bases {
            let key =
                TrainingSet::from_palette(palette).ok().map(|set| cache_key(&set, palette.settings.basis_dimension));
            if key.is_some() && key != self.basis_asked {
                let request =
                    Request { generation, palette: palette.clone(), cancel: Arc::default(), feasibility: None };
                if tx.send(request).is_ok() {
                    self.pending_basis = Some(generation);
                    self.basis_asked = key;
                }
            }
        }
    }

    /// Have every following solve also compute the mismatch region of `cell` (None: none).
    pub fn set_feasibility(&mut self, cell: Option<usize>) {
        self.feasibility = cell;
    }

    /// The generation being solved, if any.
    pub fn solving(&self) -> Option<u64> {
        self.pending_solve
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
            Reply::Trained(t) if self.pending_basis == Some(t.generation) => self.pending_basis = None,
            _ => {}
        }
    }

    /// A reply if one is ready, without waiting.
    pub fn try_reply(&mut self) -> Option<Reply> {
        let reply = self.replies.try_recv().ok()?;
        self.note(&reply);
        Some(reply)
    }

    /// Wait up to `timeout` for a reply.
    pub fn wait_reply(&mut self, timeout: Duration) -> Option<Reply> {
        match self.replies.recv_timeout(timeout) {
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
