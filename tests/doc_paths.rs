//! Every path of the repository that the docs and the code's comments name exists: a moved or renamed
//! file fails here, not in a reader's hands. Scanned: README.md and docs/ whole; the comments of the
//! Rust and WGSL files of src/, shaders/, tests/ and python/; the Python and shell scripts and the
//! Markdown of ci/, benches/ and python/ whole. A path is a word starting with one of the repository's
//! top-level folders (`src/`, `shaders/`, `docs/`, ...), checked relative to the repository's root.
//! Not paths: patterns and placeholders (`src/materials/<kind>/`, `benches/results/splat-YYYY-MM-DD.md`,
//! `scenes/NAME.toml`), and what the scripts create (a `.venv`, `benches/gpu-results`). Paths the code
//! writes under `target/` or reads outside the repository (`../shared/`) are not words of these
//! folders.

use std::path::{Path, PathBuf};

/// What the repository's scripts create when run: named, not kept.
const CREATED: &[&str] = &["/.venv", "benches/gpu-results"];

/// The repository's top-level folders a named path starts with.
const ROOTS: &[&str] = &[
    "src", "shaders", "docs", "tests", "benches", "ci", "scenes", "python", "assets", "deploy",
];

/// Text files scanned, by extension.
const SCANNED: &[&str] = &["rs", "wgsl", "md", "py", "sh", "toml", "yml", "yaml"];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        let name = e.file_name().to_string_lossy().into_owned();
        if name.starts_with('.') || name == "target" || name == "__pycache__" {
            continue;
        }
        if p.is_dir() {
            files(&p, out);
        } else if p
            .extension()
            .is_some_and(|x| SCANNED.contains(&x.to_string_lossy().as_ref()))
        {
            out.push(p);
        }
    }
}

/// The repository paths `text` names: words `<root>/...` of path characters, without a trailing
/// sentence's punctuation, skipping patterns (`<`, `*`, `{`, `$`). A word is read whole: a path inside
/// a longer one, a URL's `/docs/...` and a path after `../` (relative to another file) are not read as
/// paths from the root.
fn named_paths(text: &str) -> Vec<String> {
    let bytes = text.as_bytes();
    let is_path_char = |c: u8| {
        c.is_ascii_alphanumeric()
            || matches!(
                c,
                b'/' | b'.' | b'_' | b'-' | b'<' | b'>' | b'*' | b'{' | b'}' | b'$'
            )
    };
    let mut out = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        if !is_path_char(bytes[i]) {
            i += 1;
            continue;
        }
        let start = i;
        while i < bytes.len() && is_path_char(bytes[i]) {
            i += 1;
        }
        let word = &text[start..i];
        let Some((root, _)) = word.split_once('/') else {
            continue;
        };
        let placeholder = word.contains(['<', '>', '*', '{', '}', '$'])
            || word.contains("YYYY")
            || word.contains("NAME");
        if !ROOTS.contains(&root) || placeholder || CREATED.iter().any(|c| word.contains(c)) {
            continue;
        }
        let word = word.trim_end_matches(['.', ',', ':', ';', '-']);
        out.push(word.to_string());
    }
    out
}

#[test]
fn named_paths_exist() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scanned = vec![root.join("README.md")];
    for dir in ["docs", "src", "shaders", "tests", "python", "ci", "benches"] {
        files(&root.join(dir), &mut scanned);
    }
    assert!(scanned.len() > 100, "found only {} files", scanned.len());
    let mut missing = Vec::new();
    let mut checked = 0;
    for file in &scanned {
        let text = std::fs::read_to_string(file).unwrap_or_default();
        let code = file.extension().is_some_and(|x| x == "rs" || x == "wgsl");
        for (n, line) in text.lines().enumerate() {
            // In code, the comments: what a string holds is the code's business (and its tests').
            let line = match line.find("//") {
                Some(i) if code => &line[i..],
                None if code => continue,
                _ => line,
            };
            for path in named_paths(line) {
                checked += 1;
                if !root.join(&path).exists() {
                    let rel = file.strip_prefix(root).unwrap_or(file);
                    missing.push(format!("{}:{}: {path}", rel.display(), n + 1));
                }
            }
        }
    }
    assert!(
        checked > 300,
        "only {checked} named paths: the scan is broken"
    );
    assert!(
        missing.is_empty(),
        "{} named paths do not exist (fix the text, or the path):\n{}",
        missing.len(),
        missing.join("\n")
    );
}

#[test]
fn the_scan_finds_paths_and_skips_patterns() {
    assert_eq!(
        named_paths("see src/scene/bsdfs.rs, and docs/cli.md."),
        ["src/scene/bsdfs.rs", "docs/cli.md"]
    );
    assert!(named_paths("src/materials/<kind>/mod.rs and tests/*.rs").is_empty());
    assert!(named_paths("../shared/docs/cli.md and target/debug/vkpath").is_empty());
    assert!(
        named_paths("benches/peers/.venv/bin/python benches/results/x-YYYY-MM-DD.md").is_empty()
    );
    assert_eq!(
        named_paths("include_str!(\"../../shaders/rng.wgsl\")"),
        Vec::<String>::new(),
        "a path after ../ is relative to its file"
    );
}
