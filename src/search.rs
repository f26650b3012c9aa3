//! The whole search: template, cascade, grouping, with timings.

use std::fmt;
use std::str::FromStr;

use crate::cascade::{LayerStats, Observer, Stage, run_cascade};
use crate::clock::now_ms;
use crate::descriptor::harmonics::ClutterGuard;
use crate::descriptor::{ClutterPolicy, HarmonicsDescriptor, SphericalTransform, VolumeDescriptor};
use crate::error::{Error, Result};
use crate::exec::Backend;
use crate::instances::{Instance, Verified, group, local_bests};
use crate::scene::Scene;
use crate::template::{Template, TemplateSource};
use crate::verify::Verifier;

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
}

impl DescriptorKind {
    /// The name used on the command line and in reports.
    pub fn name(self) -> &'static str {
        match self {
            DescriptorKind::VolumeHarmonics => "volume+harmonics",
            DescriptorKind::Volume => "volume",
            DescriptorKind::Harmonics => "harmonics",
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
            _ => Err(Error::invalid_option(
                "descriptor",
                format!("'{s}' is not one of volume+harmonics, volume, harmonics"),
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
    /// Cap on the template's voxel grid. Default: 2 GiB.
    pub max_grid_bytes: u64,
}

impl MatchOptions {
    /// The defaults.
    pub const DEFAULT: MatchOptions = MatchOptions {
        descriptor: DescriptorKind::VolumeHarmonics,
        layers: 6,
        volume_threshold: 0.12,
        harmonics_threshold: 0.8,
        group_radius: 1.0,
        verify_threshold: 0.85,
        clutter: ClutterPolicy::DEFAULT,
        backend: Backend::Parallel,
        max_grid_bytes: 2 << 30,
    };

    fn validate(&self) -> Result<()> {
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
        positive("group radius", self.group_radius)?;
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

/// The template as the report shows it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct TemplateInfo {
    /// c_T: template-model coordinates, or world for a selection.
    pub center: [f64; 3],
    /// r_k.
    pub radius: f64,
}

/// The grid as the report shows it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct GridInfo {
    /// Voxels along the longest side.
    pub resolution: u32,
    /// Edge length of a voxel.
    pub voxel_size: f64,
    /// Candidate points.
    pub skin_voxels: usize,
}

/// Milliseconds per stage.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct Timings {
    /// Reading and parsing the files (filled in by whoever loaded them).
    pub load: f64,
    /// Voxelizing the scene.
    pub voxelize: f64,
    /// Building the template and its descriptors.
    pub template: f64,
    /// The cascade.
    #[serde(rename = "match")]
    pub match_: f64,
    /// Verifying and grouping survivors.
    pub group: f64,
    /// All of the above.
    pub total: f64,
}

impl Timings {
    /// Recomputes `total` from the parts.
    pub fn sum(&mut self) {
        self.total = self.load + self.voxelize + self.template + self.match_ + self.group;
    }
}

/// Everything a search found, in the shape of the CLI's JSON.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct MatchReport {
    /// The template's centre and outer radius.
    pub template: TemplateInfo,
    /// The occurrences, best first.
    pub instances: Vec<Instance>,
    /// Per-layer statistics of every stage.
    pub stages: Vec<LayerStats>,
    /// The voxel grid.
    pub grid: GridInfo,
    /// Stage timings.
    #[serde(rename = "timings_ms")]
    pub timings: Timings,
}

/// A readable table: template, grid, every layer, the instances, timings.
impl fmt::Display for MatchReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let t = &self.template;
        writeln!(
            f,
            "template: centre ({:.4}, {:.4}, {:.4}), radius {:.4}",
            t.center[0], t.center[1], t.center[2], t.radius
        )?;
        writeln!(
            f,
            "grid: {} voxels on the longest side, voxel {:.5}, {} candidate points\n",
            self.grid.resolution, self.grid.voxel_size, self.grid.skin_voxels
        )?;
        writeln!(
            f,
            "{:<10} {:>5} {:>8} {:>10} {:>10} {:>9}",
            "stage", "layer", "radius", "candidates", "survivors", "ms"
        )?;
        for s in &self.stages {
            writeln!(
                f,
                "{:<10} {:>5} {:>8.4} {:>10} {:>10} {:>9.1}",
                s.descriptor, s.layer, s.radius, s.candidates, s.survivors, s.ms
            )?;
        }
        writeln!(f, "\n{} instance(s):", self.instances.len())?;
        for (i, inst) in self.instances.iter().enumerate() {
            let p = inst.position;
            writeln!(
                f,
                "  #{:<3} at ({:.4}, {:.4}, {:.4})  distance {:.4}  agreement {:.3}  support {}",
                i + 1,
                p[0],
                p[1],
                p[2],
                inst.distance,
                inst.score,
                inst.support
            )?;
        }
        let tm = &self.timings;
        write!(
            f,
            "\ntime (ms): load {:.1}, voxelize {:.1}, template {:.1}, match {:.1}, group {:.1}, total {:.1}",
            tm.load, tm.voxelize, tm.template, tm.match_, tm.group, tm.total
        )
    }
}

/// Searches `scene` for every occurrence of `source`.
pub fn search(
    scene: &Scene,
    source: &TemplateSource,
    options: &MatchOptions,
    observer: &mut dyn Observer,
) -> Result<MatchReport> {
    options.validate()?;
    let t0 = now_ms();
    let template = Template::new(
        source,
        scene,
        options.layers,
        options.backend,
        options.max_grid_bytes,
    )?;
    let radii = template.radii();
    let (tsolid, tvoxel, backend) = (template.solid(scene), template.voxel(), options.backend);
    let transform = SphericalTransform::new();
    // The balls' tables are built once, then bound to each solid's layout.
    let balls = VolumeDescriptor::unbound_balls(radii, scene.voxel_size(), backend);
    let template_balls: Vec<_> = balls
        .iter()
        .map(|b| b.clone().bind(tsolid, backend))
        .collect();
    let volume = VolumeDescriptor::with_balls(
        scene.solid(),
        scene.skin(),
        radii,
        balls
            .into_iter()
            .map(|b| b.bind(scene.solid(), backend))
            .collect(),
        VolumeDescriptor::describe_with(tsolid, tvoxel, &template_balls),
        options.volume_threshold,
    )
    .with_clutter(options.clutter);
    let harmonics = match options.descriptor {
        DescriptorKind::Volume => None,
        _ => Some(
            HarmonicsDescriptor::new(
                scene.solid(),
                scene.skin(),
                &transform,
                radii,
                HarmonicsDescriptor::describe(tsolid, tvoxel, radii, &transform, backend),
                options.harmonics_threshold,
                backend,
            )
            .with_clutter(ClutterGuard {
                policy: options.clutter,
                balls: volume.balls(),
                template: volume.template(),
            }),
        ),
    };
    let mut stages: Vec<&dyn Stage> = Vec::new();
    if options.descriptor != DescriptorKind::Harmonics {
        stages.push(&volume);
    }
    if let Some(h) = &harmonics {
        stages.push(h);
    }
    let t1 = now_ms();
    let candidates = (0..scene.skin().len() as u32).collect();
    let (survivors, stats) = run_cascade(&stages, candidates, options.backend, observer)?;
    let t2 = now_ms();
    let position = |p| scene.position(p);
    let bests = local_bests(&survivors, position, radii[0]);
    let voxel = scene.voxel_size();
    let radii_voxels: Vec<f64> = radii.iter().map(|r| r / voxel).collect();
    let verifier = Verifier::new(
        tsolid,
        tvoxel,
        template.center_offset(scene),
        &radii_voxels,
        options
            .clutter
            .hidden_surface_for(matches!(source, TemplateSource::Selection { .. })),
        backend,
    );
    let verified: Vec<Verified> = backend
        .map_each(bests.len(), |i| {
            let v = scene.skin()[bests[i].point as usize];
            let placement = verifier.check(scene.solid(), scene.near_surface(), v);
            Verified {
                survivor: bests[i],
                score: placement.score(),
                position: scene.position(bests[i].point) + placement.offset * voxel,
            }
        })
        .into_iter()
        .filter(|v| v.score >= options.verify_threshold)
        .collect();
    let instances = group(
        &verified,
        &survivors,
        position,
        options.group_radius * template.radius(),
    );
    let t3 = now_ms();
    let mut timings = Timings {
        load: 0.0,
        voxelize: scene.voxelize_ms(),
        template: t1 - t0,
        match_: t2 - t1,
        group: t3 - t2,
        total: 0.0,
    };
    timings.sum();
    Ok(MatchReport {
        template: TemplateInfo {
            center: template.center().to_array(),
            radius: template.radius(),
        },
        instances,
        stages: stats,
        grid: GridInfo {
            resolution: scene.resolution(),
            voxel_size: scene.voxel_size(),
            skin_voxels: scene.skin().len(),
        },
        timings,
    })
}
