//! How to search: the descriptor chain, its thresholds and the backend.
//!
//! [`MatchOptions`] is the one schema of the search's settings: the CLI
//! flattens it into flags (clap, with the `cli` feature), the JavaScript
//! binding reads it from an object (serde, camelCase, unknown keys refused,
//! with the `serde` feature), and a test holds the npm package's
//! `index.d.ts` to it. A new option is a new field here and nowhere else.

use std::fmt;
use std::str::FromStr;

use crate::descriptor::ClutterPolicy;
use crate::error::{Error, Result};
use crate::exec::Threads;

/// Which descriptors the cascade runs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "lowercase"))]
#[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
#[cfg_attr(feature = "cli", value(rename_all = "lower"))]
pub enum DescriptorKind {
    /// The volume prefilter, then the spherical harmonics (the paper's SHD).
    #[default]
    #[cfg_attr(feature = "serde", serde(rename = "volume+harmonics"))]
    #[cfg_attr(feature = "cli", value(name = "volume+harmonics"))]
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
    /// Every descriptor chain, the default first.
    pub const ALL: [DescriptorKind; 4] = [
        DescriptorKind::VolumeHarmonics,
        DescriptorKind::Volume,
        DescriptorKind::Harmonics,
        DescriptorKind::Curvature,
    ];

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
        DescriptorKind::ALL
            .into_iter()
            .find(|kind| kind.name() == s)
            .ok_or_else(|| {
                let names: Vec<&str> = DescriptorKind::ALL.iter().map(|k| k.name()).collect();
                Error::invalid_option(
                    "descriptor",
                    format!("'{s}' is not one of {}", names.join(", ")),
                )
            })
    }
}

/// How to search.
///
/// Field docs are the CLI's help as well: their first line is what `--help`
/// prints.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(
    feature = "serde",
    serde(rename_all = "camelCase", deny_unknown_fields, default)
)]
#[cfg_attr(feature = "cli", derive(clap::Args))]
#[non_exhaustive]
pub struct MatchOptions {
    /// The descriptor chain.
    ///
    /// Default: volume+harmonics.
    #[cfg_attr(feature = "cli", arg(long, value_enum, long_help = None, default_value_t = MatchOptions::DEFAULT.descriptor))]
    pub descriptor: DescriptorKind,
    /// Number of radii k.
    ///
    /// Default: 6 (the paper's).
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.layers))]
    pub layers: usize,
    /// Volume stage threshold: the sum of the balls' solid-fraction
    /// differences.
    ///
    /// Default: 0.12 (the paper's epsilon').
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.volume_threshold))]
    pub volume_threshold: f64,
    /// Harmonics stage threshold, in voxels of equivalent deviation.
    ///
    /// The normalized distance of `crate::descriptor::harmonics`.
    /// Default: 0.8.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.harmonics_threshold))]
    pub harmonics_threshold: f64,
    /// Curvature stage threshold: the sum of squared differences of the
    /// Gaussian curvatures scaled by r_k^2.
    ///
    /// See `crate::descriptor::curvature`. Default: 2.5.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.curvature_threshold))]
    pub curvature_threshold: f64,
    /// Curvature: 0 makes every vertex a candidate; a positive value runs a
    /// first pass on one vertex per grid cell of this side (a share of r_1),
    /// several times faster, but it can miss an occurrence.
    ///
    /// 0 (the default) is the paper's schema on the whole mesh. Otherwise one
    /// vertex per cell is a candidate of a first pass with a looser
    /// threshold, and every vertex near its survivors one of the final pass.
    /// At 0.5 this is 1.5-20 times faster on the shared scenes, but what it
    /// finds depends on where the cells fall: turning remeshed-cow can lose
    /// an occurrence, and on CAD meshes (few vertices, sharp edges) it loses
    /// most: 2 of the 8 copies on real-saw-roller (docs/CHANGELOG.md).
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.curvature_spacing))]
    pub curvature_spacing: f64,
    /// Survivors within this share of r_k of a better one join its instance.
    ///
    /// An occurrence claims the ball its descriptor describes. Default: 1.0.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.group_radius))]
    pub group_radius: f64,
    /// Verification: the least share of the template's surface that must lie
    /// on the scene's surface (0..1).
    ///
    /// Measured with the template placed at the point and its pose refined.
    /// Default: 0.85.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.verify_threshold))]
    pub verify_threshold: f64,
    /// Verification: the largest share of a model template's surface that
    /// other material may hide (0..1).
    ///
    /// Surface that lands inside the scene's solid; a selection is held to
    /// discretization's share ([`ClutterPolicy::DISCRETIZATION_HIDDEN`]).
    /// Default: 0.3: true occurrences sunk into a slab hide 10-27%,
    /// placements of a part on the wrong part of a whole 20-50%.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.hidden_surface))]
    pub hidden_surface: f64,
    /// Verification on the meshes: how far from the scene's surface a point
    /// of the template's may lie at the instance's pose, as a share of the
    /// template's radius (0..1).
    ///
    /// A copy remeshed or noisy lies within 0.3%; one twisted by 30 degrees
    /// keeps 89% of its surface within 3%. Near twins on the same object
    /// (the other foot of a figure, the other end of a rocker arm) agree
    /// as well as that: lower it (0.01) where copies are exact, as CAD and
    /// BIM instances are. Default: 0.03.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.surface_tolerance))]
    pub surface_tolerance: f64,
    /// Voxel descriptors: the least number of voxels the template's
    /// bounding radius spans; a smaller template refines the grid, one
    /// spanning more than three times this coarsens it.
    ///
    /// The scene's resolution is raised for the search until the template
    /// spans this many voxels: a part that is 2% of an assembly spans 10 at
    /// resolution 512, where a copy's pose and a longer pin look alike. A
    /// part half the scene would span over 100, and its ball tables grow
    /// with the cube of that: it is searched where it spans three times
    /// this (the meshes make the pose exact). 0 keeps the scene's
    /// resolution. Default: 32.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.template_voxels))]
    pub template_voxels: f64,
    /// Voxel descriptors: one candidate point per cube of this many voxels
    /// a side (1 makes every skin voxel a candidate).
    ///
    /// A copy's anchor is then within a voxel or two of a candidate, which
    /// the descriptors' thresholds absorb, and verification and the pose
    /// refinement place the template exactly; a template whose anchor's
    /// descriptors change by a threshold within a voxel is searched at 1.
    /// Default: 2, about 3x fewer candidates.
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.candidate_spacing))]
    pub candidate_spacing: u32,
    /// Keep whole copies only: instances whose own part the template
    /// explains entirely, not a larger part that holds it.
    ///
    /// For deduplicating CAD and BIM exports; the default reports
    /// part-in-whole occurrences too, the paper's case (each instance's
    /// `whole` says which it is). Not with the curvature descriptor, which
    /// finds no pose.
    #[cfg_attr(feature = "cli", arg(long, long_help = None))]
    pub whole_copies: bool,
    /// Keep near twins: instances that fit the template measurably worse
    /// than the scene's exact copies do.
    ///
    /// By default, where some instance fits the template within float
    /// rounding (CAD and BIM copies do), those whose residual passes
    /// rounding by 1e-3 r_k are refused: an ankle for a knee, a longer
    /// leg. Scenes without an exact copy (bent or remeshed ones) keep them
    /// all either way.
    #[cfg_attr(feature = "cli", arg(long, long_help = None))]
    pub keep_near_twins: bool,
    /// When extra material (other objects) excuses the outer layers; see
    /// `crate::descriptor::clutter`. Default: [`ClutterPolicy::DEFAULT`].
    /// The library's setting, for experiments; not on the CLI or in JavaScript.
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = ClutterPolicy::DEFAULT))]
    pub clutter: ClutterPolicy,
    /// Curvature: refuse a search whose layers would measure more
    /// triangles than this (gathered into a vertex's neighbourhood or
    /// clipped by its sphere), with [`crate::Error::CurvatureTooMuchWork`].
    ///
    /// The search's time follows this count; slivers and fans put
    /// thousands of triangles in every ball and make it quadratic in the
    /// mesh. The embedder's setting, not on the CLI or in JavaScript.
    /// Default: 2^30, about two minutes of one core; the shared scenes
    /// need at most 5.3e8 (crowd-rocker, a large template on a fine mesh).
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = MatchOptions::DEFAULT.max_curvature_work))]
    pub max_curvature_work: f64,
    /// Volume and harmonics: refuse a search whose distinct parts would
    /// take more work than this (about nanoseconds of one core), judged
    /// from a sample of the parts searched first.
    ///
    /// The refusal is [`crate::Error::PartsTooMuchWork`].
    /// Each distinct part that could hold a copy is searched on its own,
    /// a few milliseconds each; tens of thousands of near twins take
    /// minutes. Raise it to search such a scene whole anyway.
    /// Default: 3e10, about 30 s of one core (15-20 s on two): past it a
    /// person waits with no result in sight; a building of 10 000
    /// distinct parts takes about 2.5e10. Checked within a part as well,
    /// after each layer and before verifying ([`crate::Error::WorkLimit`]).
    #[cfg_attr(feature = "cli", arg(long, long_help = None, default_value_t = MatchOptions::DEFAULT.max_part_work))]
    pub max_part_work: f64,
    /// Serial or parallel. Default: parallel. The CLI sets it from
    /// `--threads`; JavaScript from the build it loaded.
    #[cfg_attr(feature = "serde", serde(skip))]
    #[cfg_attr(feature = "cli", arg(skip = Threads::Parallel))]
    pub backend: Threads,
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
        hidden_surface: 0.3,
        surface_tolerance: 0.03,
        template_voxels: 32.0,
        candidate_spacing: 2,
        whole_copies: false,
        keep_near_twins: false,
        clutter: ClutterPolicy::DEFAULT,
        max_curvature_work: (1u64 << 30) as f64,
        max_part_work: 3.0e10,
        backend: Threads::Parallel,
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
        for (name, limit) in [
            ("max curvature work", self.max_curvature_work),
            ("max part work", self.max_part_work),
        ] {
            if limit.is_nan() || limit <= 0.0 {
                return Err(Error::invalid_option(
                    name,
                    format!("must be a positive number, got {limit}"),
                ));
            }
        }
        positive("surface tolerance", self.surface_tolerance)?;
        if self.surface_tolerance > 1.0 {
            return Err(Error::invalid_option(
                "surface tolerance",
                format!("must lie in 0..=1, got {}", self.surface_tolerance),
            ));
        }
        if !(self.template_voxels.is_finite() && (0.0..=4096.0).contains(&self.template_voxels)) {
            return Err(Error::invalid_option(
                "template voxels",
                format!("must lie in 0..=4096, got {}", self.template_voxels),
            ));
        }
        if !(1..=8).contains(&self.candidate_spacing) {
            return Err(Error::invalid_option(
                "candidate spacing",
                format!("must lie in 1..=8 voxels, got {}", self.candidate_spacing),
            ));
        }
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
            ("hidden surface", self.hidden_surface),
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
        if self.whole_copies && self.descriptor == DescriptorKind::Curvature {
            return Err(Error::invalid_option(
                "whole copies",
                "the curvature descriptor finds no pose, so it cannot tell a whole copy; use a voxel descriptor".to_string(),
            ));
        }
        Ok(())
    }
}

impl MatchOptions {
    /// The hidden share allowed for a template: a selection was cut from the
    /// scene with everything its sphere held, surroundings included, so
    /// only discretization can hide its surface.
    pub(crate) fn hidden_surface_for(&self, selection: bool) -> f64 {
        if selection {
            self.hidden_surface
                .min(ClutterPolicy::DISCRETIZATION_HIDDEN)
        } else {
            self.hidden_surface
        }
    }
}

impl Default for MatchOptions {
    fn default() -> Self {
        Self::DEFAULT
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_selection_may_hide_only_discretization() {
        let options = MatchOptions::DEFAULT;
        assert_eq!(options.hidden_surface_for(false), options.hidden_surface);
        assert_eq!(
            options.hidden_surface_for(true),
            ClutterPolicy::DISCRETIZATION_HIDDEN
        );
    }

    #[test]
    fn every_descriptor_name_parses_back() {
        for kind in DescriptorKind::ALL {
            assert_eq!(kind.name().parse::<DescriptorKind>().unwrap(), kind);
        }
        let error = "curvatur"
            .parse::<DescriptorKind>()
            .unwrap_err()
            .to_string();
        assert!(
            error.contains("volume+harmonics, volume, harmonics, curvature"),
            "{error}"
        );
    }
}
