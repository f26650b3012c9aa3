//! Progress on standard error while a job runs, so that a search of many
//! parts or a slow descriptor does not look like a hang: one line redrawn
//! in place on a terminal, or plain lines (`--progress` into a file or a
//! pipe), at most a few a second. A terminal shows nothing for a job that
//! ends within [`QUIET_START`].

use std::io::Write;
use std::ops::ControlFlow;
use std::time::{Duration, Instant};

use fast_reject::{LayerStats, Observer, Progress};

/// A job shorter than this shows nothing on a terminal.
const QUIET_START: Duration = Duration::from_millis(500);

/// How often a terminal's line is redrawn.
const TERMINAL_EVERY: Duration = Duration::from_millis(100);

/// How often a plain line is written: a log, not an animation.
const LINES_EVERY: Duration = Duration::from_secs(1);

/// How progress is shown.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Mode {
    Off,
    /// Redrawn in place with a carriage return.
    Terminal,
    /// One line per report.
    Lines,
}

/// The job's progress as a line on standard error.
pub struct ProgressLine {
    mode: Mode,
    started: Instant,
    drawn: Option<Instant>,
    /// Whether a terminal line is on screen, to be cleared.
    on_screen: bool,
    phase: &'static str,
    step: Option<Progress>,
    /// When the step began, for the time left.
    step_started: Instant,
    layer: Option<(&'static str, usize)>,
}

impl ProgressLine {
    /// Shows progress when standard error is a terminal, or everywhere when
    /// `asked` (the `--progress` flag).
    pub fn new(asked: bool) -> ProgressLine {
        use std::io::IsTerminal;
        let mode = if std::io::stderr().is_terminal() {
            Mode::Terminal
        } else if asked {
            Mode::Lines
        } else {
            Mode::Off
        };
        ProgressLine {
            mode,
            started: Instant::now(),
            drawn: None,
            on_screen: false,
            phase: "starting",
            step: None,
            step_started: Instant::now(),
            layer: None,
        }
    }

    /// The job moves on to `phase` ("loading the scene", "searching").
    pub fn phase(&mut self, phase: &'static str) {
        self.phase = phase;
        self.step = None;
        self.layer = None;
        self.draw(true);
    }

    /// Clears the terminal's line before the report is printed.
    pub fn finish(&mut self) {
        if self.on_screen {
            let _ = write!(std::io::stderr(), "\r\x1b[K");
            self.on_screen = false;
        }
    }

    fn text(&self) -> String {
        let mut text = format!(
            "[{:5.1} s] {}",
            self.started.elapsed().as_secs_f64(),
            self.phase
        );
        if let Some(p) = self.step {
            text += &format!(
                ": {} {} of {} ({:.0}%)",
                p.step,
                p.done,
                p.total,
                100.0 * p.share()
            );
            let spent = self.step_started.elapsed().as_secs_f64();
            // Told once the pace is known: a few seconds and a few per cent.
            if spent > 2.0 && p.share() >= 0.05 && p.share() < 1.0 {
                let left = spent * (1.0 - p.share()) / p.share();
                text += &format!(", about {left:.0} s left");
            }
        }
        // Parts searched side by side report their layers together: one
        // part's layer says nothing of the search's progress.
        let per_layer = self.step.is_none_or(|p| p.step == Progress::WINDOWS);
        if let (Some((descriptor, layer)), true) = (self.layer, per_layer) {
            text += &format!(", {descriptor} layer {layer}");
        }
        text
    }

    /// Draws the line if it is time to; `changed` (a new phase) draws it
    /// at once once the quiet start has passed.
    fn draw(&mut self, changed: bool) {
        let now = Instant::now();
        // Asked for, every phase is logged; on a terminal, a short job
        // does not flicker.
        let quiet = self.mode == Mode::Terminal && now - self.started < QUIET_START;
        if self.mode == Mode::Off || quiet {
            return;
        }
        let every = match self.mode {
            Mode::Terminal => TERMINAL_EVERY,
            _ => LINES_EVERY,
        };
        if !changed && self.drawn.is_some_and(|t| now - t < every) {
            return;
        }
        self.drawn = Some(now);
        let text = self.text();
        let mut err = std::io::stderr().lock();
        // Progress is a courtesy: a closed standard error stops nothing.
        let _ = match self.mode {
            Mode::Terminal => write!(err, "\r\x1b[K{text}"),
            _ => writeln!(err, "{text}"),
        };
        let _ = err.flush();
        self.on_screen = self.mode == Mode::Terminal;
    }
}

impl Observer for ProgressLine {
    fn on_layer(&mut self, stats: &LayerStats) -> ControlFlow<()> {
        self.layer = Some((stats.descriptor, stats.layer));
        self.draw(false);
        ControlFlow::Continue(())
    }

    fn on_progress(&mut self, progress: &Progress) -> ControlFlow<()> {
        if progress.done == 0 || self.step.is_none_or(|p| p.step != progress.step) {
            self.step_started = Instant::now();
        }
        self.step = Some(*progress);
        self.draw(false);
        ControlFlow::Continue(())
    }
}

impl Drop for ProgressLine {
    fn drop(&mut self) {
        self.finish();
    }
}
