//! Checkpoint files: a header (magic, format version, payload length, blake3 of the
//! payload) then the payload. Written to a temporary name in the same folder, fsynced, then
//! renamed, so a file under a final name is always complete; verified on every load.

use super::codec::{self, FORMAT_VERSION};
use serde::Serialize;
use serde::de::DeserializeOwned;
use std::fs::{self, File};
use std::io::Write;
use std::path::{Path, PathBuf};

const MAGIC: &[u8; 8] = b"SOFTGRN\x01";
const HEADER: usize = 8 + 4 + 8 + 32;

/// Why a checkpoint file was not trusted.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum Corrupt {
    #[error("not a softgrain checkpoint (bad magic)")]
    Magic,
    #[error("format version {0}, this build reads {FORMAT_VERSION}")]
    Version(u32),
    #[error("truncated: header says {expected} payload bytes, file has {found}")]
    Truncated { expected: u64, found: u64 },
    #[error("payload hash mismatch (flipped bytes)")]
    Hash,
    #[error("payload does not decode: {0}")]
    Decode(String),
}

/// Writes `value` to `path` atomically (temp file + fsync + rename + directory fsync).
pub fn save<T: Serialize>(path: &Path, value: &T) -> std::io::Result<()> {
    let payload = codec::encode(value).map_err(std::io::Error::other)?;
    let mut bytes = Vec::with_capacity(HEADER + payload.len());
    bytes.extend_from_slice(MAGIC);
    bytes.extend_from_slice(&FORMAT_VERSION.to_le_bytes());
    bytes.extend_from_slice(&(payload.len() as u64).to_le_bytes());
    bytes.extend_from_slice(blake3::hash(&payload).as_bytes());
    bytes.extend_from_slice(&payload);
    write_atomic(path, &bytes)
}

/// Writes bytes under `path` so that the final name only ever holds complete content.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> std::io::Result<()> {
    let dir = path.parent().unwrap_or(Path::new("."));
    fs::create_dir_all(dir)?;
    let tmp = temp_name(path);
    let result = (|| {
        let mut f = File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        fs::rename(&tmp, path)?;
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
        Ok(())
    })();
    if result.is_err() {
        let _ = fs::remove_file(&tmp);
    }
    result
}

/// The temporary name used while writing `path`: hidden, and unique per process.
pub fn temp_name(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Removes every temporary file (see `temp_name`) under `dir`: half-written files of a
/// killed run. Only call it while holding the folder's lock.
pub fn remove_temp_files(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            remove_temp_files(&p);
        } else if p.file_name().is_some_and(|n| {
            let n = n.to_string_lossy();
            n.starts_with('.') && n.contains(".tmp-")
        }) {
            let _ = fs::remove_file(&p);
        }
    }
}

/// Reads and verifies a checkpoint. `Ok(None)` when there is no file.
pub fn load<T: DeserializeOwned>(path: &Path) -> std::io::Result<Option<Result<T, Corrupt>>> {
    let bytes = match fs::read(path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(e),
    };
    Ok(Some(
        verify(&bytes).and_then(|p| codec::decode(p).map_err(Corrupt::Decode)),
    ))
}

/// Checks the header and the payload hash; returns the payload.
pub fn verify(bytes: &[u8]) -> Result<&[u8], Corrupt> {
    if bytes.len() < HEADER || &bytes[..8] != MAGIC {
        return Err(Corrupt::Magic);
    }
    let version = u32::from_le_bytes(bytes[8..12].try_into().expect("4 bytes"));
    if version != FORMAT_VERSION {
        return Err(Corrupt::Version(version));
    }
    let expected = u64::from_le_bytes(bytes[12..20].try_into().expect("8 bytes"));
    let payload = &bytes[HEADER..];
    if payload.len() as u64 != expected {
        return Err(Corrupt::Truncated {
            expected,
            found: payload.len() as u64,
        });
    }
    if blake3::hash(payload).as_bytes() != &bytes[20..52] {
        return Err(Corrupt::Hash);
    }
    Ok(payload)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_and_every_corruption_is_caught() {
        let dir = std::env::temp_dir().join(format!("sg-store-{}", std::process::id()));
        let path = dir.join("x.ckpt");
        let value: Vec<f64> = (0..100).map(|k| k as f64 * 0.1).collect();
        save(&path, &value).unwrap();
        assert_eq!(load::<Vec<f64>>(&path).unwrap(), Some(Ok(value.clone())));
        let good = fs::read(&path).unwrap();
        for k in [0, 9, 13, 30, good.len() - 1] {
            let mut bad = good.clone();
            bad[k] ^= 0x40;
            assert!(verify(&bad).is_err(), "flip at {k} not caught");
        }
        assert!(matches!(
            verify(&good[..good.len() - 5]),
            Err(Corrupt::Truncated { .. })
        ));
        let mut old = good.clone();
        old[8] = 0;
        assert!(matches!(verify(&old), Err(Corrupt::Version(0))));
        assert!(
            fs::read_dir(&dir).unwrap().count() == 1,
            "a temp file was left"
        );
        fs::remove_dir_all(&dir).unwrap();
    }
}
