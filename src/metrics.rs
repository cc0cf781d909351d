//! Accuracy metrics of a visibility image against the reference (DESIGN.md section 4), over the
//! pixels of a mask (covered by geometry and facing the light). Knows nothing of the pipeline or
//! of techniques.

use crate::visibility::Visibility;

/// Errors of one image.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Errors {
    /// Root-mean-square error.
    pub rmse: f64,
    /// Mean absolute error.
    pub mae: f64,
    /// Percentage of pixels with |v - v_ref| > 0.5 (acne, leaks, aliasing).
    pub wrong_pct: f64,
    /// RMSE where 0 < v_ref < 1 (0 when there is no penumbra).
    pub penumbra_rmse: f64,
    /// Pixels measured.
    pub pixels: u64,
    /// Penumbra pixels measured.
    pub penumbra_pixels: u64,
}

/// Compares `v` with `reference` over `mask`. Non-finite values of `v` count as maximal
/// error (1), so a technique cannot hide failures behind NaN. Where either image has colour,
/// RMSE and MAE run over every channel of every pixel (a scalar counts in each channel), and
/// wrong % and the penumbra mask use luminance.
pub fn compare(v: &Visibility, reference: &Visibility, mask: &[bool]) -> Errors {
    match (v, reference) {
        (Visibility::Scalar(a), Visibility::Scalar(b)) => compare_scalar(a, b, mask),
        _ => compare_rgb(v, reference, mask),
    }
}

fn compare_rgb(v: &Visibility, reference: &Visibility, mask: &[bool]) -> Errors {
    let (mut se, mut ae, mut wrong, mut n, mut pse, mut pn) = (0.0f64, 0.0f64, 0u64, 0u64, 0.0f64, 0u64);
    for (i, &m) in mask.iter().enumerate().take(v.len().min(reference.len())) {
        let (a, r) = (v.rgb(i), reference.rgb(i));
        if !m || !r.is_finite() {
            continue;
        }
        let d = if a.is_finite() {
            (a - r).abs().as_dvec3()
        } else {
            glam::DVec3::ONE
        };
        se += d.length_squared();
        ae += d.x + d.y + d.z;
        n += 1;
        let (la, lr) = (v.value(i), reference.value(i));
        let dl = if la.is_finite() { (la - lr).abs() } else { 1.0 };
        if dl > 0.5 {
            wrong += 1;
        }
        if lr > 0.0 && lr < 1.0 {
            pse += d.length_squared();
            pn += 1;
        }
    }
    if n == 0 {
        return Errors::default();
    }
    Errors {
        rmse: (se / (3 * n) as f64).sqrt(),
        mae: ae / (3 * n) as f64,
        wrong_pct: 100.0 * wrong as f64 / n as f64,
        penumbra_rmse: if pn > 0 { (pse / (3 * pn) as f64).sqrt() } else { 0.0 },
        pixels: n,
        penumbra_pixels: pn,
    }
}

/// [`compare`] of two scalar images.
pub fn compare_scalar(v: &[f32], reference: &[f32], mask: &[bool]) -> Errors {
    let (mut se, mut ae, mut wrong, mut n, mut pse, mut pn) = (0.0f64, 0.0f64, 0u64, 0u64, 0.0f64, 0u64);
    for ((&a, &r), &m) in v.iter().zip(reference).zip(mask) {
        if !m || !r.is_finite() {
            continue;
        }
        let d = if a.is_finite() {
            (a as f64 - r as f64).abs()
        } else {
            1.0
        };
        se += d * d;
        ae += d;
        n += 1;
        if d > 0.5 {
            wrong += 1;
        }
        if r > 0.0 && r < 1.0 {
            pse += d * d;
            pn += 1;
        }
    }
    if n == 0 {
        return Errors::default();
    }
    Errors {
        rmse: (se / n as f64).sqrt(),
        mae: ae / n as f64,
        wrong_pct: 100.0 * wrong as f64 / n as f64,
        penumbra_rmse: if pn > 0 { (pse / pn as f64).sqrt() } else { 0.0 },
        pixels: n,
        penumbra_pixels: pn,
    }
}

/// Calls `f(i, j)` for every pair of horizontally and vertically neighbouring masked pixels
/// of the same object (`ids`) whose reference values are both strictly between `lo` and `hi`
/// (the penumbra, or its inner part); `width` is the images' row length.
fn penumbra_pairs(
    reference: &Visibility,
    mask: &[bool],
    ids: &[u32],
    width: usize,
    (lo, hi): (f32, f32),
    n: usize,
    mut f: impl FnMut(usize, usize),
) {
    if width == 0 {
        return;
    }
    let inside = |i: usize| {
        let r = reference.value(i);
        mask[i] && r > lo && r < hi
    };
    for i in 0..n {
        if !inside(i) {
            continue;
        }
        let right = (i % width + 1 < width).then_some(i + 1);
        let down = (i + width < n).then_some(i + width);
        for j in [right, down].into_iter().flatten() {
            if inside(j) && ids[i] == ids[j] {
                f(i, j);
            }
        }
    }
}

/// Visibility discontinuities inside the penumbra (Cournia fig. 4.8): the mean, over the
/// pairs of horizontally and vertically neighbouring masked pixels of the same object (`ids`)
/// whose reference values are both in the penumbra (strictly between 0 and 1), of
/// `max(0, |v_i - v_j| - |r_i - r_j|)`: how much the technique jumps between neighbours
/// beyond the truth's own change. `width` is the images' row length; non-finite values of `v`
/// count as a jump of 1. 0 without penumbra pairs.
pub fn discontinuity(v: &Visibility, reference: &Visibility, mask: &[bool], ids: &[u32], width: usize) -> f64 {
    let n = v.len().min(reference.len()).min(mask.len()).min(ids.len());
    let (mut sum, mut pairs) = (0.0f64, 0u64);
    penumbra_pairs(reference, mask, ids, width, (0.0, 1.0), n, |i, j| {
        let (a, b) = (v.value(i), v.value(j));
        let dv = if a.is_finite() && b.is_finite() {
            (a - b).abs() as f64
        } else {
            1.0
        };
        let dr = (reference.value(i) - reference.value(j)).abs() as f64;
        sum += (dv - dr).max(0.0);
        pairs += 1;
    });
    if pairs == 0 {
        0.0
    } else {
        sum / pairs as f64
    }
}

/// Banding inside the penumbra (Cournia fig. 5.3): the fraction of the neighbouring pixel
/// pairs of [`discontinuity`] whose reference values are both in the inner penumbra (0.02 to
/// 0.98) and whose technique values are both strictly between 0 and 1 and equal within
/// `1e-5`: plateaus of one partial visibility where the truth is a ramp. A regular filter
/// grid makes them (its taps cross an edge all at once); jitter and a smooth estimate do not.
/// Umbra and lit plateaus (0 or 1) are a penumbra width error and do not count. 0 without
/// such pairs.
pub fn banding(v: &Visibility, reference: &Visibility, mask: &[bool], ids: &[u32], width: usize) -> f64 {
    let n = v.len().min(reference.len()).min(mask.len()).min(ids.len());
    let (mut flat, mut pairs) = (0u64, 0u64);
    penumbra_pairs(reference, mask, ids, width, (0.02, 0.98), n, |i, j| {
        let (a, b) = (v.value(i), v.value(j));
        let partial = |x: f32| x > 0.0 && x < 1.0;
        if partial(a) && partial(b) && (a - b).abs() <= 1e-5 {
            flat += 1;
        }
        pairs += 1;
    });
    if pairs == 0 {
        0.0
    } else {
        flat as f64 / pairs as f64
    }
}

/// Flicker along a camera path: the mean over consecutive frames and masked pixels of
/// `max(0, |v_t - v_{t-1}| - |r_t - r_{t-1}|)`: change of the technique beyond the change of
/// the truth at the same pixel.
pub fn flicker(frames: &[(Visibility, &Visibility, &[bool])]) -> f64 {
    let mut acc = Flicker::default();
    for w in frames.windows(2) {
        acc.add((&w[0].0, w[0].1, w[0].2), (&w[1].0, w[1].1, w[1].2));
    }
    acc.value()
}

/// [`flicker`] one pair of consecutive frames at a time, so that a camera path's frames need
/// not all be kept.
#[derive(Copy, Clone, Debug, Default)]
pub struct Flicker {
    sum: f64,
    n: u64,
}

impl Flicker {
    /// Adds the change from `prev` to `cur` (each: technique, reference, metric mask).
    pub fn add(&mut self, prev: (&Visibility, &Visibility, &[bool]), cur: (&Visibility, &Visibility, &[bool])) {
        let ((v0, r0, m0), (v1, r1, m1)) = (prev, cur);
        for i in 0..v1.len().min(v0.len()) {
            let (a0, a1, b0, b1) = (v0.value(i), v1.value(i), r0.value(i), r1.value(i));
            if !(m0[i] && m1[i] && b0.is_finite() && b1.is_finite()) {
                continue;
            }
            let dv = if a0.is_finite() && a1.is_finite() {
                (a1 - a0).abs() as f64
            } else {
                1.0
            };
            let dr = (b1 - b0).abs() as f64;
            self.sum += (dv - dr).max(0.0);
            self.n += 1;
        }
    }

    /// The mean so far (0 before any pair).
    pub fn value(&self) -> f64 {
        if self.n == 0 {
            0.0
        } else {
            self.sum / self.n as f64
        }
    }
}

/// The median and 99th percentile (nearest rank) of a per-pixel shadow-map texel footprint
/// ([`crate::shadow::light::texel_footprint`], in camera pixels) over the pixels of `mask`
/// where it is finite; NaN for both where there is none.
pub fn footprint(values: &[f32], mask: &[bool]) -> (f64, f64) {
    let mut v: Vec<f64> = values
        .iter()
        .zip(mask)
        .filter(|(f, m)| **m && f.is_finite())
        .map(|(f, _)| *f as f64)
        .collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    let rank = ((0.99 * v.len() as f64).ceil() as usize).clamp(1, v.len()) - 1;
    (median_of(&mut v), v[rank])
}

/// Median of timings (seconds), the value reported after warm-up runs.
pub fn median(mut v: Vec<f64>) -> f64 {
    median_of(&mut v)
}

/// Median of a list of values, sorted in place (0 for none).
pub fn median_of(v: &mut [f64]) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn metrics_on_a_known_case() {
        let r = [0.0, 1.0, 0.5, 1.0, f32::NAN];
        let v = [0.0, 0.0, 0.75, f32::NAN, 1.0];
        let m = [true, true, true, true, true];
        let e = compare_scalar(&v, &r, &m);
        assert_eq!(e.pixels, 4);
        assert_eq!(e.penumbra_pixels, 1);
        assert!((e.mae - (0.0 + 1.0 + 0.25 + 1.0) / 4.0).abs() < 1e-12);
        assert!((e.wrong_pct - 50.0).abs() < 1e-12);
        assert!((e.penumbra_rmse - 0.25).abs() < 1e-12);
        assert!((e.rmse - ((1.0 + 0.0625 + 1.0) / 4.0f64).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn colour_metrics_run_over_channels_and_wrong_uses_luminance() {
        use glam::Vec3;
        let r = Visibility::Rgb(vec![Vec3::new(1.0, 0.0, 0.0), Vec3::ONE]);
        // A grey technique: 1 everywhere (pixel 0 is off by 1 in two channels).
        let v = Visibility::Scalar(vec![1.0, 1.0]);
        let e = compare(&v, &r, &[true, true]);
        assert_eq!(e.pixels, 2);
        assert!((e.rmse - (2.0f64 / 6.0).sqrt()).abs() < 1e-9);
        assert!((e.mae - 2.0 / 6.0).abs() < 1e-9);
        // Luminance of (1, 0, 0) is 0.2126: off by 0.79 > 0.5, one wrong pixel of two.
        assert!((e.wrong_pct - 50.0).abs() < 1e-9);
        assert_eq!(e.penumbra_pixels, 1);
        // Scalar against scalar is the scalar comparison.
        let a = Visibility::Scalar(vec![0.25, 1.0]);
        let b = Visibility::Scalar(vec![0.0, 1.0]);
        assert_eq!(
            compare(&a, &b, &[true, true]),
            compare_scalar(&[0.25, 1.0], &[0.0, 1.0], &[true, true])
        );
    }

    #[test]
    fn flicker_ignores_changes_of_the_truth() {
        let m = [true; 2];
        let s = |v: Vec<f32>| Visibility::Scalar(v);
        let (r0, r1) = (s(vec![0.0, 1.0]), s(vec![1.0, 1.0]));
        let f = [
            (s(vec![0.0, 1.0]), &r0, &m[..]),
            (s(vec![1.0, 1.0]), &r1, &m[..]),
            (s(vec![0.0, 1.0]), &r1, &m[..]),
        ];
        // Frame 1->2: both change pixel 0 (no flicker); frame 2->3: only v changes (1 of 2 pixels).
        assert!((flicker(&f) - 0.25).abs() < 1e-12);
    }

    #[test]
    fn banding_counts_partial_plateaus_on_a_ramp_and_not_a_smooth_estimate() {
        // One row of 9 pixels on a true ramp 0.1 .. 0.9.
        let truth: Vec<f32> = (0..9).map(|i| 0.1 + 0.1 * i as f32).collect();
        let (m, ids) = (vec![true; 9], vec![0u32; 9]);
        let s = |v: Vec<f32>| Visibility::Scalar(v);
        let r = s(truth.clone());
        // The truth itself and any strictly monotone estimate: no plateau.
        assert_eq!(banding(&r, &r, &m, &ids, 9), 0.0);
        // Steps of three: 0.2 0.2 0.2 0.5 0.5 0.5 0.8 0.8 0.8 -> 6 flat pairs of 8.
        let steps: Vec<f32> = (0..9).map(|i| 0.2 + 0.3 * (i / 3) as f32).collect();
        assert!((banding(&s(steps), &r, &m, &ids, 9) - 0.75).abs() < 1e-12);
        // Umbra and lit plateaus are not bands.
        let hard: Vec<f32> = (0..9).map(|i| if i < 5 { 0.0 } else { 1.0 }).collect();
        assert_eq!(banding(&s(hard), &r, &m, &ids, 9), 0.0);
        // Different objects break the pairs.
        let flat = s(vec![0.5; 9]);
        assert_eq!(banding(&flat, &r, &m, &ids, 9), 1.0);
        let alternating: Vec<u32> = (0..9).map(|i| i % 2).collect();
        assert_eq!(banding(&flat, &r, &m, &alternating, 9), 0.0);
    }
}
