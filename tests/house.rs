//! The library's house rules, read from its source: every `unsafe` block says why it is
//! sound, errors are typed (no `Result<_, String>` outside the command line), no function
//! runs past 150 lines, and no library message names a command-line flag (the CLI adds its
//! flags to the library's errors).

use std::path::{Path, PathBuf};

/// Every `.rs` file under `dir`, sorted.
fn sources(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).expect("a source folder") {
            let p = e.expect("a folder entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The library's files (the command line's, `src/cli/`, left out).
fn library() -> Vec<(PathBuf, String)> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
    sources(&root)
        .into_iter()
        .filter(|p| !p.starts_with(root.join("cli")))
        .map(|p| {
            let text = std::fs::read_to_string(&p).expect("a readable source file");
            (p, text)
        })
        .collect()
}

/// The code of a line: what comes before a `//` comment (string literals holding `//` are
/// rare enough in this code base to be read as comments: the rules only get laxer there).
fn code(line: &str) -> &str {
    line.split("//").next().unwrap_or("")
}

/// Lines of `text` inside `#[cfg(test)]` modules, which the rules leave to the tests.
fn test_lines(text: &str) -> Vec<bool> {
    let lines: Vec<&str> = text.lines().collect();
    let mut out = vec![false; lines.len()];
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim_start().starts_with("#[cfg(test)]") && lines.get(i + 1).is_some_and(|l| l.contains("mod ")) {
            let indent = lines[i + 1].len() - lines[i + 1].trim_start().len();
            let mut j = i + 1;
            while j < lines.len() {
                out[j] = true;
                if j > i + 1 && lines[j].len() - lines[j].trim_start().len() == indent && lines[j].trim() == "}" {
                    break;
                }
                j += 1;
            }
            i = j;
        }
        i += 1;
    }
    out
}

#[test]
fn every_unsafe_block_says_why_it_is_sound() {
    let mut missing = Vec::new();
    for (path, text) in library() {
        let lines: Vec<&str> = text.lines().collect();
        for (i, line) in lines.iter().enumerate() {
            let c = code(line);
            let block = c.contains("unsafe {") || c.contains("unsafe impl");
            if !block || line.contains("SAFETY") {
                continue;
            }
            // The note stands in the comment lines just above (or above the statement the
            // block is part of, a few lines up).
            let noted = lines[i.saturating_sub(12)..i]
                .iter()
                .rev()
                .take_while(|l| {
                    let t = l.trim();
                    t.starts_with("//") || t.starts_with("#[") || !t.ends_with(';') && !t.ends_with('}')
                })
                .any(|l| l.contains("SAFETY"));
            if !noted {
                missing.push(format!("{}:{}", path.display(), i + 1));
            }
        }
    }
    assert!(
        missing.is_empty(),
        "unsafe blocks without a SAFETY note:\n{}",
        missing.join("\n")
    );
}

/// The library's lines outside test modules for which `bad` holds, as `file:line: text`.
fn lines_where(bad: impl Fn(&str) -> bool) -> Vec<String> {
    let mut found = Vec::new();
    for (path, text) in library() {
        let tests = test_lines(&text);
        for (i, line) in text.lines().enumerate() {
            if !tests[i] && bad(line) {
                found.push(format!("{}:{}: {}", path.display(), i + 1, line.trim()));
            }
        }
    }
    found
}

#[test]
fn library_errors_are_typed() {
    let found = lines_where(|line| {
        let c = code(line).replace(' ', "");
        c.contains("Result<") && c.contains(",String>")
    });
    assert!(
        found.is_empty(),
        "Result<_, String> in the library:\n{}",
        found.join("\n")
    );
}

#[test]
fn no_library_function_runs_past_150_lines() {
    let mut long = Vec::new();
    for (path, text) in library() {
        let lines: Vec<&str> = text.lines().collect();
        let tests = test_lines(&text);
        for (i, line) in lines.iter().enumerate() {
            let t = line.trim_start();
            let is_fn = [
                "fn ",
                "pub fn ",
                "pub(crate) fn ",
                "pub(super) fn ",
                "unsafe fn ",
                "pub unsafe fn ",
            ]
            .iter()
            .any(|k| t.starts_with(k));
            if !is_fn || tests[i] {
                continue;
            }
            // The body ends at the first line that closes at the function's indentation.
            let indent = line.len() - t.len();
            let Some(open) = (i..lines.len())
                .find(|&j| code(lines[j]).trim_end().ends_with('{') || code(lines[j]).trim_end().ends_with(';'))
            else {
                continue;
            };
            if code(lines[open]).trim_end().ends_with(';') {
                continue; // a declaration without a body
            }
            let end = (open + 1..lines.len())
                .find(|&j| {
                    lines[j].len() - lines[j].trim_start().len() == indent && lines[j].trim_start().starts_with('}')
                })
                .unwrap_or(lines.len() - 1);
            if end - i + 1 > 150 {
                long.push(format!("{}:{} ({} lines)", path.display(), i + 1, end - i + 1));
            }
        }
    }
    assert!(
        long.is_empty(),
        "library functions over 150 lines:\n{}",
        long.join("\n")
    );
}

#[test]
fn library_messages_name_no_command_line_flag() {
    // A flag in a string literal: `--` and a letter between quotes.
    let found = lines_where(|line| {
        code(line).split('"').skip(1).step_by(2).any(|lit| {
            lit.match_indices("--")
                .any(|(k, _)| lit[k + 2..].chars().next().is_some_and(|ch| ch.is_ascii_lowercase()))
        })
    });
    assert!(
        found.is_empty(),
        "library strings that name a flag:\n{}",
        found.join("\n")
    );
}
