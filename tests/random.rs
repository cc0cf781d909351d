//! Claims that hold on any scene: properties of the techniques over generated scenes
//! ([`penumbra::scene::random`]), seeds that nobody picked. The cases run at 160x90 with fixed
//! seeds, so CI replays the same scenes; `PENUMBRA_PROPTEST_CASES=N` runs N of them (and
//! fresh seeds with `PENUMBRA_PROPTEST_SEED=S`). A failing seed is written by
//! `penumbra random --seed N --opaque --light KIND` as a scene file to open, render and
//! inspect like any fixture.

use penumbra::frame;
use penumbra::metrics::compare_scalar;
use penumbra::pipeline::Pipeline;
use penumbra::scene::random::{random, Params};
use penumbra::scene::Scene;
use penumbra::shadow;
use proptest::prelude::*;

/// Cases per property: `PENUMBRA_PROPTEST_CASES`, or `default`.
fn cases(default: u32) -> u32 {
    std::env::var("PENUMBRA_PROPTEST_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// The seed of the case generator: `PENUMBRA_PROPTEST_SEED`, or a fixed one.
fn rng_seed() -> proptest::test_runner::RngSeed {
    proptest::test_runner::RngSeed::Fixed(
        std::env::var("PENUMBRA_PROPTEST_SEED")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(0x0043_5eed),
    )
}

/// `technique`'s wrong % against the hard reference (one ray to the light's centre) over the
/// pixels that face the light.
fn hard_wrong(s: &Scene, technique: &str) -> f64 {
    let p = Pipeline::new(2).unwrap();
    let f = frame::frame(&p, s, 0, 0).unwrap();
    let r = penumbra::reference::Reference::new(s);
    let opts = penumbra::reference::ReferenceOptions {
        area: false,
        ..Default::default()
    };
    let rv = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &opts));
    let v = shadow::create(technique, &[]).unwrap().visibility(&p, &f).unwrap();
    compare_scalar(&v.to_scalar(), &rv.to_scalar(), &f.metric_mask()).wrong_pct
}

/// Opaque scenes under the hard lights.
fn hard_params() -> Params {
    Params {
        translucent: false,
        lights: vec!["directional", "spot", "point"],
        ..Params::default()
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: cases(64),
        rng_seed: rng_seed(),
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// Shadow volumes and the IZB against the hard reference on random opaque scenes. Over
    /// 500 seeds at 160x90 (2026-12-06): mean 0.012 % (shadow volumes) and 0.004 % (IZB), above 0.05 % on 24 and 6 seeds,
    /// worst 0.213 % and 0.210 %, mostly on the same pixels: the back of a smooth-shaded open
    /// heightfield patch, where the interpolated normal faces the light and the facet does
    /// not (the reference's ray leaves through the surface; both rasterized techniques count
    /// the point lit). Until a mask names those pixels, the bound is 0.3 %; the two exact
    /// techniques agree with each other within 0.2 % (measured at most 0.127 %).
    #[test]
    fn exact_techniques_are_exact_on_random_scenes(seed in any::<u64>()) {
        let s = random(seed, &hard_params()).unwrap();
        let sv = hard_wrong(&s, "shadow-volume");
        let izb = hard_wrong(&s, "izb");
        prop_assert!(sv <= 0.3 && izb <= 0.3, "seed {seed}: shadow-volume {sv} %, izb {izb} % wrong");
        prop_assert!((sv - izb).abs() <= 0.2, "seed {seed}: shadow-volume {sv} % vs izb {izb} %");
    }
}

/// Soft techniques reduce to hard ones under a hard light (directional, spot, point): on
/// each generated scene no worse than the hard map beyond a margin, and no worse on average
/// beyond a smaller one. Measured over 300 seeds (2026-12-06), percentage points of wrong
/// pixels above the map's (mean 0.297 %): PCSS and PVM at most +0.015 (mean -0.018), CHS
/// +0.72 (mean +0.006), multi-sample maps +0.31 (mean +0.040), PVMF +2.18 (mean +0.159: its
/// map is 512² by default, the plain map's 2048²). PVMF's former default depth layer, the
/// dissertation's second depth, leaks light through open surfaces under any light: over 40
/// seeds up to 9.8 % wrong where the map is 0.9 %; midpoint is its default now.
#[test]
fn soft_techniques_reduce_to_the_hard_map_under_hard_lights() {
    let n = cases(48) as u64;
    let margins = [
        ("pcss", 0.05, 0.05),
        ("chs", 1.0, 0.1),
        ("pvm", 0.05, 0.05),
        ("multi-sample", 0.5, 0.1),
        ("pvmf", 2.5, 0.25),
    ];
    let mut sums = [0.0f64; 6];
    for seed in 0..n {
        let s = random(seed, &hard_params()).unwrap();
        let map = hard_wrong(&s, "shadow-map");
        sums[0] += map;
        for (k, (t, margin, _)) in margins.iter().enumerate() {
            let w = hard_wrong(&s, t);
            sums[k + 1] += w;
            assert!(w <= map + margin, "seed {seed}: {t} {w} % wrong, the hard map {map} %");
        }
    }
    for (k, (t, _, mean_margin)) in margins.iter().enumerate() {
        let (mean, map) = (sums[k + 1] / n as f64, sums[0] / n as f64);
        assert!(
            mean <= map + mean_margin,
            "{t}: mean {mean} % wrong, the hard map's {map} %"
        );
    }
}
