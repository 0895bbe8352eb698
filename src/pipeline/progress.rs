//! Progress of long loops: an indicatif bar on a terminal; when stderr is a file or a pipe
//! (a run under nohup or a batch scheduler), plain lines at every 10% and at least every
//! five minutes, which a log keeps; nothing in quiet mode.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;
use std::sync::{Arc, Mutex};
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
    start: Instant,
    last_line: Instant,
    /// Position at the last line (0 before the first).
    last_pos: u64,
}

impl Progress {
    /// A bar counting to `total` (e.g. simulated time in µs, or steps), labelled `label`.
    pub fn new(label: &str, total: u64, quiet: bool) -> Self {
        let bar = ProgressBar::with_draw_target(Some(total), ProgressDrawTarget::stderr());
        let to_log = !quiet && !std::io::stderr().is_terminal();
        if quiet || to_log {
            bar.set_draw_target(ProgressDrawTarget::hidden());
        }
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
                start: now,
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
        self.bar.set_position(pos);
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
        let due = percent(pos) / LOG_PERCENT > percent(self.last_pos) / LOG_PERCENT
            || (pos > self.last_pos && now - self.last_line >= LOG_INTERVAL);
        if !due || pos == 0 {
            return;
        }
        let elapsed = now - self.start;
        // Remaining time at the mean rate so far.
        let eta = elapsed.mul_f64((self.total - pos) as f64 / pos as f64);
        eprintln!(
            "{:>22} {:>3}% after {}, eta {} ({msg})",
            self.label,
            percent(pos),
            clock(elapsed),
            clock(eta)
        );
        self.last_line = now;
        self.last_pos = pos;
    }
}

/// h:mm:ss.
fn clock(d: Duration) -> String {
    let s = d.as_secs();
    format!("{}:{:02}:{:02}", s / 3600, s / 60 % 60, s % 60)
}
