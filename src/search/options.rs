//! How to search: the descriptor chain, its thresholds and the backend.

use std::fmt;
use std::str::FromStr;

use crate::descriptor::ClutterPolicy;
use crate::error::{Error, Result};
use crate::exec::Backend;

/// Which descriptors the cascade runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum DescriptorKind {
    /// The volume prefilter, then the spherical harmonics (the paper's SHD).
    #[default]
    VolumeHarmonics,
    /// The volume descriptor alone.
    Volume,
    /// The spherical harmonics alone.
    Harmonics,
    /// Gaussian curvature on the mesh (paper, sec. 4.3): for shapes bent
    /// out of their rigid pose.
    Curvature,
}

impl DescriptorKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            DescriptorKind::VolumeHarmonics => "volume+harmonics",
            DescriptorKind::Volume => "volume",
            DescriptorKind::Harmonics => "harmonics",
            DescriptorKind::Curvature => "curvature",
        }
    }
}

impl fmt::Display for DescriptorKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for DescriptorKind {
    type Err = Error;
    fn from_str(s: &str) -> Result<Self> {
        match s {
            "volume+harmonics" => Ok(DescriptorKind::VolumeHarmonics),
            "volume" => Ok(DescriptorKind::Volume),
            "harmonics" => Ok(DescriptorKind::Harmonics),
            "curvature" => Ok(DescriptorKind::Curvature),
            _ => Err(Error::invalid_option(
                "descriptor",
                format!("'{s}' is not one of volume+harmonics, volume, harmonics, curvature"),
            )),
        }
    }
}

/// How to search.
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub struct MatchOptions {
    /// The descriptor chain. Default: volume+harmonics.
    pub descriptor: DescriptorKind,
    /// Number of radii k. Default: 6 (the paper's).
    pub layers: usize,
    /// Volume stage: bound on the sum of fraction differences. Default: 0.12
    /// (the paper's epsilon').
    pub volume_threshold: f64,
    /// Harmonics stage: bound on the normalized distance, in voxels of
    /// equivalent deviation (see [`crate::descriptor::harmonics`]).
    /// Default: 0.8.
    pub harmonics_threshold: f64,
    /// Curvature stage: bound on the sum of squared differences of the
    /// Gaussian curvatures scaled by r_k^2 (see
    /// [`crate::descriptor::curvature`]). Default: 2.5.
    pub curvature_threshold: f64,
    /// Curvature stage: 0 (the default) makes every vertex a candidate, the
    /// paper's schema on the whole mesh. A positive value is the side of
    /// grid cells, as a fraction of r_1: one vertex per cell is a candidate
    /// of a first pass with a looser threshold, and every vertex near its
    /// survivors one of the final pass. At 0.5 this is 1.5-20 times faster on
    /// the shared scenes, but what it finds depends on where the cells fall:
    /// turning remeshed-cow can lose an occurrence (see the README).
    pub curvature_spacing: f64,
    /// Survivors within this fraction of r_k of a better one join its
    /// instance: an occurrence claims the ball its descriptor describes.
    /// Default: 1.0.
    pub group_radius: f64,
    /// Verification: the least share of the template's surface that must
    /// land on the scene's surface when the template is placed at a point
    /// (0..1), after the pose is refined. Default: 0.85.
    pub verify_threshold: f64,
    /// When extra material (other objects) excuses the outer layers; see
    /// [`crate::descriptor::clutter`]. Default: [`ClutterPolicy::DEFAULT`].
    pub clutter: ClutterPolicy,
    /// Serial or parallel. Default: parallel.
    pub backend: Backend,
}

impl MatchOptions {
    /// The defaults.
    pub const DEFAULT: MatchOptions = MatchOptions {
        descriptor: DescriptorKind::VolumeHarmonics,
        layers: 6,
        volume_threshold: 0.12,
        harmonics_threshold: 0.8,
        curvature_threshold: 2.5,
        curvature_spacing: 0.0,
        group_radius: 1.0,
        verify_threshold: 0.85,
        clutter: ClutterPolicy::DEFAULT,
        backend: Backend::Parallel,
    };

    pub(crate) fn validate(&self) -> Result<()> {
        let positive = |name, v: f64| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(Error::invalid_option(
                    name,
                    format!("must be a positive number, got {v}"),
                ))
            }
        };
        positive("volume threshold", self.volume_threshold)?;
        positive("harmonics threshold", self.harmonics_threshold)?;
        positive("curvature threshold", self.curvature_threshold)?;
        positive("group radius", self.group_radius)?;
        if !(self.curvature_spacing.is_finite() && self.curvature_spacing >= 0.0) {
            return Err(Error::invalid_option(
                "curvature spacing",
                format!(
                    "must be 0 or a positive number, got {}",
                    self.curvature_spacing
                ),
            ));
        }
        for (name, share) in [
            ("verify threshold", self.verify_threshold),
            ("hidden surface", self.clutter.hidden_surface),
        ] {
            if !(0.0..=1.0).contains(&share) {
                return Err(Error::invalid_option(
                    name,
                    format!("must lie in 0..=1, got {share}"),
                ));
            }
        }
        if !(1..=64).contains(&self.layers) {
            return Err(Error::invalid_option(
                "layers",
                format!("{} is outside 1..=64", self.layers),
            ));
        }
        Ok(())
    }
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}
