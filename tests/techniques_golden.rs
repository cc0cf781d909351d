//! Golden hashes of every technique's visibility (each sweep option set) on fixtures that
//! exercise every light kind: a change to any is a change to what a technique computes.
//! The hashes of the first five techniques were recorded before the techniques moved into
//! their family folders, so the test also proves that the move changed no output. The same
//! hashes hold on x86-64 (baseline and x86-64-v2) and on aarch64: `.ci/run` checks all three.

use penumbra::frame;
use penumbra::pipeline::Pipeline;
use penumbra::scene::file::load;
use penumbra::shadow;
use std::path::Path;

const SCENES: &[&str] = &["contact", "point_casters", "planar", "cookie", "long_view"];

/// Scenes only the techniques that do not work everywhere run on (terrain occlusion height
/// needs a heightfield); those also run on the scenes above that they work on (cascades on
/// the directional lights').
const SPECIAL: &[&str] = &["forest_floor"];

/// Every technique's hash on `scene`, one line per option set (`scene technique [set] hash`).
fn hashes(scene: &str) -> Vec<String> {
    let p = Pipeline::new(2).unwrap();
    let mut out = Vec::new();
    let s = load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
    let f = frame::frame(&p, &s, 0, 0).unwrap();
    let special = SPECIAL.contains(&scene);
    for t in shadow::registry::registry() {
        if t.name == "reference" || !t.applies_to(&s) || (special && t.applies.is_none()) {
            continue;
        }
        for set in t.sweep.iter().chain(t.extended) {
            let sets: Vec<(String, String)> = set.iter().map(|(k, v)| (k.to_string(), v.to_string())).collect();
            let mut tech = shadow::registry::create(t.name, &sets).unwrap();
            let start = std::time::Instant::now();
            let v = tech.visibility(&p, &f).unwrap();
            if std::env::var_os("PENUMBRA_GOLDEN_TIMES").is_some() {
                eprintln!(
                    "{:9.1} ms {scene} {} {sets:?}",
                    start.elapsed().as_secs_f64() * 1e3,
                    t.name
                );
            }
            let label = sets
                .iter()
                .map(|(k, v)| format!("{k}={v}"))
                .collect::<Vec<_>>()
                .join(";");
            out.push(format!("{scene} {} [{label}] {:016x}", t.name, v.hash()));
        }
    }
    out
}

/// `scene`'s hashes against its recorded ones: each recorded set gives its hash, and every
/// set computed has one recorded (a new sweep or extended option set without one fails here
/// instead of passing unchecked).
fn check(scene: &str) {
    let got = hashes(scene);
    if std::env::var_os("PENUMBRA_PRINT_GOLDEN").is_some() {
        println!("{}", got.join("\n"));
    }
    let want: Vec<&str> = GOLDEN
        .lines()
        .map(str::trim)
        .filter(|l| l.split(' ').next() == Some(scene))
        .collect();
    assert!(!want.is_empty(), "no golden hashes recorded for {scene}");
    let mut bad = Vec::new();
    for w in &want {
        let key = &w[..w.rfind(' ').unwrap()];
        match got
            .iter()
            .find(|g| g.starts_with(key) && g[key.len()..].starts_with(' '))
        {
            Some(g) if g == w => {}
            Some(g) => bad.push(format!("changed: {g} (was {w})")),
            None => bad.push(format!("missing: {w}")),
        }
    }
    for g in &got {
        let key = &g[..g.rfind(' ').unwrap()];
        if !want
            .iter()
            .any(|w| w.starts_with(key) && w[key.len()..].starts_with(' '))
        {
            bad.push(format!("unrecorded: {g}"));
        }
    }
    assert!(bad.is_empty(), "{}\nall:\n{}", bad.join("\n"), got.join("\n"));
}

// One test per scene, so that the harness runs them side by side (two at a time on two
// cores): the passes that do not fill both cores overlap.
#[test]
fn contact_matches_its_golden_hashes() {
    check("contact");
}

#[test]
fn point_casters_matches_its_golden_hashes() {
    check("point_casters");
}

#[test]
fn planar_matches_its_golden_hashes() {
    check("planar");
}

#[test]
fn cookie_matches_its_golden_hashes() {
    check("cookie");
}

#[test]
fn long_view_matches_its_golden_hashes() {
    check("long_view");
}

#[test]
fn forest_floor_matches_its_golden_hashes() {
    check("forest_floor");
}

/// Every golden line names one of the scenes above (a scene dropped from the tests would
/// otherwise leave its hashes unchecked).
#[test]
fn every_golden_line_belongs_to_a_tested_scene() {
    for l in GOLDEN.lines().map(str::trim).filter(|l| !l.is_empty()) {
        let scene = l.split(' ').next().unwrap();
        assert!(SCENES.iter().chain(SPECIAL).any(|s| *s == scene), "{l}");
    }
}

const GOLDEN: &str = "
contact shadow-map [size=256] 1c0ef221403e0758
contact shadow-map [size=512] 264f8a0a621b5ed8
contact shadow-map [size=2048] 75bae200d6633fe5
contact shadow-map [units=0;slope=0] b6353def132e6555
contact shadow-map [units=100000] 3547d67b6aa8a825
contact shadow-map [units=0;slope=0;normal=1.5] fb3eb94250dde205
contact shadow-map [units=0;slope=0;receiver=true] 3e3e816634509828
contact shadow-map [layer=second;units=0;slope=0] 5aa4c74f41db3385
contact shadow-map [layer=midpoint;units=0;slope=0] 4ebe8eaf1d131935
contact shadow-map [layer=id] 651c0162c8c9a915
contact shadow-map [fit=receivers;snap=true] 75bae200d6633fe5
contact shadow-map [filter=pcf2] 907ef9f8dba68601
contact shadow-map [filter=depth-bilinear] 5c045c450d579218
contact shadow-map [filter=grid] 508e9f6a8a282d60
contact shadow-map [filter=tent] 65c2ac19f788129e
contact shadow-map [filter=poisson] 0af85d8025f465f6
contact shadow-map [filter=rotated] ff56e28d2e31fd8b
contact shadow-map [filter=spiral] 52b395b7bec54be7
contact shadow-map [size=1024] 076f1858599bb525
contact shadow-map [size=4096] ba8673bc99cad7b5
contact shadow-map [format=u16] 3547d67b6aa8a825
contact shadow-map [filter=grid;kernel=9;cone=2] 1a39a9fa7ad2d31d
contact shadow-map [format=u24] 75bae200d6633fe5
contact shadow-map [fit=receivers] 75bae200d6633fe5
contact shadow-map [filter=grid;hierarchy=true] 508e9f6a8a282d60
contact shadow-map [filter=grid;kernel=9] 7b6e13a8538ee45d
contact shadow-map [filter=grid;kernel=9;receiver=true;units=0;slope=0] 39db5d8c75781a91
contact shadow-map [filter=poisson;taps=64] 365ce555465c876d
contact shadow-map [filter=poisson;world=0.1] c46e215a500beac8
contact pcss [] d990530360d3a0ff
contact pcss [blockers=32;taps=64] ffc30a446e42e4b5
contact pcss [disk=rotated] 96d9cf5380b7b2f9
contact pcss [size=512] 779da90751d6c2f3
contact pcss [hierarchy=true] d990530360d3a0ff
contact pcss [disk=spiral;taps=32] 1e5734e9dbd6b8f3
contact pcss [receiver=true;units=0;slope=0] a402ff9ae5ac09ca
contact pcss [angle=1] d990530360d3a0ff
contact chs [] c5b758684d06f0fa
contact chs [size=512] c4bcc160ae1c8007
contact chs [kernel=3] 6e2286df5645d16d
contact chs [kernel=11] 0cd4a3607d73578a
contact chs [size=4096] 5e8cfee56dd3927c
contact multi-sample [samples=4;size=512] 5a1c09c980fbf84f
contact multi-sample [samples=16;size=512] 0a55054bffce9761
contact multi-sample [samples=16;method=volumes] e1f3861245a5e622
contact multi-sample [] 8c6b969444e041fa
contact multi-sample [samples=64;size=512] 07989989190a996b
contact multi-sample [samples=256;size=512] 1e4733f1659f9abd
contact multi-sample [samples=64;method=volumes] e522ee1b58217d16
contact shadow-volume [] 2fd73c8de3d90925
contact shadow-volume [mode=zfail] 2fd73c8de3d90925
contact shadow-volume [mode=zfail-infinite] 2fd73c8de3d90925
contact shadow-volume [mode=zpass] 2fd73c8de3d90925
contact planar [] 320c333d5ce43035
contact planar [stencil=off;darkness=0.5] 372dd351e7c89995
contact cookie [] aa1baa004244fa95
contact cookie [filter=bilinear] c93d6c01041b34c0
contact izb [] 2fd73c8de3d90925
contact izb [size=256] 2fd73c8de3d90925
contact izb [raster=standard] 3731232881757c18
contact izb [samples=4] 65fd796df2f84518
contact hybrid [] d45bccf606578031
contact hybrid [units=100000] 2fd73c8de3d90925
contact hybrid [from=0;to=1] 60ac82a6b4d03761
contact hybrid [from=2;to=12] e00e0e1d4d817126
contact pvm [] ae57b06d69c32c78
contact pvm [size=512] bccfae381d92b958
contact pvm [size=4096] 6848dfe0b1a9cb4f
contact pvm [light=2] 7d84d201f8c91acb
contact pvm [smooth=true] 5a69ccd88931b9e2
contact pvmf [] 56c1812264504b68
contact pvmf [size=2048] d86b68773eaf8166
contact pvmf [pcf=3] 41c0bdbb6af8c10c
contact pvmf [jitter=false] 7a9826441d1e3986
contact pvmf [layer=second] ee6d463c36fb6045
contact pvmf [layer=first] 245a9f0abacd81ab
contact pvmf [pcf=12;size=1024] cd059d85d66d49ae
contact pvmf [spread=1] e86c684e49fc2c4a
contact pvmf [blur=12] d009e66e82de62b3
contact pvmf [ids=group;blur=12] d009e66e82de62b3
contact pvmf [blur=4] f5b66c82000786b4
contact transparency-map [] 076f1858599bb525
contact transparency-map [size=512] 264f8a0a621b5ed8
contact opacity-maps [] 264f8a0a621b5ed8
contact opacity-maps [layout=uniform;slices=4] 264f8a0a621b5ed8
contact opacity-maps [layout=uniform;slices=16] 264f8a0a621b5ed8
contact opacity-maps [slices=16] 264f8a0a621b5ed8
contact deep-shadow-map [] a9dd6ffed1c995b1
contact deep-shadow-map [filter=nearest] 264f8a0a621b5ed8
contact avsm [] 264f8a0a621b5ed8
contact avsm [nodes=4] 264f8a0a621b5ed8
contact avsm [nodes=16] 264f8a0a621b5ed8
contact avsm [order=reverse] 264f8a0a621b5ed8
contact screen-space [] 8b05f36839dfc355
contact screen-space [steps=8] 3a9f721b97ed1725
contact screen-space [steps=32] 8c60fe91fcc69185
contact screen-space [jitter=false] 9301bdc05eaad0c5
contact screen-space [thickness=0.05] 85b576b4b3484225
contact screen-space [thickness=5] a50382bf4ca4db45
contact screen-space [steps=64] 6b76add8bb07c465
contact screen-space [length=0.5] 3d76e3f467457578
contact contact-map [] 31de89983e0cffe5
contact contact-map [units=100000] 0853bb11a1f75b78
contact contact-map [length=0.5] df910a63f94f84e8
contact contact-map [filter=pcf2;steps=8] 5543e213d57a0aee
contact contact-map [size=512] 950c0c16363e30d8
contact contact-map [steps=32;jitter=false] 64f120af938d1598
point_casters shadow-map [size=256] 4237a06666f59f15
point_casters shadow-map [size=512] 4963da0d1b015b75
point_casters shadow-map [size=2048] 39af367eaad6dfd5
point_casters shadow-map [units=0;slope=0] 892d8110d46dd045
point_casters shadow-map [units=100000] 2005f4ade2e3e925
point_casters shadow-map [units=0;slope=0;normal=1.5] 988ceaaa376515b5
point_casters shadow-map [units=0;slope=0;receiver=true] d3144980d5799ed5
point_casters shadow-map [layer=second;units=0;slope=0] 500b9fb4e77009d5
point_casters shadow-map [layer=midpoint;units=0;slope=0] e4da828f378cdb35
point_casters shadow-map [layer=id] b7140fea95c13ac8
point_casters shadow-map [fit=receivers;snap=true] 39af367eaad6dfd5
point_casters shadow-map [filter=pcf2] 5cf7740f5c778bb6
point_casters shadow-map [filter=depth-bilinear] db99638e356394c5
point_casters shadow-map [filter=grid] 630d27bd3da46d08
point_casters shadow-map [filter=tent] 3ab574c893504221
point_casters shadow-map [filter=poisson] c2bcbc83d9dc7a64
point_casters shadow-map [filter=rotated] 940ebb0152322b42
point_casters shadow-map [filter=spiral] 2867844c5de86420
point_casters shadow-map [size=1024] eb4285b6e9e8b4c5
point_casters shadow-map [size=4096] eb3d53ec1b7cb125
point_casters shadow-map [format=u16] d3160f5380812d25
point_casters shadow-map [filter=grid;kernel=9;cone=2] 4d3066a990c75efd
point_casters shadow-map [format=u24] 39af367eaad6dfd5
point_casters shadow-map [fit=receivers] 39af367eaad6dfd5
point_casters shadow-map [filter=grid;hierarchy=true] 630d27bd3da46d08
point_casters shadow-map [filter=grid;kernel=9] ccc1938b40d24448
point_casters shadow-map [filter=grid;kernel=9;receiver=true;units=0;slope=0] b0446c9b0f92e9eb
point_casters shadow-map [filter=poisson;taps=64] 7a67e0628b7605fd
point_casters shadow-map [filter=poisson;world=0.1] d3f53c228df8c0a9
point_casters pcss [] 5cf7740f5c778bb6
point_casters pcss [blockers=32;taps=64] 5cf7740f5c778bb6
point_casters pcss [disk=rotated] 5cf7740f5c778bb6
point_casters pcss [size=512] 5c8845f300fe21e6
point_casters pcss [hierarchy=true] 5cf7740f5c778bb6
point_casters pcss [disk=spiral;taps=32] 5cf7740f5c778bb6
point_casters pcss [receiver=true;units=0;slope=0] 8765e99c53e672b7
point_casters pcss [angle=1] 5cf7740f5c778bb6
point_casters chs [] 99bc0072e022658c
point_casters chs [size=512] 8c63f69b8f60d3e4
point_casters chs [kernel=3] 99bc0072e022658c
point_casters chs [kernel=11] 99bc0072e022658c
point_casters chs [size=4096] a0747605ae0af72a
point_casters multi-sample [samples=4;size=512] 5c8845f300fe21e6
point_casters multi-sample [samples=16;size=512] 5c8845f300fe21e6
point_casters multi-sample [samples=16;method=volumes] 49cc2c02f488c815
point_casters multi-sample [] 1d122a0eeac54073
point_casters multi-sample [samples=64;size=512] 5c8845f300fe21e6
point_casters multi-sample [samples=256;size=512] 5c8845f300fe21e6
point_casters multi-sample [samples=64;method=volumes] 49cc2c02f488c815
point_casters shadow-volume [] 49cc2c02f488c815
point_casters shadow-volume [mode=zfail] 49cc2c02f488c815
point_casters shadow-volume [mode=zfail-infinite] fa835dbb83b2f868
point_casters shadow-volume [mode=zpass] 49cc2c02f488c815
point_casters planar [] 86fe0dd698d6de78
point_casters planar [stencil=off;darkness=0.5] e4f682dfebe61022
point_casters cookie [] 09bd284926ebd478
point_casters cookie [filter=bilinear] ded4554a99be3cb5
point_casters izb [] 7d2dde7445ac2ca5
point_casters izb [size=256] 7d2dde7445ac2ca5
point_casters izb [raster=standard] 05e07069e83cd455
point_casters izb [samples=4] f979eb70de328af2
point_casters hybrid [] 7d2dde7445ac2ca5
point_casters hybrid [units=100000] 7d2dde7445ac2ca5
point_casters hybrid [from=0;to=1] 7d2dde7445ac2ca5
point_casters hybrid [from=2;to=12] 7d2dde7445ac2ca5
point_casters pvm [] 5cf7740f5c778bb6
point_casters pvm [size=512] 5c8845f300fe21e6
point_casters pvm [size=4096] f426b7e1d9bcc0b9
point_casters pvm [light=2] 5cf7740f5c778bb6
point_casters pvm [smooth=true] 5cf7740f5c778bb6
point_casters pvmf [] 7b2ece62d6779cc6
point_casters pvmf [size=2048] 7c17fdfede3eadaa
point_casters pvmf [pcf=3] 7b2ece62d6779cc6
point_casters pvmf [jitter=false] 7b2ece62d6779cc6
point_casters pvmf [layer=second] 85cbe94ce5ae7a20
point_casters pvmf [layer=first] 5c8845f300fe21e6
point_casters pvmf [pcf=12;size=1024] 1906163e8e157f79
point_casters pvmf [spread=1] 7b2ece62d6779cc6
point_casters pvmf [blur=12] 7b2ece62d6779cc6
point_casters pvmf [ids=group;blur=12] 7b2ece62d6779cc6
point_casters pvmf [blur=4] 7b2ece62d6779cc6
point_casters transparency-map [] eb4285b6e9e8b4c5
point_casters transparency-map [size=512] 4963da0d1b015b75
point_casters opacity-maps [] 4963da0d1b015b75
point_casters opacity-maps [layout=uniform;slices=4] 4963da0d1b015b75
point_casters opacity-maps [layout=uniform;slices=16] 4963da0d1b015b75
point_casters opacity-maps [slices=16] 4963da0d1b015b75
point_casters deep-shadow-map [] 5c8845f300fe21e6
point_casters deep-shadow-map [filter=nearest] 4963da0d1b015b75
point_casters avsm [] 4963da0d1b015b75
point_casters avsm [nodes=4] 4963da0d1b015b75
point_casters avsm [nodes=16] 4963da0d1b015b75
point_casters avsm [order=reverse] 4963da0d1b015b75
point_casters screen-space [] 194650067781af08
point_casters screen-space [steps=8] 7247688b2b47c4c5
point_casters screen-space [steps=32] 118d9e607b49b7f8
point_casters screen-space [jitter=false] 2c61b7db7e77d9b5
point_casters screen-space [thickness=0.05] 6953b2b1200a5e48
point_casters screen-space [thickness=5] 86956b8f46376b38
point_casters screen-space [steps=64] 1e0bcec79770d458
point_casters screen-space [length=0.5] 3c1b2b8656042055
point_casters contact-map [] 3cff25ab48003d45
point_casters contact-map [units=100000] 5e6eaab9918915a8
point_casters contact-map [length=0.5] 7f75c231e0faf7d8
point_casters contact-map [filter=pcf2;steps=8] 2e867ae40e72875c
point_casters contact-map [size=512] 8d117c2e65e76198
point_casters contact-map [steps=32;jitter=false] 08296eff2720d685
planar shadow-map [size=256] ab8dd7edf6ab2875
planar shadow-map [size=512] 53067c7945199088
planar shadow-map [size=2048] 7d894ff8ea3b9b15
planar shadow-map [units=0;slope=0] 8cef36f63f32e4c8
planar shadow-map [units=100000] e3d67641ce8b98a5
planar shadow-map [units=0;slope=0;normal=1.5] 3f870d4974876f05
planar shadow-map [units=0;slope=0;receiver=true] 398e9a5190bef098
planar shadow-map [layer=second;units=0;slope=0] 52439751eefbd678
planar shadow-map [layer=midpoint;units=0;slope=0] bc6f8150d6bc5a58
planar shadow-map [layer=id] 1bfe5019d8f87995
planar shadow-map [fit=receivers;snap=true] 7d894ff8ea3b9b15
planar shadow-map [filter=pcf2] 23320e1ef49a833f
planar shadow-map [filter=depth-bilinear] 84cf309d540edad5
planar shadow-map [filter=grid] 3db72ed5c9827c03
planar shadow-map [filter=tent] 9b5c480d3d6ae8de
planar shadow-map [filter=poisson] 4ba29983ab1d6bac
planar shadow-map [filter=rotated] 814a2f8d43a05f5b
planar shadow-map [filter=spiral] 831bd1b36058d64e
planar shadow-map [size=1024] d6e87c4048aeae68
planar shadow-map [size=4096] 9184b3db883b3e15
planar shadow-map [format=u16] 7cc019d357502cc5
planar shadow-map [filter=grid;kernel=9;cone=2] 31ca2075100d105e
planar shadow-map [format=u24] 7d894ff8ea3b9b15
planar shadow-map [fit=receivers] 7d894ff8ea3b9b15
planar shadow-map [filter=grid;hierarchy=true] 3db72ed5c9827c03
planar shadow-map [filter=grid;kernel=9] 0b807ec2ce4a306c
planar shadow-map [filter=grid;kernel=9;receiver=true;units=0;slope=0] c078ca04f96bef3a
planar shadow-map [filter=poisson;taps=64] 5e29f88a042e7dfa
planar shadow-map [filter=poisson;world=0.1] 7c8e6c7fbc76326e
planar pcss [] 23320e1ef49a833f
planar pcss [blockers=32;taps=64] 23320e1ef49a833f
planar pcss [disk=rotated] 23320e1ef49a833f
planar pcss [size=512] bf66250e8b430bb8
planar pcss [hierarchy=true] 23320e1ef49a833f
planar pcss [disk=spiral;taps=32] 23320e1ef49a833f
planar pcss [receiver=true;units=0;slope=0] bf589c331455984f
planar pcss [angle=1] 23320e1ef49a833f
planar chs [] 3042e54cd70337f1
planar chs [size=512] 6d836b34a6bfe496
planar chs [kernel=3] 3042e54cd70337f1
planar chs [kernel=11] 3042e54cd70337f1
planar chs [size=4096] 8b3c3ff744319c8d
planar multi-sample [samples=4;size=512] bf66250e8b430bb8
planar multi-sample [samples=16;size=512] bf66250e8b430bb8
planar multi-sample [samples=16;method=volumes] 881fa311863269c5
planar multi-sample [] abd017b87bede45f
planar multi-sample [samples=64;size=512] bf66250e8b430bb8
planar multi-sample [samples=256;size=512] bf66250e8b430bb8
planar multi-sample [samples=64;method=volumes] 881fa311863269c5
planar shadow-volume [] 881fa311863269c5
planar shadow-volume [mode=zfail] 881fa311863269c5
planar shadow-volume [mode=zfail-infinite] 2273997bb7ea0cf5
planar shadow-volume [mode=zpass] 881fa311863269c5
planar planar [] 935ee71a0211e3d8
planar planar [stencil=off;darkness=0.5] d7d1a79663bdbf45
planar cookie [] b60477ecdbd2c815
planar cookie [filter=bilinear] d911fc5a0ae3990a
planar izb [] e7ae3989c62b5f28
planar izb [size=256] e7ae3989c62b5f28
planar izb [raster=standard] 5b00abc8cd2b1445
planar izb [samples=4] 37ac2438e3ecc465
planar hybrid [] e7ae3989c62b5f28
planar hybrid [units=100000] e7ae3989c62b5f28
planar hybrid [from=0;to=1] e7ae3989c62b5f28
planar hybrid [from=2;to=12] e7ae3989c62b5f28
planar pvm [] 23320e1ef49a833f
planar pvm [size=512] bf66250e8b430bb8
planar pvm [size=4096] 560900ced498629b
planar pvm [light=2] 23320e1ef49a833f
planar pvm [smooth=true] 23320e1ef49a833f
planar pvmf [] 7fbda3195cf2ec62
planar pvmf [size=2048] 94d43e6e056d572b
planar pvmf [pcf=3] 7fbda3195cf2ec62
planar pvmf [jitter=false] 7fbda3195cf2ec62
planar pvmf [layer=second] 05cbfabb9605187b
planar pvmf [layer=first] bf66250e8b430bb8
planar pvmf [pcf=12;size=1024] 3db30c36c404272c
planar pvmf [spread=1] 7fbda3195cf2ec62
planar pvmf [blur=12] 7fbda3195cf2ec62
planar pvmf [ids=group;blur=12] 7fbda3195cf2ec62
planar pvmf [blur=4] 7fbda3195cf2ec62
planar transparency-map [] d6e87c4048aeae68
planar transparency-map [size=512] 53067c7945199088
planar opacity-maps [] 53067c7945199088
planar opacity-maps [layout=uniform;slices=4] 53067c7945199088
planar opacity-maps [layout=uniform;slices=16] 53067c7945199088
planar opacity-maps [slices=16] 53067c7945199088
planar deep-shadow-map [] bf66250e8b430bb8
planar deep-shadow-map [filter=nearest] 53067c7945199088
planar avsm [] 53067c7945199088
planar avsm [nodes=4] 53067c7945199088
planar avsm [nodes=16] 53067c7945199088
planar avsm [order=reverse] 53067c7945199088
planar screen-space [] 12f5978cb6f214a8
planar screen-space [steps=8] 2edd67b2ada9e458
planar screen-space [steps=32] 9e48ef2b2aad95d8
planar screen-space [jitter=false] 0a0326ecd545b798
planar screen-space [thickness=0.05] a98de12c19f2aae8
planar screen-space [thickness=5] e8fc95fd97f38a18
planar screen-space [steps=64] d2f1c6a2a8bc9ec8
planar screen-space [length=0.5] 7cc886e27fdd7df5
planar contact-map [] 7d894ff8ea3b9b15
planar contact-map [units=100000] c29789c89aa85058
planar contact-map [length=0.5] 7d894ff8ea3b9b15
planar contact-map [filter=pcf2;steps=8] 7fa78d7dfc394083
planar contact-map [size=512] 4acef62ca1164cc8
planar contact-map [steps=32;jitter=false] 7d894ff8ea3b9b15
cookie shadow-map [size=256] 4010de312a0892e8
cookie shadow-map [size=512] 28363364b0baaf95
cookie shadow-map [size=2048] 3550b2d723a08648
cookie shadow-map [units=0;slope=0] 6083908b1160cdd8
cookie shadow-map [units=100000] 4c7d348089c73ec8
cookie shadow-map [units=0;slope=0;normal=1.5] 8cf68f5fe9004535
cookie shadow-map [units=0;slope=0;receiver=true] 1a183e4ec9c83ef8
cookie shadow-map [layer=second;units=0;slope=0] 2204cc161ac33fb8
cookie shadow-map [layer=midpoint;units=0;slope=0] 8ece0131a1b26865
cookie shadow-map [layer=id] 79b25910a67152c5
cookie shadow-map [fit=receivers;snap=true] e090023ecd149ca8
cookie shadow-map [filter=pcf2] 4c5336fb78a5ead6
cookie shadow-map [filter=depth-bilinear] 0eebeba6fcb811c5
cookie shadow-map [filter=grid] dc4d21fbe8ccb416
cookie shadow-map [filter=tent] bda6d5874f805cdc
cookie shadow-map [filter=poisson] 516d2f4db09e906b
cookie shadow-map [filter=rotated] fdc9ef23771e8a88
cookie shadow-map [filter=spiral] 5b22969c28ceab35
cookie shadow-map [size=1024] f1ec318a3fe4fce8
cookie shadow-map [size=4096] 51b9ab028f78aa38
cookie shadow-map [format=u16] 3550b2d723a08648
cookie shadow-map [filter=grid;kernel=9;cone=2] 95ff2920312ef98c
cookie shadow-map [format=u24] 3550b2d723a08648
cookie shadow-map [fit=receivers] c6bf8d6418c3dd88
cookie shadow-map [filter=grid;hierarchy=true] dc4d21fbe8ccb416
cookie shadow-map [filter=grid;kernel=9] 1ab8ea6e71d80359
cookie shadow-map [filter=grid;kernel=9;receiver=true;units=0;slope=0] e882cb97a7106293
cookie shadow-map [filter=poisson;taps=64] 2c290cbd90ba26f3
cookie shadow-map [filter=poisson;world=0.1] 98c7792b521d0ca1
cookie pcss [] 4c5336fb78a5ead6
cookie pcss [blockers=32;taps=64] 4c5336fb78a5ead6
cookie pcss [disk=rotated] 4c5336fb78a5ead6
cookie pcss [size=512] 96fa409facbd0227
cookie pcss [hierarchy=true] 4c5336fb78a5ead6
cookie pcss [disk=spiral;taps=32] 4c5336fb78a5ead6
cookie pcss [receiver=true;units=0;slope=0] 94a1574890ba8a3b
cookie pcss [angle=1] 0a87bdc35e76c62e
cookie chs [] cf0a63ecad3f9932
cookie chs [size=512] 4bd80d64e4644e0e
cookie chs [kernel=3] cf0a63ecad3f9932
cookie chs [kernel=11] cf0a63ecad3f9932
cookie chs [size=4096] f233398844a2536e
cookie multi-sample [samples=4;size=512] 96fa409facbd0227
cookie multi-sample [samples=16;size=512] 96fa409facbd0227
cookie multi-sample [samples=16;method=volumes] 98dcae3592fe9025
cookie multi-sample [] 3b1b45ca10f34dbb
cookie multi-sample [samples=64;size=512] 96fa409facbd0227
cookie multi-sample [samples=256;size=512] 96fa409facbd0227
cookie multi-sample [samples=64;method=volumes] 98dcae3592fe9025
cookie shadow-volume [] 98dcae3592fe9025
cookie shadow-volume [mode=zfail] 98dcae3592fe9025
cookie shadow-volume [mode=zfail-infinite] 28d0f8b2db2ce268
cookie shadow-volume [mode=zpass] 98dcae3592fe9025
cookie planar [] ca99ebfbd3792425
cookie planar [stencil=off;darkness=0.5] ca99ebfbd3792425
cookie cookie [] 34382f8b54217b35
cookie cookie [filter=bilinear] b6b0542fa6ee02a6
cookie izb [] 98dcae3592fe9025
cookie izb [size=256] 98dcae3592fe9025
cookie izb [raster=standard] 995597da4d751a88
cookie izb [samples=4] 297454ae2832ced2
cookie hybrid [] 98dcae3592fe9025
cookie hybrid [units=100000] 98dcae3592fe9025
cookie hybrid [from=0;to=1] 98dcae3592fe9025
cookie hybrid [from=2;to=12] 98dcae3592fe9025
cookie pvm [] 4c5336fb78a5ead6
cookie pvm [size=512] 96fa409facbd0227
cookie pvm [size=4096] 706389ba97b5e8c1
cookie pvm [light=2] 4c5336fb78a5ead6
cookie pvm [smooth=true] 4c5336fb78a5ead6
cookie pvmf [] d3021412ca5f4568
cookie pvmf [size=2048] 9ff1bce38d9b1158
cookie pvmf [pcf=3] d3021412ca5f4568
cookie pvmf [jitter=false] d3021412ca5f4568
cookie pvmf [layer=second] 10026a753b9d4c16
cookie pvmf [layer=first] 96fa409facbd0227
cookie pvmf [pcf=12;size=1024] 0b6c5cc150a756aa
cookie pvmf [spread=1] d3021412ca5f4568
cookie pvmf [blur=12] d3021412ca5f4568
cookie pvmf [ids=group;blur=12] d3021412ca5f4568
cookie pvmf [blur=4] d3021412ca5f4568
cookie transparency-map [] f1ec318a3fe4fce8
cookie transparency-map [size=512] 28363364b0baaf95
cookie opacity-maps [] 28363364b0baaf95
cookie opacity-maps [layout=uniform;slices=4] 28363364b0baaf95
cookie opacity-maps [layout=uniform;slices=16] 28363364b0baaf95
cookie opacity-maps [slices=16] 28363364b0baaf95
cookie deep-shadow-map [] 96fa409facbd0227
cookie deep-shadow-map [filter=nearest] 28363364b0baaf95
cookie avsm [] 28363364b0baaf95
cookie avsm [nodes=4] 28363364b0baaf95
cookie avsm [nodes=16] 28363364b0baaf95
cookie avsm [order=reverse] 28363364b0baaf95
cookie screen-space [] 74b62c66322ce838
cookie screen-space [steps=8] e5c6b2f6c0a4c005
cookie screen-space [steps=32] 4f0ca0da51eacbb8
cookie screen-space [jitter=false] 1029edca6cb24a78
cookie screen-space [thickness=0.05] 8f08e7042b0118f8
cookie screen-space [thickness=5] 14c03d5157074848
cookie screen-space [steps=64] e5bc6dc698c61f68
cookie screen-space [length=0.5] a2c8a925765b2fe5
cookie contact-map [] 3550b2d723a08648
cookie contact-map [units=100000] 4c7d348089c73ec8
cookie contact-map [length=0.5] 3550b2d723a08648
cookie contact-map [filter=pcf2;steps=8] 4c5336fb78a5ead6
cookie contact-map [size=512] 28363364b0baaf95
cookie contact-map [steps=32;jitter=false] 3550b2d723a08648
long_view shadow-map [size=256] 101c28efd5ca7618
long_view shadow-map [size=512] 31e8d66c38255b25
long_view shadow-map [size=2048] 625a43ee896ee645
long_view shadow-map [units=0;slope=0] 9c17c3e85d9b1cd5
long_view shadow-map [units=100000] f468ebde5b1f90c8
long_view shadow-map [units=0;slope=0;normal=1.5] 5ab18de447cb1698
long_view shadow-map [units=0;slope=0;receiver=true] ceb59c4bb5144338
long_view shadow-map [layer=second;units=0;slope=0] 3a39e6bbdc41da98
long_view shadow-map [layer=midpoint;units=0;slope=0] 9043403405a5a858
long_view shadow-map [layer=id] 8171e47fac7e1985
long_view shadow-map [fit=receivers;snap=true] 705a3582c6188be8
long_view shadow-map [filter=pcf2] 60a49f05eaadf84d
long_view shadow-map [filter=depth-bilinear] 8ddfa5af435981f5
long_view shadow-map [filter=grid] 6e74d3f5862c5df6
long_view shadow-map [filter=tent] ef81da20899c5b47
long_view shadow-map [filter=poisson] 9ba75b17c4bbfaf6
long_view shadow-map [filter=rotated] be43cdb729202426
long_view shadow-map [filter=spiral] 13bb28111b406153
long_view shadow-map [size=1024] 467baf28f97c71d8
long_view shadow-map [size=4096] 7b5a196827746208
long_view shadow-map [format=u16] 625a43ee896ee645
long_view shadow-map [filter=grid;kernel=9;cone=2] 0c6a37cf51b02d13
long_view shadow-map [format=u24] 625a43ee896ee645
long_view shadow-map [fit=receivers] 5423531193960ef5
long_view shadow-map [filter=grid;hierarchy=true] 6e74d3f5862c5df6
long_view shadow-map [filter=grid;kernel=9] 6874635c948a5911
long_view shadow-map [filter=grid;kernel=9;receiver=true;units=0;slope=0] 7058d65ccb79ef61
long_view shadow-map [filter=poisson;taps=64] b5db64e344d0de4a
long_view shadow-map [filter=poisson;world=0.1] e0cea3b581d086e3
long_view pcss [] 60a49f05eaadf84d
long_view pcss [blockers=32;taps=64] 60a49f05eaadf84d
long_view pcss [disk=rotated] 60a49f05eaadf84d
long_view pcss [size=512] 20f5c43da491eeef
long_view pcss [hierarchy=true] 60a49f05eaadf84d
long_view pcss [disk=spiral;taps=32] 60a49f05eaadf84d
long_view pcss [receiver=true;units=0;slope=0] 2966ba792279e85b
long_view pcss [angle=1] 3e11f6b2b203c3a7
long_view chs [] 89e410b7cd1bbc60
long_view chs [size=512] 6f8a92c11e3949df
long_view chs [kernel=3] 89e410b7cd1bbc60
long_view chs [kernel=11] 89e410b7cd1bbc60
long_view chs [size=4096] 96a132e184af8d1a
long_view multi-sample [samples=4;size=512] 20f5c43da491eeef
long_view multi-sample [samples=16;size=512] 20f5c43da491eeef
long_view multi-sample [samples=16;method=volumes] c470dd4e31f291b8
long_view multi-sample [] 69c6cd1ae733bfae
long_view multi-sample [samples=64;size=512] 20f5c43da491eeef
long_view multi-sample [samples=256;size=512] 20f5c43da491eeef
long_view multi-sample [samples=64;method=volumes] c470dd4e31f291b8
long_view shadow-volume [] c470dd4e31f291b8
long_view shadow-volume [mode=zfail] c470dd4e31f291b8
long_view shadow-volume [mode=zfail-infinite] a023432d53f6f625
long_view shadow-volume [mode=zpass] c470dd4e31f291b8
long_view planar [] e0e5043d9ede3b95
long_view planar [stencil=off;darkness=0.5] 9b6e36a5c0a76fa5
long_view cookie [] 8cc1804dacf62135
long_view cookie [filter=bilinear] bc92601305405580
long_view izb [] a023432d53f6f625
long_view izb [size=256] a023432d53f6f625
long_view izb [raster=standard] f3013b410a491278
long_view izb [samples=4] ac8fb19272e34848
long_view hybrid [] a023432d53f6f625
long_view hybrid [units=100000] a023432d53f6f625
long_view hybrid [from=0;to=1] a023432d53f6f625
long_view hybrid [from=2;to=12] a023432d53f6f625
long_view pvm [] 60a49f05eaadf84d
long_view pvm [size=512] 20f5c43da491eeef
long_view pvm [size=4096] 05d4e484337a7072
long_view pvm [light=2] 60a49f05eaadf84d
long_view pvm [smooth=true] 60a49f05eaadf84d
long_view pvmf [] 17c1a5af943d82fb
long_view pvmf [size=2048] fdb0a6e3f20ead29
long_view pvmf [pcf=3] 17c1a5af943d82fb
long_view pvmf [jitter=false] 17c1a5af943d82fb
long_view pvmf [layer=second] 31ab430aa42ec4d0
long_view pvmf [layer=first] 20f5c43da491eeef
long_view pvmf [pcf=12;size=1024] ae2011c2108f61dd
long_view pvmf [spread=1] 17c1a5af943d82fb
long_view pvmf [blur=12] 17c1a5af943d82fb
long_view pvmf [ids=group;blur=12] 17c1a5af943d82fb
long_view pvmf [blur=4] 17c1a5af943d82fb
long_view transparency-map [] 467baf28f97c71d8
long_view transparency-map [size=512] 31e8d66c38255b25
long_view opacity-maps [] 31e8d66c38255b25
long_view opacity-maps [layout=uniform;slices=4] 31e8d66c38255b25
long_view opacity-maps [layout=uniform;slices=16] 31e8d66c38255b25
long_view opacity-maps [slices=16] 31e8d66c38255b25
long_view deep-shadow-map [] 20f5c43da491eeef
long_view deep-shadow-map [filter=nearest] 31e8d66c38255b25
long_view avsm [] 31e8d66c38255b25
long_view avsm [nodes=4] 31e8d66c38255b25
long_view avsm [nodes=16] 31e8d66c38255b25
long_view avsm [order=reverse] 31e8d66c38255b25
long_view screen-space [] 83b81426d85aaaa8
long_view screen-space [steps=8] 63b3c951402371f8
long_view screen-space [steps=32] 0b309cd99ca5e1b5
long_view screen-space [jitter=false] 1ca4bbaf1b85dd88
long_view screen-space [thickness=0.05] 453f6184b1dda5e8
long_view screen-space [thickness=5] f34a96e821040008
long_view screen-space [steps=64] c01082435fd7a0c5
long_view screen-space [length=0.5] 67bdfc2cbf30c785
long_view contact-map [] 3601d79c65727548
long_view contact-map [units=100000] e1b9b66b56fa0128
long_view contact-map [length=0.5] b1513b3092c464b8
long_view contact-map [filter=pcf2;steps=8] 16c4e9cf2ab60f84
long_view contact-map [size=512] 550cb1d3f7cd0685
long_view contact-map [steps=32;jitter=false] b9d62f67384794f5
forest_floor terrain-height [] f02e2295511e0f7a
forest_floor terrain-height [objects=true] 04ca35f459efe7ec
forest_floor terrain-height [grid=128] 4083755e76bd664c
forest_floor terrain-height [band=0] 0e7ebcdaa9d0ecb5
forest_floor terrain-height [step=1;iterations=2] e8c7ec054962b9a0
forest_floor terrain-height [grid=1024;size=4096] 3b05190c65358469
forest_floor terrain-height [iterations=0] e8c7ec054962b9a0
contact vsm [] c4a714028e50f59a
contact vsm [bleeding=0.3] d288b65de9ed5d6c
contact vsm [prefilter=box;radius=2] 94a2a8d3f4b256ca
contact vsm [prefilter=sat;variable=true] 19411ef3ba7e9d7a
contact vsm [prefilter=mips] f9ef11985b75e650
contact vsm [storage=f16] f854eb4c4467fe09
contact vsm [radius=8;size=1024] b2a8c31cf71c5675
contact convolution [] 25af4f76503b439f
contact convolution [terms=4] 42f7010b649dc0b1
contact convolution [terms=16] be6a9a7a5090ea73
contact convolution [damping=2] 9d1a81491598394b
contact esm [] b7d9e4a00739984c
contact esm [exponent=30] 8402d9c8e1f01313
contact esm [log=false;prefilter=sat] 04611d21737484b8
contact esm [prefilter=mips] c1e05a09bfc569cf
contact esm [storage=f16;exponent=10;log=false] a9d7f7ceebf7f894
contact evsm [] 8cbcf10ceb32c9ab
contact evsm [components=2] 1f2df41f01e589af
contact evsm [storage=f16;positive=5.54] 1525548c5389f5fc
contact evsm [positive=80] c08e6315be04c218
point_casters vsm [] 4d6e1c7ab2feff57
point_casters vsm [bleeding=0.3] e736c6f611f79fe1
point_casters vsm [prefilter=box;radius=2] 3185da0397b3054d
point_casters vsm [prefilter=sat;variable=true] e7fd1a1ef509802a
point_casters vsm [prefilter=mips] 165e22602efb3624
point_casters vsm [storage=f16] 8ff3ba834bed0672
point_casters vsm [radius=8;size=1024] a4fcae0cb73b1529
point_casters convolution [] de6c7719a20722ec
point_casters convolution [terms=4] 04368c0c5d4a920c
point_casters convolution [terms=16] 9b01461c57d46980
point_casters convolution [damping=2] 648deb8709a617a3
point_casters esm [] 64f8d8afc78abb43
point_casters esm [exponent=30] 056d694a855bd9ef
point_casters esm [log=false;prefilter=sat] ccc724b660ae37fa
point_casters esm [prefilter=mips] 7065478567ba4619
point_casters esm [storage=f16;exponent=10;log=false] 4c1e616b206477be
point_casters evsm [] a4d38cff43e13233
point_casters evsm [components=2] 976400455a5b3d87
point_casters evsm [storage=f16;positive=5.54] b531a8950cef396e
point_casters evsm [positive=80] 1872bd09ebe0bbef
planar vsm [] b51ff45b66736c96
planar vsm [bleeding=0.3] a090737585d2f01b
planar vsm [prefilter=box;radius=2] c2828a6abd5266aa
planar vsm [prefilter=sat;variable=true] 3c7c54e7baa60052
planar vsm [prefilter=mips] f4e4f5fa8aa4ca44
planar vsm [storage=f16] 6b7793326167dde1
planar vsm [radius=8;size=1024] 23756d3846cba953
planar convolution [] 38c681975a1b347b
planar convolution [terms=4] 9f63abddb2ff917c
planar convolution [terms=16] 0f5a35973322681b
planar convolution [damping=2] 0012b808068bcb20
planar esm [] df2639b8f0d8dbd3
planar esm [exponent=30] 648b3a0f855945c2
planar esm [log=false;prefilter=sat] 64922fd776c7c743
planar esm [prefilter=mips] 3e3f5790764c0f72
planar esm [storage=f16;exponent=10;log=false] f709a5f3c60de772
planar evsm [] b1de94f53b705535
planar evsm [components=2] 727b45504e9c2dff
planar evsm [storage=f16;positive=5.54] c47b6511098ff711
planar evsm [positive=80] 9228c13653204f00
cookie vsm [] 280faf150fa6543d
cookie vsm [bleeding=0.3] 233c4355cb988398
cookie vsm [prefilter=box;radius=2] 3c9ecadadfa90a49
cookie vsm [prefilter=sat;variable=true] 1079e1e9a13728b8
cookie vsm [prefilter=mips] 3deaadcea2526f4f
cookie vsm [storage=f16] 00028ae5c853598f
cookie vsm [radius=8;size=1024] 191e0df76d7fce70
cookie convolution [] 9c522706c0cab197
cookie convolution [terms=4] 2d88a1def56515b6
cookie convolution [terms=16] 16942d2e8205cf5f
cookie convolution [damping=2] 918a63e738b7124d
cookie esm [] 419c8e77e060cd2f
cookie esm [exponent=30] 561a3f1ed7d3ef90
cookie esm [log=false;prefilter=sat] cc1e9441010a2ea4
cookie esm [prefilter=mips] 875913c5ebb27d3d
cookie esm [storage=f16;exponent=10;log=false] aeaf70c3114fc867
cookie evsm [] 1db62da446c4e3f8
cookie evsm [components=2] 538d38b25812d8a8
cookie evsm [storage=f16;positive=5.54] 75e08f29834deefd
cookie evsm [positive=80] c93edd8df4f5ce8b
long_view vsm [] 1a43894a47df4975
long_view vsm [bleeding=0.3] 3ca9c0acb6a9e048
long_view vsm [prefilter=box;radius=2] 1ee0561f9293c420
long_view vsm [prefilter=sat;variable=true] 31cdce73e0c31fa1
long_view vsm [prefilter=mips] b297b5eb0d05f4d4
long_view vsm [storage=f16] c2f231aeaa714cf0
long_view vsm [radius=8;size=1024] 808dfb534db69744
long_view convolution [] f66efe3c1094f86f
long_view convolution [terms=4] cb1bfeee16a5d540
long_view convolution [terms=16] e1cd7f489d2008f3
long_view convolution [damping=2] b1c83e659ae7c1e2
long_view esm [] 995e9c223ea66991
long_view esm [exponent=30] 35d4e8f5d8382c1a
long_view esm [log=false;prefilter=sat] 24c78995a40ca5df
long_view esm [prefilter=mips] 7da544906702cd71
long_view esm [storage=f16;exponent=10;log=false] 1d8f16a229d544d7
long_view evsm [] c3fc7c69558fb766
long_view evsm [components=2] ba6b4a86699a4c41
long_view evsm [storage=f16;positive=5.54] c2a70599da0b88f5
long_view evsm [positive=80] c3fc7c69558fb766
contact msm [] fa83f8b310a6ac08
contact msm [storage=u16;bias=0.00003] 0d5020486d06a75c
contact msm [prefilter=sat] 752e7192dde15e6f
point_casters msm [] fff33eb2f041d09c
point_casters msm [storage=u16;bias=0.00003] eeb03ea8e3a2bc4c
point_casters msm [prefilter=sat] a1c46ccae3db471d
planar msm [] c9f648028f701344
planar msm [storage=u16;bias=0.00003] f0cc23a942a3f9af
planar msm [prefilter=sat] 0495621020fc0eef
cookie msm [] d012aac96d91782b
cookie msm [storage=u16;bias=0.00003] f48617e76ff59f77
cookie msm [prefilter=sat] df99250d6ebdbe9e
long_view msm [] ae2237bd1473d3cd
long_view msm [storage=u16;bias=0.00003] 50da9f375c1add40
long_view msm [prefilter=sat] 12a436c7200ea991

cookie csm [] 215a856433234c88
cookie csm [cascades=2;size=1448] 46905cdc916b9425
cookie csm [split=log] 4aa2e60337db09aa
cookie csm [split=uniform] f98e2cbc6622a479
cookie csm [snap=true] ea5ea3b92bc7d785
cookie csm [blend=dither] 215a856433234c88
cookie csm [filter=pcf2] 6fa311c0e8d1224a
cookie csm [cascades=8;size=724] 3fe2e263a68db9e6
cookie csm [cascades=1;size=2048] 493cbd3f2a118358
cookie csm [lambda=0.9] e72b3628e90a6618
cookie csm [select=bounds] ad9c5c590e13da48
cookie csm [band=0] 215a856433234c88
cookie csm [band=0;filter=poisson;kernel=7] 172665e893031c60
cookie csm [filter=poisson;kernel=7] 413c00c72508424b
cookie csm [size=2048] 3f5f4e10eeba0c55
long_view csm [] 80bd119f326215c5
long_view csm [cascades=2;size=1448] 9209d7c29fae7508
long_view csm [split=log] db8de96685cb3ad8
long_view csm [split=uniform] 48367d134ed44d18
long_view csm [snap=true] fcc501d8f69e9925
long_view csm [blend=dither] 80bd119f326215c5
long_view csm [filter=pcf2] 0486b0c40624104f
long_view csm [cascades=8;size=724] d94f2064eddd88f5
long_view csm [cascades=1;size=2048] 285d4f35d4806a08
long_view csm [lambda=0.9] 7f3dd9f7d0a6e14d
long_view csm [select=bounds] 263cf5bf6728a7e8
long_view csm [band=0] 80bd119f326215c5
long_view csm [band=0;filter=poisson;kernel=7] 6516d0c0f51082c2
long_view csm [filter=poisson;kernel=7] d8b3b04708c4280c
long_view csm [size=2048] 65865d4ee88288e8
forest_floor csm [] 80b72c2650fa89f0
forest_floor csm [cascades=2;size=1448] 362f8d0173de9a69
forest_floor csm [split=log] 38eaeca106b49fc6
forest_floor csm [split=uniform] 5e2fd738985fb39a
forest_floor csm [snap=true] 965bf258ec713295
forest_floor csm [blend=dither] 03543f08d8e250a8
forest_floor csm [filter=pcf2] e2fece387afd510c
forest_floor csm [cascades=8;size=724] 391927909a207957
forest_floor csm [cascades=1;size=2048] aca85ec100e92e65
forest_floor csm [lambda=0.9] 57dd1fcc85ed9956
forest_floor csm [select=bounds] f47bbf072ff5d2ab
forest_floor csm [band=0] 193c0b86fbe31d98
forest_floor csm [band=0;filter=poisson;kernel=7] 85bba4f3983bd4f8
forest_floor csm [filter=poisson;kernel=7] b9936e1e3b01e459
forest_floor csm [size=2048] 9a0ddbc62ee9c007
contact vsm [cascades=4] c4a714028e50f59a
point_casters vsm [cascades=4] 4d6e1c7ab2feff57
planar vsm [cascades=4] b51ff45b66736c96
cookie vsm [cascades=4] e46d7371c2456f9a
long_view vsm [cascades=4] a5dc523ef9892746
cookie lispsm [] 7ab79ef304d9fed5
cookie lispsm [n_scale=0.5] 02677bbd335d4018
cookie lispsm [n_scale=4] d2cadc26dd4a3688
cookie lispsm [size=1024] c725179cceb14ed8
cookie lispsm [filter=pcf2] 7c9a227ed20e67e3
cookie lispsm [n_scale=0.25] 2a1b3fe5e668d228
cookie lispsm [n_scale=100] fc42058edd74cc25
cookie lispsm [filter=poisson;kernel=7] 95975f8c652ddede
cookie lispsm [size=4096] 35c63202fc177745
cookie tsm [] a739a642ae1eed88
cookie tsm [focus=0.2] fe0e827ceeb47978
cookie tsm [focus=0.8] 34b6d4543e2036d5
cookie tsm [filter=pcf2] 6eec6b7d3ac68839
cookie tsm [size=1024] f68ce6b007809fe5
cookie tsm [focus=0.05] 0a5618991a9d0285
cookie tsm [filter=poisson;kernel=7] a12be755edb8b116
long_view lispsm [] 25cdffd1708d9848
long_view lispsm [n_scale=0.5] 0e2d1dd242a97235
long_view lispsm [n_scale=4] f6026de57c090198
long_view lispsm [size=1024] 67fba825dc061a88
long_view lispsm [filter=pcf2] 6e52af64844db631
long_view lispsm [n_scale=0.25] 540b7b2ab8b9b1e8
long_view lispsm [n_scale=100] ddf9606e7ae41fd8
long_view lispsm [filter=poisson;kernel=7] 3b61944e80f3668b
long_view lispsm [size=4096] a47177c3c1a47ab8
long_view tsm [] 9e1e2e7fe5968f35
long_view tsm [focus=0.2] 84bfc9dbcb493f25
long_view tsm [focus=0.8] 7313df5446834178
long_view tsm [filter=pcf2] d57f009aaff37c67
long_view tsm [size=1024] ed68d77571240b98
long_view tsm [focus=0.05] 1e318d04cbc25de5
long_view tsm [filter=poisson;kernel=7] 06c3715c48cccc37
forest_floor lispsm [] 89d0db956a2bff48
forest_floor lispsm [n_scale=0.5] bdb564efcc9dd678
forest_floor lispsm [n_scale=4] 3c16cc42d67f7995
forest_floor lispsm [size=1024] 5d54f5209df47d18
forest_floor lispsm [filter=pcf2] 76178b8d301bce0d
forest_floor lispsm [n_scale=0.25] 2178d242ca9fc278
forest_floor lispsm [n_scale=100] 0981b6f8e1112298
forest_floor lispsm [filter=poisson;kernel=7] b98dd9bc73af86ac
forest_floor lispsm [size=4096] cdef221ba4b89f58
forest_floor tsm [] 98ef7f4d89a3f235
forest_floor tsm [focus=0.2] 42421277bd00c6b8
forest_floor tsm [focus=0.8] 41b8644fe8154948
forest_floor tsm [filter=pcf2] 3b0d71d0bc1983b8
forest_floor tsm [size=1024] 963386f8631320f5
forest_floor tsm [focus=0.05] b64cfde96bd2c588
forest_floor tsm [filter=poisson;kernel=7] 6807fd110bda2ee5
cookie sdsm [] f1f175e4a22cea35
cookie sdsm [partition=minmax] f1f175e4a22cea35
cookie sdsm [split=practical] 9ff4b4a394c86f11
cookie sdsm [latency=1] f1f175e4a22cea35
cookie sdsm [filter=pcf2] 83c6b38ee69d3cdd
cookie sdsm [cascades=2;size=1448] 03df437f1c2f8185
cookie sdsm [partition=view] 4aa2e60337db09aa
cookie sdsm [snap=true] 1408a70b5f9a0758
cookie sdsm [blend=dither] f1f175e4a22cea35
long_view sdsm [] ef0ce1745f2ae6d5
long_view sdsm [partition=minmax] ef0ce1745f2ae6d5
long_view sdsm [split=practical] b957d283503aa4d5
long_view sdsm [latency=1] ef0ce1745f2ae6d5
long_view sdsm [filter=pcf2] c2457fe38ab8ccae
long_view sdsm [cascades=2;size=1448] a1dd580c190dddd8
long_view sdsm [partition=view] db8de96685cb3ad8
long_view sdsm [snap=true] 4f223b8f896a42d5
long_view sdsm [blend=dither] ef0ce1745f2ae6d5
forest_floor sdsm [] cce248c86b31203a
forest_floor sdsm [partition=minmax] 0fa3357e7664249c
forest_floor sdsm [split=practical] d0a0bdf16c8ea898
forest_floor sdsm [latency=1] cce248c86b31203a
forest_floor sdsm [filter=pcf2] cd1602d0af3a7022
forest_floor sdsm [cascades=2;size=1448] 5f13dcbb69cce2b5
forest_floor sdsm [partition=view] 38eaeca106b49fc6
forest_floor sdsm [snap=true] 54db4b71065bc658
forest_floor sdsm [blend=dither] f7c8e1bb7db62aa5
cookie psm [] 1f7d5469a0cc8e45
cookie psm [shift=false] 1f7d5469a0cc8e45
cookie psm [filter=pcf2] 58e50ae9352643b0
cookie psm [size=1024] df73d63cb982ed08
cookie psm [filter=poisson;kernel=7] 63f293cdceceafaa
long_view psm [] a7bb0ad4787120d5
long_view psm [shift=false] a7bb0ad4787120d5
long_view psm [filter=pcf2] 67abd9810da8c980
long_view psm [size=1024] 0b7db01b0dd27fd8
long_view psm [filter=poisson;kernel=7] 40b7a2eadcf8875a
forest_floor psm [] bac452ac3c604708
forest_floor psm [shift=false] bac452ac3c604708
forest_floor psm [filter=pcf2] c797d1b7fad34831
forest_floor psm [size=1024] 3a4f3b249b0136a8
forest_floor psm [filter=poisson;kernel=7] d2468f4d16a319e2
cookie logpsm [] e2e974458c179a05
cookie logpsm [filter=pcf2] 84cdb402c52a33c5
cookie logpsm [filter=poisson;kernel=7] 97020c7cec9d34f1
cookie logpsm [n_scale=0.25] 613b6e8b75d51be8
cookie logpsm [n_scale=20] a0dca58ef9633d15
cookie logpsm [n_scale=4] 8e3ec05d36eba408
cookie logpsm [size=1024] 8d0a7b064f3aa198
cookie logpsm [size=4096] c0ba5174c36e28a5
forest_floor logpsm [] 5a1b1a23036937d8
forest_floor logpsm [filter=pcf2] 336da29f96bfacea
forest_floor logpsm [filter=poisson;kernel=7] 516ad3ae98233d4c
forest_floor logpsm [n_scale=0.25] 87aae3745279ba28
forest_floor logpsm [n_scale=20] 6ff393949b5bbec5
forest_floor logpsm [n_scale=4] 9f4bc9397c061d55
forest_floor logpsm [size=1024] dd49209d732ff035
forest_floor logpsm [size=4096] 9697416f5b8b0ec8
long_view logpsm [] 27af155822e56015
long_view logpsm [filter=pcf2] 5b2b10eae8298cef
long_view logpsm [filter=poisson;kernel=7] 3ae14ed1498dc6ab
long_view logpsm [n_scale=0.25] af1f3096c4326535
long_view logpsm [n_scale=20] 893d98215effb418
long_view logpsm [n_scale=4] d35b38f479b77fa8
long_view logpsm [size=1024] 817c08d40dc02828
long_view logpsm [size=4096] 6490453ce8b82625
";
