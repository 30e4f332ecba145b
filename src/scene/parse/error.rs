//! Why a scene could not be loaded ([`SceneError`]), and the dotted path of the key it is about: looked
//! up by its byte span in the TOML tree, or guessed from the line when the text is not TOML at all.

use std::collections::BTreeMap;
use std::fmt;
use std::ops::Range;
use std::path::Path;
use toml::Spanned;
use toml::de::{DeTable, DeValue};

/// Hint appended to errors whose fix is "make the file match the format".
pub(super) const SEE_CONTRACT: &str =
    "See the scene-format contract (scene-format.md) for every key, its unit and its default.";

// ---------------------------------------------------------------------------------------------------
// The error type
// ---------------------------------------------------------------------------------------------------

/// Why a scene could not be loaded. Its `Display` is one paragraph (no newline) of the form
/// `FILE, line N, key KEY: what is wrong. What to do.`, ready to print before exiting with status 2.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneError {
    file: String,
    line: Option<usize>,
    key: Option<String>,
    /// What is wrong, without a final full stop.
    problem: String,
    /// What to do about it, a full sentence.
    hint: String,
}

impl SceneError {
    /// A scene from another tool (super::import) that cannot be read as one: no line, the element or
    /// flag in `key` when there is one.
    pub(crate) fn import(
        path: &Path,
        key: Option<String>,
        problem: impl Into<String>,
        hint: &str,
    ) -> SceneError {
        SceneError::new(path.display().to_string(), None, key, problem, hint)
    }

    /// A problem at a line of a file of another format (super::mitsuba): `key` names the element.
    pub(crate) fn at(
        path: &Path,
        line: Option<usize>,
        key: Option<String>,
        problem: impl Into<String>,
        hint: &str,
    ) -> SceneError {
        SceneError::new(path.display().to_string(), line, key, problem, hint)
    }

    /// The same problem reported at another file, line and key (a scene translated from another format
    /// reports where its source said what the TOML reader refused).
    pub(crate) fn relocated(
        self,
        file: String,
        line: Option<usize>,
        key: Option<String>,
    ) -> SceneError {
        SceneError {
            file,
            line,
            key,
            ..self
        }
    }

    /// The scene file could not be read at all.
    pub fn io(path: &Path, e: &std::io::Error) -> SceneError {
        SceneError::new(
            path.display().to_string(),
            None,
            None,
            format!("cannot read the scene file: {e}"),
            "Check that the path is right and that the file is readable.",
        )
    }

    /// The scene file is not UTF-8 text: the line and column of the first byte that is not.
    pub fn not_utf8(path: &Path, bytes: &[u8], valid_up_to: usize) -> SceneError {
        let before = &bytes[..valid_up_to];
        let line = before.iter().filter(|&&b| b == b'\n').count() + 1;
        let line_start = before
            .iter()
            .rposition(|&b| b == b'\n')
            .map_or(0, |i| i + 1);
        let column = String::from_utf8_lossy(&before[line_start..])
            .chars()
            .count()
            + 1;
        SceneError::new(
            path.display().to_string(),
            Some(line),
            None,
            format!(
                "the file is not UTF-8 text: the byte 0x{:02x} at column {column} is not valid UTF-8",
                bytes[valid_up_to]
            ),
            "TOML files are UTF-8: save the scene file in that encoding.",
        )
    }

    /// The scene file is larger than `limit` bytes (refused before it is read).
    pub fn too_large(path: &Path, limit: u64) -> SceneError {
        SceneError::new(
            path.display().to_string(),
            None,
            None,
            format!(
                "the scene file is larger than the limit of {} MiB for a scene file",
                limit >> 20
            ),
            "Put large geometry in [[mesh]] tables (Wavefront OBJ files) instead of inline [[sphere]] and [[triangle]] tables.",
        )
    }

    /// The file as given by the user, or `<default scene>` for the embedded scene.
    pub fn file(&self) -> &str {
        &self.file
    }

    /// The 1-based line the problem is on, when it is known.
    pub fn line(&self) -> Option<usize> {
        self.line
    }

    /// The dotted key path of the offending value, e.g. `sphere[2].radius` or `materials.glass.ior`.
    /// Array-of-tables indices are 0-based, in file order.
    pub fn key(&self) -> Option<&str> {
        self.key.as_deref()
    }

    pub(super) fn new(
        file: String,
        line: Option<usize>,
        key: Option<String>,
        problem: impl Into<String>,
        hint: impl Into<String>,
    ) -> SceneError {
        // Messages can quote user text (a bad material name, a TOML parser message); the one-paragraph
        // promise must hold whatever they contain.
        let one_line = |s: String| s.split_whitespace().collect::<Vec<_>>().join(" ");
        let problem = one_line(problem.into());
        SceneError {
            file,
            line,
            key,
            problem: problem.trim_end_matches('.').to_string(),
            hint: one_line(hint.into()),
        }
    }
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.file)?;
        if let Some(line) = self.line {
            write!(f, ", line {line}")?;
        }
        if let Some(key) = &self.key {
            write!(f, ", key {key}")?;
        }
        write!(f, ": {}. {}", self.problem, self.hint)
    }
}

impl std::error::Error for SceneError {}

// ---------------------------------------------------------------------------------------------------
// Locating keys
// ---------------------------------------------------------------------------------------------------

pub(super) fn join_key(path: &str, key: &str) -> String {
    if path.is_empty() {
        key.to_string()
    } else {
        format!("{path}.{key}")
    }
}

/// The dotted path (`sphere[1].center`) of the innermost key or value in `table` whose span satisfies
/// `hit`. Children are searched before their parent so that the most specific key wins; this matters
/// because a `[table]`'s span is only its header, and an array of tables shares its span with its first
/// element.
pub(super) fn find_key_path(
    table: &DeTable<'_>,
    path: &str,
    hit: &dyn Fn(&Range<usize>) -> bool,
) -> Option<String> {
    table.iter().find_map(|(key, value)| {
        let key_path = join_key(path, key.get_ref());
        find_in_value(value, &key_path, hit).or_else(|| hit(&key.span()).then_some(key_path))
    })
}

fn find_in_value(
    value: &Spanned<DeValue<'_>>,
    path: &str,
    hit: &dyn Fn(&Range<usize>) -> bool,
) -> Option<String> {
    let inside = match value.get_ref() {
        DeValue::Table(table) => find_key_path(table, path, hit),
        DeValue::Array(items) => items
            .iter()
            .enumerate()
            .find_map(|(i, item)| find_in_value(item, &format!("{path}[{i}]"), hit)),
        _ => None,
    };
    inside.or_else(|| hit(&value.span()).then(|| path.to_string()))
}

/// For text that is not valid TOML: the key assigned on the line holding `offset`, prefixed by the
/// table header above it (`camera.fov`, `sphere[1].radius`). Best effort: `None` when the line is not
/// a plain `key = value`.
pub(super) fn guess_key_at(text: &str, offset: usize) -> Option<String> {
    let bytes = text.as_bytes();
    let offset = offset.min(bytes.len());
    // Newlines are ASCII, so slicing at them always lands on a char boundary.
    let start = bytes[..offset]
        .iter()
        .rposition(|&b| b == b'\n')
        .map_or(0, |i| i + 1);
    let end = bytes[start..]
        .iter()
        .position(|&b| b == b'\n')
        .map_or(bytes.len(), |i| start + i);
    let line = text[start..end].split('#').next().unwrap_or("").trim();
    let is_bare_key = |s: &str| {
        !s.is_empty()
            && s.chars()
                .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
    };
    // A broken or duplicated `[table]` header names the table itself.
    if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
        let name = name.trim_matches(['[', ']']).trim();
        return is_bare_key(name).then(|| name.to_string());
    }
    let (lhs, _) = line.split_once('=')?;
    let key = lhs.trim();
    if !is_bare_key(key) {
        return None;
    }

    // The last header before this line decides the prefix; `[[name]]` headers are counted so that the
    // index matches the one the other errors use.
    let mut header: Option<String> = None;
    let mut array_counts: BTreeMap<&str, usize> = BTreeMap::new();
    for line in text[..start].lines() {
        let line = line.split('#').next().unwrap_or("").trim();
        if let Some(name) = line.strip_prefix("[[").and_then(|l| l.strip_suffix("]]")) {
            let name = name.trim();
            let count = array_counts.entry(name).or_insert(0);
            header = Some(format!("{name}[{count}]"));
            *count += 1;
        } else if let Some(name) = line.strip_prefix('[').and_then(|l| l.strip_suffix(']')) {
            header = Some(name.trim().to_string());
        }
    }
    if header
        .as_deref()
        .is_some_and(|h| !is_bare_key(&h.replace(['[', ']'], "")))
    {
        return Some(key.to_string());
    }
    Some(match header {
        Some(h) => join_key(&h, key),
        None => key.to_string(),
    })
}

/// The text between `prefix` and the next backtick, e.g. the field name in "missing field `radius`".
pub(super) fn backticked_after<'m>(message: &'m str, prefix: &str) -> Option<&'m str> {
    let rest = message.strip_prefix(prefix)?;
    rest.split_once('`').map(|(name, _)| name)
}

/// serde names Rust types in its messages; say what they mean in TOML terms.
pub(super) fn plain_words(message: &str) -> String {
    // An integer that does not fit the type serde was asked for (i64 for integer keys, and anything
    // beyond i64 for float keys) comes out as "integer `N` as i128, expected f32" and the like.
    let integer = backticked_after(message, "invalid value: integer `")
        .or_else(|| backticked_after(message, "invalid type: integer `"));
    if let Some(digits) = integer
        && (message.contains("` as i128")
            || message.contains("` as u128")
            || message.ends_with("expected i64"))
    {
        return format!("the integer {digits} is out of range");
    }

    let mut words = message
        .replace("invalid type: map", "invalid type: table")
        .replace("expected f32", "expected a number")
        .replace("expected i64", "expected an integer")
        .replace("a sequence", "an array")
        .replace("expected a string", "expected a string in quotes");
    // "expected struct RawCamera" -> "expected a table": the Raw* names mean nothing to a user.
    if let Some(at) = words.find("struct Raw") {
        let rest = &words[at + "struct Raw".len()..];
        let name_len = rest
            .find(|c: char| !c.is_ascii_alphanumeric())
            .unwrap_or(rest.len());
        words.replace_range(at..at + "struct Raw".len() + name_len, "a table");
    }
    words
}

#[cfg(test)]
mod tests {
    use crate::scene::parse::parse_scene;
    use crate::scene::parse::tests::MINIMAL;

    #[test]
    fn syntax_errors_guess_the_key_from_the_line() {
        let text = "[camera]\nposition = [0, 0, 1]\n\n[[sphere]]\nradius = 1\n[[sphere]]\nradius = 1.2.3\n";
        let err = parse_scene(text, None).expect_err("not TOML");
        assert_eq!(err.line(), Some(7));
        assert_eq!(err.key(), Some("sphere[1].radius"));
    }

    #[test]
    fn messages_quoting_user_text_stay_on_one_line() {
        let text = format!(
            "{MINIMAL}\n[[sphere]]\ncenter = [0, 0, 0]\nradius = 1\nmaterial = \"two\\nlines\"\n"
        );
        let err = parse_scene(&text, None).expect_err("undefined material");
        assert!(!err.to_string().contains('\n'), "{err}");
    }
}
