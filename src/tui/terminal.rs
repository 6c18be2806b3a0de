//! The real terminal: raw mode and the alternate screen, restored by a guard on every way out — normal
//! return, error, and (through ratatui's panic hook) a panic.

use crate::tui::event_loop::{Events, Input};
use ratatui::DefaultTerminal;
use ratatui::crossterm::event::{self, Event};
use std::io;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Owns the terminal while the designer runs; restores it when dropped.
pub struct TerminalGuard {
    pub terminal: DefaultTerminal,
}

impl TerminalGuard {
    /// Enter raw mode and the alternate screen; installs a panic hook that restores the terminal first.
    /// Without a terminal on both standard input and output it fails before writing anything (no stray
    /// escape sequences in a redirected output).
    pub fn enter() -> io::Result<TerminalGuard> {
        use std::io::IsTerminal;
        if !(io::stdin().is_terminal() && io::stdout().is_terminal()) {
            return Err(io::Error::other("standard input and output are not both a terminal"));
        }
        match ratatui::try_init() {
            Ok(terminal) => Ok(TerminalGuard { terminal }),
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
        ratatui::restore();
    }
}

/// Keys and resizes from the terminal, and the end signals (SIGTERM, SIGHUP) as [`Input::Terminated`].
pub struct TerminalEvents {
    terminated: Arc<AtomicBool>,
}

impl TerminalEvents {
    /// Listen to the terminal, and to SIGTERM and SIGHUP (whose default action would leave the terminal in
    /// raw mode on the alternate screen and lose unsaved work).
    pub fn new() -> io::Result<TerminalEvents> {
        let terminated = Arc::new(AtomicBool::new(false));
        #[cfg(unix)]
        for signal in [signal_hook::consts::SIGTERM, signal_hook::consts::SIGHUP] {
            signal_hook::flag::register(signal, terminated.clone())?;
        }
        Ok(TerminalEvents { terminated })
    }
}

/// How often a wait for input looks at the end signals.
const SIGNAL_CHECK: Duration = Duration::from_millis(50);

impl Events for TerminalEvents {
    fn next(&mut self, timeout: Duration) -> io::Result<Option<Input>> {
        let mut left = timeout;
        loop {
            if self.terminated.load(Ordering::Relaxed) {
                return Ok(Some(Input::Terminated));
            }
            let slice = left.min(SIGNAL_CHECK);
            if event::poll(slice)? {
                break;
            }
            left = left.saturating_sub(slice);
            if left.is_zero() {
                return Ok(None);
            }
        }
        Ok(match event::read()? {
            Event::Key(k) => Some(Input::Key(k)),
            Event::Resize(_, _) => Some(Input::Resize),
            _ => None,
        })
    }
}
