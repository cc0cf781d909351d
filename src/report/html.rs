//! The report page as standalone HTML (from its Markdown).

use super::xml;
use std::fmt::Write as _;

/// The same report as a standalone HTML page (tables and images, no scripts).
pub fn report_html(markdown: &str) -> String {
    let mut html = String::from("<!doctype html><html><head><meta charset=\"utf-8\"><title>penumbra sweep</title><style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:3px 6px}img{max-width:100%}td img{width:160px}</style></head><body>\n");
    let mut in_table = false;
    for line in markdown.lines() {
        let img = |t: &str| -> String {
            // ![alt](src) -> <img>
            let mut out = String::new();
            let mut rest = t;
            while let Some(a) = rest.find("![") {
                out.push_str(&xml(&rest[..a]));
                let after = &rest[a + 2..];
                let (Some(b), Some(c)) = (after.find("]("), after.find(')')) else {
                    out.push_str(&xml(&rest[a..]));
                    return out;
                };
                out.push_str(&format!(
                    "<img alt=\"{}\" src=\"{}\">",
                    xml(&after[..b]),
                    xml(&after[b + 2..c])
                ));
                rest = &after[c + 1..];
            }
            out.push_str(&xml(rest));
            out
        };
        if line.starts_with('|') {
            if line.contains("---") {
                continue;
            }
            let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).collect();
            if !in_table {
                html.push_str("<table><tr>");
                for c in &cells {
                    let _ = write!(html, "<th>{}</th>", img(c));
                }
                html.push_str("</tr>\n");
                in_table = true;
                continue;
            }
            html.push_str("<tr>");
            for c in &cells {
                let _ = write!(html, "<td>{}</td>", img(c));
            }
            html.push_str("</tr>\n");
            continue;
        }
        if in_table {
            html.push_str("</table>\n");
            in_table = false;
        }
        if let Some(t) = line.strip_prefix("## ") {
            let _ = writeln!(html, "<h2>{}</h2>", xml(t));
        } else if let Some(t) = line.strip_prefix("# ") {
            let _ = writeln!(html, "<h1>{}</h1>", xml(t));
        } else if !line.trim().is_empty() {
            let _ = writeln!(html, "<p>{}</p>", img(line));
        }
    }
    if in_table {
        html.push_str("</table>\n");
    }
    html.push_str("</body></html>\n");
    html
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn html_report_converts_tables_and_images() {
        let md = "# t\n\n| a | b |\n| --- | --- |\n| x | ![](p.png) |\n";
        let h = report_html(md);
        assert!(
            h.contains("<th>a</th>") && h.contains("<img alt=\"\" src=\"p.png\">"),
            "{h}"
        );
    }
}
