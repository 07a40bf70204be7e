//! The progress line of long work (a render, `conformance`'s cases,
//! `bench`'s frames): how far it is, on stderr, with the time it has taken
//! and an estimate of what is left. On a terminal indicatif draws it (in
//! place, at most a few times a second, fitted to the terminal's width);
//! the text is this module's. A status line printed meanwhile (`outln!`,
//! `errln!`) clears it first and it is drawn again below (`suspend`).

use crate::render::{Progress, Told};
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::sync::Mutex;
use std::time::{Duration, Instant};

/// How long a render runs before a terminal is shown its progress: a
/// quick one prints no line to clear.
const SHOW_AFTER: Duration = Duration::from_secs(1);
/// How often a terminal's line is redrawn at most (indicatif's rate):
/// every 200 ms.
const REDRAWS_PER_SECOND: u8 = 5;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Mode {
    /// stderr is not a terminal, or `-q`: nothing (a log is not littered,
    /// a quiet command says nothing).
    Off,
    /// One line redrawn in place, from the render's first second on.
    Terminal,
    /// `RAYCAST_PROGRESS=1`: every step on a line of its own, at once
    /// (`progress: …`), for scripts and tests; asked for by name, so `-q`
    /// does not hide them.
    Lines,
}

/// The mode for a process where `RAYCAST_PROGRESS=1` is set (`lines`),
/// `-q` was given (`quiet`), and stderr is a terminal (`terminal`).
fn mode(lines: bool, quiet: bool, terminal: bool) -> Mode {
    if lines {
        Mode::Lines
    } else if terminal && !quiet {
        Mode::Terminal
    } else {
        Mode::Off
    }
}

/// The terminal's progress line while one is shown, for `suspend`.
static SHOWN: Mutex<Option<ProgressBar>> = Mutex::new(None);

/// Runs `print` with the progress line on the terminal, if one is shown,
/// cleared for it and drawn again after: a status line printed while a
/// long piece of work runs does not land on top of the line.
pub fn suspend<T>(print: impl FnOnce() -> T) -> T {
    let shown = SHOWN.lock().unwrap_or_else(|e| e.into_inner()).clone();
    match shown {
        Some(bar) => bar.suspend(print),
        None => print(),
    }
}

/// Runs `work` with the progress line of `label` to tell, cleared after it.
pub fn told<T>(label: impl Into<String>, work: impl FnOnce(Told) -> T) -> T {
    let mode = mode(
        std::env::var("RAYCAST_PROGRESS").is_ok_and(|v| v == "1"),
        !crate::says(crate::Verbosity::Summary),
        std::io::stderr().is_terminal(),
    );
    let line =
        ProgressLine::new(label, mode, Instant::now(), || ProgressDrawTarget::stderr_with_hz(REDRAWS_PER_SECOND));
    let out = work(&|step| line.tell(step));
    line.finish();
    out
}

/// The progress of one picture's render (`tell` from any thread).
struct ProgressLine {
    label: String,
    start: Instant,
    mode: Mode,
    /// The terminal's line: drawing nowhere until it is first shown.
    bar: ProgressBar,
    /// Where `bar` draws once shown (stderr; a test's terminal).
    target: fn() -> ProgressDrawTarget,
    /// The last fraction shown (None: nothing shown yet).
    shown: Mutex<Option<f64>>,
}

impl ProgressLine {
    /// For the picture `label` names, started at `start`.
    fn new(label: impl Into<String>, mode: Mode, start: Instant, target: fn() -> ProgressDrawTarget) -> ProgressLine {
        let style = ProgressStyle::with_template("{wide_msg}").expect("a template of one placeholder");
        let bar = ProgressBar::with_draw_target(None, ProgressDrawTarget::hidden()).with_style(style);
        ProgressLine { label: label.into(), start, mode, bar, target, shown: Mutex::new(None) }
    }

    /// Shows `p` where the mode says to; a step behind one already shown
    /// (threads finishing out of order) is dropped.
    fn tell(&self, p: Progress) {
        if self.mode == Mode::Off {
            return;
        }
        let elapsed = self.start.elapsed();
        let mut shown = self.shown.lock().unwrap_or_else(|e| e.into_inner());
        if shown.is_some_and(|fraction| p.fraction < fraction) {
            return;
        }
        if self.mode == Mode::Terminal {
            if elapsed < SHOW_AFTER {
                return;
            }
            if shown.is_none() {
                self.bar.set_draw_target((self.target)());
                *SHOWN.lock().unwrap_or_else(|e| e.into_inner()) = Some(self.bar.clone());
            }
            self.bar.set_message(self.text(&p, elapsed));
        } else {
            let mut err = std::io::stderr().lock();
            let _ = writeln!(err, "progress: {}", self.text(&p, elapsed));
            let _ = err.flush();
        }
        *shown = Some(p.fraction);
    }

    /// Clears the terminal's line, if it showed one (the render's own
    /// lines follow).
    fn finish(&self) {
        if self.shown.lock().unwrap_or_else(|e| e.into_inner()).is_some() && self.mode == Mode::Terminal {
            *SHOWN.lock().unwrap_or_else(|e| e.into_inner()) = None;
        }
        self.bar.finish_and_clear();
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
        let line = ProgressLine::new("a.png", Mode::Lines, Instant::now(), ProgressDrawTarget::hidden);
        let p = Progress { fraction: 0.25, detail: "sample 1 of 4".into() };
        assert_eq!(line.text(&p, Duration::from_secs(3)), "a.png: 25% (sample 1 of 4), 3.0 s so far, about 9.0 s left");
        let p = Progress { fraction: 1.0, detail: "sample 4 of 4".into() };
        assert_eq!(line.text(&p, Duration::from_secs(12)), "a.png: 100% (sample 4 of 4), 12 s so far");
    }

    /// `RAYCAST_PROGRESS=1` prints lines whatever else holds; a terminal
    /// gets the line unless `-q`; anything else, nothing.
    #[test]
    fn quiet_hides_the_terminal_line_but_not_the_lines_asked_for() {
        assert_eq!(mode(true, true, false), Mode::Lines);
        assert_eq!(mode(true, false, true), Mode::Lines);
        assert_eq!(mode(false, false, true), Mode::Terminal);
        assert_eq!(mode(false, true, true), Mode::Off);
        assert_eq!(mode(false, false, false), Mode::Off);
    }

    /// What a terminal was sent: each line written, and each clearing as "<clear>".
    static SCREEN: Mutex<Vec<String>> = Mutex::new(Vec::new());

    /// A terminal 100 columns wide that keeps what it is sent in SCREEN.
    #[derive(Debug)]
    struct Screen;

    impl indicatif::TermLike for Screen {
        fn width(&self) -> u16 {
            100
        }
        fn move_cursor_up(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_down(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_right(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn move_cursor_left(&self, _: usize) -> std::io::Result<()> {
            Ok(())
        }
        fn write_line(&self, s: &str) -> std::io::Result<()> {
            SCREEN.lock().unwrap().push(s.to_string());
            Ok(())
        }
        fn write_str(&self, s: &str) -> std::io::Result<()> {
            self.write_line(s)
        }
        fn clear_line(&self) -> std::io::Result<()> {
            SCREEN.lock().unwrap().push("<clear>".into());
            Ok(())
        }
        fn flush(&self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// On a terminal: nothing in the first second, then the text, never a
    /// step behind, and cleared at the end.
    #[test]
    fn a_terminal_sees_the_text_after_a_second_and_it_is_cleared() {
        let step = |fraction: f64, n: u32| Progress { fraction, detail: format!("sample {n} of 4") };
        let screen = || ProgressDrawTarget::term_like(Box::new(Screen));
        let quick = ProgressLine::new("quick.png", Mode::Terminal, Instant::now(), screen);
        quick.tell(step(0.5, 2));
        quick.finish();
        assert!(SCREEN.lock().unwrap().is_empty(), "{:?}", SCREEN.lock().unwrap());

        let long = ProgressLine::new("long.png", Mode::Terminal, Instant::now() - Duration::from_secs(4), screen);
        long.tell(step(0.5, 2));
        long.tell(step(0.25, 1));
        let drawn: Vec<String> =
            SCREEN.lock().unwrap().iter().filter(|l| !l.trim().is_empty() && *l != "<clear>").cloned().collect();
        assert_eq!(drawn.len(), 1, "{drawn:?}");
        assert!(
            drawn[0].starts_with("long.png: 50% (sample 2 of 4), 4.") && drawn[0].ends_with(" s left"),
            "{drawn:?}"
        );
        long.finish();
        assert_eq!(SCREEN.lock().unwrap().last().map(String::as_str), Some("<clear>"));
    }
}
