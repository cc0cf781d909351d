//! Golden hashes of the reference's visibility on every fixture, hard and area (64 samples per
//! penumbra pixel, which takes every path of the sampler): the ground truth must not move when
//! its acceleration structure, its build or its traversal changes, only when what it computes
//! is meant to change.

use penumbra::frame;
use penumbra::pipeline::Pipeline;
use penumbra::reference::{Reference, ReferenceOptions};
use penumbra::scene::file::load;
use std::path::Path;

/// The reference's hashes on every other fixture (sorted by name), starting at `part` (0 or
/// 1): two tests, so that the harness overlaps the scenes' serial parts (loading, the BVH's
/// top levels).
fn hashes(part: usize) -> Vec<String> {
    let p = Pipeline::new(2).unwrap();
    let mut names: Vec<String> = std::fs::read_dir("fixtures/scenes")
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .map(|p| p.file_stem().unwrap().to_string_lossy().into_owned())
        .collect();
    names.sort();
    let mut out = Vec::new();
    for scene in names.iter().skip(part).step_by(2) {
        let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = frame::frame(&p, &s, 0, 0).unwrap();
        let r = Reference::new(&s);
        for (label, opts) in [
            (
                "hard",
                ReferenceOptions {
                    area: false,
                    ..Default::default()
                },
            ),
            (
                "area64",
                ReferenceOptions {
                    area_samples: 64,
                    ..Default::default()
                },
            ),
        ] {
            let v = p.install(|| r.visibility(f.points(), f.width() as usize, &f.light, &opts));
            out.push(format!("{scene} {label} {:016x}", v.hash()));
        }
    }
    out
}

/// Part `part`'s hashes against the recorded ones of the same scenes, in order.
fn check(part: usize) {
    let got = hashes(part);
    if std::env::var_os("PENUMBRA_PRINT_GOLDEN").is_some() {
        println!("{}", got.join("\n"));
    }
    let scenes: Vec<&str> = got.iter().map(|g| g.split(' ').next().unwrap()).collect();
    let want: Vec<&str> = GOLDEN
        .lines()
        .map(str::trim)
        .filter(|l| !l.is_empty() && scenes.contains(&l.split(' ').next().unwrap()))
        .collect();
    assert_eq!(want.len(), got.len(), "fixtures added or removed:\n{}", got.join("\n"));
    let bad: Vec<String> = want
        .iter()
        .zip(&got)
        .filter(|(w, g)| w != g)
        .map(|(w, g)| format!("changed: {g} (was {w})"))
        .collect();
    assert!(bad.is_empty(), "{}", bad.join("\n"));
}

#[test]
fn reference_outputs_match_their_golden_hashes_first_half() {
    check(0);
}

#[test]
fn reference_outputs_match_their_golden_hashes_second_half() {
    check(1);
}

/// Every recorded scene is still a fixture (a removed fixture's lines would otherwise go
/// unchecked).
#[test]
fn every_golden_line_names_a_fixture() {
    for l in GOLDEN.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let scene = l.split(' ').next().unwrap();
        assert!(Path::new(&format!("fixtures/scenes/{scene}.toml")).exists(), "{l}");
    }
}

const GOLDEN: &str = "
behind_eye hard 7cc34d1ebfe197a5
behind_eye area64 7cc34d1ebfe197a5
big_light hard 5bce5fa3e2cb2db5
big_light area64 6629d44df2e9bf60
contact hard 2fd73c8de3d90925
contact area64 3060df55a81db12b
cookie hard 98dcae3592fe9025
cookie area64 98dcae3592fe9025
curtain hard afc80c7b83cd656c
curtain area64 afc80c7b83cd656c
eye_in_volume hard b9b902d75af454d5
eye_in_volume area64 b9b902d75af454d5
facing_light hard 3fc5db1eb6acf625
facing_light area64 3fc5db1eb6acf625
facing_sun hard 829dbcc4d8e212c5
facing_sun area64 829dbcc4d8e212c5
far_plane hard 3d67203d4715c298
far_plane area64 3d67203d4715c298
forest hard e775b7d05552a438
forest area64 ed0809815c53486a
forest_floor hard 69379f97ac810b28
forest_floor area64 69379f97ac810b28
grazing hard 80d515230cb75075
grazing area64 80d515230cb75075
hidden_caster hard c1420752c00f69f5
hidden_caster area64 c1420752c00f69f5
layers hard 18ee2b4e570516d4
layers area64 18ee2b4e570516d4
long_view hard e478e3196b10c3e8
long_view area64 e478e3196b10c3e8
moving_sun hard 9ad33f8a97ef6835
moving_sun area64 9ad33f8a97ef6835
near_plane hard 5a23e25645c78675
near_plane area64 5a23e25645c78675
offscreen hard bf8760d8b6588735
offscreen area64 bf8760d8b6588735
orbit hard 91068e51b4879a35
orbit area64 91068e51b4879a35
overlap hard 40ce94697231f145
overlap area64 d92925fe968154a3
pan_to_sky hard 86a97125a1ea4b25
pan_to_sky area64 86a97125a1ea4b25
pergola hard a65dcb4069fc4315
pergola area64 8aa247bb46d42115
planar hard 2273997bb7ea0cf5
planar area64 2273997bb7ea0cf5
point_casters hard fa835dbb83b2f868
point_casters area64 fa835dbb83b2f868
smoke hard 37ae6e36b4f14ca8
smoke area64 37ae6e36b4f14ca8
spheres hard 3d785b99090ae698
spheres area64 3d785b99090ae698
stack hard df21eb1c7844be75
stack area64 47755835a8dfe045
stained_glass hard d4a9a59bc1803348
stained_glass area64 d4a9a59bc1803348
street hard 1d5541b23e424ef5
street area64 1d5541b23e424ef5
subtexel_path hard 9ad33f8a97ef6835
subtexel_path area64 9ad33f8a97ef6835
terrain hard 68fa3bac37446695
terrain area64 68fa3bac37446695
thin_sheet hard df6631047c08de65
thin_sheet area64 df6631047c08de65
wires hard 48ea67295b84b325
wires area64 48ea67295b84b325
";
