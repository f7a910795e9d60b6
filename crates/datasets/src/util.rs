//! Helpers shared by the readers: file access with path-naming errors, number parsing.

use std::fs;
use std::path::{Path, PathBuf};

use crate::DatasetError;

/// Reads a whole file.
pub(crate) fn read_bytes(path: &Path) -> Result<Vec<u8>, DatasetError> {
    fs::read(path).map_err(|e| DatasetError::io(path, e))
}

/// Reads a whole UTF-8 text file.
pub(crate) fn read_text(path: &Path) -> Result<String, DatasetError> {
    let bytes = read_bytes(path)?;
    String::from_utf8(bytes).map_err(|e| DatasetError::malformed(path, format!("not UTF-8 text: {e}")))
}

/// Sorted entries of a directory whose file names satisfy `keep`.
pub(crate) fn list_dir(dir: &Path, keep: impl Fn(&str) -> bool) -> Result<Vec<PathBuf>, DatasetError> {
    let rd = fs::read_dir(dir).map_err(|e| DatasetError::io(dir, e))?;
    let mut out = Vec::new();
    for entry in rd {
        let entry = entry.map_err(|e| DatasetError::io(dir, e))?;
        let name = entry.file_name();
        if let Some(name) = name.to_str() {
            if keep(name) {
                out.push(entry.path());
            }
        }
    }
    out.sort();
    Ok(out)
}

/// Rewrites the non-standard number tokens Python's `json` module writes (`NaN`, `Infinity`, `-Infinity`) to
/// `null` outside strings, so that a strict JSON parser accepts the file. Borrowed when there are none.
pub(crate) fn python_json_to_strict(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.contains("NaN") && !text.contains("Infinity") {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len());
    let mut in_string = false;
    let mut escaped = false;
    let mut rest = text;
    while let Some(c) = rest.chars().next() {
        if in_string {
            out.push(c);
            if escaped {
                escaped = false;
            } else if c == '\\' {
                escaped = true;
            } else if c == '"' {
                in_string = false;
            }
            rest = &rest[c.len_utf8()..];
            continue;
        }
        let token = ["-Infinity", "Infinity", "NaN"].into_iter().find(|t| rest.starts_with(t));
        if let Some(t) = token {
            out.push_str("null");
            rest = &rest[t.len()..];
            continue;
        }
        if c == '"' {
            in_string = true;
        }
        out.push(c);
        rest = &rest[c.len_utf8()..];
    }
    std::borrow::Cow::Owned(out)
}

/// Parses a finite f64.
pub(crate) fn parse_f64(token: &str, what: &str) -> Result<f64, String> {
    let v: f64 = token.trim().parse().map_err(|_| format!("{what}: `{token}` is not a number"))?;
    if !v.is_finite() {
        Err(format!("{what}: `{token}` is not finite"))
    } else if v.abs() > f64::from(f32::MAX) {
        // Every value ends up as f32 in the monitor: beyond its range it would silently become infinite.
        Err(format!("{what}: `{token}` is beyond the f32 range the monitor works in"))
    } else {
        Ok(v)
    }
}

/// Converts an f64 that the caller validated as finite and metre/second-scale into f32.
#[allow(clippy::cast_possible_truncation)] // monitor precision is f32; values are bounded metres, radians, m/s
pub(crate) fn f32_of(v: f64) -> f32 {
    v as f32
}

/// Central finite-difference speeds of one track: `obs` is `(t_s, x_m, y_m)` sorted by time, returns one speed
/// per observation (m/s) or `None` when neither neighbour is within `max_gap_s`.
///
/// Interior observations use `(p[i+1] - p[i-1]) / (t[i+1] - t[i-1])` when both neighbours are within
/// `max_gap_s`, otherwise the one-sided difference to the nearer valid neighbour.
pub(crate) fn finite_difference_speeds(obs: &[(f64, f64, f64)], max_gap_s: f64) -> Vec<Option<f64>> {
    let diff = |a: &(f64, f64, f64), b: &(f64, f64, f64)| -> Option<f64> {
        let dt = b.0 - a.0;
        if dt > 0.0 && dt <= max_gap_s + 1e-9 {
            Some((b.1 - a.1).hypot(b.2 - a.2) / dt)
        } else {
            None
        }
    };
    (0..obs.len())
        .map(|i| {
            let cur = obs.get(i)?;
            let prev = i.checked_sub(1).and_then(|j| obs.get(j)).filter(|p| diff(p, cur).is_some());
            let next = obs.get(i + 1).filter(|n| diff(cur, n).is_some());
            match (prev, next) {
                (Some(p), Some(n)) => Some((n.1 - p.1).hypot(n.2 - p.2) / (n.0 - p.0)),
                (Some(p), None) => diff(p, cur),
                (None, Some(n)) => diff(cur, n),
                (None, None) => None,
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn python_json_tokens() {
        let t = python_json_to_strict(r#"{"a": [NaN, -Infinity, 1], "s": "NaN \" Infinity"}"#);
        assert_eq!(t, r#"{"a": [null, null, 1], "s": "NaN \" Infinity"}"#);
        assert!(matches!(python_json_to_strict("[1, 2]"), std::borrow::Cow::Borrowed(_)));
    }

    #[test]
    fn finite_differences() {
        let obs = [(0.0, 0.0, 0.0), (0.1, 1.0, 0.0), (0.2, 3.0, 0.0), (5.0, 0.0, 0.0)];
        let v = finite_difference_speeds(&obs, 0.5);
        assert!((v[0].unwrap() - 10.0).abs() < 1e-9);
        assert!((v[1].unwrap() - 15.0).abs() < 1e-9);
        assert!((v[2].unwrap() - 20.0).abs() < 1e-9);
        assert!(v[3].is_none());
    }
}
