//! Progress of long loops: an indicatif bar on a terminal; when stderr is a file or a pipe
//! (a run under nohup or a batch scheduler), plain lines at every 10% and at least every
//! five minutes, which a log keeps; nothing in quiet mode. The bars of stages running side
//! by side (independent cases, `super::run`) share the terminal through one `MultiProgress`.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};

/// At most this long between two log lines while the loop advances.
const LOG_INTERVAL: Duration = Duration::from_secs(300);
/// A log line at every this many percent.
const LOG_PERCENT: u64 = 10;

#[derive(Clone)]
pub struct Progress {
    bar: ProgressBar,
    /// Set when progress goes to a log instead of a bar.
    log: Option<Arc<Mutex<Log>>>,
}

struct Log {
    label: String,
    total: u64,
    /// The first position reported and when: a stage resumed from a snapshot starts at
    /// its snapshot's position, and its rate counts from there.
    origin: Option<(u64, Instant)>,
    last_line: Instant,
    /// Position at the last line (0 before the first).
    last_pos: u64,
}

impl Progress {
    /// A bar counting to `total` (e.g. simulated time in µs, or steps), labelled `label`.
    pub fn new(label: &str, total: u64, quiet: bool) -> Self {
        static BARS: OnceLock<MultiProgress> = OnceLock::new();
        let to_log = !quiet && !std::io::stderr().is_terminal();
        let bar = if quiet || to_log {
            ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::hidden())
        } else {
            BARS.get_or_init(MultiProgress::new)
                .add(ProgressBar::new(total))
        };
        bar.set_style(
            ProgressStyle::with_template(
                "{prefix:>22} [{bar:30}] {percent:>3}% {elapsed_precise} eta {eta} {msg}",
            )
            .expect("template")
            .progress_chars("=> "),
        );
        bar.set_prefix(label.to_string());
        let log = to_log.then(|| {
            let now = Instant::now();
            Arc::new(Mutex::new(Log {
                label: label.to_string(),
                total: total.max(1),
                origin: None,
                last_line: now,
                last_pos: 0,
            }))
        });
        Progress { bar, log }
    }

    /// Where the loop stands, e.g. "40% (ε = 0.008, 13 sweeps/step)".
    pub fn describe(&self) -> String {
        let total = self.bar.length().unwrap_or(0).max(1);
        let percent = 100 * self.bar.position().min(total) / total;
        match self.bar.message() {
            m if m.is_empty() => format!("{percent}%"),
            m => format!("{percent}% ({m})"),
        }
    }

    pub fn set(&self, pos: u64, msg: impl Into<String>) {
        let msg = msg.into();
        if let Some(log) = &self.log {
            log.lock().expect("progress log").line(pos, &msg);
        }
        let first = self.bar.position() == 0;
        self.bar.set_position(pos);
        if first {
            // a resumed stage's first position is its snapshot's, not this run's work
            self.bar.reset_eta();
        }
        self.bar.set_message(msg);
    }

    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}

impl Log {
    /// Prints "label  40% after 0:12:03, eta 0:18:04 (msg)" when due: at each multiple of
    /// 10%, or when the loop advanced and the last line is five minutes old.
    fn line(&mut self, pos: u64, msg: &str) {
        let pos = pos.min(self.total);
        let percent = |pos: u64| pos * 100 / self.total;
        let now = Instant::now();
        let (from, start) = *self.origin.get_or_insert((pos, now));
        let due = percent(pos) / LOG_PERCENT > percent(self.last_pos) / LOG_PERCENT
            || (pos > self.last_pos && now - self.last_line >= LOG_INTERVAL);
        if !due || pos == 0 {
            return;
        }
        let elapsed = now - start;
        let eta = remaining(elapsed, from, pos, self.total).map_or("?".into(), clock);
        eprintln!(
            "{:>22} {:>3}% after {}, eta {eta} ({msg})",
            self.label,
            percent(pos),
            clock(elapsed),
        );
        self.last_line = now;
        self.last_pos = pos;
    }
}

/// Remaining time at the mean rate since the run reached `from` (`elapsed` ago); `None`
/// before it has advanced.
fn remaining(elapsed: Duration, from: u64, pos: u64, total: u64) -> Option<Duration> {
    (pos > from).then(|| elapsed.mul_f64(total.saturating_sub(pos) as f64 / (pos - from) as f64))
}

/// h:mm:ss.
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_resumed_run_estimates_from_its_own_rate() {
        let min = Duration::from_secs(60);
        // fresh: 10% in 1 min leaves 9 min
        assert_eq!(remaining(min, 0, 10, 100), Some(9 * min));
        // resumed at 23%: 3% in 15 min leaves 74% at 5 min per percent
        assert_eq!(remaining(15 * min, 23, 26, 100), Some(370 * min));
        // not advanced yet: no estimate rather than a division by zero
        assert_eq!(remaining(min, 23, 23, 100), None);
    }
}
