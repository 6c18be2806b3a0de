//! The solver off the UI thread: one worker thread takes solve requests over a channel, always works on
//! the newest one (older queued requests are dropped unread), and can be cancelled mid-solve through
//! [`SolveOptions::cancel`]. Every request carries the palette's generation so the UI can drop replies
//! to palettes that have since changed.

use crate::basis::Basis;
use crate::colorimetry::Colorimetry;
use crate::design::{self, DesignError, Solution, SolveOptions};
use crate::palette::Palette;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, Sender, TryRecvError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// A palette to solve.
#[derive(Debug)]
pub struct Request {
    pub generation: u64,
    pub palette: Palette,
    pub basis: Option<Arc<Basis>>,
    pub cancel: Arc<AtomicBool>,
}

/// The outcome of one solve.
#[derive(Debug)]
pub struct Reply {
    pub generation: u64,
    pub result: Result<Arc<Solution>, DesignError>,
    /// Wall-clock time of the solve.
    pub elapsed: Duration,
}

/// Handle on the worker thread.
#[derive(Debug)]
pub struct Worker {
    requests: Option<Sender<Request>>,
    replies: Receiver<Reply>,
    /// Cancel flag of the newest request.
    cancel: Option<Arc<AtomicBool>>,
    /// The newest generation submitted and not yet answered.
    pending: Option<u64>,
    thread: Option<JoinHandle<()>>,
}

/// Solve requests in order, skipping to the newest queued one.
fn serve(requests: Receiver<Request>, replies: Sender<Reply>, time_limit: Duration) {
    let colorimetry = Colorimetry::default();
    while let Ok(mut request) = requests.recv() {
        // Drop stale work: only the newest queued request matters.
        loop {
            match requests.try_recv() {
                Ok(newer) => request = newer,
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        let started = Instant::now();
        let result = if request.cancel.load(Ordering::Relaxed) {
            Err(DesignError::Cancelled)
        } else {
            let options = SolveOptions { time_limit, cancel: Some(request.cancel.clone()) };
            design::solve(&request.palette, request.basis.as_deref(), &colorimetry, &options).map(Arc::new)
        };
        let reply = Reply { generation: request.generation, result, elapsed: started.elapsed() };
        if replies.send(reply).is_err() {
            return;
        }
    }
}

impl Worker {
    /// Start the worker thread; each solve is capped at `time_limit`.
    pub fn start(time_limit: Duration) -> std::io::Result<Worker> {
        let (request_tx, request_rx) = mpsc::channel();
        let (reply_tx, reply_rx) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("metamer-solve".into())
            .spawn(move || serve(request_rx, reply_tx, time_limit))?;
        Ok(Worker { requests: Some(request_tx), replies: reply_rx, cancel: None, pending: None, thread: Some(thread) })
    }

    /// Solve `palette` (generation `generation`), cancelling whatever runs now.
    pub fn submit(&mut self, generation: u64, palette: Palette, basis: Option<Arc<Basis>>) {
        if let Some(old) = self.cancel.take() {
            old.store(true, Ordering::Relaxed);
        }
        let cancel = Arc::new(AtomicBool::new(false));
        self.cancel = Some(cancel.clone());
        let sent =
            self.requests.as_ref().is_some_and(|tx| tx.send(Request { generation, palette, basis, cancel }).is_ok());
        self.pending = sent.then_some(generation);
    }

    /// The generation being solved, if any.
    pub fn pending(&self) -> Option<u64> {
        self.pending
    }

    fn note(&mut self, reply: &Reply) {
        if self.pending == Some(reply.generation) {
            self.pending = None;
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
        // Closing the request channel ends the thread once its (cancelled) solve returns; the UI does not
        // wait for that, so quitting never hangs on a solver that checks its cancel flag late.
        self.requests = None;
        drop(self.thread.take());
    }
}
