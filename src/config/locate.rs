//! Finds the line and column of a dotted key in block-style YAML, for errors found after
//! parsing (range checks). Flow mappings and anchors are not followed: the key is then
//! reported without a position.

/// 1-based (line, column) of the key `a.b.c`.
pub fn key_position(text: &str, dotted: &str) -> Option<(u64, u64)> {
    let want: Vec<&str> = dotted.split('.').collect();
    // stack of (indent, key) for the current line's ancestors
    let mut stack: Vec<(usize, String)> = Vec::new();
    for (n, line) in text.lines().enumerate() {
        let body = line.split('#').next().unwrap_or("");
        let trimmed = body.trim_start();
        if trimmed.is_empty() || trimmed.starts_with('-') {
            continue;
        }
        let indent = body.len() - trimmed.len();
        let Some((key, _)) = trimmed.split_once(':') else {
            continue;
        };
        while stack.last().is_some_and(|(i, _)| *i >= indent) {
            stack.pop();
        }
        stack.push((indent, key.trim().trim_matches(['"', '\'']).to_string()));
        if stack.len() == want.len() && stack.iter().zip(&want).all(|((_, k), w)| k == w) {
            return Some((n as u64 + 1, indent as u64 + 1));
        }
    }
    None
}

/// The dotted key defined on `line` (1-based) and its value text, if that line holds a
/// block-style `key: value` (list items are named by their index).
pub fn key_at(text: &str, line: u64) -> Option<(String, String)> {
    let mut stack: Vec<(usize, String)> = Vec::new();
    let mut items: Vec<(usize, usize)> = Vec::new(); // (indent, count) of open lists
    for (n, raw) in text.lines().enumerate() {
        let body = raw.split('#').next().unwrap_or("");
        let trimmed = body.trim_start();
        if trimmed.is_empty() {
            continue;
        }
        let mut indent = body.len() - trimmed.len();
        let mut rest = trimmed;
        if let Some(after) = rest.strip_prefix("- ") {
            while items.last().is_some_and(|(i, _)| *i > indent) {
                items.pop();
            }
            match items.last_mut() {
                Some((i, c)) if *i == indent => *c += 1,
                _ => items.push((indent, 0)),
            }
            while stack.last().is_some_and(|(i, _)| *i > indent) {
                stack.pop();
            }
            let idx = items.last().map_or(0, |(_, c)| *c);
            stack.push((indent + 1, idx.to_string()));
            rest = after.trim_start();
            indent += 2;
        }
        let Some((key, value)) = rest.split_once(':') else {
            continue;
        };
        while stack.last().is_some_and(|(i, _)| *i >= indent) {
            stack.pop();
        }
        stack.push((indent, key.trim().trim_matches(['"', '\'']).to_string()));
        if n as u64 + 1 == line {
            let path: Vec<&str> = stack.iter().map(|(_, k)| k.as_str()).collect();
            return Some((path.join("."), value.trim().to_string()));
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::key_position;

    #[test]
    fn finds_nested_keys() {
        let t = "name: x\nprepare:\n  # comment\n  grains: 3\n  diameter: [1, 2]\ncompact:\n  grains: 4\n";
        assert_eq!(key_position(t, "prepare.grains"), Some((4, 3)));
        assert_eq!(key_position(t, "compact.grains"), Some((7, 3)));
        assert_eq!(key_position(t, "name"), Some((1, 1)));
        assert_eq!(key_position(t, "prepare.radius"), None);
    }

    #[test]
    fn names_the_key_on_a_line() {
        let t = "name: x\nprepare:\n  grains: three\n  bodies:\n    - position: [0, 1]\n      radius: a\n    - radius: b\n";
        assert_eq!(
            super::key_at(t, 3),
            Some(("prepare.grains".into(), "three".into()))
        );
        assert_eq!(
            super::key_at(t, 6),
            Some(("prepare.bodies.0.radius".into(), "a".into()))
        );
        assert_eq!(
            super::key_at(t, 7),
            Some(("prepare.bodies.1.radius".into(), "b".into()))
        );
    }
}
