//! Pose refinement on the meshes: the last step from a verified placement to
//! the pose reported.
//!
//! Verification places the template on voxels, and a voxel grid cannot tell
//! a pose better than about a voxel at the template's rim: a degree or two,
//! several per cent of the radius on a thin part. It cannot tell either
//! side of a plate four voxels thick. The meshes can: the template's
//! surface samples are pulled onto the scene's triangles by iterative
//! closest points (point-to-plane, with a light point-to-point term that
//! keeps a turn about a symmetry axis from drifting), trimmed so that what
//! lies farther than a voxel or two (clutter, missing material) does not
//! pull. Unless the first fit is already exact, the template turned by
//! every quarter turn about each of its principal axes is aligned too, and
//! replaces the first when its samples lie clearly nearer the scene: a
//! template found upside down or on its side is turned back, a symmetric
//! one keeps the first fit.
//!
//! Then the meshes judge the occurrence ([`surface_fit`]): the share
//! of the template's surface within a few per cent of its radius of the
//! scene's, at the exact pose.

use glam::{DMat3, DQuat};

use crate::math::{Aabb, Vec3, symmetric_eigen};
use crate::mesh::{TriMesh, closest_point_on_triangle};

/// Correspondences farther than this (voxels) are trimmed at the start; the
/// gate then closes to [`FINAL_GATE`].
const START_GATE: f64 = 3.0;

/// The gate at the end of the alignment, in voxels.
const FINAL_GATE: f64 = 1.0;

/// Weight of the point-to-point term against the point-to-plane one.
const POINT_WEIGHT: f64 = 0.1;

/// Correspondences whose normals differ by more than this are trimmed
/// (cosine, once the majority has told which way the scene faces: see
/// [`icp`]).
const NORMAL_COSINE: f64 = 0.5;

/// A turned alignment replaces the placement found first when its misfit
/// is below this share of the first's, and lower by [`FLIP_MARGIN`] voxels:
/// a symmetric template's turns tie, and the first stays.
const FLIP_SHARE: f64 = 0.5;

/// See [`FLIP_SHARE`].
const FLIP_MARGIN: f64 = 0.005;

/// A rigid transform x -> R x + t.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Rigid {
    /// The rotation.
    pub rotation: DMat3,
    /// The translation.
    pub translation: Vec3,
}

impl Rigid {
    /// The transform of a row-major 4x4 matrix (last row ignored).
    pub fn from_rows(m: &[[f64; 4]; 4]) -> Rigid {
        Rigid {
            rotation: DMat3::from_cols(
                Vec3::new(m[0][0], m[1][0], m[2][0]),
                Vec3::new(m[0][1], m[1][1], m[2][1]),
                Vec3::new(m[0][2], m[1][2], m[2][2]),
            ),
            translation: Vec3::new(m[0][3], m[1][3], m[2][3]),
        }
    }

    /// The row-major 4x4 matrix.
    pub fn to_rows(self) -> [[f64; 4]; 4] {
        let r = self.rotation;
        let t = self.translation;
        [
            [r.x_axis.x, r.y_axis.x, r.z_axis.x, t.x],
            [r.x_axis.y, r.y_axis.y, r.z_axis.y, t.y],
            [r.x_axis.z, r.y_axis.z, r.z_axis.z, t.z],
            [0.0, 0.0, 0.0, 1.0],
        ]
    }

    /// Where the transform takes `p`.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// First `other`, then this transform.
    pub fn after(&self, other: &Rigid) -> Rigid {
        Rigid {
            rotation: self.rotation * other.rotation,
            translation: self.rotation * other.translation + self.translation,
        }
    }

    /// The transform back: `inverse().apply(apply(p)) == p`.
    pub fn inverse(&self) -> Rigid {
        let rotation = self.rotation.transpose();
        Rigid {
            rotation,
            translation: -(rotation * self.translation),
        }
    }

    /// A turn by `angle` about the line through `pivot` along `axis`.
    fn turn(pivot: Vec3, axis: Vec3, angle: f64) -> Rigid {
        let rotation = DMat3::from_quat(DQuat::from_axis_angle(axis.normalize(), angle));
        Rigid {
            rotation,
            translation: pivot - rotation * pivot,
        }
    }
}

/// Points spread evenly over a template's surface, with their triangles'
/// normals, and the frame of their spread (for the turns).
pub struct SurfaceSamples {
    points: Vec<Vec3>,
    normals: Vec<Vec3>,
    centroid: Vec3,
    /// The farthest sample from the centroid: how far a turn moves the rim.
    reach: f64,
    axes: [Vec3; 3],
    /// The axis the samples are nearly a body of revolution about, if any
    /// (see [`REVOLUTION_SHARE`]), with what breaks the symmetry.
    revolution: Option<Revolution>,
    /// The triangle each point lies on.
    sources: Vec<u32>,
    /// The piece (a shell of the template) each point lies on, where
    /// [`SurfaceSamples::with_pieces`] said; else empty.
    pieces: Vec<u32>,
}

impl SurfaceSamples {
    /// About `count` samples spread over `triangles` by area (stratified,
    /// deterministic), keeping those `keep` accepts.
    pub fn new(
        triangles: &[[Vec3; 3]],
        count: usize,
        keep: impl Fn(Vec3) -> bool,
    ) -> SurfaceSamples {
        let areas: Vec<f64> = triangles
            .iter()
            .map(|[a, b, c]| 0.5 * (*b - *a).cross(*c - *a).length())
            .collect();
        let total: f64 = areas.iter().sum();
        let (mut points, mut normals, mut sources) = (Vec::new(), Vec::new(), Vec::new());
        if total > 0.0 && count > 0 {
            let step = total / count as f64;
            let (mut t, mut before) = (0, 0.0);
            for j in 0..count {
                let at = (j as f64 + 0.5) * step;
                while t + 1 < triangles.len() && before + areas[t] < at {
                    before += areas[t];
                    t += 1;
                }
                // A low-discrepancy point of the triangle (the R2 sequence,
                // folded into the lower half of the unit square).
                let (mut u, mut v) = (
                    (0.5 + j as f64 * 0.754_877_666_246_692_8).fract(),
                    (0.5 + j as f64 * 0.569_840_290_998_053_3).fract(),
                );
                if u + v > 1.0 {
                    (u, v) = (1.0 - u, 1.0 - v);
                }
                let [a, b, c] = triangles[t];
                let p = a + (b - a) * u + (c - a) * v;
                if keep(p) {
                    points.push(p);
                    normals.push((b - a).cross(c - a).normalize_or_zero());
                    sources.push(t as u32);
                }
            }
        }
        let n = points.len().max(1) as f64;
        let centroid = points.iter().fold(Vec3::ZERO, |s, &p| s + p) / n;
        let mut m = [[0.0; 3]; 3];
        for p in &points {
            let d = (*p - centroid).to_array();
            for i in 0..3 {
                for j in 0..3 {
                    m[i][j] += d[i] * d[j];
                }
            }
        }
        let (moments, axes) = symmetric_eigen(m);
        let reach = points
            .iter()
            .map(|p| p.distance(centroid))
            .fold(0.0, f64::max);
        let revolution = revolution_axis(moments)
            .and_then(|k| Revolution::new(&points, &normals, axes[k], centroid, reach));
        SurfaceSamples {
            points,
            normals,
            centroid,
            reach,
            axes,
            revolution,
            sources,
            pieces: Vec::new(),
        }
    }

    /// The samples, each told its piece: `piece_of[t]` for triangle `t`.
    /// [`surface_fit`] then judges each piece of enough samples alone, so
    /// that a copy missing a small shell is not one.
    pub fn with_pieces(mut self, piece_of: &[u32]) -> SurfaceSamples {
        self.pieces = self.sources.iter().map(|&t| piece_of[t as usize]).collect();
        self
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The points.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// The principal axes of their spread.
    pub fn axes(&self) -> [Vec3; 3] {
        self.axes
    }
}

/// A scene's triangles near an occurrence, bucketed in a uniform grid for
/// closest-point queries. It holds triangle numbers, not corners: a part
/// of tens of thousands of triangles is indexed once per instance and
/// thread.
pub struct SurfaceIndex<'a> {
    mesh: &'a TriMesh,
    triangles: Vec<u32>,
    /// Each triangle's bounding sphere (centre of its box), to skip it.
    spheres: Vec<([f32; 3], f32)>,
    origin: Vec3,
    cell: f64,
    dims: [i64; 3],
    /// Cell c's triangles are `members[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    members: Vec<u32>,
}

impl<'a> SurfaceIndex<'a> {
    /// Indexes the parts of `mesh`'s `triangles` inside `bounds`, in cells
    /// of side `cell`.
    pub fn new(
        mesh: &'a TriMesh,
        triangles: Vec<u32>,
        bounds: Aabb,
        cell: f64,
    ) -> SurfaceIndex<'a> {
        // A few triangles are tested one by one: walking cells costs more.
        let cell = if triangles.len() <= FEW_TRIANGLES {
            cell.max(bounds.extent().max_element())
        } else {
            cell
        };
        let dims = (bounds.extent() / cell)
            .ceil()
            .max(Vec3::ONE)
            .to_array()
            .map(|d| d as i64);
        let cells = (dims[0] * dims[1] * dims[2]) as usize;
        let origin = bounds.min;
        let range = |t: &[Vec3; 3]| -> Option<([i64; 3], [i64; 3])> {
            let b = Aabb::around(t.iter().copied())?;
            let lo = ((b.min - origin) / cell).floor().to_array();
            let hi = ((b.max - origin) / cell).floor().to_array();
            let mut out = ([0; 3], [0; 3]);
            for i in 0..3 {
                out.0[i] = (lo[i] as i64).max(0);
                out.1[i] = (hi[i] as i64).min(dims[i] - 1);
                if out.0[i] > out.1[i] {
                    return None;
                }
            }
            Some(out)
        };
        let index = |x: i64, y: i64, z: i64| ((z * dims[1] + y) * dims[0] + x) as usize;
        let mut counts = vec![0u32; cells + 1];
        // Each triangle's cells, worked out twice rather than stored.
        let cells_of = |i: usize| range(&mesh.corners(triangles[i] as usize));
        let each_cell = |r: &([i64; 3], [i64; 3]), f: &mut dyn FnMut(usize)| {
            for z in r.0[2]..=r.1[2] {
                for y in r.0[1]..=r.1[1] {
                    for x in r.0[0]..=r.1[0] {
                        f(index(x, y, z));
                    }
                }
            }
        };
        for i in 0..triangles.len() {
            if let Some(r) = cells_of(i) {
                each_cell(&r, &mut |c| counts[c + 1] += 1);
            }
        }
        for c in 0..cells {
            counts[c + 1] += counts[c];
        }
        let mut fill = counts.clone();
        let mut members = vec![0u32; counts[cells] as usize];
        for i in 0..triangles.len() {
            if let Some(r) = cells_of(i) {
                each_cell(&r, &mut |c| {
                    members[fill[c] as usize] = i as u32;
                    fill[c] += 1;
                });
            }
        }
        let spheres = triangles
            .iter()
            .map(|&t| {
                let corners = mesh.corners(t as usize);
                let b = Aabb::around(corners).expect("three corners");
                let c = b.center();
                let r = corners.iter().map(|&p| p.distance(c)).fold(0.0, f64::max);
                // Rounded outwards: f32 must not cut a triangle off.
                (
                    c.as_vec3().to_array(),
                    (r * (1.0 + 1e-5) + 1e-5 * c.abs().max_element()) as f32,
                )
            })
            .collect();
        SurfaceIndex {
            mesh,
            triangles,
            spheres,
            origin,
            cell,
            dims,
            starts: counts,
            members,
        }
    }

    /// The closest surface point to `p` within `reach`, with its
    /// triangle's normal.
    fn nearest(&self, p: Vec3, reach: f64) -> Option<(Vec3, Vec3, f64)> {
        let (q, t, distance) = self.nearest_triangle(p, reach)?;
        let [a, b, c] = self.mesh.corners(self.triangles[t] as usize);
        Some((q, (b - a).cross(c - a).normalize_or_zero(), distance))
    }

    /// Whether some surface lies within `reach` of `p`: the closest-point
    /// search, stopped at the first triangle in reach.
    pub fn reaches(&self, p: Vec3, reach: f64) -> bool {
        self.nearest_triangle_until(p, reach, reach).is_some()
    }

    /// The closest surface point to `p` within `reach`, the number of its
    /// triangle in this index, and its distance.
    fn nearest_triangle(&self, p: Vec3, reach: f64) -> Option<(Vec3, usize, f64)> {
        self.nearest_triangle_until(p, reach, -1.0)
    }

    /// [`Self::nearest_triangle`], but the first triangle found within
    /// `enough` ends the search.
    fn nearest_triangle_until(
        &self,
        p: Vec3,
        reach: f64,
        enough: f64,
    ) -> Option<(Vec3, usize, f64)> {
        let home = ((p - self.origin) / self.cell)
            .floor()
            .to_array()
            .map(|c| c as i64);
        let rings = (reach / self.cell).ceil() as i64 + 1;
        let mut best: Option<(Vec3, usize)> = None;
        let mut bound = reach;
        // A triangle is listed in every cell its box meets, so a large one
        // (a part of a few triangles) would be tested again in each cell of
        // every ring. The first few tested are remembered and skipped.
        let mut tested = [0u32; TESTED_MEMORY];
        let mut remembered = 0usize;
        // Ring by ring outwards: past ring k, everything is at least k
        // cells away.
        for k in 0..=rings {
            let range = |i: usize| (home[i] - k).max(0)..=(home[i] + k).min(self.dims[i] - 1);
            for z in range(2) {
                for y in range(1) {
                    let inner = (z - home[2]).abs() < k && (y - home[1]).abs() < k;
                    for x in range(0) {
                        if inner && (x - home[0]).abs() < k {
                            continue;
                        }
                        let min = self.origin + Vec3::new(x as f64, y as f64, z as f64) * self.cell;
                        let gap = (min - p).max(p - (min + self.cell)).max(Vec3::ZERO);
                        if gap.length_squared() > bound * bound {
                            continue;
                        }
                        let c = ((z * self.dims[1] + y) * self.dims[0] + x) as usize;
                        for &t in
                            &self.members[self.starts[c] as usize..self.starts[c + 1] as usize]
                        {
                            if tested[..remembered].contains(&t) {
                                continue;
                            }
                            let (centre, radius) = self.spheres[t as usize];
                            let centre =
                                Vec3::new(centre[0] as f64, centre[1] as f64, centre[2] as f64);
                            if p.distance(centre) - radius as f64 > bound {
                                continue;
                            }
                            if remembered < TESTED_MEMORY {
                                tested[remembered] = t;
                                remembered += 1;
                            }
                            let [a, b, cc] = self.mesh.corners(self.triangles[t as usize] as usize);
                            let q = closest_point_on_triangle(p, a, b, cc, t as usize);
                            if q.distance2 <= bound * bound {
                                bound = q.distance2.sqrt();
                                best = Some((q.point, t as usize));
                                if bound <= enough {
                                    return best.map(|(q, t)| (q, t, bound));
                                }
                            }
                        }
                    }
                }
            }
            if best.is_some() && bound <= k as f64 * self.cell {
                break;
            }
        }
        best.map(|(q, t)| (q, t, bound))
    }
}

/// An index of at most this many triangles is one cell.
const FEW_TRIANGLES: usize = 16;

/// How many tested triangles a closest-point query remembers: enough for
/// a small part's, few enough that looking them up costs less than a test.
const TESTED_MEMORY: usize = 16;

/// The outcome of an alignment.
#[derive(Clone, Copy, Debug)]
pub struct Alignment {
    /// The refined pose, template to scene.
    pub pose: Rigid,
    /// The samples' mean distance to the scene's surface, in voxels, each
    /// capped at one.
    pub misfit: f64,
}

/// Aligns `samples` (template coordinates) onto `scene` from `start`, and
/// from `start` turned by every quarter turn about each of the samples'
/// principal axes, quickly on a quarter of the samples; the best is then
/// aligned in full. `voxel` is the grid's voxel size, the scale of every
/// tolerance.
pub fn align(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    start: Rigid,
    voxel: f64,
) -> Alignment {
    let first = icp(samples, scene, start, voxel, QUICK);
    let mut best = first;
    // No turn can beat a fit this close (see FLIP_SHARE).
    let axes = if first.misfit * FLIP_SHARE > FLIP_MARGIN {
        samples.axes.as_slice()
    } else {
        &[]
    };
    for &axis in axes {
        for step in 1..TURN_STEPS {
            let angle = std::f64::consts::TAU * step as f64 / TURN_STEPS as f64;
            let turned = start.after(&Rigid::turn(samples.centroid, axis, angle));
            let turned = best_shift(samples, scene, turned, axis, voxel);
            let a = icp(samples, scene, turned, voxel, TURNED);
            if a.misfit < best.misfit.min(first.misfit * FLIP_SHARE - FLIP_MARGIN) {
                best = a;
            }
        }
    }
    let full = icp(samples, scene, best.pose, voxel, FULL);
    match &samples.revolution {
        Some(revolution) if full.misfit > EXACT_MISFIT => {
            about_revolution_axis(samples, scene, full, revolution, voxel)
        }
        _ => full,
    }
}

/// What makes a body of near revolution turn one way: its axis, a point
/// on it, and the samples off every surface of revolution about it.
#[derive(Clone, Debug)]
struct Revolution {
    axis: Vec3,
    pivot: Vec3,
    /// Samples whose normal line misses the axis by more than
    /// [`FEATURE_SHARE`] of the reach: the side of a boss, a pin's hole
    /// across the axis. A facet of a polygonal drum misses it by less.
    features: Vec<u32>,
}

impl Revolution {
    /// The axis fitted from the principal `axis` by the normal lines, or
    /// None where they meet no axis (more than half the samples break it).
    fn new(
        points: &[Vec3],
        normals: &[Vec3],
        axis: Vec3,
        centroid: Vec3,
        reach: f64,
    ) -> Option<Self> {
        let (mut axis, mut pivot) = (axis.normalize(), centroid);
        for _ in 0..AXIS_FITS {
            pivot = axis_point(points, normals, axis, pivot, centroid)?;
            axis = axis_direction(points, normals, pivot, axis);
        }
        let features: Vec<u32> = points
            .iter()
            .zip(normals)
            .enumerate()
            .filter(|(_, (p, n))| {
                let w = axis.cross(**n);
                w.length() > 0.1 && (**p - pivot).dot(w.normalize()).abs() > FEATURE_SHARE * reach
            })
            .map(|(i, _)| i as u32)
            .collect();
        (2 * features.len() <= points.len()).then_some(Revolution {
            axis,
            pivot,
            features,
        })
    }
}

/// `full`, or the template turned about its axis of near revolution to
/// where what breaks the symmetry lies clearly nearer the scene. ICP
/// brings back only a few degrees about such an axis: a piston's pin
/// bosses, a wheel's valve, are too small a hold on the turn. So every turn
/// that moves the rim by half a voxel is scored on the feature samples
/// alone (the rest lie alike at every turn), and the best is aligned.
fn about_revolution_axis(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    full: Alignment,
    revolution: &Revolution,
    voxel: f64,
) -> Alignment {
    let features = &revolution.features;
    if features.is_empty() {
        return full;
    }
    // A feature's normal runs along the turn, so a turn's error shows in
    // full: turns half a voxel apart at the rim put the nearest within a
    // quarter voxel of its place, and the scan counts within half a voxel.
    let lands_within =
        |pose: &Rigid, p: Vec3, within: f64| scene.reaches(pose.apply(p), within * voxel);
    let lands = |pose: &Rigid, p: Vec3| lands_within(pose, p, 0.25);
    let stride = (features.len() / REVOLUTION_SAMPLES).max(1);
    // How many of every `stride`-th feature land within `within` voxels;
    // None once too few are left to make more than `beat`.
    let on_features_above = |pose: &Rigid, stride: usize, within: f64, beat: Option<usize>| {
        let scored = features.len().div_ceil(stride);
        let mut hits = 0;
        for (k, &i) in features.iter().step_by(stride).enumerate() {
            if beat.is_some_and(|b| hits + (scored - k) <= b) {
                return None;
            }
            hits += usize::from(lands_within(pose, samples.points[i as usize], within));
        }
        (beat.is_none_or(|b| hits > b)).then_some(hits)
    };
    let on_features = |pose: &Rigid, stride: usize, within: f64| {
        on_features_above(pose, stride, within, None).expect("nothing to beat")
    };
    let scored = features.len().div_ceil(stride);
    let gain = |n: usize| (n as f64 * REVOLUTION_GAIN).ceil().max(MIN_REVOLUTION_GAIN) as usize;
    let steps = ((std::f64::consts::TAU * samples.reach / (0.5 * voxel)).ceil() as usize)
        .clamp(MIN_REVOLUTION_STEPS, MAX_REVOLUTION_STEPS);
    let mut best = (on_features(&full.pose, stride, 0.5) + gain(scored), None);
    // Nearest turns first: of turns alike (a piston's two bosses), the
    // least. A turn's count stops once it can no longer beat the best.
    let nearest_first = (1..=steps / 2).flat_map(|k| [k as f64, -(k as f64)]);
    for step in nearest_first.take(steps - 1) {
        let angle = std::f64::consts::TAU * step / steps as f64;
        let turned = full
            .pose
            .after(&Rigid::turn(revolution.pivot, revolution.axis, angle));
        if let Some(n) = on_features_above(&turned, stride, 0.5, Some(best.0)) {
            best = (n, Some(turned));
        }
    }
    let Some(turned) = best.1 else {
        return full;
    };
    let turned = best_shift(samples, scene, turned, revolution.axis, voxel);
    let refined = icp(samples, scene, turned, voxel, FULL);
    // The features land clearly better, and the rest no worse.
    let on_all = |pose: &Rigid| samples.points.iter().filter(|&&p| lands(pose, p)).count();
    let better_features = on_features(&refined.pose, 1, 0.25)
        >= on_features(&full.pose, 1, 0.25) + gain(features.len());
    if better_features && on_all(&refined.pose) >= on_all(&full.pose) {
        refined
    } else {
        full
    }
}

/// Which principal axis, by its moment, the samples are nearly a body of
/// revolution about: the other two moments within [`REVOLUTION_SHARE`] of
/// each other, and this one clear of them by [`REVOLUTION_CLEAR`] (a
/// cube's or a sphere's three alike name no axis). Only a start: the
/// normal lines fit the axis and say whether there is one.
fn revolution_axis(moments: [f64; 3]) -> Option<usize> {
    let within = |a: f64, b: f64, share: f64| a.min(b) >= share * a.max(b);
    (0..3).find(|&k| {
        let (i, j) = ((k + 1) % 3, (k + 2) % 3);
        within(moments[i], moments[j], REVOLUTION_SHARE)
            && !within(
                moments[k],
                0.5 * (moments[i] + moments[j]),
                REVOLUTION_CLEAR,
            )
    })
}

/// Samples within [`AXIS_TRIM`] times the median of `off` of them: the
/// rest (a boss on one side) break the symmetry and would pull the fit.
fn trimmed<T: Copy>(items: &[T], off: impl Fn(T) -> f64) -> Vec<T> {
    let mut offs: Vec<f64> = items.iter().map(|&t| off(t)).collect();
    offs.sort_by(f64::total_cmp);
    let keep = AXIS_TRIM * offs.get(offs.len() / 2).copied().unwrap_or(0.0).max(1e-12);
    items.iter().copied().filter(|&t| off(t) <= keep).collect()
}

/// The point of the axis along `axis` that lies level with `level`. On a
/// surface of revolution every normal line meets the axis, so a point c
/// of it makes (p - c) . (axis x n) vanish at every sample: c by trimmed
/// least squares, from the fit `near` before. None where no sample says
/// (normals along the axis, a disc).
fn axis_point(
    points: &[Vec3],
    normals: &[Vec3],
    axis: Vec3,
    near: Vec3,
    level: Vec3,
) -> Option<Vec3> {
    // Samples whose normal runs nearly along the axis (a flat end) say
    // nothing of where it is.
    let sides: Vec<(Vec3, Vec3)> = points
        .iter()
        .zip(normals)
        .filter_map(|(&p, &n)| {
            let w = axis.cross(n);
            (w.length() > 0.1).then(|| (p, w.normalize()))
        })
        .collect();
    // Normal equations, with a a^T pinning c's component along the axis.
    let mut m = DMat3::from_cols(axis * axis.x, axis * axis.y, axis * axis.z);
    let mut rhs = axis * axis.dot(level);
    for (p, w) in trimmed(&sides, |(p, w)| (p - near).dot(w).abs()) {
        m += DMat3::from_cols(w * w.x, w * w.y, w * w.z);
        rhs += w * w.dot(p);
    }
    (m.determinant().abs() >= 1e-9).then(|| m.inverse() * rhs)
}

/// The axis through `point` nearest `axis` that the normal lines meet:
/// a . ((p - c) x n) vanishes for each, so a is the least eigenvector of
/// the trimmed sum of those products. Flat ends agree with every axis
/// along their normal, so they stay.
fn axis_direction(points: &[Vec3], normals: &[Vec3], point: Vec3, axis: Vec3) -> Vec3 {
    let arms: Vec<Vec3> = points
        .iter()
        .zip(normals)
        .map(|(&p, &n)| (p - point).cross(n))
        .collect();
    let mut m = [[0.0; 3]; 3];
    for u in trimmed(&arms, |u| u.dot(axis).abs()) {
        for (i, row) in m.iter_mut().enumerate() {
            for (j, x) in row.iter_mut().enumerate() {
                *x += u[i] * u[j];
            }
        }
    }
    let (_, vectors) = symmetric_eigen(m);
    let least = vectors[2];
    if least.dot(axis) < 0.0 { -least } else { least }
}

/// Fits of the axis, each trimming what the last left far off.
const AXIS_FITS: usize = 6;

/// Samples farther off the axis's fit than this many times the median are
/// trimmed from the next.
const AXIS_TRIM: f64 = 3.0;

/// Two principal moments within this share of each other make the third
/// axis a start for one of near revolution: a boss on one side (a wheel's
/// valve, a piston's pin bosses) parts them by a tenth or more.
const REVOLUTION_SHARE: f64 = 0.75;

/// ...if the third moment is not within this share of theirs.
const REVOLUTION_CLEAR: f64 = 0.9;

/// Turns scored about an axis of near revolution, the identity included:
/// half a voxel apart at the rim, within these bounds.
const MIN_REVOLUTION_STEPS: usize = 24;
const MAX_REVOLUTION_STEPS: usize = 1440;

/// A turn about an axis of near revolution must lay this share of the
/// feature samples more on the scene, and at least this many.
const REVOLUTION_GAIN: f64 = 0.1;
const MIN_REVOLUTION_GAIN: f64 = 3.0;

/// A sample whose normal line misses the axis of near revolution by this
/// share of the reach breaks the symmetry.
const FEATURE_SHARE: f64 = 0.1;

/// Feature samples each turn about an axis of near revolution is scored
/// on, at most.
const REVOLUTION_SAMPLES: usize = 512;

/// A full fit this close (mean distance, voxels) is exact: no turn can
/// better it.
const EXACT_MISFIT: f64 = 0.01;

/// Turns tried about each principal axis, the identity included. Finer
/// steps would catch a body of revolution placed turned about its axis by
/// another angle (ICP brings back only a few degrees), at a cost: 24 steps
/// made twisted-homer's search three times as long.
const TURN_STEPS: usize = 4;

/// How the template's surface lies on the scene's at a pose.
#[derive(Clone, Debug, PartialEq)]
pub struct SurfaceFit {
    /// The share of the samples that lie within the tolerance of the
    /// scene's surface, of those not hidden (see [`surface_fit`]).
    pub agreement: f64,
    /// The root mean square distance of the samples that lie within the
    /// tolerance to the scene's surface (scene units): float rounding for
    /// an exact copy, measurably more for a near twin or a bent copy.
    pub residual: f64,
    /// The scene triangle (mesh numbering) each of those samples lies on.
    pub landed: Vec<u32>,
    /// The least agreement of a piece of at least [`PIECE_SAMPLES`]
    /// samples (see [`SurfaceSamples::with_pieces`]); the agreement where
    /// the samples have no pieces.
    pub weakest_piece: f64,
}

impl SurfaceFit {
    /// The copy's score: its agreement, or a shell's where one is missing.
    /// A shell missing costs little of the whole surface (a pin, a wheel's
    /// hub), but the copy is not one.
    pub fn score(&self) -> f64 {
        if self.weakest_piece < PIECE_PRESENT {
            self.weakest_piece
        } else {
            self.agreement
        }
    }
}

/// A piece of fewer samples is judged only with the rest: its share would
/// turn on a sample or two.
pub const PIECE_SAMPLES: usize = 16;

/// A piece of which less than this share lies on the scene's surface is
/// missing there. A near twin's or a bent copy's shell still lies mostly
/// on the scene (a ball 12% larger than the template's: 64% of it); a
/// missing one nowhere.
pub const PIECE_PRESENT: f64 = 0.5;

/// The share of `samples`, placed by `pose`, that lie within `tolerance` of
/// the scene's surface, of those not `hidden` (inside other material: a
/// neighbour fused to the copy, the ground), up to `max_hidden` of them.
/// This is the final word on an occurrence: the voxels' test allows a voxel
/// or two, several per cent of a small template's radius, where a similar
/// but different shape (the other end of a rocker arm, the other ear of a
/// bunny) still lands. With it, the residual and where the samples
/// landed.
pub fn surface_fit(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    pose: Rigid,
    tolerance: f64,
    hidden: impl Fn(Vec3) -> bool,
    max_hidden: f64,
) -> SurfaceFit {
    let (mut landed, mut squares) = (Vec::new(), 0.0);
    // Per piece: samples, those on the scene's surface, those hidden.
    let count = samples.pieces.iter().max().map_or(1, |&p| p as usize + 1);
    let mut tally = vec![[0usize; 3]; count];
    for (i, &p) in samples.points.iter().enumerate() {
        let q = pose.apply(p);
        let piece = samples.pieces.get(i).map_or(0, |&g| g as usize);
        tally[piece][0] += 1;
        if let Some((_, t, distance)) = scene.nearest_triangle(q, tolerance) {
            landed.push(scene.triangles[t]);
            squares += distance * distance;
            tally[piece][1] += 1;
        } else if hidden(q) {
            tally[piece][2] += 1;
        }
    }
    let share = |[total, on, buried]: [usize; 3]| {
        let excused = (buried as f64).min(max_hidden * total as f64);
        let seen = total as f64 - excused;
        if seen <= 0.0 { 0.0 } else { on as f64 / seen }
    };
    let whole = tally
        .iter()
        .fold([0usize; 3], |s, t| [s[0] + t[0], s[1] + t[1], s[2] + t[2]]);
    let agreement = share(whole);
    let weakest_piece = tally
        .iter()
        .filter(|t| t[0] >= PIECE_SAMPLES)
        .map(|&t| share(t))
        .fold(agreement, f64::min);
    SurfaceFit {
        agreement,
        residual: (squares / landed.len().max(1) as f64).sqrt(),
        landed,
        weakest_piece,
    }
}

/// Samples within this many voxels of the scene's surface pull the pose in
/// [`stray_share`]'s refit: a near twin's shared body lies within rounding
/// of the scene, its differing part a tenth of a voxel off or more.
const SNAP_GATE: f64 = 0.1;

/// Refit iterations at most: the pose moves by a fraction of a voxel.
const SNAP_ITERATIONS: usize = 10;

/// The refit pins six degrees of freedom on every fourth sample; the share
/// is still counted on all of them.
const SNAP_STRIDE: usize = 4;

/// The share of `samples` that still lie off the scene's surface, by more
/// than `off` or on nothing (`hidden` ones aside), once the pose is refit
/// on the samples within [`SNAP_GATE`] voxels alone. A near twin of a part
/// built from the same data (a tower whose setback moved) shares most of
/// its surface with the template exactly, so the mesh alignment settles
/// between that body and the part that differs; refit on the body, the
/// difference shows in full. An exact copy, and a copy meshed anew (off
/// by its chords, far less than `off`), leave next to nothing off.
pub fn stray_share(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    start: Rigid,
    voxel: f64,
    off: f64,
    hidden: impl Fn(Vec3) -> bool,
) -> f64 {
    let mut pose = start;
    for _ in 0..SNAP_ITERATIONS {
        let pairs: Vec<(Vec3, Vec3, Vec3)> = samples
            .points
            .iter()
            .step_by(SNAP_STRIDE)
            .filter_map(|&p| {
                let p = pose.apply(p);
                let (q, m, _) = scene.nearest(p, SNAP_GATE * voxel)?;
                Some((p, q, m))
            })
            .collect();
        let Some((pivot, turn, shift)) = pair_step(&pairs, voxel) else {
            break;
        };
        pose = moved(pose, pivot, turn, shift);
        // The rim moves by a thousandth of a voxel.
        if turn.length() * samples.reach < 1e-3 * voxel && shift.length() < 1e-3 * voxel {
            break;
        }
    }
    let (mut counted, mut stray) = (0usize, 0usize);
    for &p in &samples.points {
        let q = pose.apply(p);
        if scene.reaches(q, off) {
            counted += 1;
        } else if !hidden(q) {
            counted += 1;
            stray += 1;
        }
    }
    stray as f64 / counted.max(1) as f64
}

/// Turns about parallel axes through two points differ by a shift across
/// the axis: the template's symmetry axis, if it has one, need not pass
/// through the samples' centroid. So the turned placement is tried
/// shifted by whole voxels across `axis` (template coordinates), up to
/// [`SHIFT_SEARCH`] each way, on a few samples, and the best kept.
fn best_shift(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    turned: Rigid,
    axis: Vec3,
    voxel: f64,
) -> Rigid {
    let e1 = axis.any_orthonormal_vector();
    let e2 = axis.normalize().cross(e1);
    let (e1, e2) = (turned.rotation * e1 * voxel, turned.rotation * e2 * voxel);
    let stride = (samples.points.len() / SHIFT_SAMPLES).max(1);
    let misfit = |pose: &Rigid| -> f64 {
        samples
            .points
            .iter()
            .step_by(stride)
            .map(|&p| {
                scene
                    .nearest(pose.apply(p), voxel)
                    .map_or(1.0, |n| n.2 / voxel)
            })
            .sum()
    };
    let mut best = (misfit(&turned), turned);
    // Every other voxel first, then the voxels around the best.
    let shifted = |centre: Rigid, u: i32, v: i32| Rigid {
        translation: centre.translation + e1 * u as f64 + e2 * v as f64,
        ..centre
    };
    for (reach, step) in [(SHIFT_SEARCH, 2), (1, 1)] {
        let centre = best.1;
        for u in (-reach..=reach).step_by(step) {
            for v in (-reach..=reach).step_by(step) {
                let pose = shifted(centre, u, v);
                let m = misfit(&pose);
                if m < best.0 {
                    best = (m, pose);
                }
            }
        }
    }
    best.1
}

/// Voxels each way the turned placement is shifted (see [`best_shift`]).
const SHIFT_SEARCH: i32 = 4;

/// Samples the shifts are scored on.
const SHIFT_SAMPLES: usize = 32;

/// How far one alignment goes.
#[derive(Clone, Copy)]
struct Run {
    /// Every this many samples.
    stride: usize,
    /// Iterations at most.
    iterations: usize,
    /// Iterations over which the gate closes.
    closing: usize,
}

/// Comparing placements: a quarter of the samples, a few iterations.
const QUICK: Run = Run {
    stride: 4,
    iterations: 8,
    closing: 4,
};

/// Trying a turned placement: an eighth of the samples.
const TURNED: Run = Run {
    stride: 8,
    iterations: 8,
    closing: 4,
};

/// The placement reported. Most placements settle within 20 iterations;
/// a nearly axisymmetric part (a truck's wheel pair, its tread the only
/// hold on the turn about the axle) creeps on, a little each step.
const FULL: Run = Run {
    stride: 1,
    iterations: 80,
    closing: 10,
};

/// A step at most this many times larger again is added to a run of steps
/// that creep the same way (see [`Course::stretch`]).
const MAX_STRETCH: f64 = 10.0;

/// Two steps go the same way when the cosine between them (turns measured
/// at the rim, as shifts) is above this.
const SAME_WAY: f64 = 0.98;

/// The pose has settled when, over this many iterations...
const SETTLE_ITERATIONS: usize = 4;

/// ...no sample moved more than this (voxels): a near twin's pairs come
/// and go at the gate, and its pose wanders by a hundredth of a voxel or
/// so without end.
const SETTLE_MOVE: f64 = 0.05;

/// The course of an ICP run: where its steps go, and where it has been.
struct Course {
    /// How far the rim lies from the samples' centroid.
    reach: f64,
    /// The last step, turn at the rim and shift, in voxels; none right
    /// after a stretched one.
    last: Option<[f64; 6]>,
    /// The poses of the last [`SETTLE_ITERATIONS`] iterations, oldest first.
    recent: std::collections::VecDeque<Rigid>,
}

impl Course {
    fn new(reach: f64) -> Course {
        Course {
            reach,
            last: None,
            recent: std::collections::VecDeque::with_capacity(SETTLE_ITERATIONS + 1),
        }
    }

    /// How much more of the step (`turn`, `shift`) to take: where this
    /// step goes the same way as the last and is shorter by a ratio q,
    /// the steps to come would add up to q / (1 - q) of it (Besl and
    /// McKay's acceleration). A creeping turn then takes a few iterations,
    /// not dozens.
    fn stretch(&mut self, turn: Vec3, shift: Vec3, voxel: f64) -> f64 {
        let rim = turn * (self.reach / voxel);
        let step = [
            rim.x,
            rim.y,
            rim.z,
            shift.x / voxel,
            shift.y / voxel,
            shift.z / voxel,
        ];
        let length = |v: &[f64; 6]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
        let stretch = self.last.map_or(0.0, |last| {
            let (now, before) = (length(&step), length(&last));
            let cosine = step.iter().zip(&last).map(|(a, b)| a * b).sum::<f64>()
                / (now * before).max(f64::MIN_POSITIVE);
            match cosine > SAME_WAY && now < before {
                true => (now / (before - now)).min(MAX_STRETCH),
                false => 0.0,
            }
        });
        self.last = (stretch == 0.0).then_some(step);
        stretch
    }

    /// Whether `pose`, with the poses before it, has settled: the last
    /// few iterations together moved no sample more than [`SETTLE_MOVE`].
    fn settled(&mut self, pose: Rigid, centroid: Vec3, voxel: f64) -> bool {
        self.recent.push_back(pose);
        if self.recent.len() <= SETTLE_ITERATIONS {
            return false;
        }
        let then = self.recent.pop_front().expect("more than one pose");
        let moved = pose.after(&then.inverse());
        let at = then.apply(centroid);
        moved.apply(at).distance(at) + turn_angle(moved.rotation) * self.reach < SETTLE_MOVE * voxel
    }
}

/// The angle `rotation` turns by, from its trace.
fn turn_angle(rotation: DMat3) -> f64 {
    let r = rotation;
    ((r.x_axis.x + r.y_axis.y + r.z_axis.z - 1.0) / 2.0)
        .clamp(-1.0, 1.0)
        .acos()
}

/// Iterative closest points from `start`. A sample is paired only with
/// surface facing its way, never with the far side of a thin plate; which
/// way is "its way" (the scene's triangles may be wound the other way, an
/// inverted export) is the majority's in the first iteration.
fn icp(
    samples: &SurfaceSamples,
    scene: &SurfaceIndex,
    start: Rigid,
    voxel: f64,
    run: Run,
) -> Alignment {
    let mut pose = start;
    let mut facing = 0.0;
    let mut course = Course::new(samples.reach);
    for iteration in 0..run.iterations {
        let share = iteration as f64 / run.closing.max(1) as f64;
        let gate = voxel * (START_GATE + (FINAL_GATE - START_GATE) * share.min(1.0));
        let near: Vec<(Vec3, Vec3, Vec3, f64)> = samples
            .points
            .iter()
            .zip(&samples.normals)
            .step_by(run.stride)
            .filter_map(|(&p, &n)| {
                let p = pose.apply(p);
                let (q, m, _) = scene.nearest(p, gate)?;
                Some((p, q, m, (pose.rotation * n).dot(m)))
            })
            .collect();
        if facing == 0.0 {
            let sum: f64 = near.iter().map(|n| n.3.signum()).sum();
            facing = if sum < 0.0 { -1.0 } else { 1.0 };
        }
        let pairs: Vec<(Vec3, Vec3, Vec3)> = near
            .iter()
            .filter(|n| facing * n.3 >= NORMAL_COSINE)
            .map(|n| (n.0, n.1, n.2))
            .collect();
        let Some((pivot, turn, shift)) = pair_step(&pairs, voxel) else {
            break;
        };
        let scale = 1.0 + course.stretch(turn, shift, voxel);
        pose = moved(pose, pivot, turn * scale, shift * scale);
        // Converged: the rim moves by a hundredth of a voxel.
        if turn.length() < 1e-4 && shift.length() < 1e-2 * voxel {
            break;
        }
        if course.settled(pose, samples.centroid, voxel) {
            break;
        }
    }
    let (mut misfit, mut total) = (0.0, 0usize);
    for p in samples.points.iter().step_by(run.stride) {
        total += 1;
        misfit += scene.nearest(pose.apply(*p), voxel).map_or(voxel, |n| n.2) / voxel;
    }
    Alignment {
        pose,
        misfit: misfit / total.max(1) as f64,
    }
}

/// One point-to-plane step on `pairs` (point, match, normal), about their
/// centroid: the pivot, the turn (scaled axis) and the shift; `None` with
/// fewer than six pairs or when they do not fix a pose.
fn pair_step(pairs: &[(Vec3, Vec3, Vec3)], voxel: f64) -> Option<(Vec3, Vec3, Vec3)> {
    if pairs.len() < 6 {
        return None;
    }
    let pivot = pairs.iter().fold(Vec3::ZERO, |s, (p, _, _)| s + *p) / pairs.len() as f64;
    let (turn, shift) = solve_step(pairs, pivot, voxel)?;
    Some((pivot, turn, shift))
}

/// `pose` turned by `turn` (scaled axis) about `pivot`, then shifted.
fn moved(pose: Rigid, pivot: Vec3, turn: Vec3, shift: Vec3) -> Rigid {
    let rotation = DMat3::from_quat(DQuat::from_scaled_axis(turn));
    Rigid {
        rotation: rotation * pose.rotation,
        translation: rotation * (pose.translation - pivot) + pivot + shift,
    }
}

/// The small turn (scaled axis) about `pivot` and shift that best lay the
/// placed points on their closest points' planes (Gauss-Newton, with a
/// weighted point-to-point term), or `None` when the system is singular.
fn solve_step(pairs: &[(Vec3, Vec3, Vec3)], pivot: Vec3, voxel: f64) -> Option<(Vec3, Vec3)> {
    let mut a = [[0.0f64; 6]; 6];
    let mut b = [0.0f64; 6];
    // Lengths in voxels keep the rotation and translation columns alike.
    let scale = 1.0 / voxel;
    let mut add = |j: [f64; 6], r: f64, w: f64| {
        for i in 0..6 {
            for k in 0..6 {
                a[i][k] += w * j[i] * j[k];
            }
            b[i] -= w * j[i] * r;
        }
    };
    for &(p, q, n) in pairs {
        let d = (p - pivot) * scale;
        let r = (p - q) * scale;
        let c = d.cross(n);
        add([c.x, c.y, c.z, n.x, n.y, n.z], r.dot(n), 1.0);
        for (k, e) in [Vec3::X, Vec3::Y, Vec3::Z].into_iter().enumerate() {
            let c = d.cross(e);
            add([c.x, c.y, c.z, e.x, e.y, e.z], r[k], POINT_WEIGHT);
        }
    }
    let x = solve6(a, b)?;
    Some((
        Vec3::new(x[0], x[1], x[2]),
        Vec3::new(x[3], x[4], x[5]) * voxel,
    ))
}

/// Solves a 6x6 system by Gaussian elimination with partial pivoting.
fn solve6(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-12 {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        for row in col + 1..6 {
            let f = a[row][col] / a[col][col];
            for k in col..6 {
                a[row][k] -= f * a[col][k];
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let s: f64 = (row + 1..6).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    Some(x)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::shapes::cuboid;

    fn corners(mesh: &TriMesh) -> Vec<[Vec3; 3]> {
        (0..mesh.triangles().len())
            .map(|t| mesh.corners(t))
            .collect()
    }

    fn index(mesh: &TriMesh, voxel: f64) -> SurfaceIndex<'_> {
        let b = mesh.bounds();
        let pad = Vec3::splat(4.0 * voxel);
        SurfaceIndex::new(
            mesh,
            (0..mesh.triangles().len() as u32).collect(),
            Aabb {
                min: b.min - pad,
                max: b.max + pad,
            },
            2.0 * voxel,
        )
    }

    fn angle(a: DMat3, b: DMat3) -> f64 {
        turn_angle(a * b.transpose())
    }

    /// The closest point found through the cells is the closest of all
    /// triangles, whether the index is one cell (a box of 12 triangles,
    /// each tested once) or many (a sphere of 960), at every distance.
    #[test]
    fn the_nearest_triangle_is_the_closest_of_all() {
        for mesh in [
            cuboid(Vec3::ZERO, Vec3::new(4.0, 1.0, 2.0)),
            crate::mesh::shapes::uv_sphere(Vec3::new(2.0, 0.5, 1.0), 1.5, 16, 32),
        ] {
            let index = index(&mesh, 0.1);
            let mut seed = 7u64;
            let mut random = || {
                seed = seed
                    .wrapping_mul(6364136223846793005)
                    .wrapping_add(1442695040888963407);
                (seed >> 11) as f64 / (1u64 << 53) as f64
            };
            for _ in 0..500 {
                let p = Vec3::new(
                    random() * 5.0 - 0.5,
                    random() * 2.0 - 0.5,
                    random() * 3.0 - 0.5,
                );
                let exact = mesh.closest_point(p).distance2.sqrt();
                let found = index.nearest_triangle(p, 0.4).map(|n| n.2);
                if exact <= 0.4 {
                    let found = found.expect("a triangle within reach");
                    assert!(
                        (found - exact).abs() < 1e-12,
                        "{found} against {exact} at {p}"
                    );
                } else {
                    assert!(found.is_none(), "nothing within reach of {p}");
                }
            }
        }
    }

    /// An asymmetric block (an L of two boxes) placed by a known pose is
    /// recovered from a start a voxel and a few degrees off.
    #[test]
    fn a_pose_off_by_a_voxel_and_degrees_is_recovered() {
        let mut template = cuboid(Vec3::ZERO, Vec3::new(4.0, 1.0, 1.0));
        template.append(&cuboid(Vec3::ZERO, Vec3::new(1.0, 2.5, 1.0)));
        let tris = corners(&template);
        let truth = Rigid {
            rotation: DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.4, -0.9, 1.3)),
            translation: Vec3::new(10.0, -3.0, 2.0),
        };
        let scene = template.map_positions(|p| truth.apply(p)).unwrap();
        let voxel = 0.1;
        let samples = SurfaceSamples::new(&tris, 2000, |_| true);
        let start = Rigid {
            rotation: DMat3::from_quat(DQuat::from_scaled_axis(Vec3::new(0.03, -0.02, 0.04)))
                * truth.rotation,
            translation: truth.translation + Vec3::new(0.08, -0.05, 0.06),
        };
        let a = align(&samples, &index(&scene, voxel), start, voxel);
        assert!(angle(a.pose.rotation, truth.rotation).to_degrees() < 0.1);
        assert!((a.pose.translation - truth.translation).length() < 0.01);
        assert!(a.misfit < 0.01, "{}", a.misfit);
    }

    /// A plate 8 x 0.4 x 2 with a rib along one face's edge.
    fn ribbed_plate() -> TriMesh {
        let mut plate = cuboid(Vec3::ZERO, Vec3::new(8.0, 0.4, 2.0));
        plate.append(&cuboid(Vec3::new(0.0, 0.4, 0.0), Vec3::new(8.0, 0.7, 0.3)));
        plate
    }

    /// A plate whose one face carries a rib, found the other side up, is
    /// turned over: the half-turn lays more of it on the scene.
    #[test]
    fn a_plate_found_upside_down_is_turned_over() {
        let template = ribbed_plate();
        let tris = corners(&template);
        let truth = Rigid {
            rotation: DMat3::from_rotation_z(0.3),
            translation: Vec3::new(1.0, 2.0, 3.0),
        };
        let scene = template.map_positions(|p| truth.apply(p)).unwrap();
        let voxel = 0.1;
        let samples = SurfaceSamples::new(&tris, 3000, |_| true);
        // Upside down about the plate's long axis through its middle.
        let flip = Rigid::turn(Vec3::new(4.0, 0.2, 1.0), Vec3::X, std::f64::consts::PI);
        let start = truth.after(&flip);
        let a = align(&samples, &index(&scene, voxel), start, voxel);
        assert!(angle(a.pose.rotation, truth.rotation).to_degrees() < 0.5);
        assert!((a.pose.translation - truth.translation).length() < 0.05);
    }

    /// A ring (a torus about z) with a small boss on its rim, as a piston
    /// has pin bosses: a body of revolution but for the boss.
    fn bossed_ring() -> TriMesh {
        let mut ring = crate::mesh::shapes::torus(Vec3::ZERO, 3.0, 0.8, 64, 16);
        ring.append(&cuboid(
            Vec3::new(3.6, -0.3, -0.3),
            Vec3::new(4.2, 0.3, 0.3),
        ));
        ring
    }

    /// A boss large and high enough to tilt the principal axes does not
    /// tilt the axis of revolution the normal lines meet.
    #[test]
    fn the_axis_of_revolution_is_fitted_past_a_boss_that_tilts_the_moments() {
        let mut ring = crate::mesh::shapes::torus(Vec3::ZERO, 3.0, 0.8, 64, 16);
        ring.append(&cuboid(Vec3::new(3.6, -0.4, 0.6), Vec3::new(4.4, 0.4, 1.4)));
        let samples = SurfaceSamples::new(&corners(&ring), 4000, |_| true);
        let tilt = |v: Vec3| {
            v.normalize()
                .dot(Vec3::Z)
                .abs()
                .min(1.0)
                .acos()
                .to_degrees()
        };
        let principal = samples
            .axes
            .iter()
            .map(|&a| tilt(a))
            .fold(f64::MAX, f64::min);
        let fitted = samples.revolution.as_ref().expect("an axis of revolution");
        assert!(
            principal > 1.0,
            "the boss tilts the moments by {principal} degrees"
        );
        assert!(
            tilt(fitted.axis) < 0.05,
            "fitted {} degrees off",
            tilt(fitted.axis)
        );
        assert!((fitted.pivot - fitted.axis * fitted.pivot.dot(fitted.axis)).length() < 0.01);
        assert!(!fitted.features.is_empty());
    }

    /// A ring found turned about its axis by more than ICP brings back
    /// (the boss is its only hold on the turn) is turned back onto the
    /// boss.
    #[test]
    fn a_ring_found_turned_about_its_axis_is_turned_back() {
        let template = bossed_ring();
        let tris = corners(&template);
        let truth = Rigid {
            rotation: DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.5, 0.2, -0.7)),
            translation: Vec3::new(5.0, -1.0, 2.0),
        };
        let scene = template.map_positions(|p| truth.apply(p)).unwrap();
        let voxel = 0.1;
        let samples = SurfaceSamples::new(&tris, 4000, |_| true);
        for degrees in [9.0f64, -23.0, 140.0] {
            let turned = Rigid::turn(Vec3::ZERO, Vec3::Z, degrees.to_radians());
            let a = align(&samples, &index(&scene, voxel), truth.after(&turned), voxel);
            let off = angle(a.pose.rotation, truth.rotation).to_degrees();
            assert!(off < 0.5, "started {degrees} degrees off, ended {off}");
            assert!(a.misfit < 0.01, "{}", a.misfit);
        }
    }

    /// The same plate found lying on its side (a quarter turn about its
    /// long axis) is stood back up.
    #[test]
    fn a_plate_found_on_its_side_is_turned_back() {
        let template = ribbed_plate();
        let tris = corners(&template);
        let truth = Rigid {
            rotation: DMat3::from_rotation_y(-0.6),
            translation: Vec3::new(-2.0, 1.0, 0.5),
        };
        let scene = template.map_positions(|p| truth.apply(p)).unwrap();
        let voxel = 0.1;
        let samples = SurfaceSamples::new(&tris, 3000, |_| true);
        let side = Rigid::turn(
            Vec3::new(4.0, 0.2, 1.0),
            Vec3::X,
            std::f64::consts::FRAC_PI_2,
        );
        let a = align(&samples, &index(&scene, voxel), truth.after(&side), voxel);
        assert!(angle(a.pose.rotation, truth.rotation).to_degrees() < 0.5);
        assert!((a.pose.translation - truth.translation).length() < 0.05);
    }

    fn agreement(
        samples: &SurfaceSamples,
        index: &SurfaceIndex,
        pose: Rigid,
        tol: f64,
        hidden: impl Fn(Vec3) -> bool,
        max_hidden: f64,
    ) -> f64 {
        surface_fit(samples, index, pose, tol, hidden, max_hidden).agreement
    }

    /// A bar of 4 x 1 x 1 laid on one of 3 x 1 x 1: of its 18 square units
    /// of surface, the far end and the side faces past `tolerance` from the
    /// shorter bar's end (5 - 4 tolerance) are off. What `hidden` excuses
    /// counts neither way, up to `max_hidden` of the samples.
    #[test]
    fn agreement_is_the_share_of_surface_on_the_scene() {
        let template = cuboid(Vec3::ZERO, Vec3::new(4.0, 1.0, 1.0));
        let scene = cuboid(Vec3::ZERO, Vec3::new(3.0, 1.0, 1.0));
        let samples = SurfaceSamples::new(&corners(&template), 4000, |_| true);
        let index = index(&scene, 0.1);
        let pose = Rigid {
            rotation: DMat3::IDENTITY,
            translation: Vec3::ZERO,
        };
        let tol = 0.05;
        let off = 5.0 - 4.0 * tol;
        let none = |_: Vec3| false;
        let a = agreement(&samples, &index, pose, tol, none, 1.0);
        assert!((a - (18.0 - off) / 18.0).abs() < 0.01, "{a}");
        // Past x = 3.5: 3 square units off the scene, all excused, or a
        // tenth of the samples.
        let beyond = |p: Vec3| p.x > 3.5;
        let a = agreement(&samples, &index, pose, tol, beyond, 1.0);
        assert!((a - (18.0 - off) / 15.0).abs() < 0.01, "{a}");
        let a = agreement(&samples, &index, pose, tol, beyond, 0.1);
        assert!((a - (18.0 - off) / 16.2).abs() < 0.01, "{a}");
        let exact = agreement(&samples, &self::index(&template, 0.1), pose, tol, none, 0.0);
        assert_eq!(exact, 1.0);
    }

    /// A template of a large cube and a small one beside it, on a scene
    /// of the large cube alone: nearly all the surface lies on the scene,
    /// but the small cube's piece none of it.
    #[test]
    fn a_missing_piece_is_the_weakest() {
        let mut template = cuboid(Vec3::ZERO, Vec3::splat(3.0));
        template.append(&cuboid(Vec3::new(4.0, 0.0, 0.0), Vec3::new(4.5, 0.5, 0.5)));
        let scene = cuboid(Vec3::ZERO, Vec3::splat(3.0));
        let piece_of: Vec<u32> = (0..template.triangles().len())
            .map(|t| u32::from(t >= 12))
            .collect();
        let samples = SurfaceSamples::new(&corners(&template), 4000, |_| true);
        let pose = Rigid {
            rotation: DMat3::IDENTITY,
            translation: Vec3::ZERO,
        };
        let none = |_: Vec3| false;
        let whole = surface_fit(&samples, &index(&scene, 0.1), pose, 0.05, none, 0.0);
        assert!(
            (whole.agreement - 54.0 / 55.5).abs() < 0.01,
            "{}",
            whole.agreement
        );
        assert_eq!(whole.weakest_piece, whole.agreement);
        let samples = samples.with_pieces(&piece_of);
        let fit = surface_fit(&samples, &index(&scene, 0.1), pose, 0.05, none, 0.0);
        assert_eq!(fit.agreement, whole.agreement);
        assert_eq!(fit.weakest_piece, 0.0);
        let exact = surface_fit(&samples, &index(&template, 0.1), pose, 0.05, none, 0.0);
        assert_eq!(exact.weakest_piece, 1.0);
    }

    #[test]
    fn rows_round_trip() {
        let r = Rigid {
            rotation: DMat3::from_quat(DQuat::from_euler(glam::EulerRot::XYZ, 0.1, 0.2, 0.3)),
            translation: Vec3::new(1.0, 2.0, 3.0),
        };
        let back = Rigid::from_rows(&r.to_rows());
        assert!((back.rotation - r.rotation).abs_diff_eq(DMat3::ZERO, 1e-12));
        assert_eq!(back.translation, r.translation);
        let p = Vec3::new(0.5, -1.0, 2.0);
        let m = r.to_rows();
        let q = Vec3::new(
            m[0][0] * p.x + m[0][1] * p.y + m[0][2] * p.z + m[0][3],
            m[1][0] * p.x + m[1][1] * p.y + m[1][2] * p.z + m[1][3],
            m[2][0] * p.x + m[2][1] * p.y + m[2][2] * p.z + m[2][3],
        );
        assert!((q - r.apply(p)).length() < 1e-12);
    }

    #[test]
    fn steps_creeping_one_way_are_stretched_by_the_steps_to_come() {
        let mut course = Course::new(10.0);
        let voxel = 0.5;
        // Shifts of 0.1 then 0.09 voxel: the rest of the series adds 9
        // times the last.
        let step = |size: f64| Vec3::new(size * voxel, 0.0, 0.0);
        assert_eq!(course.stretch(Vec3::ZERO, step(0.1), voxel), 0.0);
        let stretch = course.stretch(Vec3::ZERO, step(0.09), voxel);
        assert!((stretch - 9.0).abs() < 1e-9, "{stretch}");
        // The stretched step starts a new run.
        assert_eq!(course.stretch(Vec3::ZERO, step(0.05), voxel), 0.0);
        // A step back, or one that grows, is taken as it is.
        assert_eq!(course.stretch(Vec3::ZERO, step(-0.04), voxel), 0.0);
        assert_eq!(course.stretch(Vec3::ZERO, step(-0.08), voxel), 0.0);
        // A slow geometric creep is stretched at most MAX_STRETCH times.
        let mut slow = Course::new(10.0);
        slow.stretch(Vec3::ZERO, step(0.1), voxel);
        assert_eq!(slow.stretch(Vec3::ZERO, step(0.099), voxel), MAX_STRETCH);
        // A turn counts at the rim: 0.01 rad at a reach of 10 is 0.2 voxel.
        let mut turning = Course::new(10.0);
        turning.stretch(Vec3::Z * 0.01, Vec3::ZERO, voxel);
        let stretch = turning.stretch(Vec3::Z * 0.005, Vec3::ZERO, voxel);
        assert!((stretch - 1.0).abs() < 1e-9, "{stretch}");
    }

    #[test]
    fn a_pose_that_wanders_within_a_twentieth_of_a_voxel_has_settled() {
        let voxel = 0.1;
        let centroid = Vec3::new(1.0, 2.0, 3.0);
        let at = |shift: f64, turn: f64| Rigid {
            rotation: DMat3::from_rotation_z(turn),
            translation: Vec3::new(shift, 0.0, 0.0),
        };
        let mut wandering = Course::new(2.0);
        let mut moving = Course::new(2.0);
        let mut turning = Course::new(2.0);
        for i in 0..SETTLE_ITERATIONS {
            let wobble = if i % 2 == 0 { 0.01 } else { -0.01 } * voxel;
            assert!(!wandering.settled(at(wobble, 0.0), centroid, voxel));
            assert!(!moving.settled(at(0.02 * voxel * i as f64, 0.0), centroid, voxel));
            assert!(!turning.settled(at(0.0, 0.001 * i as f64), centroid, voxel));
        }
        assert!(wandering.settled(at(0.0, 0.0), centroid, voxel));
        // 0.08 voxel over four iterations, and a turn of 0.004 rad at a
        // reach of 20 voxels: still going somewhere.
        let n = SETTLE_ITERATIONS as f64;
        assert!(!moving.settled(at(0.02 * voxel * n, 0.0), centroid, voxel));
        assert!(!turning.settled(at(0.0, 0.001 * n), centroid, voxel));
    }
}
