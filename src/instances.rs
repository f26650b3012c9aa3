//! From survivors to instances.
//!
//! The points that pass the cascade gather in blobs: around each occurrence's
//! centre, and around places the rotation-invariant descriptors cannot tell
//! from it (a mirror-symmetric twin, a similar part). So:
//!
//! 1. [`local_bests`]: the best point (smallest distance) of each blob, by a
//!    greedy suppression at a small radius;
//! 2. each local best is verified ([`crate::verify`]): the template placed
//!    there with a proper rotation must lie on the scene's surface;
//! 3. [`group`]: among the verified points, the best placement founds an
//!    instance, reported where the placement puts the template's point c_T,
//!    and claims every other placement within the template's outer radius
//!    r_k that it does not lie apart from ([`Extent`]): two placements of
//!    one copy overlap, while copies standing side by side, whose balls
//!    overlap when the template is long or flat, lie apart.

use glam::DMat3;

use crate::align::Rigid;
use crate::cascade::Survivor;
use crate::math::Vec3;

/// One occurrence of the template.
#[derive(Clone, Debug, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize))]
pub struct Instance {
    /// World position of the instance's point (where c_T lies).
    pub position: [f64; 3],
    /// Its final descriptor distance.
    pub distance: f64,
    /// Verification score: the share of the template's surface that lies
    /// on the scene's at the instance's pose (0..1), or of a template's
    /// shell that is missing there; None where the descriptor has no
    /// verification (curvature).
    pub score: Option<f64>,
    /// How many surviving points the instance gathered.
    pub support: usize,
    /// The template's pose: a 4x4 row-major matrix (last row 0 0 0 1) from
    /// template to scene coordinates, like the transforms of the shared
    /// scenes' truth.json (for a selection, template coordinates are the
    /// scene's). It maps c_T to `position`. None where the descriptor has no
    /// verification (curvature), which is what finds the rotation.
    pub pose: Option<[[f64; 4]; 4]>,
    /// How closely the template's surface lies on the scene's at the
    /// pose: the root mean square distance of its samples within the
    /// surface tolerance, in scene units. Float rounding for an exact copy,
    /// measurably more for a near twin. None without a pose.
    pub residual: Option<f64>,
    /// Whether the copy's own part is entirely explained by the template (a
    /// whole copy), rather than lying inside a larger whole; None without a
    /// pose.
    pub whole: Option<bool>,
    /// The share of the template's surface left off the scene's once the
    /// pose is refit on what fits closely ([`crate::align::stray_share`]):
    /// what tells a near twin sharing most of the template's data exactly.
    #[cfg_attr(feature = "serde", serde(skip))]
    pub(crate) stray: Option<f64>,
}

/// A survivor with its verification.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Verified {
    /// The cascade's survivor.
    pub survivor: Survivor,
    /// Its verification score.
    pub score: f64,
    /// Where its placement puts the template's point c_T (world).
    pub position: Vec3,
    /// The placement as a pose (see [`Instance::pose`]).
    pub pose: Option<[[f64; 4]; 4]>,
}

/// The row-major 4x4 transform that turns by `rotation` (rows) about the
/// template's point `center` and moves it to `position`: x -> R (x - c) + p.
pub fn placement_transform(rotation: &[Vec3; 3], center: Vec3, position: Vec3) -> [[f64; 4]; 4] {
    let row = |i: usize| {
        let r = rotation[i];
        [r.x, r.y, r.z, position[i] - r.dot(center)]
    };
    [row(0), row(1), row(2), [0.0, 0.0, 0.0, 1.0]]
}

/// The best survivor of each blob: survivors are taken by increasing
/// distance (ties by point index) and each suppresses the others within
/// `radius`.
pub fn local_bests(
    survivors: &[Survivor],
    position: impl Fn(u32) -> Vec3,
    radius: f64,
) -> Vec<Survivor> {
    let mut order: Vec<&Survivor> = survivors.iter().collect();
    order.sort_by(|a, b| {
        a.distance
            .total_cmp(&b.distance)
            .then(a.point.cmp(&b.point))
    });
    let r2 = radius * radius;
    let mut kept: Vec<(Vec3, Survivor)> = Vec::new();
    for s in order {
        let p = position(s.point);
        if kept.iter().all(|(q, _)| (*q - p).length_squared() > r2) {
            kept.push((p, *s));
        }
    }
    kept.into_iter().map(|(_, s)| s).collect()
}

/// The template's surface about c_T, to tell two placements of it apart: a
/// plane that separates their samples, with `margin` to spare for the
/// placements' error, leaves them in two places, so they are two copies
/// however close their centres. Without it, the template's ball alone
/// tells, and a tower beside a tower of its kind, closer than r_k, was one
/// copy. The planes tried lie across the line between the centres and
/// across the template's axes as each pose turns them: a CAD part's faces
/// are square to its own axes or its principal ones, and where c_T lies
/// on one face, copies turned half way stand diagonally to each other.
pub struct Extent {
    /// Sample points less c_T, in template coordinates.
    offsets: Vec<Vec3>,
    /// Directions in template coordinates whose planes are tried.
    axes: Vec<Vec3>,
    margin: f64,
}

impl Extent {
    /// `points` on the template's surface, about `center` (c_T), with
    /// `margin` in scene units; `axes` (template coordinates) are tried
    /// besides the template's own x, y and z.
    pub fn new(points: &[Vec3], center: Vec3, axes: &[Vec3], margin: f64) -> Extent {
        let mut tried = vec![Vec3::X, Vec3::Y, Vec3::Z];
        tried.extend(
            axes.iter()
                .map(|a| a.normalize_or_zero())
                .filter(|a| *a != Vec3::ZERO),
        );
        Extent {
            offsets: points.iter().map(|&p| p - center).collect(),
            axes: tried,
            margin,
        }
    }

    /// How far the template turned by `rotation` reaches from c_T along
    /// `u`.
    fn support(&self, rotation: &DMat3, u: Vec3) -> f64 {
        // Along u in the scene is along R^T u in the template.
        let w = rotation.transpose() * u;
        self.offsets
            .iter()
            .map(|o| o.dot(w))
            .fold(f64::NEG_INFINITY, f64::max)
    }

    /// Whether the template at c_T = `a` turned by `pose_a` and at `b`
    /// turned by `pose_b` lie apart; never without both poses.
    pub fn apart(
        &self,
        (a, pose_a): (Vec3, Option<&[[f64; 4]; 4]>),
        (b, pose_b): (Vec3, Option<&[[f64; 4]; 4]>),
    ) -> bool {
        let (Some(pose_a), Some(pose_b)) = (pose_a, pose_b) else {
            return false;
        };
        let d = b - a;
        let length = d.length();
        if length <= self.margin || self.offsets.is_empty() {
            return false;
        }
        let (turn_a, turn_b) = (
            Rigid::from_rows(pose_a).rotation,
            Rigid::from_rows(pose_b).rotation,
        );
        let mut across = std::iter::once(d / length)
            .chain(self.axes.iter().flat_map(|&e| [turn_a * e, turn_b * e]));
        across.any(|w| {
            // Facing from a to b.
            let w = if d.dot(w) < 0.0 { -w } else { w };
            self.support(&turn_a, w) + self.support(&turn_b, -w) + self.margin < d.dot(w)
        })
    }
}

/// A placement: c_T's position and, once known, the pose.
type Placement<'a> = (Vec3, Option<&'a [[f64; 4]; 4]>);

/// Whether placement `b` is placement `a` seen again: within `radius`, and
/// not apart by `extent`.
fn same_copy(a: Placement, b: Placement, radius: f64, extent: Option<&Extent>) -> bool {
    a.0.distance_squared(b.0) <= radius * radius && !extent.is_some_and(|e| e.apart(a, b))
}

/// Instances from verified points, each at the position its placement
/// implies (best score first, ties by distance, then point index), a
/// placement within `radius` of an instance joining it unless `extent`
/// says they lie apart; `survivors` are all the cascade's survivors,
/// counted as the support of the nearest instance whose ball they fall in.
pub fn group(
    verified: &[Verified],
    survivors: &[Survivor],
    position: impl Fn(u32) -> Vec3,
    radius: f64,
    extent: Option<&Extent>,
) -> Vec<Instance> {
    let mut order: Vec<&Verified> = verified.iter().collect();
    order.sort_by(|a, b| {
        b.score
            .total_cmp(&a.score)
            .then(a.survivor.distance.total_cmp(&b.survivor.distance))
            .then(a.survivor.point.cmp(&b.survivor.point))
    });
    let r2 = radius * radius;
    let mut found: Vec<(Vec3, Instance)> = Vec::new();
    for v in order {
        let p = v.position;
        let joins = |(c, i): &(Vec3, Instance)| {
            same_copy((*c, i.pose.as_ref()), (p, v.pose.as_ref()), radius, extent)
        };
        if !found.iter().any(joins) {
            found.push((
                p,
                Instance {
                    position: p.to_array(),
                    distance: v.survivor.distance,
                    score: Some(v.score),
                    support: 0,
                    pose: v.pose,
                    residual: None,
                    whole: None,
                    stray: None,
                },
            ));
        }
    }
    for s in survivors {
        let p = position(s.point);
        let nearest = found
            .iter_mut()
            .map(|(c, inst)| ((*c - p).length_squared(), inst))
            .filter(|(d2, _)| *d2 <= r2)
            .min_by(|a, b| a.0.total_cmp(&b.0));
        if let Some((_, inst)) = nearest {
            inst.support += 1;
        }
    }
    found.into_iter().map(|(_, i)| i).collect()
}

/// The report's order: by score, then by distance.
pub fn best_first(a: &Instance, b: &Instance) -> std::cmp::Ordering {
    b.score
        .unwrap_or(0.0)
        .total_cmp(&a.score.unwrap_or(0.0))
        .then(a.distance.total_cmp(&b.distance))
}

/// Where an instance stands.
fn placement(i: &Instance) -> Placement<'_> {
    (Vec3::from_array(i.position), i.pose.as_ref())
}

/// One instance per copy, as [`group`] keeps one per blob: of instances
/// within `radius` of a better one ([`best_first`]) and not apart from it
/// by `extent`, only the best is kept, with their support (a copy found
/// from two windows of a part). The kept ones stay in their order.
pub fn merge_duplicates(
    instances: Vec<Instance>,
    radius: f64,
    extent: Option<&Extent>,
) -> Vec<Instance> {
    let mut order: Vec<usize> = (0..instances.len()).collect();
    order.sort_by(|&a, &b| best_first(&instances[a], &instances[b]));
    let mut support: Vec<usize> = instances.iter().map(|i| i.support).collect();
    let mut merged = vec![false; instances.len()];
    let mut kept: Vec<usize> = Vec::new();
    for k in order {
        let seen = |&&j: &&usize| {
            same_copy(
                placement(&instances[j]),
                placement(&instances[k]),
                radius,
                extent,
            )
        };
        match kept.iter().find(seen) {
            Some(&j) => {
                support[j] += instances[k].support;
                merged[k] = true;
            }
            None => kept.push(k),
        }
    }
    instances
        .into_iter()
        .zip(support)
        .zip(merged)
        .filter(|(_, merged)| !merged)
        .map(|((instance, support), _)| Instance {
            support,
            ..instance
        })
        .collect()
}

/// A residual this far above float rounding, as a share of r_k, is still
/// an exact copy's: the mesh alignment stops a little short of the last bit.
const EXACT_FIT: f64 = 1e-4;

/// Where the scene holds exact copies, an instance whose residual passes
/// float rounding by this share of r_k, ten times the exact copies' bound,
/// does not fit exactly...
const NEAR_TWIN_FIT: f64 = 1e-3;

/// ...and, if this share of its template samples does not land either, it
/// is a near twin (an ankle for a knee lands 0.88). A copy meshed anew
/// lands whole (1.0) though it fits no better than a twin (remeshed heads
/// at up to 2.2e-3 r_k beside an exact one).
const FULL_COVER: f64 = 0.95;

/// ...or, however much of it lands, if this share of it lies off the
/// scene's once refit on what fits closely (see [`Instance::stray`]): the
/// towers of a city whose setback moved leave 5-10% off, a tower taller
/// than the template, which holds it whole, under 1% (the rim of its top
/// face near the walls).
const STRAY_SHARE: f64 = 0.02;

/// A selection's own instance lies where its template was read, within
/// this share of r_k.
const SAME_PLACE: f64 = 0.01;

/// How many f32 roundings of a coordinate a residual may hold: the scene's
/// and the template's positions are rounded, and so are their triangles'
/// closest points.
const ROUNDING_ULPS: f64 = 16.0;

/// How far `residual` passes float rounding at `position`, as a share of
/// `radius`: rounding grows with the coordinates' magnitude, and
/// `template_center`'s counts too.
fn excess_fit(residual: f64, position: Vec3, template_center: Vec3, radius: f64) -> f64 {
    let magnitude = position.length().max(template_center.length()) + radius;
    (residual - ROUNDING_ULPS * f64::from(f32::EPSILON) * magnitude) / radius
}

/// Whether only [`Instance::stray`] could tell that an instance with this
/// fit is a near twin: it lands whole, but not within rounding. The refit
/// it takes is spared the others.
pub(crate) fn stray_decides(
    score: f64,
    residual: f64,
    position: Vec3,
    template_center: Vec3,
    radius: f64,
) -> bool {
    score >= FULL_COVER && excess_fit(residual, position, template_center, radius) > NEAR_TWIN_FIT
}

/// Drops the near twins where the scene shows what an exact copy fits at.
///
/// An exact CAD or BIM copy lies on the template within float rounding; a
/// similar part (an ankle for a knee) lies measurably off it, and some of
/// the template lands on nothing. A fixed score cannot tell them apart
/// without losing bent copies, so the scene decides: only where some
/// instance fits within rounding (the data has exact copies) are those
/// that neither fit within [`NEAR_TWIN_FIT`] nor land [`FULL_COVER`]
/// refused, and so are those that, refit on what fits closely, leave
/// [`STRAY_SHARE`] off. A scene of bent or remeshed copies only keeps them all. Rounding grows
/// with the coordinates' magnitude: a copy far from the origin rounds more,
/// and `template_center`'s magnitude counts too. A selection's template is
/// `in_scene`: the instance it is read from fits exactly whatever the data,
/// so it is no evidence.
pub fn refuse_near_twins(
    instances: &mut Vec<Instance>,
    template_center: Vec3,
    radius: f64,
    in_scene: bool,
) {
    let excess = |i: &Instance| {
        i.residual
            .map(|r| excess_fit(r, Vec3::from(i.position), template_center, radius))
    };
    let itself = |i: &Instance| {
        in_scene && Vec3::from(i.position).distance(template_center) <= SAME_PLACE * radius
    };
    let exact = instances
        .iter()
        .any(|i| !itself(i) && excess(i).is_some_and(|e| e <= EXACT_FIT));
    if exact {
        let twin = |i: &Instance| {
            let off = i.score.is_some_and(|s| s < FULL_COVER)
                || i.stray.is_some_and(|s| s >= STRAY_SHARE);
            excess(i).is_some_and(|e| e > NEAR_TWIN_FIT) && off
        };
        instances.retain(|i| !twin(i));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn blobs_reduce_to_their_best_and_instances_to_their_best_placement() {
        let pts = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(0.1, 0.0, 0.0),
            Vec3::new(0.6, 0.0, 0.0),
            Vec3::new(5.0, 0.0, 0.0),
            Vec3::new(5.1, 0.1, 0.0),
        ];
        let d = [0.3, 0.2, 0.25, 0.1, 0.4];
        let s: Vec<Survivor> = (0..5)
            .map(|i| Survivor {
                point: i,
                distance: d[i as usize],
                anchors: 1,
            })
            .collect();
        let pos = |i: u32| pts[i as usize];
        let bests = local_bests(&s, pos, 0.2);
        assert_eq!(
            bests.iter().map(|b| b.point).collect::<Vec<_>>(),
            vec![3, 1, 2]
        );
        // Point 2 (a "twin" at 0.6) places the template worse than point 1.
        let scores = [0.0, 0.9, 0.5, 0.95, 0.0];
        let v: Vec<Verified> = bests
            .iter()
            .map(|&b| Verified {
                survivor: b,
                score: scores[b.point as usize],
                position: pos(b.point),
                pose: None,
            })
            .collect();
        let g = group(&v, &s, pos, 1.0, None);
        assert_eq!(g.len(), 2);
        assert_eq!(g[0].position, [5.0, 0.0, 0.0]);
        assert_eq!(g[0].support, 2);
        assert_eq!(g[1].position, [0.1, 0.0, 0.0]);
        assert_eq!(g[1].support, 3);
    }

    #[test]
    fn a_placement_transform_moves_c_t_to_the_position_and_turns_about_it() {
        // A quarter turn about z: x -> y, y -> -x.
        let rotation = [
            Vec3::new(0.0, -1.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 0.0, 1.0),
        ];
        let (center, position) = (Vec3::new(1.0, 2.0, 3.0), Vec3::new(10.0, 20.0, 30.0));
        let t = placement_transform(&rotation, center, position);
        let apply = |p: Vec3| {
            Vec3::new(
                t[0][0] * p.x + t[0][1] * p.y + t[0][2] * p.z + t[0][3],
                t[1][0] * p.x + t[1][1] * p.y + t[1][2] * p.z + t[1][3],
                t[2][0] * p.x + t[2][1] * p.y + t[2][2] * p.z + t[2][3],
            )
        };
        assert!((apply(center) - position).length() < 1e-12);
        // One unit along x from c_T lands one unit along y from the position.
        let moved = apply(center + Vec3::X) - position;
        assert!((moved - Vec3::Y).length() < 1e-12, "{moved}");
        assert_eq!(t[3], [0.0, 0.0, 0.0, 1.0]);
    }

    #[test]
    fn placements_lie_apart_only_when_a_plane_between_them_separates_them() {
        // A 4 x 1 x 1 bar about c_T = its middle; poses turn it about z.
        let points: Vec<Vec3> = (0..=40)
            .flat_map(|i| {
                let x = -2.0 + 0.1 * f64::from(i);
                [-0.5, 0.5].into_iter().map(move |y| Vec3::new(x, y, 0.0))
            })
            .collect();
        let extent = Extent::new(&points, Vec3::ZERO, &[], 0.2);
        let straight = placement_transform(&[Vec3::X, Vec3::Y, Vec3::Z], Vec3::ZERO, Vec3::ZERO);
        let turned = placement_transform(&[Vec3::Y, -Vec3::X, Vec3::Z], Vec3::ZERO, Vec3::ZERO);
        let at = |p: Vec3, pose| (p, Some(pose));
        let o = Vec3::ZERO;
        // Side by side across the bar, 1.5 apart: apart, though 1.5 is well
        // within the bar's radius of 2.
        assert!(extent.apart(at(o, &straight), at(Vec3::new(0.0, 1.5, 0.0), &straight)));
        // Along it, 1.5 apart: they overlap, one copy.
        assert!(!extent.apart(at(o, &straight), at(Vec3::new(1.5, 0.0, 0.0), &straight)));
        // The margin: touching, or a little apart, is one copy.
        assert!(!extent.apart(at(o, &straight), at(Vec3::new(0.0, 1.1, 0.0), &straight)));
        // A quarter turn reaches 2 along y: 2.6 apart is not enough...
        assert!(!extent.apart(at(o, &straight), at(Vec3::new(0.0, 2.6, 0.0), &turned)));
        // ...2.8 is.
        assert!(extent.apart(at(o, &straight), at(Vec3::new(0.0, 2.8, 0.0), &turned)));
        // Side by side and along: the line between the centres crosses
        // the bars, but a plane square to y separates them.
        assert!(extent.apart(at(o, &straight), at(Vec3::new(3.0, 1.5, 0.0), &straight)));
        // Without a pose, never.
        assert!(!extent.apart((o, None), at(Vec3::new(0.0, 1.5, 0.0), &straight)));
    }

    #[test]
    fn duplicates_merge_into_the_best_and_the_kept_keep_their_order() {
        let at = |x: f64, score: f64| Instance {
            position: [x, 0.0, 0.0],
            distance: 0.0,
            score: Some(score),
            support: 1,
            pose: None,
            residual: None,
            whole: None,
            stray: None,
        };
        let merged = merge_duplicates(
            vec![at(0.0, 0.7), at(5.0, 0.8), at(0.3, 0.9), at(0.5, 0.6)],
            0.4,
            None,
        );
        // 0.0 and 0.5 lie within 0.4 of 0.3, the best of the three; 0.5 is
        // not within 0.4 of 0.0, but it joins the best, not a chain.
        let mut best = at(0.3, 0.9);
        best.support = 3;
        assert_eq!(merged, vec![at(5.0, 0.8), best]);
    }

    fn fitted(x: f64, residual: f64) -> Instance {
        Instance {
            position: [x, 0.0, 0.0],
            distance: 0.0,
            score: Some(if residual > 1e-4 { 0.9 } else { 1.0 }),
            support: 1,
            pose: None,
            residual: Some(residual),
            whole: Some(true),
            stray: Some(0.0),
        }
    }

    #[test]
    fn near_twins_go_only_where_the_scene_has_exact_copies() {
        let radius = 0.5;
        let exact = fitted(1.0, 1e-7);
        let twin = fitted(3.0, 2e-3 * radius);
        let far_exact = Instance {
            score: Some(0.9),
            ..fitted(1e4, 2e-4 * radius)
        };
        let mut with_exact = vec![exact.clone(), twin.clone(), far_exact.clone()];
        refuse_near_twins(&mut with_exact, Vec3::ZERO, radius, false);
        // Far from the origin, rounding alone is 2e-3 of a unit.
        assert_eq!(with_exact, vec![exact, far_exact]);

        let bent = fitted(2.0, 1e-2 * radius);
        let mut bent_only = vec![bent.clone(), twin.clone()];
        refuse_near_twins(&mut bent_only, Vec3::ZERO, radius, false);
        assert_eq!(bent_only, vec![bent.clone(), twin.clone()]);

        // A selection's own instance is exact whatever the copies are.
        let selected = fitted(5.0, 0.0);
        let mut selection = vec![selected.clone(), bent.clone()];
        refuse_near_twins(&mut selection, Vec3::new(5.0, 0.0, 0.0), radius, true);
        assert_eq!(selection, vec![selected, bent.clone()]);

        // A copy meshed anew lands whole, though it fits no better.
        let remeshed = Instance {
            score: Some(1.0),
            ..twin.clone()
        };
        let exact = fitted(1.0, 1e-7);
        let mut mixed = vec![exact.clone(), remeshed.clone(), twin];
        refuse_near_twins(&mut mixed, Vec3::ZERO, radius, false);
        assert_eq!(mixed, vec![exact.clone(), remeshed.clone()]);

        // A twin that lands whole but leaves some of itself off once refit
        // on its shared body; the same beside bent copies only is kept.
        let whole_twin = Instance {
            stray: Some(0.05),
            ..remeshed.clone()
        };
        let mut landed = vec![exact.clone(), remeshed.clone(), whole_twin.clone()];
        refuse_near_twins(&mut landed, Vec3::ZERO, radius, false);
        assert_eq!(landed, vec![exact, remeshed]);
        let mut no_exact = vec![bent.clone(), whole_twin.clone()];
        refuse_near_twins(&mut no_exact, Vec3::ZERO, radius, false);
        assert_eq!(no_exact, vec![bent, whole_twin]);
    }
}
