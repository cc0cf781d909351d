//! The CLI's error: a message for the terminal. A library error becomes one with how the CLI
//! raises the limit it hit (the library's messages name no flag).

use penumbra::{Error, Resource};
use std::fmt;

/// A message for `penumbra: error: ...`.
#[derive(Debug)]
pub struct CliError(pub String);

impl fmt::Display for CliError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl From<String> for CliError {
    fn from(s: String) -> CliError {
        CliError(s)
    }
}

impl From<&str> for CliError {
    fn from(s: &str) -> CliError {
        CliError(s.to_string())
    }
}

impl From<Error> for CliError {
    fn from(e: Error) -> CliError {
        let hint = match &e {
            Error::Budget {
                resource: Resource::Memory,
                ..
            } => " (raise the limit with --max-memory)",
            Error::Budget {
                resource: Resource::Triangles,
                ..
            } => " (raise it with PENUMBRA_MAX_TRIANGLES)",
            Error::Budget {
                what,
                resource: Resource::Entries,
                ..
            } if what.contains("option capacity") => " (raise it with --set capacity=...)",
            _ => "",
        };
        CliError(format!("{e}{hint}"))
    }
}

impl From<penumbra::pipeline::PipelineError> for CliError {
    fn from(e: penumbra::pipeline::PipelineError) -> CliError {
        CliError::from(Error::from(e))
    }
}
