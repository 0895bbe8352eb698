//! One run at a time per output folder: a lock file holding the holder's pid, created
//! exclusively and complete (hard link); a lock whose process is gone is stale and taken
//! over.

use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

pub struct Lock {
    path: PathBuf,
}

impl Lock {
    /// Takes the lock at `path`, or says which live process holds it. The pid is written to
    /// a file of this process's own first and hard-linked to `path`, which fails if `path`
    /// exists: the lock never appears empty, so a run starting at the same moment cannot
    /// read it as stale and take it over.
    pub fn take(path: &Path) -> Result<Lock, String> {
        let err = |p: &Path, e: std::io::Error| format!("{}: {e}", p.display());
        if let Some(dir) = path.parent() {
            fs::create_dir_all(dir).map_err(|e| err(dir, e))?;
        }
        // unique per call: threads of one process share its pid
        static CALLS: AtomicU64 = AtomicU64::new(0);
        let call = CALLS.fetch_add(1, Ordering::Relaxed);
        let own = path.with_extension(format!("pid-{}-{call}", std::process::id()));
        let mut f = fs::File::create(&own).map_err(|e| err(&own, e))?;
        writeln!(f, "{}", std::process::id())
            .and_then(|_| f.sync_all())
            .map_err(|e| err(&own, e))?;
        let taken = Self::link(&own, path);
        let _ = fs::remove_file(&own);
        taken
    }

    fn link(own: &Path, path: &Path) -> Result<Lock, String> {
        for _ in 0..2 {
            match fs::hard_link(own, path) {
                Ok(()) => {
                    return Ok(Lock {
                        path: path.to_path_buf(),
                    });
                }
                Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => {
                    let holder = fs::read_to_string(path).unwrap_or_default();
                    let pid: Option<u32> = holder.trim().parse().ok();
                    if pid.is_some_and(alive) {
                        return Err(format!(
                            "another softgrain run (pid {}) is writing to this folder; lock {}",
                            pid.unwrap_or(0),
                            path.display()
                        ));
                    }
                    // stale: its process is gone (or the file is unreadable)
                    let _ = fs::remove_file(path);
                }
                Err(e) => return Err(format!("{}: {e}", path.display())),
            }
        }
        Err(format!("could not take the lock {}", path.display()))
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
}

/// Whether a process with this pid exists (Linux: /proc).
fn alive(pid: u32) -> bool {
    pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Barrier};

    #[test]
    fn of_runs_starting_together_exactly_one_takes_the_lock() {
        let dir = std::env::temp_dir().join(format!("softgrain-lock-{}", std::process::id()));
        for round in 0..200 {
            let path = dir.join(format!("{round}/.lock"));
            let start = Arc::new(Barrier::new(4));
            let threads: Vec<_> = (0..4)
                .map(|_| {
                    let (path, start) = (path.clone(), start.clone());
                    std::thread::spawn(move || {
                        start.wait();
                        Lock::take(&path)
                    })
                })
                .collect();
            // every lock is held until all threads have tried
            let held: Vec<Result<Lock, String>> =
                threads.into_iter().map(|t| t.join().unwrap()).collect();
            let taken = held.iter().filter(|r| r.is_ok()).count();
            assert_eq!(taken, 1, "round {round}: {taken} holders");
        }
        let _ = fs::remove_dir_all(&dir);
    }
}
