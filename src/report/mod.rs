//! Reporting: every file the sweep and the CLI write about a run, one format per file:
//! [`images`] (visibility, reference, error), [`mod@csv`], [`chart`] (SVG), [`markdown`] and
//! [`html`] (the report page), [`across`] (settings across many scenes), [`cache`] (reference images on disk) and [`files`] (a run's
//! files in a folder). Measuring is [`crate::run`]'s, which writes nothing.

pub mod across;
pub mod cache;
pub mod chart;
pub mod csv;
pub mod files;
pub mod html;
pub mod images;
pub mod markdown;

pub use cache::DirCache;
pub use chart::{chart_points, class_chart_svg, pareto, path_chart_svg, ChartPoint};
pub use csv::{csv, path_csv, read_csv};
pub use html::report_html;
pub use images::{error_image, visibility_image};
pub use markdown::{report_markdown, summary_markdown, Rows};

/// What the report says of a scene: its name, the failure it shows (the scene file's opening
/// comment) and its class. The sweep writes it beside the CSV (`scenes.json`) so shards merge.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SceneInfo {
    /// Scene name.
    pub name: String,
    /// What it shows and the failure it is for.
    pub description: String,
    /// Its class.
    #[serde(with = "class_key")]
    pub class: crate::scene::SceneClass,
    /// The scene file the sweep read (for the commands the report gives; empty if unknown).
    #[serde(default)]
    pub file: String,
}

mod class_key {
    use crate::scene::SceneClass;
    use serde::{Deserialize, Deserializer, Serializer};

    pub fn serialize<S: Serializer>(c: &SceneClass, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(c.key())
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<SceneClass, D::Error> {
        let k = String::deserialize(d)?;
        SceneClass::from_key(&k).ok_or_else(|| serde::de::Error::custom(format!("unknown scene class '{k}'")))
    }
}

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
