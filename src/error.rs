//! The library's one error type: what went wrong, in a form callers can match on, with a
//! message that says where (file, line, field; technique and option; the limit and the need).
//!
//! Library messages name no command-line flag: a program built on the library knows how its
//! users raise a limit (the CLI adds `--max-memory` to [`Error::Budget`] of [`Resource::Memory`]).

use crate::pipeline::{size_text, PipelineError};
use std::fmt;
use std::path::PathBuf;

/// Everything the library can refuse, above the pipeline's own [`PipelineError`].
#[derive(Debug)]
#[non_exhaustive]
pub enum Error {
    /// Scene input is wrong: a scene file, an OBJ or glTF it names, or a scene built in code.
    Scene {
        /// The file (or the name given to a text parsed from memory).
        file: PathBuf,
        /// 1-based line, where the text has lines.
        line: Option<usize>,
        /// The section, e.g. `[[object]] #2 (box)`.
        section: Option<String>,
        /// The field, e.g. `translate`.
        field: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A technique's option is wrong (unknown key, bad value, out of range, or a combination
    /// the technique cannot take).
    Option {
        /// The technique's registry name (filled in by the registry when a shared pass raised it).
        technique: Option<String>,
        /// The option's key.
        key: String,
        /// The value given, as text (empty when the error is about the key alone).
        value: String,
        /// What is wrong with it.
        message: String,
    },
    /// A technique cannot take this input (an unknown name, a light or scene it does not
    /// handle).
    Technique {
        /// The technique's registry name, or the unknown name asked for.
        technique: Option<String>,
        /// What is wrong.
        message: String,
    },
    /// A computation would need more than its limit (memory, triangles, list entries).
    Budget {
        /// The technique that asked, when a technique did.
        technique: Option<String>,
        /// What would need it, e.g. `the light's maps (6 views, option size=16384)`.
        what: String,
        /// Needed, in the resource's unit.
        needed: u64,
        /// The limit, in the resource's unit.
        limit: u64,
        /// Which resource.
        resource: Resource,
    },
    /// The pipeline refused a target or a draw.
    Pipeline(PipelineError),
    /// A file could not be read or written.
    Io {
        /// The file.
        path: PathBuf,
        /// What was being done and the system's reason.
        message: String,
    },
    /// An argument given in code is out of its domain (a light or frame index, a workload size,
    /// a malformed `key=value`).
    Input {
        /// What is wrong.
        message: String,
    },
}

/// The unit of a [`Error::Budget`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum Resource {
    /// Bytes of live buffers, against [`crate::pipeline::memory_limit`].
    Memory,
    /// Triangles of a scene, against [`crate::scene::file::triangle_budget`].
    Triangles,
    /// Entries of a fixed-size structure (list samples, silhouette edges, triangle ids).
    Entries,
}

/// The library's result.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// A scene error at `file`, with no line or field.
    pub fn scene(file: impl Into<PathBuf>, message: impl Into<String>) -> Error {
        Error::Scene {
            file: file.into(),
            line: None,
            section: None,
            field: None,
            message: message.into(),
        }
    }

    /// An option error of a technique that is named later ([`Error::in_technique`]).
    pub fn option(key: &str, value: impl fmt::Display, message: impl Into<String>) -> Error {
        Error::Option {
            technique: None,
            key: key.to_string(),
            value: value.to_string(),
            message: message.into(),
        }
    }

    /// Input a technique cannot take; the technique is named later ([`Error::in_technique`]).
    pub fn technique(message: impl Into<String>) -> Error {
        Error::Technique {
            technique: None,
            message: message.into(),
        }
    }

    /// A budget error with no technique yet.
    pub fn budget(what: impl Into<String>, needed: u64, limit: u64, resource: Resource) -> Error {
        Error::Budget {
            technique: None,
            what: what.into(),
            needed,
            limit,
            resource,
        }
    }

    /// An argument out of its domain.
    pub fn input(message: impl Into<String>) -> Error {
        Error::Input {
            message: message.into(),
        }
    }

    /// An I/O error on `path`: `doing` (e.g. "cannot read scene file") and the reason.
    pub fn io(path: impl Into<PathBuf>, doing: &str, reason: impl fmt::Display) -> Error {
        Error::Io {
            path: path.into(),
            message: format!("{doing}: {reason}"),
        }
    }

    /// Names the technique of an option, technique or budget error that has none yet (the
    /// registry calls this, so a shared pass's errors say which technique ran it).
    pub fn in_technique(mut self, name: &str) -> Error {
        if let Error::Option { technique, .. } | Error::Technique { technique, .. } | Error::Budget { technique, .. } =
            &mut self
        {
            technique.get_or_insert_with(|| name.to_string());
        }
        self
    }

    /// Puts `what` before the subject of a budget error (e.g. the structure whose buffers ran
    /// out of memory); other errors are returned as they are.
    pub fn within(self, what: &str) -> Error {
        match self {
            Error::Budget {
                technique,
                what: inner,
                needed,
                limit,
                resource,
            } => Error::Budget {
                technique,
                what: format!("{what}: {inner}"),
                needed,
                limit,
                resource,
            },
            Error::Pipeline(p @ PipelineError::OverBudget(_)) => Error::from(p).within(what),
            e => e,
        }
    }
}

fn technique_prefix(f: &mut fmt::Formatter<'_>, t: &Option<String>) -> fmt::Result {
    match t {
        Some(t) => write!(f, "technique '{t}': "),
        None => Ok(()),
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::Scene {
                file,
                line,
                section,
                field,
                message,
            } => {
                write!(f, "{}", file.display())?;
                if let Some(l) = line {
                    write!(f, ":{l}")?;
                }
                match (section, field) {
                    (Some(s), Some(k)) => write!(f, ": {s}, field `{k}`: {message}"),
                    (Some(s), None) => write!(f, ": {s}: {message}"),
                    (None, Some(k)) => write!(f, ": field `{k}`: {message}"),
                    (None, None) => write!(f, ": {message}"),
                }
            }
            Error::Option {
                technique,
                key,
                value,
                message,
            } => {
                technique_prefix(f, technique)?;
                if value.is_empty() {
                    write!(f, "option {key}: {message}")
                } else {
                    write!(f, "option {key}={value} {message}")
                }
            }
            Error::Technique { technique, message } => {
                technique_prefix(f, technique)?;
                write!(f, "{message}")
            }
            Error::Budget {
                technique,
                what,
                needed,
                limit,
                resource,
            } => {
                technique_prefix(f, technique)?;
                match resource {
                    Resource::Memory => write!(
                        f,
                        "{what} would bring the buffers alive to {}, beyond the memory limit of {}",
                        size_text(*needed),
                        size_text(*limit)
                    ),
                    Resource::Triangles => write!(
                        f,
                        "{what} make {needed} triangles in the scene, beyond its budget of {limit}"
                    ),
                    Resource::Entries => write!(f, "{what}: {needed}, beyond the limit of {limit}"),
                }
            }
            Error::Pipeline(e) => write!(f, "{e}"),
            Error::Io { path, message } => write!(f, "{}: {message}", path.display()),
            Error::Input { message } => write!(f, "{message}"),
        }
    }
}

impl std::error::Error for Error {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            Error::Pipeline(e) => Some(e),
            _ => None,
        }
    }
}

impl From<PipelineError> for Error {
    /// A pipeline error; a surface past the memory budget becomes [`Error::Budget`], so that
    /// callers match memory limits in one place.
    fn from(e: PipelineError) -> Error {
        match e {
            PipelineError::OverBudget(o) => Error::budget(o.what(), o.total(), o.limit, Resource::Memory),
            e => Error::Pipeline(e),
        }
    }
}

/// Why a value was refused, as the end of a sentence ("is not a number", "is not finite"):
/// the caller puts what it names before it (a technique's option, a scene's field) when it
/// makes an [`Error`] of it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Reason(pub String);

impl std::fmt::Display for Reason {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<&str> for Reason {
    fn from(s: &str) -> Reason {
        Reason(s.to_string())
    }
}

impl From<String> for Reason {
    fn from(s: String) -> Reason {
        Reason(s)
    }
}

impl From<Reason> for String {
    fn from(r: Reason) -> String {
        r.0
    }
}

/// A character a terminal would act on instead of showing: a control character (ANSI
/// escapes begin with one) or a bidirectional control that reorders what follows it.
fn hidden(c: char) -> bool {
    c.is_control()
        || matches!(c, '\u{200e}' | '\u{200f}' | '\u{061c}' | '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

/// A whole message as a terminal should get it: every character [`quoted`] escapes in a name
/// (control characters, bidirectional controls) written as a `\u{..}` escape, but line
/// breaks and tabs kept. The command line prints errors, notes and progress through it, so
/// that no text from input acts on the terminal, whichever message carries it.
pub fn for_terminal(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(|c| hidden(c) && c != '\n' && c != '\t') {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if hidden(c) && c != '\n' && c != '\t' {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else {
            out.push(c);
        }
    }
    std::borrow::Cow::Owned(out)
}

/// Most characters of a name that came from input which a message shows ([`quoted`]).
pub const MAX_SHOWN_NAME: usize = 200;

/// A name that came from input (an object's, a node's, a file's), quoted for a message that
/// may reach a terminal: control characters (ANSI escapes among them) and the bidirectional
/// controls that reorder what a terminal shows are written as `\u{..}` escapes, and a name
/// past [`MAX_SHOWN_NAME`] characters is cut, saying how long it was.
pub fn quoted(name: &str) -> String {
    let mut out = String::with_capacity(name.len().min(4 * MAX_SHOWN_NAME) + 2);
    out.push('\'');
    for c in name.chars().take(MAX_SHOWN_NAME) {
        if hidden(c) {
            out.push_str(&format!("\\u{{{:x}}}", c as u32));
        } else if c == '\'' || c == '\\' {
            out.push('\\');
            out.push(c);
        } else {
            out.push(c);
        }
    }
    out.push('\'');
    let n = name.chars().count();
    if n > MAX_SHOWN_NAME {
        out.push_str(&format!(" (cut: {n} characters)"));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::OverBudget;

    #[test]
    fn messages_reach_the_terminal_without_its_controls() {
        assert_eq!(for_terminal("plain\nlines\tand tabs"), "plain\nlines\tand tabs");
        assert_eq!(
            for_terminal("a \u{1b}[2J b \u{202e}c \u{7}"),
            "a \\u{1b}[2J b \\u{202e}c \\u{7}"
        );
    }

    #[test]
    fn names_from_input_are_quoted_without_terminal_controls() {
        assert_eq!(quoted("ground"), "'ground'");
        // An ANSI clear-screen, a window-title change and a right-to-left override.
        let q = quoted("a\u{1b}[2Jb\u{1b}]0;pwned\u{7}c\u{202e}d");
        assert!(!q.chars().any(|c| c.is_control() || c == '\u{202e}'), "{q}");
        assert_eq!(q, "'a\\u{1b}[2Jb\\u{1b}]0;pwned\\u{7}c\\u{202e}d'");
        assert_eq!(quoted("it's"), "'it\\'s'");
        let long = "x".repeat(1 << 20);
        let q = quoted(&long);
        assert!(q.len() < 300 && q.ends_with("(cut: 1048576 characters)"), "{}", q.len());
    }

    #[test]
    fn messages_say_where() {
        let e = Error::Scene {
            file: "a.toml".into(),
            line: Some(3),
            section: Some("[[object]] #1 (box)".into()),
            field: Some("size".into()),
            message: "-1 must be positive".into(),
        };
        assert_eq!(
            e.to_string(),
            "a.toml:3: [[object]] #1 (box), field `size`: -1 must be positive"
        );
        let e = Error::option("size", 3, "is outside [16, 16384]").in_technique("pcss");
        assert_eq!(e.to_string(), "technique 'pcss': option size=3 is outside [16, 16384]");
        // The first technique to name an error keeps it.
        assert!(e.in_technique("hybrid").to_string().starts_with("technique 'pcss'"));
    }

    #[test]
    fn memory_errors_are_budgets_and_name_no_flag() {
        let p = PipelineError::OverBudget(OverBudget {
            width: 100,
            height: 100,
            bytes: 40_000,
            live: 0,
            limit: 10_000,
        });
        let e = Error::from(p).within("the light's maps (1 view, option size=100)");
        assert!(matches!(
            e,
            Error::Budget {
                resource: Resource::Memory,
                needed: 40_000,
                limit: 10_000,
                ..
            }
        ));
        let t = e.in_technique("shadow-map").to_string();
        // Regression: a request whose size overflowed the live total wrapped around in the
        // pipeline's message (1 MiB alive) or panicked with overflow checks.
        let huge = PipelineError::OverBudget(OverBudget {
            width: 1,
            height: 1,
            bytes: u64::MAX,
            live: 1 << 20,
            limit: 1 << 30,
        });
        let m = huge.to_string();
        assert!(
            m.contains("alive to 17592186044416 MiB, beyond the memory limit of 1024 MiB"),
            "{m}"
        );
        assert!(
            t.starts_with("technique 'shadow-map': the light's maps (1 view, option size=100): 100x100 buffers"),
            "{t}"
        );
        assert!(!t.contains("--"), "{t}");
    }
}
