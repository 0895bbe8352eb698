//! Pipeline files: parse (serde-saphyr, unknown keys rejected), apply `--set` overrides,
//! validate ranges. Every error names the file, the key, the value and, for YAML, the
//! line and column.

pub mod defaults;
pub(crate) mod locate;
mod schema;
mod validate;

pub use schema::*;

use std::fmt;
use std::path::{Path, PathBuf};

/// Wrong input: exit status 2 at the command line.
#[derive(Debug, Clone, PartialEq)]
pub struct InputError {
    pub file: PathBuf,
    /// Dotted key path, or empty when the YAML itself is malformed.
    pub key: String,
    pub value: String,
    /// What is allowed, or the parser's message.
    pub message: String,
    /// 1-based (line, column) in the file, when known.
    pub at: Option<(u64, u64)>,
    /// Set when the value came from `--set` rather than the file.
    pub from_set: bool,
}

impl fmt::Display for InputError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file.display())?;
        if let Some((l, c)) = self.at {
            write!(f, ":{l}:{c}")?;
        }
        write!(f, ": ")?;
        if self.from_set {
            write!(f, "--set ")?;
        }
        if !self.key.is_empty() {
            write!(f, "{}", self.key)?;
            if !self.value.is_empty() {
                write!(f, " = {}", self.value)?;
            }
            write!(f, ": ")?;
        }
        write!(f, "{}", self.message)
    }
}

impl std::error::Error for InputError {}

/// A loaded pipeline with the text it came from (for locating keys in later errors).
#[derive(Clone, Debug)]
pub struct Loaded {
    pub pipeline: Pipeline,
    pub file: PathBuf,
    /// The pipelines named under `include`, loaded and validated the same way.
    pub included: Vec<Loaded>,
}

impl Loaded {
    /// The pipeline a planned node belongs to (0: this one, k: the k-th included).
    pub fn pipeline(&self, source: usize) -> &Pipeline {
        match source {
            0 => &self.pipeline,
            k => &self.included[k - 1].pipeline,
        }
    }

    /// The file a planned node comes from.
    pub fn file(&self, source: usize) -> &Path {
        match source {
            0 => &self.file,
            k => &self.included[k - 1].file,
        }
    }
}

/// Reads, overrides and validates a pipeline file.
pub fn load(file: &Path, sets: &[String]) -> Result<Loaded, Box<InputError>> {
    load_inner(file, sets).map_err(Box::new)
}

// Boxed once, at the public edge (`load`).
#[allow(clippy::result_large_err)]
fn load_inner(file: &Path, sets: &[String]) -> Result<Loaded, InputError> {
    let err = |key: &str, value: &str, message: String| InputError {
        file: file.to_path_buf(),
        key: key.to_string(),
        value: value.to_string(),
        message,
        at: None,
        from_set: false,
    };
    let text = std::fs::read_to_string(file)
        .map_err(|e| err("", "", format!("cannot read the file: {e}")))?;
    let mut pipeline: Pipeline = serde_saphyr::from_str(&text).map_err(|e| {
        let mut ie = err("", "", first_line(&e.to_string()));
        ie.at = e.location().map(|l| (l.line(), l.column()));
        // name the key and value on that line when there is one
        if let Some((key, value)) = ie.at.and_then(|(line, _)| locate::key_at(&text, line)) {
            ie.key = key;
            ie.value = value;
        }
        ie
    })?;
    let mut set_keys = Vec::new();
    for s in sets {
        let (key, value) = s
            .split_once('=')
            .ok_or_else(|| set_err(file, s, "", "expected KEY=VALUE".into()))?;
        pipeline = apply_set(&pipeline, key.trim(), value.trim())
            .map_err(|m| set_err(file, key, value, m))?;
        set_keys.push(key.trim().to_string());
    }
    validate::check(&pipeline).map_err(|(key, value, message)| InputError {
        at: if set_keys.contains(&key) {
            None
        } else {
            locate::key_position(&text, &key)
        },
        from_set: set_keys.contains(&key),
        ..err(&key, &value, message)
    })?;
    let mut included = Vec::new();
    for (k, name) in pipeline.include.iter().enumerate() {
        let key = format!("include[{k}]");
        let path = file.parent().unwrap_or(Path::new(".")).join(name);
        let inc = load_inner(&path, &[]).map_err(|e| InputError {
            at: locate::key_position(&text, "include"),
            ..err(
                &key,
                name,
                format!("the included pipeline is not valid: {e}"),
            )
        })?;
        if !inc.included.is_empty() {
            return Err(InputError {
                at: locate::key_position(&text, "include"),
                ..err(
                    &key,
                    name,
                    "an included pipeline may not include others".into(),
                )
            });
        }
        if inc.pipeline.name == pipeline.name {
            return Err(err(&key, name, "has the same name as this pipeline".into()));
        }
        included.push(inc);
    }
    Ok(Loaded {
        pipeline,
        file: file.to_path_buf(),
        included,
    })
}

fn set_err(file: &Path, key: &str, value: &str, message: String) -> InputError {
    InputError {
        file: file.to_path_buf(),
        key: key.to_string(),
        value: value.to_string(),
        message,
        at: None,
        from_set: true,
    }
}

/// The parser's message without its own "error: line L column C: " prefix (the position
/// is printed once, as file:line:column).
pub(crate) fn first_line(s: &str) -> String {
    let line = s.lines().next().unwrap_or("");
    let stripped = line.strip_prefix("error: ").unwrap_or(line);
    match stripped
        .strip_prefix("line ")
        .and_then(|r| r.split_once(": "))
    {
        Some((pos, rest)) if pos.contains("column") => rest.to_string(),
        _ => stripped.to_string(),
    }
}

/// Overrides one value by its dotted path, exactly as editing the file would: the result is
/// re-read through the same typed schema (pipeline files and bench files alike).
pub(crate) fn apply_set<T: serde::Serialize + serde::de::DeserializeOwned>(
    p: &T,
    key: &str,
    value: &str,
) -> Result<T, String> {
    let mut tree = serde_json::to_value(p).map_err(|e| e.to_string())?;
    let new: serde_json::Value = serde_saphyr::from_str(value)
        .map_err(|e| format!("not a YAML value: {}", first_line(&e.to_string())))?;
    let mut node = &mut tree;
    let parts: Vec<&str> = key.split('.').collect();
    for (k, part) in parts.iter().enumerate() {
        if node.is_null() {
            *node = serde_json::Value::Object(Default::default());
        }
        let obj = node
            .as_object_mut()
            .ok_or_else(|| format!("`{}` is not a section", parts[..k].join(".")))?;
        if !obj.contains_key(*part) && !obj.is_empty() {
            return Err(format!("unknown key `{part}`"));
        }
        node = obj
            .entry(part.to_string())
            .or_insert(serde_json::Value::Null);
    }
    *node = new;
    serde_json::from_value(tree).map_err(|e| e.to_string())
}
