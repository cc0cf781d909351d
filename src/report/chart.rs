//! SVG charts: speed against accuracy (time on a log axis, RMSE up, the Pareto front drawn)
//! and time and counters along a camera path.

use super::xml;
use crate::run::{PathFrame, RunResult};
use std::fmt::Write as _;

/// Indices of the Pareto-optimal points (no other point both faster and more accurate).
pub fn pareto(points: &[(f64, f64)]) -> Vec<usize> {
    let mut idx: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].0.is_finite() && points[i].1.is_finite())
        .collect();
    idx.sort_by(|&a, &b| {
        points[a]
            .0
            .total_cmp(&points[b].0)
            .then(points[a].1.total_cmp(&points[b].1))
    });
    let mut front = Vec::new();
    let mut best = f64::INFINITY;
    for i in idx {
        if points[i].1 < best {
            best = points[i].1;
            front.push(i);
        }
    }
    front
}

/// A speed/accuracy chart as SVG: x = milliseconds (log scale), y = RMSE, one labelled point
/// per result, the Pareto front as a line.
pub fn chart_svg(title: &str, results: &[RunResult]) -> String {
    let (w, h, ml, mr, mt, mb) = (760.0, 480.0, 70.0, 30.0, 40.0, 60.0);
    let pts: Vec<(f64, f64)> = results.iter().map(|r| (r.ms.max(1e-3), r.errors.rmse)).collect();
    let (xmin, xmax) = pts
        .iter()
        .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let ymax = pts.iter().map(|p| p.1).fold(0.0, f64::max).max(1e-3) * 1.1;
    let (lx0, lx1) = (
        (xmin.max(1e-3)).log10().floor(),
        (xmax.max(1e-3))
            .log10()
            .ceil()
            .max(xmin.max(1e-3).log10().floor() + 1.0),
    );
    let px = |x: f64| ml + (x.log10() - lx0) / (lx1 - lx0) * (w - ml - mr);
    let py = |y: f64| h - mb - y / ymax * (h - mt - mb);
    let mut s = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        w / 2.0,
        xml(title)
    );
    let _ = writeln!(
        s,
        "<line x1=\"{ml}\" y1=\"{}\" x2=\"{}\" y2=\"{}\" stroke=\"black\"/>",
        h - mb,
        w - mr,
        h - mb
    );
    let _ = writeln!(
        s,
        "<line x1=\"{ml}\" y1=\"{mt}\" x2=\"{ml}\" y2=\"{}\" stroke=\"black\"/>",
        h - mb
    );
    let mut d = lx0;
    while d <= lx1 + 1e-9 {
        let x = px(10f64.powf(d));
        let _ = writeln!(s, "<line x1=\"{x}\" y1=\"{mt}\" x2=\"{x}\" y2=\"{}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">{} ms</text>", h - mb, h - mb + 16.0, 10f64.powf(d));
        d += 1.0;
    }
    for k in 0..=4 {
        let y = ymax * k as f64 / 4.0;
        let _ = writeln!(s, "<line x1=\"{ml}\" y1=\"{py}\" x2=\"{}\" y2=\"{py}\" stroke=\"#eee\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">{y:.3}</text>", w - mr, ml - 6.0, py(y) + 4.0, py = py(y));
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">time per frame (ms, log scale)</text>",
        w / 2.0,
        h - 18.0
    );
    let _ = writeln!(
        s,
        "<text x=\"16\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {})\">RMSE of visibility</text>",
        h / 2.0,
        h / 2.0
    );
    let front = pareto(&pts);
    let line: Vec<String> = front
        .iter()
        .map(|&i| format!("{:.1},{:.1}", px(pts[i].0), py(pts[i].1)))
        .collect();
    if line.len() > 1 {
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#c33\" stroke-width=\"1.5\" stroke-dasharray=\"4 3\"/>",
            line.join(" ")
        );
    }
    for (i, r) in results.iter().enumerate() {
        let (x, y) = (px(pts[i].0), py(pts[i].1));
        let fill = if front.contains(&i) { "#c33" } else { "#369" };
        let _ = writeln!(
            s,
            "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"4\" fill=\"{fill}\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>",
            x + 6.0,
            y - 4.0,
            xml(&r.label())
        );
    }
    s.push_str("</svg>\n");
    s
}

/// Time and counters along a camera path as SVG: one panel per series (time first, then each
/// counter that is not zero on every frame), frame index on x. RTR 7.3 calls the cost of
/// shadow volumes unpredictable: this is where users see it.
pub fn path_chart_svg(title: &str, frames: &[PathFrame]) -> String {
    let mut series: Vec<(String, Vec<f64>)> = vec![("time (ms)".into(), frames.iter().map(|f| f.ms).collect())];
    if let Some(f0) = frames.first() {
        for (k, (name, _)) in f0.counters.iter().enumerate() {
            let v: Vec<f64> = frames.iter().map(|f| f.counters.get(k).map_or(0.0, |c| c.1)).collect();
            if v.iter().any(|&x| x != 0.0) {
                series.push((name.to_string(), v));
            }
        }
    }
    let (w, ph, ml, mr, mt) = (760.0, 150.0, 90.0, 30.0, 40.0);
    let h = mt + ph * series.len() as f64 + 40.0;
    let n = frames.len().max(2) - 1;
    let px = |i: usize| ml + i as f64 / n as f64 * (w - ml - mr);
    let mut s = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        w / 2.0,
        xml(title)
    );
    for (k, (name, v)) in series.iter().enumerate() {
        let top = mt + ph * k as f64;
        let bottom = top + ph - 30.0;
        let hi = v.iter().copied().fold(0.0, f64::max).max(1e-9) * 1.1;
        let py = |y: f64| bottom - y / hi * (bottom - top);
        let _ = writeln!(
            s,
            "<line x1=\"{ml}\" y1=\"{bottom}\" x2=\"{}\" y2=\"{bottom}\" stroke=\"black\"/><line x1=\"{ml}\" y1=\"{top}\" x2=\"{ml}\" y2=\"{bottom}\" stroke=\"black\"/>",
            w - mr
        );
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"end\">{}</text><text x=\"{}\" y=\"{}\" text-anchor=\"end\">0</text><text x=\"{}\" y=\"{}\" font-weight=\"bold\">{}</text>",
            ml - 6.0,
            top + 10.0,
            fmt_si(hi),
            ml - 6.0,
            bottom,
            ml + 6.0,
            top + 10.0,
            xml(name)
        );
        let line: Vec<String> = v
            .iter()
            .enumerate()
            .map(|(i, &y)| format!("{:.1},{:.1}", px(i), py(y)))
            .collect();
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#369\" stroke-width=\"1.5\"/>",
            line.join(" ")
        );
    }
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">frame of the camera path (0 to {n})</text>",
        w / 2.0,
        h - 14.0
    );
    s.push_str("</svg>\n");
    s
}

/// A number with an SI suffix (1.2k, 3.4M) for axis labels.
fn fmt_si(x: f64) -> String {
    match x.abs() {
        a if a >= 1e9 => format!("{:.1}G", x / 1e9),
        a if a >= 1e6 => format!("{:.1}M", x / 1e6),
        a if a >= 1e3 => format!("{:.1}k", x / 1e3),
        _ => format!("{x:.2}"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pareto_front_keeps_only_undominated_points() {
        let pts = [(1.0, 0.5), (2.0, 0.2), (3.0, 0.3), (0.5, 0.9), (4.0, 0.1), (2.5, 0.2)];
        assert_eq!(pareto(&pts), vec![3, 0, 1, 4]);
    }
}
