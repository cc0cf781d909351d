//! The irregular z-buffer's unit tests: the four-lane list test against the one-sample
//! one, and the parallel list sort against the serial one.

use super::*;
use proptest::prelude::*;
use std::path::Path;

/// [`test_list`] one sample at a time, with the one-sample tests.
fn test_list_one(o: &Occluder, list: &mut [ListSample], l: ListLight) -> (f32, u32) {
    let (mut far, mut tests) = (f32::NEG_INFINITY, 0);
    for s in list {
        if s.state >= SHADOWED {
            continue;
        }
        if s.state != o.id {
            tests += 1;
            if !o.same_side_as_light(s.position) {
                let to = if l.directional {
                    l.direction
                } else {
                    l.position - s.position
                };
                if o.blocks(s.position, to, l.directional) {
                    s.state = SHADOWED | o.id;
                    continue;
                }
            }
        }
        far = far.max(axis_at(l.axis, s.position));
    }
    (far, tests)
}

fn v3() -> impl Strategy<Value = Vec3> {
    (-2.0f32..2.0, -2.0f32..2.0, -2.0f32..2.0).prop_map(|(x, y, z)| Vec3::new(x, y, z))
}

proptest! {
    /// The four-lane occluder test gives the one-sample test's states, test count and
    /// largest lit depth, for directional and point lights, samples on, near, above and
    /// below the triangle (and on its edges), and degenerate triangles.
    #[test]
    fn four_lane_occluder_test_equals_the_one_sample_test(
        tri in (v3(), v3(), v3(), 0u8..4),
        light in (v3(), any::<bool>()),
        samples in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, -0.5f32..0.5, (0u8..6, 0u8..4), v3()), 0..14),
    ) {
        let (a, mut b, mut c, degenerate) = tri;
        match degenerate {
            0 => b = a,
            1 => c = a + (b - a) * 0.5,
            _ => {}
        }
        let (lp, directional) = (light.0 * 3.0, light.1);
        let l = Light {
            kind: if directional { LightKind::Directional } else { LightKind::Point },
            position: lp,
            direction: (Vec3::new(0.1, -1.0, 0.2) + light.0 * 0.3).normalize(),
            intensity: 1.0,
        };
        let o = Occluder::new(a, b, c, &l, 7);
        let axis = Vec4::new(0.3, -0.8, 0.1, 0.5);
        let dir = -l.direction;
        let mut list: Vec<ListSample> = samples
            .iter()
            .map(|&(u, v, h, (kind, st), free)| {
                let (u, v) = if u + v > 1.0 { (1.0 - u, 1.0 - v) } else { (u, v) };
                let on = a + (b - a) * u + (c - a) * v;
                let position = match kind {
                    0 => free,
                    1 => on,
                    2 => a + (b - a) * u, // on an edge
                    3 => [a, b, c][(u * 3.0) as usize % 3], // on a vertex
                    4 => [a, b, c][(u * 3.0) as usize % 3] + dir * h, // above or below one
                    _ => on + (b - a).cross(c - a).normalize_or_zero() * h,
                };
                let state = match st {
                    0 => 7, // on the occluder itself
                    1 => SHADOWED | 3,
                    2 => 9,
                    _ => NO_TRIANGLE,
                };
                ListSample { position, state }
            })
            .collect();
        let mut one = list.clone();
        let at = ListLight {
            directional,
            position: lp,
            direction: dir,
            axis,
        };
        let got = test_list(&o, &mut list, at);
        let want = test_list_one(&o, &mut one, at);
        prop_assert_eq!(&list, &one);
        prop_assert_eq!(got.1, want.1);
        prop_assert!(got.0 == want.0, "far {} against {}", got.0, want.0);
    }
}

/// The parallel counting sort gives the serial one's lists: walking the samples in order,
/// each lands at its texel's next free place, with its own record.
#[test]
fn parallel_list_sort_equals_the_serial_one() {
    let p = Pipeline::new(2).unwrap();
    for (scene, k) in [("point_casters", "1"), ("contact", "4")] {
        let s = crate::scene::file::load(Path::new(&format!("fixtures/scenes/{scene}.toml"))).unwrap();
        let f = crate::frame::frame(&p, &s, 0, 0).unwrap();
        let mut t = IrregularZBuffer::new(Options {
            samples: crate::shadow::options::OptionValue::parse(k).unwrap(),
            ..Default::default()
        });
        t.run(&p, &f, &mut Passes::start()).unwrap();
        assert!(t.total > 2 * MIN_CHUNK, "{scene}: too few samples to test chunks");
        let size = t.opts.size;
        let samples = camera_samples(&f, t.opts.samples);
        assert_eq!(samples.len(), t.total);
        let mut slot = vec![None; samples.len()];
        for (v, (view, _)) in t.views.iter().enumerate() {
            for (at, &i) in view.order.iter().enumerate() {
                assert!(slot[i as usize].is_none(), "{scene}: sample {i} stored twice");
                slot[i as usize] = Some((v, at));
            }
        }
        let mut cursors: Vec<Vec<u32>> = t.views.iter().map(|(v, _)| v.store.offsets().to_vec()).collect();
        let mut inserted = 0;
        for (i, smp) in samples.iter().enumerate() {
            let Some((v, at)) = slot[i] else { continue };
            inserted += 1;
            let (uv, _) = t.views.get(v).0.base.lookup(smp.point.position).unwrap();
            let (tx, ty) = t.views.get(v).0.grid.texel(uv);
            let c = &mut cursors[v][ty * size as usize + tx];
            assert_eq!(at as u32, *c, "{scene}: sample {i} out of the serial order");
            *c += 1;
            let rec = t.views.get(v).0.store.data()[at];
            assert_eq!(rec.position, offset_origin(smp.point.position, smp.point.face));
            assert_eq!(t.slot(i), Some((v, at)));
        }
        assert_eq!(inserted, t.inserted);
        assert!(t.views.len() > 1 || scene == "contact", "{scene}: expected cube faces");
    }
}
