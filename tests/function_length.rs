//! No function over 150 lines (src/, shaders/, python/src/): a function that holds a whole format or a
//! whole pass is split by concept. The functions still longer are listed in [`TOO_LONG`], each with its
//! length today; the list may only shrink: a new long function fails, and so does a listed one that
//! grew or was split (then its line goes), so the list always says what is left.
//!
//! A function's length is from its `fn` line to its closing brace, counted by a scanner that skips
//! comments, strings (raw ones too) and character literals.

use std::path::{Path, PathBuf};

const LIMIT: usize = 150;

/// The functions over the limit today: (file, function, lines). Shrinks as they are split.
const TOO_LONG: &[(&str, &str, usize)] = &[
    ("src/render/mod.rs", "check_device_memory", 204),
    ("src/render/mod.rs", "build", 202),
    ("src/scene/mitsuba/sensor.rs", "sensor", 199),
    ("src/checkpoint/mod.rs", "decode", 198),
    ("src/scene/mitsuba/translate.rs", "scene", 194),
    ("src/gpu/context.rs", "new", 187),
    ("src/scene/gltf.rs", "add", 178),
    ("src/gpu/kernel.rs", "submit", 174),
    ("src/scene/parse/settings.rs", "camera", 171),
    ("src/scene/parse/params.rs", "texture_ref", 167),
    ("src/scene/gltf_scene.rs", "scene_toml", 160),
    ("src/kernel/upload.rs", "build", 161),
    ("src/scene/ply.rs", "parse_ply", 160),
    ("shaders/trace.wgsl", "path_step", 156),
    ("python/src/lib.rs", "render", 155),
];

fn files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for e in entries.flatten() {
        let p = e.path();
        if p.is_dir() {
            files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs" || x == "wgsl") {
            out.push(p);
        }
    }
}

/// `text` with every comment, string and character literal blanked (newlines kept), so that braces
/// and `fn` are the code's.
fn code_only(text: &str) -> String {
    let c: Vec<char> = text.chars().collect();
    let at = |i: usize, s: &str| s.chars().enumerate().all(|(k, x)| c.get(i + k) == Some(&x));
    let find = |from: usize, s: &str| {
        (from..c.len())
            .find(|&j| at(j, s))
            .map_or(c.len(), |j| j + s.chars().count())
    };
    let mut out = String::with_capacity(text.len());
    let mut i = 0;
    while i < c.len() {
        let end = if at(i, "//") {
            (i..c.len()).find(|&j| c[j] == '\n').unwrap_or(c.len())
        } else if at(i, "/*") {
            find(i + 2, "*/")
        } else if c[i] == 'r' && (at(i + 1, "\"") || at(i + 1, "#\"") || at(i + 1, "##\"")) {
            // r"...", r#"..."#: closed by a quote and as many #s.
            let hashes = c[i + 1..].iter().take_while(|&&x| x == '#').count();
            let close: String = std::iter::once('"')
                .chain(std::iter::repeat_n('#', hashes))
                .collect();
            find(i + 2 + hashes, &close)
        } else if c[i] == '"' {
            let mut j = i + 1;
            while j < c.len() && c[j] != '"' {
                j += if c[j] == '\\' { 2 } else { 1 };
            }
            (j + 1).min(c.len())
        } else if c[i] == '\'' && c.get(i + 1) == Some(&'\\') {
            // '\n', '\u{7f}': to the closing quote.
            (i + 2..c.len())
                .find(|&j| c[j] == '\'')
                .map_or(c.len(), |j| j + 1)
        } else if c[i] == '\'' && c.get(i + 2) == Some(&'\'') {
            i + 3 // 'x' (a lifetime 'a has no closing quote)
        } else {
            out.push(c[i]);
            i += 1;
            continue;
        };
        out.extend(c[i..end].iter().map(|&x| if x == '\n' { x } else { ' ' }));
        i = end;
    }
    out
}

/// Each function of `text` with a body: (name, first line, lines).
fn functions(text: &str) -> Vec<(String, usize, usize)> {
    let code = code_only(text);
    let lines: Vec<&str> = code.lines().collect();
    let mut out = Vec::new();
    for (n, line) in lines.iter().enumerate() {
        let Some(at) = line.split_whitespace().position(|w| w == "fn") else {
            continue;
        };
        let Some(name) = line.split_whitespace().nth(at + 1) else {
            continue;
        };
        let name: String = name
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        // From the `fn`, the first `{` opens the body unless a `;` ends a declaration first.
        let (mut depth, mut opened) = (0i64, false);
        'scan: for (m, l) in lines.iter().enumerate().skip(n) {
            let from = if m == n {
                line.find("fn ").unwrap_or(0)
            } else {
                0
            };
            for c in l[from..].chars() {
                match c {
                    '{' => {
                        depth += 1;
                        opened = true;
                    }
                    '}' => depth -= 1,
                    ';' if !opened => break 'scan,
                    _ => {}
                }
                if opened && depth == 0 {
                    out.push((name.clone(), n + 1, m - n + 1));
                    break 'scan;
                }
            }
        }
    }
    out
}

#[test]
fn no_function_is_longer_than_the_limit_but_the_listed_ones() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut scanned = Vec::new();
    for dir in ["src", "shaders", "python/src"] {
        files(&root.join(dir), &mut scanned);
    }
    let mut long = Vec::new();
    for file in &scanned {
        let rel = file
            .strip_prefix(root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let text = std::fs::read_to_string(file).unwrap();
        for (name, line, len) in functions(&text) {
            if len > LIMIT {
                long.push((rel.clone(), name, len, line));
            }
        }
    }
    let mut problems = Vec::new();
    for (file, name, len, line) in &long {
        match TOO_LONG.iter().find(|(f, n, _)| f == file && n == name) {
            None => problems.push(format!(
                "{file}:{line}: {name} has {len} lines (limit {LIMIT}): split it by concept"
            )),
            Some((_, _, listed)) if len > listed => problems.push(format!(
                "{file}:{line}: {name} grew to {len} lines (listed at {listed})"
            )),
            Some((_, _, listed)) if len < listed => problems.push(format!(
                "{file}:{line}: {name} shrank to {len} lines: update its line in TOO_LONG to {len}"
            )),
            _ => {}
        }
    }
    for (file, name, _) in TOO_LONG {
        if !long.iter().any(|(f, n, _, _)| f == file && n == name) {
            problems.push(format!(
                "{file}: {name} is within the limit now: remove its line from TOO_LONG"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}

#[test]
fn the_scanner_counts_bodies_not_strings_or_comments() {
    let text = "fn a() {\n    let s = \"}\"; // }\n    let c = '}';\n    let r = r#\"}\"#;\n}\nfn b(x: &'static str) -> u32;\nfn c<'a>(x: &'a str) {\n    /* { */\n}\n";
    assert_eq!(
        functions(text),
        [("a".to_string(), 1, 5), ("c".to_string(), 7, 3)]
    );
}
