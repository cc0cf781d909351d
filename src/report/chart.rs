//! SVG charts: speed against accuracy per scene class (time on a log axis, the class's error
//! up, families coloured, the Pareto front drawn) and time and counters along a camera path.

use super::xml;
use crate::metrics;
use crate::run::{PathFrame, RunResult};
use crate::scene::SceneClass;
use crate::shadow::Family;
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

/// One point of a speed/accuracy chart: a technique setting over the scenes of a class.
#[derive(Clone, Debug, PartialEq)]
pub struct ChartPoint {
    /// `technique [settings]`.
    pub label: String,
    /// Technique name.
    pub technique: String,
    /// Whether the setting is the technique's defaults.
    pub default: bool,
    /// Its family (the point's colour).
    pub family: Family,
    /// Median milliseconds over the scenes.
    pub ms: f64,
    /// Mean error over the scenes (the class's metric).
    pub error: f64,
    /// The scenes it was measured on.
    pub scenes: Vec<String>,
}

/// The chart's points for `results` (all of one [`SceneClass`], or of one scene): one per
/// technique setting, its median time and mean [`RunResult::class_error`] over its scenes, in
/// first-seen order.
pub fn chart_points(results: &[RunResult]) -> Vec<ChartPoint> {
    let mut points: Vec<ChartPoint> = Vec::new();
    let mut times: Vec<Vec<f64>> = Vec::new();
    for r in results {
        let label = r.label();
        let i = match points.iter().position(|p| p.label == label) {
            Some(i) => i,
            None => {
                points.push(ChartPoint {
                    label,
                    technique: r.technique.clone(),
                    default: r.settings.is_empty(),
                    family: r.family,
                    ms: 0.0,
                    error: 0.0,
                    scenes: Vec::new(),
                });
                times.push(Vec::new());
                points.len() - 1
            }
        };
        points[i].error += r.class_error();
        points[i].scenes.push(r.scene.clone());
        times[i].push(r.ms);
    }
    for (p, t) in points.iter_mut().zip(times) {
        p.error /= p.scenes.len() as f64;
        p.ms = metrics::median(t);
    }
    points
}

/// The colour of a family on every chart (a qualitative palette, distinct in greyscale too).
pub fn family_colour(f: Family) -> &'static str {
    match f {
        Family::Reference => "#000000",
        Family::Map => "#1f77b4",
        Family::Volume => "#d62728",
        Family::Planar => "#8c564b",
        Family::Exact => "#2ca02c",
        Family::Penumbra => "#9467bd",
        Family::Volumetric => "#ff7f0e",
        Family::Screen => "#17becf",
        Family::Filtered => "#bcbd22",
    }
}

/// A speed/accuracy chart as SVG for the scenes of one class (or one scene): x = median
/// milliseconds (log scale), y = the class's error ([`SceneClass::metric`]); one point per
/// technique setting coloured by family with a legend, the reference as its own mark (a
/// diamond), the Pareto front as a line, labels on the front's points and on each technique's
/// defaults where they do not overlap, and every point's numbers in a tooltip (`<title>`).
pub fn class_chart_svg(title: &str, class: SceneClass, results: &[RunResult]) -> String {
    let points = chart_points(results);
    let a = Axes::fitting(&points);
    let (w, h, ml, mr) = (a.w, a.h, a.ml, a.mr);
    let mut s = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    let _ = writeln!(
        s,
        "<text x=\"{}\" y=\"22\" font-size=\"15\" text-anchor=\"middle\">{}</text>",
        (w - mr + ml) / 2.0,
        xml(title)
    );
    a.draw(&mut s, class);
    // The Pareto front (the reference is exact by definition: left out of the front).
    let pts: Vec<(f64, f64)> = points
        .iter()
        .map(|p| {
            if p.family == Family::Reference {
                (f64::NAN, f64::NAN)
            } else {
                (p.ms.max(1e-3), p.error)
            }
        })
        .collect();
    let front = pareto(&pts);
    let line: Vec<String> = front
        .iter()
        .map(|&i| format!("{:.1},{:.1}", a.px(pts[i].0), a.py(pts[i].1)))
        .collect();
    if line.len() > 1 {
        let _ = writeln!(
            s,
            "<polyline points=\"{}\" fill=\"none\" stroke=\"#888\" stroke-width=\"1.2\" stroke-dasharray=\"4 3\"/>",
            line.join(" ")
        );
    }
    draw_points(&mut s, &a, class, &points);
    draw_labels(&mut s, &a, &points, &front);
    draw_legend(&mut s, &a, &points);
    s.push_str("</svg>\n");
    s
}

/// A speed/accuracy chart's frame: its size and margins, and its two log axes fitted to the
/// points (x: milliseconds by decades; y: errors by decades from the smallest positive one,
/// at most five below the largest).
struct Axes {
    w: f64,
    h: f64,
    ml: f64,
    mr: f64,
    mt: f64,
    mb: f64,
    lx0: f64,
    lx1: f64,
    ly0: f64,
    ly1: f64,
}

impl Axes {
    /// The axes that hold every point with a finite time and error.
    fn fitting(points: &[ChartPoint]) -> Axes {
        let (w, h, ml, mr, mt, mb) = (860.0, 520.0, 70.0, 200.0, 40.0, 60.0);
        let finite: Vec<&ChartPoint> = points
            .iter()
            .filter(|p| p.ms.is_finite() && p.error.is_finite())
            .collect();
        let xs = || finite.iter().map(|p| p.ms.max(1e-3));
        let xmin = xs().fold(f64::INFINITY, f64::min);
        let xmax = xs().fold(0.0, f64::max);
        let (xmin, xmax) = if xmin.is_finite() { (xmin, xmax) } else { (1.0, 10.0) };
        // Errors span decades (exact techniques at 0.001 %, acne at 50 %): a log axis from the
        // decade of the smallest positive error (at most five decades below the largest); errors
        // at or below its floor, zero among them, sit on the bottom line.
        let ymax = finite.iter().map(|p| p.error).fold(0.0, f64::max);
        let ypos = finite
            .iter()
            .map(|p| p.error)
            .filter(|&e| e > 0.0)
            .fold(f64::INFINITY, f64::min);
        let ly1 = if ymax > 0.0 { ymax.log10().ceil() } else { 0.0 };
        let ly0 = if ypos.is_finite() {
            ypos.log10().floor().max(ly1 - 5.0)
        } else {
            ly1 - 1.0
        }
        .min(ly1 - 1.0);
        let lx0 = xmin.log10().floor();
        let lx1 = xmax.log10().ceil().max(lx0 + 1.0);
        Axes {
            w,
            h,
            ml,
            mr,
            mt,
            mb,
            lx0,
            lx1,
            ly0,
            ly1,
        }
    }

    /// The x of `x` milliseconds.
    fn px(&self, x: f64) -> f64 {
        self.ml + (x.max(1e-3).log10() - self.lx0) / (self.lx1 - self.lx0) * (self.w - self.ml - self.mr)
    }

    /// The y of error `y` (errors at or below the axis's floor on the bottom line).
    fn py(&self, y: f64) -> f64 {
        let t = if y > 0.0 {
            ((y.log10() - self.ly0) / (self.ly1 - self.ly0)).max(0.0)
        } else {
            0.0
        };
        self.h - self.mb - t * (self.h - self.mt - self.mb)
    }

    /// Axes, decades and error ticks, and the axes' titles.
    fn draw(&self, s: &mut String, class: SceneClass) {
        let (w, h, ml, mr, mt, mb) = (self.w, self.h, self.ml, self.mr, self.mt, self.mb);
        let _ = writeln!(
            s,
            "<line x1=\"{ml}\" y1=\"{b}\" x2=\"{r}\" y2=\"{b}\" stroke=\"black\"/><line x1=\"{ml}\" y1=\"{mt}\" x2=\"{ml}\" y2=\"{b}\" stroke=\"black\"/>",
            b = h - mb,
            r = w - mr
        );
        let mut d = self.lx0;
        while d <= self.lx1 + 1e-9 {
            let x = self.px(10f64.powf(d));
            let _ = writeln!(s, "<line x1=\"{x:.1}\" y1=\"{mt}\" x2=\"{x:.1}\" y2=\"{}\" stroke=\"#ddd\"/><text x=\"{x:.1}\" y=\"{}\" text-anchor=\"middle\">{} ms</text>", h - mb, h - mb + 16.0, 10f64.powf(d));
            d += 1.0;
        }
        let mut d = self.ly0;
        while d <= self.ly1 + 1e-9 {
            let y = 10f64.powf(d);
            let label = if d == self.ly0 {
                format!("\u{2264} {y}")
            } else {
                format!("{y}")
            };
            let _ = writeln!(s, "<line x1=\"{ml}\" y1=\"{py:.1}\" x2=\"{}\" y2=\"{py:.1}\" stroke=\"#eee\"/><text x=\"{}\" y=\"{:.1}\" text-anchor=\"end\">{label}</text>", w - mr, ml - 6.0, self.py(y) + 4.0, py = self.py(y));
            d += 1.0;
        }
        let _ = writeln!(
            s,
            "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">median time per frame (ms, log scale)</text>",
            (w - mr + ml) / 2.0,
            h - 18.0
        );
        let _ = writeln!(
            s,
            "<text x=\"16\" y=\"{c}\" text-anchor=\"middle\" transform=\"rotate(-90 16 {c})\">mean {} (log scale)</text>",
            xml(class.metric()),
            c = h / 2.0
        );
    }
}

/// The points, each with its numbers as a tooltip: the reference a diamond, the others
/// circles in their family's colour.
fn draw_points(s: &mut String, a: &Axes, class: SceneClass, points: &[ChartPoint]) {
    for p in points.iter().filter(|p| p.ms.is_finite() && p.error.is_finite()) {
        let (x, y) = (a.px(p.ms), a.py(p.error));
        let tip = format!(
            "{}\nfamily: {}\nmedian time: {:.2} ms\nmean {}: {:.4}\nscenes ({}): {}",
            p.label,
            p.family.title(),
            p.ms,
            class.metric(),
            p.error,
            p.scenes.len(),
            p.scenes.join(", ")
        );
        let colour = family_colour(p.family);
        if p.family == Family::Reference {
            let _ = writeln!(
                s,
                "<path d=\"M{x:.1} {:.1} l6 6 l-6 6 l-6 -6 z\" fill=\"{colour}\"><title>{}</title></path>",
                y - 6.0,
                xml(&tip)
            );
        } else {
            let _ = writeln!(
                s,
                "<circle cx=\"{x:.1}\" cy=\"{y:.1}\" r=\"4.5\" fill=\"{colour}\" fill-opacity=\"0.85\" stroke=\"white\" stroke-width=\"0.8\"><title>{}</title></circle>",
                xml(&tip)
            );
        }
    }
}

/// Labels: the reference, the `front`, then each technique's defaults; a label that would
/// overlap one already placed is left to the tooltip.
fn draw_labels(s: &mut String, a: &Axes, points: &[ChartPoint], front: &[usize]) {
    let mut order: Vec<usize> = points
        .iter()
        .position(|p| p.family == Family::Reference)
        .into_iter()
        .collect();
    order.extend(front.iter().copied());
    order.extend((0..points.len()).filter(|&i| points[i].default));
    let mut placed: Vec<(f64, f64, f64, f64)> = Vec::new();
    for i in order {
        let p = &points[i];
        if !p.ms.is_finite() || !p.error.is_finite() {
            continue;
        }
        let (x, y) = (a.px(p.ms) + 7.0, a.py(p.error) - 5.0);
        let bw = 6.0 * p.label.chars().count() as f64;
        let b = (x, y - 10.0, x + bw, y + 2.0);
        let overlaps = placed.iter().any(|q| b.0 < q.2 && q.0 < b.2 && b.1 < q.3 && q.1 < b.3);
        if overlaps || placed.iter().any(|q| q.0 == b.0 && q.1 == b.1) {
            continue;
        }
        placed.push(b);
        let _ = writeln!(s, "<text x=\"{x:.1}\" y=\"{y:.1}\">{}</text>", xml(&p.label));
    }
}

/// The legend: the families present, the Pareto front's line, and a hint.
fn draw_legend(s: &mut String, a: &Axes, points: &[ChartPoint]) {
    let (lx, mut ly) = (a.w - a.mr + 16.0, a.mt + 10.0);
    let mut fams: Vec<Family> = points.iter().map(|p| p.family).collect();
    fams.sort();
    fams.dedup();
    for f in fams {
        let _ = writeln!(
            s,
            "<circle cx=\"{lx}\" cy=\"{ly}\" r=\"5\" fill=\"{}\"/><text x=\"{}\" y=\"{}\">{}</text>",
            family_colour(f),
            lx + 10.0,
            ly + 4.0,
            xml(f.title())
        );
        ly += 18.0;
    }
    let _ = writeln!(
        s,
        "<line x1=\"{}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"#888\" stroke-dasharray=\"4 3\"/><text x=\"{}\" y=\"{}\">Pareto front</text>",
        lx - 6.0,
        lx + 6.0,
        lx + 10.0,
        ly + 4.0
    );
    let _ = writeln!(
        s,
        "<text x=\"{lx}\" y=\"{}\" fill=\"#555\">hover a point for its numbers</text>",
        ly + 26.0
    );
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
