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
}
