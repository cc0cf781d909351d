//! Reporting: every file the sweep and the CLI write about a run, one format per file:
//! [`images`] (visibility, reference, error), [`mod@csv`], [`chart`] (SVG), [`markdown`] and
//! [`html`] (the report page), [`cache`] (reference images on disk) and [`files`] (a run's
//! files in a folder). Measuring is [`crate::run`]'s, which writes nothing.

pub mod cache;
pub mod chart;
pub mod csv;
pub mod files;
pub mod html;
pub mod images;
pub mod markdown;

pub use cache::DirCache;
pub use chart::{chart_svg, pareto, path_chart_svg};
pub use csv::{csv, path_csv};
pub use html::report_html;
pub use images::{error_image, visibility_image};
pub use markdown::{report_markdown, summary_markdown};

/// A file-name-safe version of a label.
pub fn file_safe(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '-' || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect::<String>()
        .trim_matches('_')
        .to_string()
}

/// Escapes text for XML and HTML.
pub(crate) fn xml(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
