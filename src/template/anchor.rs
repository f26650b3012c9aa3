//! The anchor: the template voxel its descriptors are read at.
//!
//! The paper reads them at c_T, the surface point nearest the centre of the
//! bounding sphere. The onion descriptors do not change when the template
//! turns, but their voxels do: where thin or open shells meet (a teapot's
//! lid on its body), the solid around c_T fills differently at every
//! orientation, and copies turned the wrong way drift past the threshold
//! (3 of 4 teapots missed). So the template is voxelized turned two ways
//! and the descriptors at c_T compared with its own there. Candidates are
//! spaced too, so a copy's best candidate is often a voxel or two off its
//! anchor: at a sharp edge (a fandisk's) the descriptors change by more
//! than a threshold within a voxel, and copies are lost the same way. So
//! the descriptors at c_T are also compared with its neighbours'. Where
//! either drift is too large, the anchor moves to the surface point within
//! r_k / 2 of c_T that is most stable. c_T stays the point reported:
//! verification's pose carries it from wherever the anchor is.

use crate::descriptor::harmonics::{Signature, SphereSampler, describe_sphere, harmonics_distance};
use crate::descriptor::{SphericalTransform, VolumeDescriptor};
use crate::error::Result;
use crate::exec::Threads;
use crate::math::Vec3;
use crate::mesh::TriMesh;
use crate::options::{DescriptorKind, MatchOptions};
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

impl Thresholds {
    /// Those of the stages `options` run.
    pub(super) fn of(options: &MatchOptions) -> Thresholds {
        Thresholds {
            volume: (options.descriptor != DescriptorKind::Harmonics)
                .then_some(options.volume_threshold),
            harmonics: (options.descriptor != DescriptorKind::Volume)
                .then_some(options.harmonics_threshold),
        }
    }
}

/// The anchor voxel of `voxels` to read descriptors at `radii` from:
/// `center`'s (c_T's), unless it is unstable; then the most stable of
/// [`ALTERNATIVES`] surface voxels spread within r_k / 2, if it is clearly
/// more stable. Unstable is either of two things, each measured in
/// thresholds: the descriptors drift when `model` (the template's own mesh,
/// voxelized on `voxels`' grid; `None` for a selection, whose part may be
/// the whole scene) turns, or they differ from those of the surface voxels
/// a copy's candidates may fall on instead (within `spacing`, the
/// candidates' cube, of the anchor).
pub(super) fn stable_anchor(
    model: Option<&TriMesh>,
    voxels: &PartVoxels,
    center: [u16; 3],
    radii: &[f64],
    thresholds: Thresholds,
    spacing: u32,
    backend: Threads,
) -> Result<Anchor> {
    let transform = SphericalTransform::new();
    let spec = voxels.grid().spec();
    let balls = VolumeDescriptor::balls_at(radii, spec.voxel_size, backend);
    let reader = Reader::new(voxels, &balls, radii, thresholds, &transform, backend);
    let turn_drift = |anchors: &[[u16; 3]], turns: &[glam::DQuat]| -> Result<Vec<f64>> {
        match model {
            Some(model) => turn_drifts(
                model, voxels, &reader, anchors, turns, radii, thresholds, backend,
            ),
            None => Ok(vec![0.0; anchors.len()]),
        }
    };
    let reach = (NEIGHBOUR_REACH * spacing as f64).max(1.0);
    let roughness = |a: [u16; 3]| roughness(voxels, &reader, a, reach, radii, thresholds);
    // One turn tells a drifting c_T; both choose among the others.
    let own_turn = turn_drift(&[center], &TURNS[..1])?[0];
    let own_rough = roughness(center);
    if own_turn <= STABLE_DRIFT && own_rough <= ROUGH_DRIFT {
        return Ok(Anchor {
            voxel: center,
            rough: false,
            steady: true,
        });
    }
    // A turning template may need to move far (a teapot's lid), and is
    // judged by its turns alone; a rough spot moves only within its
    // neighbourhood, which keeps what the descriptors see (a selection's
    // anchor far from c_T would read beyond the sphere), and is judged by
    // both drifts, each over its limit.
    let turning = own_turn > STABLE_DRIFT;
    let reach = if turning {
        radii[radii.len() - 1] / 2.0
    } else {
        radii[0]
    };
    let mut anchors = vec![center];
    anchors.extend(spread_within(
        voxels.skin(),
        center,
        reach / spec.voxel_size,
        ALTERNATIVES,
    ));
    let turns = turn_drift(&anchors, &TURNS)?;
    // c_T's is known; a turning template's others are read for the winner
    // only.
    let rough: Vec<Option<f64>> = anchors
        .iter()
        .enumerate()
        .map(|(i, &a)| match i {
            0 => Some(own_rough),
            _ if turning => None,
            _ => Some(roughness(a)),
        })
        .collect();
    let chosen = least_unstable(turns, &rough, turning);
    let voxel = anchors[chosen];
    let rough = rough[chosen].unwrap_or_else(|| roughness(voxel));
    Ok(Anchor {
        voxel,
        rough: rough > ROUGH_DRIFT,
        steady: false,
    })
}

/// Which of the anchors (c_T's first) to take, from their drifts when
/// turned and, unless the template is `turning`, against their neighbours,
/// each measured against its limit: another must do clearly better to
/// replace the paper's.
fn least_unstable(turns: Vec<f64>, rough: &[Option<f64>], turning: bool) -> usize {
    let instability: Vec<f64> = if turning {
        turns
    } else {
        turns
            .iter()
            .zip(rough)
            .map(|(&t, r)| (t / STABLE_DRIFT).max(r.unwrap_or(0.0) / ROUGH_DRIFT))
            .collect()
    };
    let best = (0..instability.len())
        .min_by(|&a, &b| instability[a].total_cmp(&instability[b]))
        .expect("c_T at least");
    if instability[best] < instability[0] * ALTERNATIVE_SHARE {
        best
    } else {
        0
    }
}

/// Further anchors of a model template, besides `primary`: up to
/// [`FURTHER_ANCHORS`] surface voxels at least [`FURTHER_APART`] r_k from
/// it and from each other, each stable under both tests of
/// [`stable_anchor`] (turning, and against its neighbours), the most stable
/// first. A copy whose primary anchor is cluttered (other material within
/// the always-counted inner layers, which no rule excuses) is found at
/// another, where its own surroundings are clean.
pub(super) fn further_anchors(
    model: &TriMesh,
    voxels: &PartVoxels,
    primary: [u16; 3],
    radii: &[f64],
    thresholds: Thresholds,
    spacing: u32,
    backend: Threads,
) -> Result<Vec<[u16; 3]>> {
    let transform = SphericalTransform::new();
    let spec = voxels.grid().spec();
    let balls = VolumeDescriptor::balls_at(radii, spec.voxel_size, backend);
    let reader = Reader::new(voxels, &balls, radii, thresholds, &transform, backend);
    let outer = radii[radii.len() - 1] / spec.voxel_size;
    let apart = FURTHER_APART * outer;
    let mut spread = spread_within(voxels.skin(), primary, outer, FURTHER_TRIED);
    spread.retain(|v| offset(v, primary).length() >= apart);
    let turns = turn_drifts(
        model, voxels, &reader, &spread, &TURNS, radii, thresholds, backend,
    )?;
    let reach = (NEIGHBOUR_REACH * spacing as f64).max(1.0);
    let mut ranked: Vec<(f64, [u16; 3])> = spread
        .iter()
        .zip(turns)
        .map(|(&v, turn)| {
            let rough = roughness(voxels, &reader, v, reach, radii, thresholds);
            ((turn / STABLE_DRIFT).max(rough / ROUGH_DRIFT), v)
        })
        .collect();

    ranked.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut chosen: Vec<[u16; 3]> = Vec::new();
    for (_, v) in ranked {
        if chosen.len() < FURTHER_ANCHORS && chosen.iter().all(|c| offset(c, v).length() >= apart) {
            chosen.push(v);
        }
    }
    Ok(chosen)
}

/// Further anchors a model template gets: with the primary, three reads of
/// each candidate's descriptor where one did.
pub(super) const FURTHER_ANCHORS: usize = 2;

/// Further anchors lie at least this share of r_k from the primary and from
/// each other: beyond the inner third of the onion that always counts, so
/// that clutter at one is outside another's inner layers.
const FURTHER_APART: f64 = 0.5;

/// Surface voxels spread over the template that are tested for further
/// anchors.
const FURTHER_TRIED: usize = 12;

/// The largest drift, over `turns`, of the descriptors at each of `anchors`
/// when `model` (voxelized on `voxels`' grid) is turned: nothing can be
/// read that is not its own.
#[allow(clippy::too_many_arguments)]
fn turn_drifts(
    model: &TriMesh,
    voxels: &PartVoxels,
    reader: &Reader,
    anchors: &[[u16; 3]],
    turns: &[glam::DQuat],
    radii: &[f64],
    thresholds: Thresholds,
    backend: Threads,
) -> Result<Vec<f64>> {
    let spec = voxels.grid().spec();
    let mut worst = vec![0.0f64; anchors.len()];
    let own: Vec<Descriptors> = anchors.iter().map(|&v| reader.at(v)).collect();
    for &turn in turns {
        let turned = model.map_positions(|p| turn * p)?;
        let turned_spec = GridSpec::around(turned.bounds(), spec.voxel_size)?;
        let turned_voxels = PartVoxels::build(&turned, &turned_spec, backend);
        let there = Reader::new(
            &turned_voxels,
            reader.balls,
            radii,
            thresholds,
            reader.transform,
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
}

/// The median drift from anchor `a` to the surface voxels within `reach`
/// voxels of it: a copy's candidate is one of them as often as it is the
/// anchor's twin.
fn roughness(
    voxels: &PartVoxels,
    reader: &Reader,
    a: [u16; 3],
    reach: f64,
    radii: &[f64],
    thresholds: Thresholds,
) -> f64 {
    let voxel = voxels.grid().spec().voxel_size;
    let here = reader.at(a);
    let mut drifts: Vec<f64> = voxels
        .skin()
        .iter()
        .filter(|n| **n != a && offset(n, a).length() <= reach)
        .map(|&n| here.drift(&reader.at(n), radii, voxel, thresholds))
        .collect();
    drifts.sort_by(f64::total_cmp);
    drifts.get(drifts.len() / 2).copied().unwrap_or(0.0)
}

/// The anchor chosen, and whether it is still rough: then no candidate
/// may be skipped (see [`ROUGH_DRIFT`]).
#[derive(Clone, Copy, Debug)]
pub(super) struct Anchor {
    pub voxel: [u16; 3],
    pub rough: bool,
    /// c_T passed both tests and is the anchor. Otherwise copies may be
    /// lost at whatever anchor is chosen, and [`further_anchors`] are read
    /// too.
    pub steady: bool,
}

/// c_T is kept unless the median drift to its neighbours exceeds this
/// many thresholds: a copy found from a neighbour would then fail the
/// cascade more often than not. The shared templates' c_T: 0.28-0.72, and
/// 0.29-0.78 for the selections every copy of which is found; 1.07-1.11
/// for two selections that lose copies (a fandisk's edge, a horse's leg).
const ROUGH_DRIFT: f64 = 1.0;

/// Neighbours within this many voxels per voxel of candidate spacing:
/// about half a candidate cube's diagonal.
const NEIGHBOUR_REACH: f64 = 0.9;

/// `v` relative to `center`, in voxels.
fn offset(v: &[u16; 3], center: [u16; 3]) -> Vec3 {
    Vec3::new(
        v[0] as f64 - center[0] as f64,
        v[1] as f64 - center[1] as f64,
        v[2] as f64 - center[2] as f64,
    )
}

/// Two turns about unrelated axes (unit quaternions: 1.1 rad about
/// (1, 2, 3) and 2.3 rad about (-2, 1, 1)), fixed so that a template always
/// gets the same anchor.
const TURNS: [glam::DQuat; 2] = [
    glam::DQuat::from_xyzw(0.139_694, 0.279_388, 0.419_082, 0.852_525),
    glam::DQuat::from_xyzw(-0.745_269, 0.372_634, 0.372_634, 0.408_487),
];

/// Up to `count` skin voxels within `reach` voxels of `center`, spread by
/// farthest-point sampling from it.
fn spread_within(skin: &[[u16; 3]], center: [u16; 3], reach: f64, count: usize) -> Vec<[u16; 3]> {
    let offset = |v: &[u16; 3]| offset(v, center);
    let near: Vec<[u16; 3]> = skin
        .iter()
        .filter(|v| offset(v).length() <= reach)
        .copied()
        .collect();
    let mut gap: Vec<f64> = near.iter().map(|v| offset(v).length()).collect();
    let mut picked = Vec::new();
    for _ in 0..count {
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
    backend: Threads,
}

impl<'a> Reader<'a> {
    fn new(
        voxels: &'a PartVoxels,
        balls: &'a [Ball],
        radii: &[f64],
        thresholds: Thresholds,
        transform: &'a SphericalTransform,
        backend: Threads,
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
