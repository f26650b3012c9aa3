//! The anchor: the template voxel its descriptors are read at.
//!
//! The paper reads them at c_T, the surface point nearest the centre of the
//! bounding sphere. The onion descriptors do not change when the template
//! turns, but their voxels do: where thin or open shells meet (a teapot's
//! lid on its body), the solid around c_T fills differently at every
//! orientation, and copies turned the wrong way drift past the threshold
//! (3 of 4 teapots missed). So the template is voxelized turned two ways
//! and the descriptors at c_T compared with its own there. Where they drift
//! by more than twice a threshold, the anchor moves to the surface
//! point within r_k / 2 of c_T that drifts least. c_T stays the point
//! reported: verification's pose carries it from wherever the anchor is.

use crate::descriptor::harmonics::{Signature, SphereSampler, describe_sphere, harmonics_distance};
use crate::descriptor::{SphericalTransform, VolumeDescriptor};
use crate::error::Result;
use crate::exec::Backend;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::scene::{PartVoxels, nearest_voxel};
use crate::voxel::{Ball, GridSpec};

/// c_T is kept unless it drifts by more than this many thresholds: on the
/// shared scenes' templates it drifts by 0.24-1.2 (read at one voxel, where
/// the cascade keeps the best of a copy's many candidates) and every copy
/// is found; on the teapot by 6.5-7.4.
const STABLE_DRIFT: f64 = 2.0;

/// Other anchors tried when c_T drifts.
const ALTERNATIVES: usize = 8;

/// Another anchor replaces c_T when it drifts less than this share of c_T's
/// drift.
const ALTERNATIVE_SHARE: f64 = 0.5;

/// What the drift is measured against: the thresholds of the stages that
/// will run (`None`: the stage does not run).
#[derive(Clone, Copy, Debug)]
pub(super) struct Thresholds {
    pub volume: Option<f64>,
    pub harmonics: Option<f64>,
}

/// The anchor voxel of `voxels` (the template `model` voxelized on its own
/// grid) to read descriptors at `radii` from: `center`'s (c_T's) voxel,
/// unless its descriptors drift when the model turns; then the least
/// drifting of [`ALTERNATIVES`] surface voxels spread within r_k / 2.
pub(super) fn stable_anchor(
    model: &TriMesh,
    voxels: &PartVoxels,
    center: [u16; 3],
    radii: &[f64],
    thresholds: Thresholds,
    backend: Backend,
) -> Result<[u16; 3]> {
    let transform = SphericalTransform::new();
    let spec = voxels.grid().spec();
    let balls = VolumeDescriptor::unbound_balls(radii, spec.voxel_size, backend);
    let drift = |anchors: &[[u16; 3]], turns: &[glam::DQuat]| -> Result<Vec<f64>> {
        let reader = Reader::new(voxels, &balls, radii, thresholds, &transform, backend);
        let own: Vec<Descriptors> = anchors.iter().map(|&v| reader.at(v)).collect();
        let mut worst = vec![0.0f64; anchors.len()];
        for &turn in turns {
            let turned = model.map_positions(|p| turn * p)?;
            let turned_spec = GridSpec::around(turned.bounds(), spec.voxel_size)?;
            let turned_voxels = PartVoxels::build(&turned, &turned_spec, backend);
            let there = Reader::new(
                &turned_voxels,
                &balls,
                radii,
                thresholds,
                &transform,
                backend,
            );
            for (i, &v) in anchors.iter().enumerate() {
                let p = turn * spec.center(v);
                let Some(w) = nearest_voxel(&turned_spec, turned_voxels.skin(), p) else {
                    continue;
                };
                let drift = own[i].drift(&there.at(w), radii, spec.voxel_size, thresholds);
                worst[i] = worst[i].max(drift);
            }
        }
        Ok(worst)
    };
    // One turn tells a drifting c_T; both choose among the others.
    let own = drift(&[center], &TURNS[..1])?[0];
    if own <= STABLE_DRIFT {
        return Ok(center);
    }
    let mut anchors = vec![center];
    anchors.extend(spread_within(
        voxels.skin(),
        center,
        radii[radii.len() - 1] / 2.0 / spec.voxel_size,
    ));
    let drifts = drift(&anchors, &TURNS)?;
    let best = (0..anchors.len())
        .min_by(|&a, &b| drifts[a].total_cmp(&drifts[b]))
        .expect("c_T at least");
    // Another anchor must do clearly better to replace the paper's.
    Ok(if drifts[best] < own * ALTERNATIVE_SHARE {
        anchors[best]
    } else {
        center
    })
}

/// Two turns about unrelated axes (unit quaternions: 1.1 rad about
/// (1, 2, 3) and 2.3 rad about (-2, 1, 1)), fixed so that a template always
/// gets the same anchor.
const TURNS: [glam::DQuat; 2] = [
    glam::DQuat::from_xyzw(0.139_694, 0.279_388, 0.419_082, 0.852_525),
    glam::DQuat::from_xyzw(-0.745_269, 0.372_634, 0.372_634, 0.408_487),
];

/// Up to [`ALTERNATIVES`] skin voxels within `reach` voxels of `center`,
/// spread by farthest-point sampling from it.
fn spread_within(skin: &[[u16; 3]], center: [u16; 3], reach: f64) -> Vec<[u16; 3]> {
    let offset = |v: &[u16; 3]| {
        Vec3::new(
            v[0] as f64 - center[0] as f64,
            v[1] as f64 - center[1] as f64,
            v[2] as f64 - center[2] as f64,
        )
    };
    let near: Vec<[u16; 3]> = skin
        .iter()
        .filter(|v| offset(v).length() <= reach)
        .copied()
        .collect();
    let mut gap: Vec<f64> = near.iter().map(|v| offset(v).length()).collect();
    let mut picked = Vec::new();
    for _ in 0..ALTERNATIVES {
        let Some((i, &g)) = gap.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            break;
        };
        if g <= 0.0 {
            break;
        }
        let p = near[i];
        picked.push(p);
        for (j, v) in near.iter().enumerate() {
            let d = (offset(v) - offset(&p)).length();
            gap[j] = gap[j].min(d);
        }
    }
    picked
}

/// The descriptors of one voxel, for the stages that run.
struct Descriptors {
    volume: Option<Vec<f64>>,
    harmonics: Option<Vec<Signature>>,
}

/// Reads [`Descriptors`] on one solid, its spheres laid out once.
struct Reader<'a> {
    voxels: &'a PartVoxels,
    balls: &'a [Ball],
    spheres: Option<Vec<SphereSampler>>,
    volume: bool,
    transform: &'a SphericalTransform,
    backend: Backend,
}

impl<'a> Reader<'a> {
    fn new(
        voxels: &'a PartVoxels,
        balls: &'a [Ball],
        radii: &[f64],
        thresholds: Thresholds,
        transform: &'a SphericalTransform,
        backend: Backend,
    ) -> Reader<'a> {
        let solid = voxels.solid();
        let voxel = solid.bits().spec().voxel_size;
        Reader {
            voxels,
            balls,
            spheres: thresholds.harmonics.map(|_| {
                radii
                    .iter()
                    .map(|r| SphereSampler::new(r / voxel, solid, backend))
                    .collect()
            }),
            volume: thresholds.volume.is_some(),
            transform,
            backend,
        }
    }

    fn at(&self, v: [u16; 3]) -> Descriptors {
        let solid = self.voxels.solid();
        Descriptors {
            volume: self
                .volume
                .then(|| VolumeDescriptor::describe_with(solid, v, self.balls, self.backend)),
            harmonics: self.spheres.as_ref().map(|spheres| {
                spheres
                    .iter()
                    .map(|s| describe_sphere(solid, v, s, self.transform))
                    .collect()
            }),
        }
    }
}

impl Descriptors {
    /// The larger of the two stages' distances to `other`, each as a
    /// share of its threshold.
    fn drift(&self, other: &Descriptors, radii: &[f64], voxel: f64, t: Thresholds) -> f64 {
        let volume = match (&self.volume, &other.volume, t.volume) {
            (Some(a), Some(b), Some(th)) => {
                a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f64>() / th
            }
            _ => 0.0,
        };
        let harmonics = match (&self.harmonics, &other.harmonics, t.harmonics) {
            (Some(a), Some(b), Some(th)) => harmonics_distance(a, b, radii, voxel) / th,
            _ => 0.0,
        };
        volume.max(harmonics)
    }
}
