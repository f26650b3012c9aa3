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
//! to the thresholds. The anchors stay the same
//! voxels (each shifted point's nearest), and verification still places
//! the unshifted template. A selection is read from the scene's voxels,
//! whose phase its copies share.

use crate::descriptor::centroid::BASE_TOLERANCE;
use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{
    CentroidDescriptor, CentroidTemplate, HarmonicsDescriptor, SphericalTransform, VolumeDescriptor,
};
use crate::error::Result;
use crate::math::Vec3;
use crate::options::{DescriptorKind, MatchOptions};
use crate::template::{TemplateSource, VoxelTemplate};
use crate::voxel::{Ball, BallMoment, Solid, voxelize};

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
    let read = |solid: &Solid| PhaseReading {
        signatures: read_at_anchors(solid, template, balls, transform, options),
        centroid: template
            .anchors()
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
        let one = read(template.voxels().solid());
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
        // The solid only: the signatures need no skin.
        let these = read(&Solid::new(voxelize(&shifted, spec, options.backend)));
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

fn read_at_anchors(
    solid: &Solid,
    template: &VoxelTemplate,
    balls: &[Ball],
    transform: &SphericalTransform,
    options: &MatchOptions,
) -> Signatures {
    let backend = options.backend;
    let anchors = template.anchors();
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
