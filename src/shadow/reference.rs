//! The reference registered as a technique (`reference`): the ray-traced ground truth, so it
//! sits on the chart as the point every technique is measured against (error 0, its own cost).

use super::*;
use crate::reference::{Reference, ReferenceOptions};

const OPTIONS: &[OptionInfo] = &[
    OptionInfo {
        key: "area",
        default: "true",
        doc: "sample the area of area lights (false: hard visibility from the centre)",
    },
    OptionInfo {
        key: "samples",
        default: "1024",
        doc: "samples per penumbra pixel (n x n strata)",
    },
];

/// Registry entry.
pub fn info() -> TechniqueInfo {
    TechniqueInfo {
        name: "reference",
        summary: "BVH ray tracer: exact hard visibility; area lights by stratified sampling (ground truth)",
        options: OPTIONS,
        sweep: &[&[]],
        create: |s| {
            let area = s.choice("area", &["true", "false"])? == "true";
            let samples = s.num("samples", 1u32, 1 << 16)?;
            Ok(Box::new(RefTechnique {
                opts: ReferenceOptions {
                    area,
                    area_samples: samples,
                    ..Default::default()
                },
                last: None,
            }))
        },
    }
}

struct RefTechnique {
    opts: ReferenceOptions,
    last: Option<Surface<f32>>,
}

impl ShadowTechnique for RefTechnique {
    fn name(&self) -> &'static str {
        "reference"
    }

    fn visibility(&mut self, p: &Pipeline, frame: &Frame) -> Result<Vec<f32>, String> {
        let r = Reference::new(frame.scene);
        let pts = frame.points();
        let v = p.install(|| r.visibility(pts, frame.width() as usize, &frame.light, &self.opts));
        self.last = Surface::from_vec(frame.width(), frame.height(), v.clone()).ok();
        Ok(v)
    }

    fn stages(&self, _: &Pipeline, _: &Frame) -> Result<Vec<Stage>, String> {
        self.last
            .iter()
            .map(|s| Stage::Scalar {
                name: "visibility".into(),
                data: s.clone(),
                lo: 0.0,
                hi: 1.0,
            })
            .map(Ok)
            .collect()
    }
}
