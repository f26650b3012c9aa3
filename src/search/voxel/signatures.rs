//! The template's signatures: what every candidate is compared with, per
//! anchor.
//!
//! A model is voxelized on its own grid, whose phase against the model's
//! faces is an accident of its bounding box. A face that falls near half
//! a voxel off the lattice gains or loses a whole layer of voxels that its
//! copies, voxelized at other phases and turns, do not. Read at one phase,
//! the harmonics of a tower standing upright in a city block missed all
//! three of its copies at resolution 512, and found them at 500 and 520.
//! So a model's signatures are the mean of two voxelizations, shifted by a
//! quarter voxel one way and the other along every axis: on each axis two
//! phases half a voxel apart, which is what a face square to that axis
//! sees (a face at an angle sees a staircase whatever the phase). The
//! template's own phase error averages out, and only the copy's is left
//! to the thresholds. Each phase is read where its skin holds the anchor's
//! point: the template's grid starts a voxel below its box, so its lowest
//! faces lie on voxel boundaries, and a quarter voxel's shift down puts
//! them in the voxel below. Read at the unshifted anchor, that phase saw
//! the anchor a voxel deep, which no copy's skin voxel ever is: a tower
//! whose c_T lies on such a face read 0.68 for its smallest ball where its
//! copies read 0.54-0.56, and lost them all. Verification still places the
//! unshifted template. A selection is read from the scene's voxels, whose
//! phase its copies share.

use crate::descriptor::centroid::BASE_TOLERANCE;
use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{
    CentroidDescriptor, CentroidTemplate, HarmonicsDescriptor, SphericalTransform, VolumeDescriptor,
};
use crate::error::Result;
use crate::math::Vec3;
use crate::options::{DescriptorKind, MatchOptions};
use crate::template::{TemplateSource, VoxelTemplate};
use crate::voxel::{Ball, BallMoment, Grid, Solid, voxelize};

/// Per anchor, the template's volume signature and, unless only the volume
/// is searched, its harmonics one; where both are, its centroid readings.
pub(super) struct Signatures {
    pub(super) volume: Vec<Vec<f64>>,
    pub(super) harmonics: Option<Vec<Vec<HarmonicsSignature>>>,
    pub(super) centroid: Option<Vec<Vec<CentroidTemplate>>>,
}

/// What one phase of the template reads, before the phases are combined.
struct PhaseReading {
    signatures: Signatures,
    /// Per anchor, per centroid ball.
    centroid: Vec<Vec<BallMoment>>,
}

/// How far the two phases are shifted along every axis, in voxels.
const SHIFTS: [f64; 2] = [-0.25, 0.25];

/// The signatures of `template` ([`TemplateSource::Model`]: the mean over
/// its phases).
pub(super) fn signatures(
    source: &TemplateSource,
    template: &VoxelTemplate,
    balls: &[Ball],
    centroid_balls: &[Ball],
    transform: &SphericalTransform,
    options: &MatchOptions,
) -> Result<Signatures> {
    let read = |solid: &Solid, anchors: &[[u16; 3]]| PhaseReading {
        signatures: read_at_anchors(solid, anchors, template, balls, transform, options),
        centroid: anchors
            .iter()
            .map(|&a| CentroidDescriptor::describe(solid, a, centroid_balls, options.backend))
            .collect(),
    };
    let with_centroid = |mut signatures: Signatures, phases: &[Vec<Vec<BallMoment>>]| {
        if options.descriptor == DescriptorKind::VolumeHarmonics {
            signatures.centroid = Some(centroid_templates(
                template,
                centroid_balls,
                phases,
                options,
            ));
        }
        signatures
    };
    let TemplateSource::Model(model) = source else {
        let one = read(template.voxels().solid(), template.anchors());
        return Ok(with_centroid(one.signatures, &[one.centroid]));
    };
    let spec = template.voxels().grid().spec();
    let mut sum: Option<Signatures> = None;
    let mut phases = Vec::new();
    for along in SHIFTS {
        let shift = Vec3::splat(along * spec.voxel_size);
        // The grid is padded by a voxel on every side: a quarter voxel's
        // shift stays inside it.
        let shifted = model.map_positions(|p| p + shift)?;
        let solid = Solid::new(voxelize(&shifted, spec, options.backend));
        let anchors: Vec<[u16; 3]> = template
            .anchors()
            .iter()
            .map(|&a| phase_anchor(solid.bits(), a, along))
            .collect();
        let these = read(&solid, &anchors);
        phases.push(these.centroid);
        sum = Some(match sum {
            None => these.signatures,
            Some(sum) => sum.plus(these.signatures),
        });
    }
    let mean = sum.expect("two phases").scaled(1.0 / SHIFTS.len() as f64);
    Ok(with_centroid(mean, &phases))
}

/// How far from its anchor, in candidate spacings, the template's offset
/// is read to bound a candidate's. A candidate the harmonics keep may
/// stand further off than one spacing (a copy's support counts them): read
/// within one, two generated scenes (gen8 h7, h8) lost their best
/// survivors and a symmetric part came out turned; within two, all 52
/// compared scenes keep their instances.
const NEIGHBOURHOOD_SPACINGS: i32 = 2;

/// The template's centroid readings per anchor and ball: the mean over the
/// `phases`, allowed to differ by their spread, by how much the offset
/// changes over the skin voxels a candidate may stand on instead of the
/// anchor (see [`NEIGHBOURHOOD_SPACINGS`]), and by [`BASE_TOLERANCE`].
fn centroid_templates(
    template: &VoxelTemplate,
    balls: &[Ball],
    phases: &[Vec<Vec<BallMoment>>],
    options: &MatchOptions,
) -> Vec<Vec<CentroidTemplate>> {
    let voxels = template.voxels();
    let reach = i32::try_from(template.candidate_spacing().max(1))
        .unwrap_or(i32::MAX / NEIGHBOURHOOD_SPACINGS)
        * NEIGHBOURHOOD_SPACINGS;
    template
        .anchors()
        .iter()
        .enumerate()
        .map(|(a, &anchor)| {
            let near: Vec<Vec<BallMoment>> = voxels
                .skin()
                .iter()
                .filter(|s| (0..3).all(|k| (i32::from(s[k]) - i32::from(anchor[k])).abs() <= reach))
                .map(|&s| CentroidDescriptor::describe(voxels.solid(), s, balls, options.backend))
                .collect();
            let here = CentroidDescriptor::describe(voxels.solid(), anchor, balls, options.backend);
            balls
                .iter()
                .enumerate()
                .map(|(layer, ball)| {
                    let r = ball.radius();
                    let read: Vec<BallMoment> = phases.iter().map(|p| p[a][layer]).collect();
                    let n = read.len() as f64;
                    let fraction = read.iter().map(|m| m.fraction()).sum::<f64>() / n;
                    let offsets: Vec<f64> = read.iter().map(|m| m.offset(r)).collect();
                    let offset = offsets.iter().sum::<f64>() / n;
                    let spread = offsets
                        .iter()
                        .fold(0.0f64, |w, o| w.max((o - offset).abs()));
                    let centre = here[layer].offset(r);
                    let moved = near
                        .iter()
                        .fold(0.0f64, |w, m| w.max((m[layer].offset(r) - centre).abs()));
                    CentroidTemplate {
                        fraction,
                        offset,
                        tolerance: BASE_TOLERANCE + spread + moved,
                    }
                })
                .collect()
        })
        .collect()
}

/// How far from an anchor, in voxels along each axis, a phase's skin is
/// looked for: a quarter voxel's shift moves a face by at most one voxel.
const PHASE_REACH: i64 = 2;

/// The skin voxel of `solid` (the template moved by `shift` voxels along
/// every axis) nearest to where `anchor`'s centre moved, within
/// [`PHASE_REACH`]; `anchor` itself where none is (a thin part's skin
/// moves with it, so there is always one).
fn phase_anchor(solid: &Grid, anchor: [u16; 3], shift: f64) -> [u16; 3] {
    let at = anchor.map(i64::from);
    let is_skin = |v: [i64; 3]| {
        solid.get(v[0], v[1], v[2])
            && (0..3).any(|k| {
                [-1, 1].iter().any(|&d| {
                    let mut n = v;
                    n[k] += d;
                    !solid.get(n[0], n[1], n[2])
                })
            })
    };
    let mut best: Option<(f64, [i64; 3])> = None;
    let reach = -PHASE_REACH..=PHASE_REACH;
    for dz in reach.clone() {
        for dy in reach.clone() {
            for dx in reach.clone() {
                let v = [at[0] + dx, at[1] + dy, at[2] + dz];
                if !is_skin(v) {
                    continue;
                }
                let d2 = [dx, dy, dz]
                    .iter()
                    .map(|&d| (d as f64 - shift).powi(2))
                    .sum::<f64>();
                if best.is_none_or(|(b, _)| d2 < b) {
                    best = Some((d2, v));
                }
            }
        }
    }
    best.map_or(anchor, |(_, v)| v.map(|c| c as u16))
}

fn read_at_anchors(
    solid: &Solid,
    anchors: &[[u16; 3]],
    template: &VoxelTemplate,
    balls: &[Ball],
    transform: &SphericalTransform,
    options: &MatchOptions,
) -> Signatures {
    let backend = options.backend;
    Signatures {
        volume: anchors
            .iter()
            .map(|&a| VolumeDescriptor::describe_with(solid, a, balls, backend))
            .collect(),
        harmonics: (options.descriptor != DescriptorKind::Volume).then(|| {
            anchors
                .iter()
                .map(|&a| {
                    HarmonicsDescriptor::describe(solid, a, template.radii(), transform, backend)
                })
                .collect()
        }),
        centroid: None,
    }
}

impl Signatures {
    fn plus(mut self, other: Signatures) -> Signatures {
        for (mine, theirs) in self.volume.iter_mut().zip(other.volume) {
            for (x, y) in mine.iter_mut().zip(theirs) {
                *x += y;
            }
        }
        if let (Some(mine), Some(theirs)) = (self.harmonics.as_mut(), other.harmonics) {
            for (layers, others) in mine.iter_mut().zip(theirs) {
                for (signature, other) in layers.iter_mut().zip(others) {
                    for (x, y) in signature.iter_mut().zip(other) {
                        *x += y;
                    }
                }
            }
        }
        self
    }

    fn scaled(mut self, factor: f64) -> Signatures {
        for x in self.volume.iter_mut().flatten() {
            *x *= factor;
        }
        for x in self.harmonics.iter_mut().flatten().flatten().flatten() {
            *x *= factor as f32;
        }
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exec::Threads;
    use crate::mesh::shapes::cuboid;
    use crate::scene::{Scene, SceneOptions};

    /// A tower's shaft: the faces nearest its centre are its long sides,
    /// square to the grid. Turned half way about the vertical, the side
    /// c_T takes lies at the other end of the template's grid, whose lowest
    /// faces sit on voxel boundaries: one of the two lands there.
    fn shaft(turned: bool) -> TemplateSource {
        let s = if turned { -1.0 } else { 1.0 };
        let box_ = cuboid(Vec3::new(-12.5, -9.0, 0.0), Vec3::new(12.5, 9.0, 47.0));
        TemplateSource::Model(
            box_.map_positions(|p| Vec3::new(s * p.x, s * p.y, p.z))
                .unwrap(),
        )
    }

    #[test]
    fn a_face_square_to_the_grid_reads_alike_at_every_phase() {
        // A skin voxel on a flat face square to the grid lies half a voxel
        // inside the solid's boundary whatever the face's phase, so its
        // balls read the same: the mean over the phases must be the
        // unshifted reading. Read at the unshifted anchor, a face on a
        // voxel boundary was a voxel deep in one phase (here the mean of
        // the smallest ball was 0.540 against 0.520).
        for turned in [false, true] {
            let source = shaft(turned);
            let TemplateSource::Model(model) = &source else {
                unreachable!()
            };
            let scene_options = SceneOptions::DEFAULT.with_backend(Threads::Serial);
            let scene = Scene::new(model.clone(), &scene_options).unwrap();
            let options = MatchOptions {
                backend: Threads::Serial,
                ..MatchOptions::DEFAULT
            };
            let lattice = scene
                .lattice_for(source.bounding_radius(), options.template_voxels)
                .unwrap();
            let template = VoxelTemplate::new(&source, &scene, &lattice, &options).unwrap();
            let voxel = lattice.spec.voxel_size;
            let balls = VolumeDescriptor::balls_at(template.radii(), voxel, Threads::Serial);
            let centroid_balls = CentroidDescriptor::balls_like(&balls, Threads::Serial);
            let read = signatures(
                &source,
                &template,
                &balls,
                &centroid_balls,
                &SphericalTransform::new(),
                &options,
            )
            .unwrap();
            let anchor = template.anchors()[0];
            let unshifted = VolumeDescriptor::describe_with(
                template.voxels().solid(),
                anchor,
                &balls,
                Threads::Serial,
            );
            for layer in 0..2 {
                let (mean, one) = (read.volume[0][layer], unshifted[layer]);
                assert!(
                    (mean - one).abs() < 0.01,
                    "turned {turned}, layer {layer}: {mean} over the phases, {one} unshifted"
                );
            }
        }
    }
}
