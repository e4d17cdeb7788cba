//! Progress where stderr is not a terminal (a log file, a pipe, a batch
//! job): the bar's text as a line every few seconds instead of a bar redrawn
//! in place, so that a long render or animation is seen to advance.
//!
//! An indicatif draw target: the bar draws itself into [`Lines`], which
//! prints what was drawn at most once per interval.

use std::io;
use std::sync::Mutex;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, TermLike};

/// Seconds between lines. `TWINRAY_PROGRESS_SECONDS` changes it (the tests
/// use a fraction of a second).
const EVERY_SECONDS: f64 = 5.0;

/// A bar of `template` (its `{spinner}` and `{bar…}` left out) that prints a
/// line every few seconds.
pub fn bar(template: &str) -> ProgressBar {
    let every = std::env::var("TWINRAY_PROGRESS_SECONDS")
        .ok()
        .and_then(|s| s.parse::<f64>().ok())
        .filter(|s| s.is_finite() && *s > 0.0)
        .unwrap_or(EVERY_SECONDS);
    let every = Duration::from_secs_f64(every);
    let lines = Lines {
        every,
        state: Mutex::new(State {
            line: String::new(),
            last: Instant::now(),
        }),
    };
    let b = ProgressBar::with_draw_target(Some(1), ProgressDrawTarget::term_like(Box::new(lines)));
    b.set_style(
        indicatif::ProgressStyle::with_template(&plain(template))
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    // Redrawn while nothing advances, so that a line is due on time.
    b.enable_steady_tick(every.min(Duration::from_secs(1)));
    b
}

/// `template` without the parts that only a terminal shows: the spinner and
/// the bar itself.
fn plain(template: &str) -> String {
    let mut out = Vec::new();
    for word in template.split(' ') {
        let drawn = word.starts_with("{spinner") || word.starts_with("[{bar");
        if !drawn && !word.is_empty() {
            out.push(word);
        }
    }
    out.join(" ")
}

#[derive(Debug)]
struct Lines {
    every: Duration,
    state: Mutex<State>,
}

#[derive(Debug)]
struct State {
    /// What the bar drew since the last flush.
    line: String,
    /// When a line was last printed (at first: when the bar began).
    last: Instant,
}

impl Lines {
    fn state(&self) -> std::sync::MutexGuard<'_, State> {
        // A poisoned lock only means a panic elsewhere: the text is still usable.
        self.state
            .lock()
            .unwrap_or_else(std::sync::PoisonError::into_inner)
    }
}

impl TermLike for Lines {
    fn width(&self) -> u16 {
        // Wide enough that indicatif never wraps the line.
        500
    }

    fn move_cursor_up(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_down(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_right(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn move_cursor_left(&self, _: usize) -> io::Result<()> {
        Ok(())
    }

    fn write_line(&self, s: &str) -> io::Result<()> {
        self.write_str(s)
    }

    fn write_str(&self, s: &str) -> io::Result<()> {
        self.state().line.push_str(s);
        Ok(())
    }

    fn clear_line(&self) -> io::Result<()> {
        self.state().line.clear();
        Ok(())
    }

    fn flush(&self) -> io::Result<()> {
        let mut state = self.state();
        let line = std::mem::take(&mut state.line);
        let line = line.trim_matches(|c: char| c.is_whitespace() || c == '\r');
        if !line.is_empty() && state.last.elapsed() >= self.every {
            state.last = Instant::now();
            eprintln!("twinray: {line}");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_spinner_and_the_bar_are_left_out() {
        assert_eq!(
            plain("{spinner} rendering [{bar:40}] {percent:>3}% {elapsed_precise} eta {eta}"),
            "rendering {percent:>3}% {elapsed_precise} eta {eta}"
        );
    }

    #[test]
    fn a_line_at_most_once_an_interval() {
        let lines = Lines {
            every: Duration::from_secs(3600),
            state: Mutex::new(State {
                line: String::new(),
                last: Instant::now(),
            }),
        };
        lines.write_str("\rrendering 10%   ").unwrap();
        lines.flush().unwrap();
        let printed = lines.state().last;
        // Not due: the drawn text is dropped, the clock not reset.
        assert!(lines.state().line.is_empty());
        lines.write_str("rendering 20%").unwrap();
        lines.flush().unwrap();
        assert_eq!(lines.state().last, printed);
    }
}
