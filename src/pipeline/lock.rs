//! One run at a time per output folder: an advisory lock (flock) on the folder's `.lock`
//! file, which also holds the holder's pid for the message. The kernel releases the lock
//! when its process ends, however it ends, so a killed run leaves nothing to take over.

use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{Read, Seek, Write};
use std::os::unix::fs::MetadataExt;
use std::path::{Path, PathBuf};

/// How many times `take` waits (1 ms each) for a status probe to let go before refusing.
const PROBE_WAITS: u32 = 1000;

pub struct Lock {
    path: PathBuf,
    /// Holds the lock until it is closed.
    _file: File,
}

impl Lock {
    /// Takes the lock at `path`, or says which process holds it.
    pub fn take(path: &Path) -> Result<Lock, String> {
        let err = |e: std::io::Error| format!("{}: {e}", path.display());
        if let Some(dir) = path.parent() {
            fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        }
        // A holder removes the file before it closes it, so the file opened here may be one
        // that was just removed: locked, it is ours only if `path` still names it.
        let mut probes_met = 0;
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(path)
                .map_err(err)?;
            match file.try_lock() {
                Ok(()) => {}
                // A shared holder is `holder`'s probe (`pipeline status`), which lets go at
                // once: wait for it rather than refuse. A run holds the lock exclusively.
                Err(TryLockError::WouldBlock)
                    if probes_met < PROBE_WAITS && file.try_lock_shared().is_ok() =>
                {
                    probes_met += 1;
                    drop(file);
                    std::thread::sleep(std::time::Duration::from_millis(1));
                    continue;
                }
                Err(TryLockError::WouldBlock) => {
                    let mut holder = String::new();
                    let _ = file.read_to_string(&mut holder);
                    let pid = match holder.trim() {
                        "" => "starting".to_string(),
                        pid => format!("pid {pid}"),
                    };
                    return Err(format!(
                        "another softgrain run ({pid}) is writing to this folder; lock {}",
                        path.display()
                    ));
                }
                Err(TryLockError::Error(e)) => return Err(err(e)),
            }
            let (ours, named) = (file.metadata().map_err(err)?, fs::metadata(path));
            if !named.is_ok_and(|m| m.dev() == ours.dev() && m.ino() == ours.ino()) {
                continue;
            }
            file.set_len(0)
                .and_then(|_| file.rewind())
                .and_then(|_| writeln!(file, "{}", std::process::id()))
                .map_err(err)?;
            return Ok(Lock {
                path: path.to_path_buf(),
                _file: file,
            });
        }
    }
}

/// The pid a run holding the lock at `path` wrote there, if a run holds it now. Probes
/// with a shared lock, released at once; a run starting at that instant waits for it.
pub fn holder(path: &Path) -> Option<String> {
    let mut file = File::open(path).ok()?;
    match file.try_lock_shared() {
        Err(TryLockError::WouldBlock) => {
            let mut pid = String::new();
            let _ = file.read_to_string(&mut pid);
            Some(pid.trim().to_string())
        }
        _ => None,
    }
}

impl Drop for Lock {
    /// Removes the file, then releases the lock by closing it (the field drops after this).
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
    }
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

    #[test]
    fn a_run_starting_during_a_status_probe_waits_for_it() {
        let dir = std::env::temp_dir().join(format!("softgrain-probe-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join(".lock");
        // a probe that holds its shared lock far longer than `holder` does
        let probe = File::create(&path).unwrap();
        probe.lock_shared().unwrap();
        let release = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(50));
            drop(probe);
        });
        let lock = Lock::take(&path);
        release.join().unwrap();
        assert!(lock.is_ok(), "{:?}", lock.err());
        // and a run holding the lock is still refused at once, named by its pid
        let other = Lock::take(&path).err().unwrap();
        assert!(
            other.contains(&format!("pid {}", std::process::id())),
            "{other}"
        );
        drop(lock);
        let _ = fs::remove_dir_all(&dir);
    }

    #[test]
    fn runs_taking_and_releasing_in_turn_never_overlap() {
        // Each thread takes the lock repeatedly, as runs started one after another do; a
        // holder's release (remove, then close) must not let two threads hold it at once.
        let dir = std::env::temp_dir().join(format!("softgrain-turns-{}", std::process::id()));
        let path = dir.join(".lock");
        let holders = Arc::new(std::sync::atomic::AtomicUsize::new(0));
        let threads: Vec<_> = (0..4)
            .map(|_| {
                let (path, holders) = (path.clone(), holders.clone());
                std::thread::spawn(move || {
                    let mut taken = 0;
                    for _ in 0..500 {
                        if let Ok(lock) = Lock::take(&path) {
                            let now = holders.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
                            assert_eq!(now, 0, "two holders at once");
                            std::thread::yield_now();
                            holders.fetch_sub(1, std::sync::atomic::Ordering::SeqCst);
                            drop(lock);
                            taken += 1;
                        }
                    }
                    taken
                })
            })
            .collect();
        let taken: usize = threads.into_iter().map(|t| t.join().unwrap()).sum();
        assert!(taken > 0);
        let _ = fs::remove_dir_all(&dir);
    }
}
