//! The report page: one standalone HTML file that opens offline (no network resources). The
//! class charts and each scene's chart are inline SVG (hover a point for its numbers); per
//! scene a table sortable by any column, with the visibility, the reference and the error
//! image side by side (click to enlarge), the camera-path charts, and the failure the
//! fixture shows in words. Every text that comes from a scene file is escaped.

use super::{chart, xml, SceneInfo};
use crate::run::RunResult;
use crate::scene::SceneClass;
use std::fmt::Write as _;

const STYLE: &str = "body{font-family:sans-serif;max-width:1200px;margin:auto;padding:0 12px;color:#222}\
table{border-collapse:collapse;font-size:13px}td,th{border:1px solid #ccc;padding:3px 6px;text-align:right}\
td:first-child,th:first-child{text-align:left}th{background:#f3f3f3;cursor:pointer;user-select:none}\
th.asc::after{content:' \\25B2'}th.desc::after{content:' \\25BC'}td img{width:110px;cursor:zoom-in;margin:1px}td.imgs{white-space:nowrap}\
details.cmd{font-size:11px;color:#555}details.cmd code{white-space:nowrap}\
.fail{background:#fff8e0;border-left:4px solid #e0b000;padding:6px 10px}nav a{margin-right:10px}\
#box{display:none;position:fixed;inset:0;background:rgba(0,0,0,.85);align-items:center;justify-content:center;cursor:zoom-out}\
#box img{max-width:95vw;max-height:90vh;image-rendering:pixelated}#box div{color:#fff;position:fixed;top:8px;left:12px}\
svg{max-width:100%;height:auto}";

const SCRIPT: &str = r#"
function sortBy(th){
  var table=th.closest('table'),i=Array.prototype.indexOf.call(th.parentNode.children,th);
  var asc=!th.classList.contains('asc');
  Array.prototype.forEach.call(th.parentNode.children,function(h){h.classList.remove('asc','desc');});
  th.classList.add(asc?'asc':'desc');
  var rows=Array.prototype.slice.call(table.tBodies[0].rows);
  rows.sort(function(a,b){
    var x=a.cells[i].getAttribute('data-v'),y=b.cells[i].getAttribute('data-v');
    var nx=parseFloat(x),ny=parseFloat(y),c;
    if(!isNaN(nx)&&!isNaN(ny)){c=nx-ny;}else{c=String(x).localeCompare(String(y));}
    return asc?c:-c;
  });
  rows.forEach(function(r){table.tBodies[0].appendChild(r);});
}
document.addEventListener('click',function(e){
  var t=e.target;
  if(t.tagName==='TH'){sortBy(t);return;}
  var box=document.getElementById('box');
  if(t.tagName==='IMG'&&t.closest('td')){
    box.querySelector('img').src=t.src;box.querySelector('div').textContent=t.alt;box.style.display='flex';return;}
  if(t.closest('#box')){box.style.display='none';}
});
document.addEventListener('keydown',function(e){if(e.key==='Escape'){document.getElementById('box').style.display='none';}});
"#;

/// A table cell with its sort key.
fn num(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("<td data-v=\"{v}\">{v:.digits$}</td>")
    } else {
        "<td data-v=\"\">-</td>".into()
    }
}

/// The report page for `results` on `scenes`. `images(r)` gives the relative paths of a run's
/// visibility, reference and error images (none: no images), `path_chart(r)` its camera-path
/// chart, `explore(file, r)` the command line that opens run `r` of scene file `file` in an
/// explorer (none: no fold-out; the caller, which knows its command line, says it).
pub fn report_html(
    results: &[RunResult],
    scenes: &[SceneInfo],
    images: &dyn Fn(&RunResult) -> Option<[String; 3]>,
    path_chart: &dyn Fn(&RunResult) -> Option<String>,
    explore: &dyn Fn(&str, &RunResult) -> Option<String>,
) -> String {
    let mut h = format!(
        "<!doctype html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>penumbra sweep</title><style>{STYLE}</style></head><body>\n<h1>penumbra sweep</h1>\n<p>Every technique setting on every scene against the ray-traced reference. Time is the median of the technique's visibility pass; errors are over pixels covered by geometry and facing the light. Errors of different kinds do not average, so the charts are per scene class: hard-light scenes by wrong pixels, area-light scenes by penumbra RMSE, transparent scenes by transmittance RMSE. Hover a chart's point for its numbers, click a column to sort, click an image to enlarge it.</p>\n<nav>"
    );
    for c in SceneClass::ALL {
        if results.iter().any(|r| r.class == c) {
            let _ = write!(h, "<a href=\"#class-{}\">{}</a>", c.key(), xml(c.title()));
        }
    }
    for s in scenes {
        let _ = write!(h, "<a href=\"#scene-{0}\">{0}</a>", xml(&s.name));
    }
    h.push_str("</nav>\n");
    for c in SceneClass::ALL {
        let rs: Vec<RunResult> = results.iter().filter(|r| r.class == c).cloned().collect();
        if rs.is_empty() {
            continue;
        }
        let mut names: Vec<&str> = scenes
            .iter()
            .filter(|s| s.class == c)
            .map(|s| s.name.as_str())
            .collect();
        names.dedup();
        let _ = writeln!(
            h,
            "<h2 id=\"class-{}\">{}</h2>\n<p>{} scene{}: {}.</p>\n{}",
            c.key(),
            xml(c.title()),
            names.len(),
            if names.len() == 1 { "" } else { "s" },
            xml(&names.join(", ")),
            chart::class_chart_svg(&format!("{}: time vs {}", c.title(), c.metric()), c, &rs)
        );
    }
    for s in scenes {
        let rs: Vec<RunResult> = results.iter().filter(|r| r.scene == s.name).cloned().collect();
        let _ = writeln!(
            h,
            "<h2 id=\"scene-{0}\">{0} <small>({1})</small></h2>\n<p class=\"fail\">{2}</p>\n{3}",
            xml(&s.name),
            xml(s.class.title()),
            xml(&s.description),
            chart::class_chart_svg(&format!("{}: time vs {}", s.name, s.class.metric()), s.class, &rs)
        );
        h.push_str("<table><thead><tr><th>technique [settings]</th><th>family</th><th>ms</th><th>RMSE</th><th>MAE</th><th>wrong %</th><th>penumbra RMSE</th><th>transparent RMSE</th><th>flicker</th><th>jumps</th><th>banding</th><th>visibility, reference, error</th></tr></thead><tbody>\n");
        for r in &rs {
            let e = &r.errors;
            let _ = write!(
                h,
                "<tr><td data-v=\"{0}\">{0}{11}</td><td data-v=\"{1}\">{1}</td>{2}{3}{4}{5}{6}{7}{8}{9}{10}",
                xml(&r.label()),
                xml(r.family.key()),
                num(r.ms, 2),
                num(e.rmse, 4),
                num(e.mae, 4),
                num(e.wrong_pct, 3),
                num(e.penumbra_rmse, 4),
                if r.transparent.pixels > 0 {
                    num(r.transparent.rmse, 4)
                } else {
                    num(f64::NAN, 0)
                },
                num(r.flicker, 4),
                num(r.discontinuity, 4),
                num(r.banding, 4),
                explore_fold(s, r, explore),
            );
            h.push_str("<td class=\"imgs\" data-v=\"\">");
            if let Some(imgs) = images(r) {
                for (src, what) in imgs.iter().zip(["visibility", "reference", "error"]) {
                    let _ = write!(
                        h,
                        "<img loading=\"lazy\" src=\"{}\" alt=\"{}: {} ({what})\">",
                        xml(src),
                        xml(&s.name),
                        xml(&r.label())
                    );
                }
            }
            h.push_str("</td></tr>\n");
        }
        h.push_str("</tbody></table>\n");
        let charts: Vec<(String, String)> = rs
            .iter()
            .filter_map(|r| path_chart(r).map(|p| (r.label(), p)))
            .collect();
        if !charts.is_empty() {
            let _ = writeln!(h, "<h3>{}: time and work along the camera path</h3>", xml(&s.name));
            for (label, p) in charts {
                let _ = writeln!(h, "<p><img src=\"{}\" alt=\"{}\"></p>", xml(&p), xml(&label));
            }
        }
    }
    let _ = write!(
        h,
        "<div id=\"box\"><div></div><img alt=\"\"></div>\n<script>{SCRIPT}</script>\n</body></html>\n"
    );
    h
}

/// The command that opens a run in an explorer (`explore`'s), as a fold-out under its label.
fn explore_fold(s: &SceneInfo, r: &RunResult, explore: &dyn Fn(&str, &RunResult) -> Option<String>) -> String {
    if s.file.is_empty() {
        return String::new();
    }
    match explore(&s.file, r) {
        Some(cmd) => format!(
            "<details class=\"cmd\"><summary>explore</summary><code>{}</code></details>",
            xml(&cmd)
        ),
        None => String::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shadow::Family;

    #[test]
    fn scene_text_is_escaped_and_the_page_has_no_network_resources() {
        let r = RunResult {
            scene: "s<x>".into(),
            technique: "shadow-map".into(),
            family: Family::Map,
            ms: 1.0,
            ..Default::default()
        };
        let scenes = [SceneInfo {
            name: "s<x>".into(),
            description: "![x](javascript:alert(1)) <script>alert(2)</script>".into(),
            class: SceneClass::Hard,
            file: "fixtures/scenes/s.toml".into(),
        }];
        let h = report_html(
            &[r],
            &scenes,
            &|_| Some(["a\".png".into(), "b.png".into(), "c.png".into()]),
            &|_| None,
            &|file, r| Some(format!("explore {file} {}", r.technique)),
        );
        assert!(!h.contains("<script>alert"), "raw HTML from a scene file");
        assert!(!h.contains("src=\"javascript:"), "a javascript: URL");
        assert!(h.contains("a&quot;.png"));
        assert!(!h.contains("http://") || !h.replace("http://www.w3.org/2000/svg", "").contains("http://"));
        assert!(!h.contains("https://"));
        assert_eq!(h.matches("<table>").count(), 1);
        assert!(h.contains("<code>explore fixtures/scenes/s.toml shadow-map</code>"));
    }
}
