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

use crate::descriptor::harmonics::Signature as HarmonicsSignature;
use crate::descriptor::{HarmonicsDescriptor, SphericalTransform, VolumeDescriptor};
use crate::error::Result;
use crate::math::Vec3;
use crate::options::{DescriptorKind, MatchOptions};
use crate::template::{TemplateSource, VoxelTemplate};
use crate::voxel::{Ball, Solid, voxelize};

/// Per anchor, the template's volume signature and, unless only the volume
/// is searched, its harmonics one.
pub(super) struct Signatures {
    pub(super) volume: Vec<Vec<f64>>,
    pub(super) harmonics: Option<Vec<Vec<HarmonicsSignature>>>,
}

/// How far the two phases are shifted along every axis, in voxels.
const SHIFTS: [f64; 2] = [-0.25, 0.25];

/// The signatures of `template` ([`TemplateSource::Model`]: the mean over
/// its phases).
pub(super) fn signatures(
    source: &TemplateSource,
    template: &VoxelTemplate,
    balls: &[Ball],
    transform: &SphericalTransform,
    options: &MatchOptions,
) -> Result<Signatures> {
    let read = |solid: &Solid| read_at_anchors(solid, template, balls, transform, options);
    let TemplateSource::Model(model) = source else {
        return Ok(read(template.voxels().solid()));
    };
    let spec = template.voxels().grid().spec();
    let mut sum: Option<Signatures> = None;
    for along in SHIFTS {
        let shift = Vec3::splat(along * spec.voxel_size);
        // The grid is padded by a voxel on every side: a quarter voxel's
        // shift stays inside it.
        let shifted = model.map_positions(|p| p + shift)?;
        // The solid only: the signatures need no skin.
        let these = read(&Solid::new(voxelize(&shifted, spec, options.backend)));
        sum = Some(match sum {
            None => these,
            Some(sum) => sum.plus(these),
        });
    }
    Ok(sum.expect("two phases").scaled(1.0 / SHIFTS.len() as f64))
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
