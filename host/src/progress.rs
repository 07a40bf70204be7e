//! `render`'s progress line: how far a long render is, on stderr, with the
//! time it has taken and an estimate of what is left.

use crate::render::{Progress, Told};
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long a render runs before a terminal is shown its progress: a
/// quick one prints no line to clear.
const SHOW_AFTER: Duration = Duration::from_secs(1);
/// The least time between two rewrites of the terminal's line.
const REWRITE_EVERY: Duration = Duration::from_millis(200);

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    /// stderr is not a terminal: nothing (a log is not littered).
    Off,
    /// One line rewritten in place, from the render's first second on.
    Terminal,
    /// `RAYCAST_PROGRESS=1`: every step on a line of its own, at once
    /// (`progress: …`), for scripts and tests.
    Lines,
}

/// Runs `work` with the progress line of `label` to tell, cleared after it.
pub fn told<T>(label: impl Into<String>, work: impl FnOnce(Told) -> T) -> T {
    let line = ProgressLine::new(label);
    let out = work(&|step| line.tell(step));
    line.finish();
    out
}

/// The progress of one picture's render (`tell` from any thread).
struct ProgressLine {
    label: String,
    start: Instant,
    mode: Mode,
    /// The last fraction shown and when (None: nothing shown yet).
    shown: Mutex<Option<(f64, Instant)>>,
}

impl ProgressLine {
    /// For the picture `label` names, started now.
    fn new(label: impl Into<String>) -> ProgressLine {
        let mode = if std::env::var("RAYCAST_PROGRESS").is_ok_and(|v| v == "1") {
            Mode::Lines
        } else if std::io::stderr().is_terminal() {
            Mode::Terminal
        } else {
            Mode::Off
        };
        ProgressLine { label: label.into(), start: Instant::now(), mode, shown: Mutex::new(None) }
    }

    /// Shows `p` where the mode says to; a step behind one already shown
    /// (threads finishing out of order) is dropped.
    fn tell(&self, p: Progress) {
        if self.mode == Mode::Off {
            return;
        }
        let now = Instant::now();
        let elapsed = now - self.start;
        let mut shown = self.shown.lock().unwrap_or_else(|e| e.into_inner());
        if shown.is_some_and(|(fraction, _)| p.fraction < fraction) {
            return;
        }
        if self.mode == Mode::Terminal
            && (elapsed < SHOW_AFTER || shown.is_some_and(|(_, at)| now - at < REWRITE_EVERY && p.fraction < 1.0))
        {
            return;
        }
        let text = self.text(&p, elapsed);
        let mut err = std::io::stderr().lock();
        let _ = match self.mode {
            Mode::Terminal => write!(err, "\r{text}\x1b[K"),
            _ => writeln!(err, "progress: {text}"),
        };
        let _ = err.flush();
        *shown = Some((p.fraction, now));
    }

    /// Clears the terminal's line, if it showed one (the render's own
    /// lines follow).
    fn finish(&self) {
        let shown = self.shown.lock().unwrap_or_else(|e| e.into_inner());
        if self.mode == Mode::Terminal && shown.is_some() {
            let mut err = std::io::stderr().lock();
            let _ = write!(err, "\r\x1b[K");
            let _ = err.flush();
        }
    }

    /// "default.png: 37% (sample 6 of 16), 4.1 s so far, about 7 s left".
    fn text(&self, p: &Progress, elapsed: Duration) -> String {
        let fraction = p.fraction.clamp(0.0, 1.0);
        let left = if fraction > 0.0 && fraction < 1.0 {
            format!(", about {} left", span(elapsed.as_secs_f64() * (1.0 - fraction) / fraction))
        } else {
            String::new()
        };
        format!(
            "{}: {:.0}% ({}), {} so far{left}",
            self.label,
            (fraction * 100.0).floor(),
            p.detail,
            span(elapsed.as_secs_f64())
        )
    }
}

/// A span of seconds as a person reads it: "0.4 s", "12 s", "3 min 05 s", "1 h 02 min".
fn span(seconds: f64) -> String {
    let whole = seconds.round() as u64;
    match whole {
        _ if seconds < 9.95 => format!("{seconds:.1} s"),
        0..60 => format!("{whole} s"),
        60..3600 => format!("{} min {:02} s", whole / 60, whole % 60),
        _ => format!("{} h {:02} min", whole / 3600, whole / 60 % 60),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_read_as_a_person_says_them() {
        assert_eq!(span(0.42), "0.4 s");
        assert_eq!(span(12.4), "12 s");
        assert_eq!(span(185.0), "3 min 05 s");
        assert_eq!(span(3725.0), "1 h 02 min");
    }

    #[test]
    fn the_text_says_the_share_the_step_and_the_time_left() {
        let line =
            ProgressLine { label: "a.png".into(), start: Instant::now(), mode: Mode::Lines, shown: Mutex::new(None) };
        let p = Progress { fraction: 0.25, detail: "sample 1 of 4".into() };
        assert_eq!(line.text(&p, Duration::from_secs(3)), "a.png: 25% (sample 1 of 4), 3.0 s so far, about 9.0 s left");
        let p = Progress { fraction: 1.0, detail: "sample 4 of 4".into() };
        assert_eq!(line.text(&p, Duration::from_secs(12)), "a.png: 100% (sample 4 of 4), 12 s so far");
    }
}
