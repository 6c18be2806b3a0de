//! The real terminal: raw mode and the alternate screen, restored by a guard on every way out — normal
//! return, error, and (through ratatui's panic hook) a panic.

use crate::tui::event_loop::Events;
use crate::tui::graphics::{Graphics, PreviewMode};
use crate::tui::msg::Msg;
use crate::tui::probe::ProbeReader;
use ratatui::DefaultTerminal;
use ratatui::crossterm::event::{self, Event};
use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::time::Duration;

/// Owns the terminal while the designer runs; restores it when dropped.
pub(crate) struct TerminalGuard {
    pub(crate) terminal: DefaultTerminal,
}

impl TerminalGuard {
    /// Enter raw mode and the alternate screen; installs a panic hook that restores the terminal first.
    /// Without a terminal on both standard input and output it fails before writing anything (no stray
    /// escape sequences in a redirected output).
    pub(crate) fn enter() -> io::Result<TerminalGuard> {
        use std::io::IsTerminal;
        if !(io::stdin().is_terminal() && io::stdout().is_terminal()) {
            return Err(io::Error::other("standard input and output are not both a terminal"));
        }
        match ratatui::try_init() {
            Ok(terminal) => {
                // Mouse capture (clicks and drags; the terminal's own text selection then needs Shift in
                // most terminals), switched off again on every way out, a panic included.
                let hook = std::panic::take_hook();
                std::panic::set_hook(Box::new(move |info| {
                    let _ = ratatui::crossterm::execute!(io::stdout(), event::DisableMouseCapture);
                    hook(info);
                }));
                if let Err(e) = ratatui::crossterm::execute!(io::stdout(), event::EnableMouseCapture) {
                    let _ = ratatui::try_restore();
                    return Err(e);
                }
                Ok(TerminalGuard { terminal })
            }
            Err(e) => {
                // Undo whatever part of the set-up succeeded (raw mode without the alternate screen…).
                let _ = ratatui::try_restore();
                Err(e)
            }
        }
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        // The alternate screen is cleared before it is left: a terminal whose size changed since the
        // designer started (tmux) may carry rows of it over into the shell's screen when it resizes that
        // back on leaving (issue 30, defect 15: rows of the designer left under the prompt).
        let _ = ratatui::crossterm::execute!(
            io::stdout(),
            event::DisableMouseCapture,
            ratatui::crossterm::terminal::Clear(ratatui::crossterm::terminal::ClearType::All),
            ratatui::crossterm::cursor::MoveTo(0, 0)
        );
        ratatui::restore();
    }
}

/// Keys and resizes from the terminal, and the end signals (SIGTERM, SIGHUP, SIGINT) as [`Msg::Terminated`], sent
/// on the loop's channel by two threads: the input thread (crossterm's blocking read, woken now and then
/// only to see whether the loop has ended) and the signal thread (signal-hook's iterator).
pub(crate) struct TerminalEvents {
    #[cfg(unix)]
    signals: Option<signal_hook::iterator::Signals>,
    #[cfg(unix)]
    handle: Option<signal_hook::iterator::Handle>,
    stop: Arc<AtomicBool>,
    /// Ask the terminal for its graphics first (`--preview` with a scene), once the first screen is drawn.
    probe: Option<PreviewMode>,
}

impl TerminalEvents {
    /// Listen to SIGTERM, SIGHUP and SIGINT (whose default action would leave the terminal in raw mode on the
    /// alternate screen and lose unsaved work) from now on; the terminal once started. In raw mode Ctrl-C is a
    /// key, so a SIGINT comes from another program (`kill -INT`, `timeout -s INT`).
    pub fn new(probe: Option<PreviewMode>) -> io::Result<TerminalEvents> {
        #[cfg(unix)]
        let signals = {
            use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
            signal_hook::iterator::Signals::new([SIGTERM, SIGHUP, SIGINT])?
        };
        Ok(TerminalEvents {
            #[cfg(unix)]
            handle: Some(signals.handle()),
            #[cfg(unix)]
            signals: Some(signals),
            stop: Arc::new(AtomicBool::new(false)),
            probe,
        })
    }
}

/// How often the input thread looks whether the loop has ended (it does not wake the loop).
const STOP_CHECK: Duration = Duration::from_millis(100);

impl Events for TerminalEvents {
    fn start(&mut self, tx: &Sender<Msg>) -> io::Result<()> {
        #[cfg(unix)]
        if let Some(mut signals) = self.signals.take() {
            let tx = tx.clone();
            std::thread::Builder::new().name("metamer-signals".into()).spawn(move || {
                for _ in signals.forever() {
                    if tx.send(Msg::Terminated).is_err() {
                        return;
                    }
                }
            })?;
        }
        // The question is written here, on the loop's thread between two draws; the answers are read by the
        // input thread before anything else, so the keys typed meanwhile are its too.
        let probe = match self.probe.take().map(Graphics::ask_terminal) {
            None => None,
            Some(Ok(Some(probe))) => Some(probe),
            Some(asked) => {
                let warning =
                    asked.err().map(|e| format!("cannot ask the terminal for its graphics ({e}): half blocks"));
                let _ = tx.send(Msg::Graphics { graphics: Graphics::halfblocks(), warning });
                None
            }
        };
        let (tx, stop) = (tx.clone(), self.stop.clone());
        std::thread::Builder::new().name("metamer-input".into()).spawn(move || {
            if let Some(probe) = probe {
                let mut reader = ProbeReader::default();
                read_answers(&mut reader);
                let (graphics, warning) = Graphics::from_answers(&probe, &reader.responses, reader.done);
                for key in reader.keys.drain(..) {
                    if tx.send(Msg::Key(key)).is_err() {
                        return;
                    }
                }
                if tx.send(Msg::Graphics { graphics, warning }).is_err() {
                    return;
                }
            }
            while !stop.load(Ordering::Relaxed) {
                let msg = match event::poll(STOP_CHECK) {
                    Ok(false) => continue,
                    Ok(true) => match event::read() {
                        Ok(Event::Key(k)) => Msg::Key(k),
                        Ok(Event::Mouse(m)) if wanted(&m) => Msg::Mouse(m),
                        Ok(Event::Resize(width, height)) => Msg::Resize { width, height },
                        Ok(_) => continue,
                        Err(_) => Msg::End,
                    },
                    Err(_) => Msg::End,
                };
                let end = matches!(msg, Msg::End);
                if tx.send(msg).is_err() || end {
                    return;
                }
            }
        })?;
        Ok(())
    }
}

/// The mouse events the designer acts on (presses, drags and releases of the buttons); moves and the
/// wheel are not sent to the loop.
fn wanted(m: &event::MouseEvent) -> bool {
    use event::MouseEventKind as M;
    matches!(m.kind, M::Down(_) | M::Drag(_) | M::Up(_))
}

/// How long the probe waits for the terminal's answers (over SSH: a round trip). Keys typed meanwhile
/// are queued, not lost; without an answer the preview is drawn in half blocks.
const PROBE_DEADLINE: Duration = Duration::from_millis(1000);

/// Read standard input's raw bytes into `reader` until the terminal's status answer or the deadline (no
/// read outlives it, so no later key goes astray).
#[cfg(unix)]
fn read_answers(reader: &mut ProbeReader) {
    use std::os::fd::AsRawFd;
    let fd = io::stdin().as_raw_fd();
    let deadline = std::time::Instant::now() + PROBE_DEADLINE;
    let mut buf = [0u8; 256];
    while !reader.done {
        let left = deadline.saturating_duration_since(std::time::Instant::now());
        if left.is_zero() {
            break;
        }
        let mut pfd = libc::pollfd { fd, events: libc::POLLIN, revents: 0 };
        let ms = libc::c_int::try_from(left.as_millis().max(1)).unwrap_or(libc::c_int::MAX);
        // SAFETY: one valid pollfd, for the duration of the call.
        let ready = unsafe { libc::poll(&mut pfd, 1, ms) };
        if ready < 0 && io::Error::last_os_error().kind() == io::ErrorKind::Interrupted {
            continue;
        }
        if ready <= 0 || pfd.revents & libc::POLLIN == 0 {
            break;
        }
        // SAFETY: reads at most buf.len() bytes into buf, which outlives the call.
        let n = unsafe { libc::read(fd, buf.as_mut_ptr().cast(), buf.len()) };
        match usize::try_from(n) {
            Ok(0) | Err(_) => break,
            Ok(n) => reader.push(&buf[..n]),
        }
    }
    reader.finish();
}

#[cfg(not(unix))]
fn read_answers(reader: &mut ProbeReader) {
    reader.finish();
}

impl Drop for TerminalEvents {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        #[cfg(unix)]
        if let Some(h) = self.handle.take() {
            h.close();
        }
    }
}
