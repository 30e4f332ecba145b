//! Writing vkpath TOML as text: what the importers (glTF, Mitsuba XML) translate a scene into, so that
//! the TOML reader checks it like any scene file and `vkpath convert` can write it out.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

/// A number as TOML writes it: the shortest text that reads back as the same f32 (the scene stores
/// f32), or TOML's nan/inf, which the TOML reader then reports where a finite number is required.
pub fn num(x: f32) -> String {
    if x.is_finite() {
        format!("{x:?}")
    } else if x.is_nan() {
        "nan".into()
    } else if x > 0.0 {
        "inf".into()
    } else {
        "-inf".into()
    }
}

/// `[x, y, z]`.
pub fn vec3(v: [f32; 3]) -> String {
    format!("[{}, {}, {}]", num(v[0]), num(v[1]), num(v[2]))
}

/// A TOML basic string: quotes and backslashes escaped, control characters as \uXXXX.
pub fn toml_string(s: &str) -> String {
    let mut out = String::from("\"");
    for c in s.chars() {
        match c {
            '"' => out += "\\\"",
            '\\' => out += "\\\\",
            c if c.is_control() => {
                let _ = write!(out, "\\u{:04X}", c as u32);
            }
            c => out.push(c),
        }
    }
    out + "\""
}

/// `p` made absolute against the working directory, `.` and `..` resolved lexically (the paths a
/// translated scene names, written relative to where the TOML will be).
pub fn absolute(p: &Path) -> PathBuf {
    let joined = std::env::current_dir().unwrap_or_default().join(p);
    let mut out = PathBuf::new();
    for c in joined.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// The path of `target` relative to the directory `dir` (both absolute), with `..` as needed; `None`
/// when they share no root (another drive).
pub fn relative_to(target: &Path, dir: &Path) -> Option<PathBuf> {
    let t: Vec<_> = target.components().collect();
    let d: Vec<_> = dir.components().collect();
    let common = t.iter().zip(&d).take_while(|(a, b)| a == b).count();
    if common == 0 {
        return None;
    }
    let mut out = PathBuf::new();
    for _ in common..d.len() {
        out.push("..");
    }
    for c in &t[common..] {
        out.push(c);
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn numbers_strings_and_paths() {
        assert_eq!(num(0.1), "0.1");
        assert_eq!(num(f32::INFINITY), "inf");
        assert_eq!(vec3([1.0, -2.5, 3.0]), "[1.0, -2.5, 3.0]");
        assert_eq!(toml_string("a\"b\\c\n"), "\"a\\\"b\\\\c\\u000A\"");
        assert_eq!(
            relative_to(Path::new("/a/b/m.obj"), Path::new("/a/c")),
            Some(PathBuf::from("../b/m.obj"))
        );
    }
}
