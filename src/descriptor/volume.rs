//! The coarse volumetric descriptor (paper, sec. 4.2, Eq. 3-4): the solid
//! fraction of the ball of radius r_i around a point, compared by the running
//! sum of absolute differences.
//!
//! It is cheap and rotation invariant, so it runs first and rejects most
//! candidates before the spherical harmonics see them. A ball is a list of
//! runs along x, counted with popcounts on the bit grid for small radii and,
//! for larger ones, on a level of the count pyramid whose blocks fit about
//! [`BLOCKS_PER_RADIUS`] times into the radius: there the ball is the set of
//! blocks whose centres lie within the radius of the (exact) voxel centre,
//! which keeps the cost of every layer about the same. Template and scene
//! are read the same way, so the small difference to an exact voxel count
//! (tested with the voxel balls) cancels out of the comparison.

use super::batch::BatchFailure;
use super::{Anchors, MAX_ANCHORS, all_anchors};
use super::{ClutterPolicy, LayerBatch, LocalFuture, OnionDescriptor};
use crate::exec::Threads;
use crate::voxel::{Ball, Solid, level_for_radius};

/// Balls are counted on blocks at least this many times smaller than their
/// radius. Measured on the cow at the pipeline's radii: the fraction differs
/// from an exact voxel count by 0.003 on average (0.016 at worst) at 4.5-5.5
/// blocks, against a threshold of 0.12 on the sum over six layers.
pub const BLOCKS_PER_RADIUS: f64 = 4.5;

/// The volume stage of the cascade: rejects a point once
/// `sum_i |CF_T(r_i) - CF(v, r_i)|` passes the threshold (Eq. 4) for every
/// anchor of the template.
pub struct VolumeDescriptor<'a> {
    solid: &'a Solid,
    points: &'a [[u16; 3]],
    balls: Vec<Ball>,
    radii: Vec<f64>,
    /// The template's fractions, one list per anchor.
    templates: Vec<Vec<f64>>,
    threshold: f64,
    clutter: ClutterPolicy,
    /// Leading layers that always count (see [`super::clutter`]).
    clean_layers: usize,
    /// Where a batch counts the layers (the same integers as the stage's
    /// own, so no guard band is needed): why it failed, if it did.
    batch: BatchFailure,
}

/// The running state of a point in the volume stage, per anchor.
#[derive(Clone, Copy, Debug, Default)]
pub struct VolumeState {
    sums: [f64; MAX_ANCHORS],
    /// Anchors still matched.
    alive: Anchors,
    /// Anchors that met a cluttered layer: their other layers are not
    /// compared.
    excused: Anchors,
}

impl<'a> VolumeDescriptor<'a> {
    /// A stage over the candidate voxels `points` of the scene `solid`, with
    /// the template's fractions at the same radii (world units), one list
    /// per anchor.
    #[cfg(any(test, feature = "internals"))]
    pub fn new(
        solid: &'a Solid,
        points: &'a [[u16; 3]],
        radii: &[f64],
        templates: Vec<Vec<f64>>,
        threshold: f64,
        backend: Threads,
    ) -> Self {
        let balls = Self::balls_for(solid, radii, backend);
        Self::with_balls(solid, points, radii, balls, templates, threshold)
    }

    /// A stage from balls made for `solid` (one per radius).
    pub fn with_balls(
        solid: &'a Solid,
        points: &'a [[u16; 3]],
        radii: &[f64],
        balls: Vec<Ball>,
        templates: Vec<Vec<f64>>,
        threshold: f64,
    ) -> Self {
        assert!((1..=MAX_ANCHORS).contains(&templates.len()));
        VolumeDescriptor {
            solid,
            points,
            balls,
            radii: radii.to_vec(),
            templates,
            threshold,
            clutter: ClutterPolicy::OFF,
            clean_layers: usize::MAX,
            batch: BatchFailure::new(),
        }
    }

    /// Excuses cluttered layers as `policy` says (see
    /// [`super::clutter`]). Default: off.
    pub fn with_clutter(mut self, policy: ClutterPolicy) -> Self {
        let voxel = self.solid.bits().spec().voxel_size;
        let radii_voxels: Vec<f64> = self.radii.iter().map(|r| r / voxel).collect();
        self.clean_layers = policy.clean_layers(&radii_voxels);
        self.clutter = policy;
        self
    }

    /// The balls, one per radius.
    pub fn balls(&self) -> &[Ball] {
        &self.balls
    }

    /// The template's fraction at each radius, per anchor.
    pub fn templates(&self) -> &[Vec<f64>] {
        &self.templates
    }

    /// The balls for `radii` (world units) on voxels of `voxel_size`, for
    /// any solid.
    pub fn balls_at(radii: &[f64], voxel_size: f64, backend: Threads) -> Vec<Ball> {
        radii
            .iter()
            .map(|r| {
                let rv = r / voxel_size;
                Ball::build(rv, level_for_radius(rv, BLOCKS_PER_RADIUS), backend)
            })
            .collect()
    }

    #[cfg(any(test, feature = "internals"))]
    fn balls_for(solid: &Solid, radii: &[f64], backend: Threads) -> Vec<Ball> {
        let voxel = solid.bits().spec().voxel_size;
        Self::balls_at(radii, voxel, backend)
            .into_iter()
            .map(|b| b.for_solid(solid, backend))
            .collect()
    }

    /// The descriptor of one voxel of any solid with this stage's voxel size:
    /// what the template side computes.
    #[cfg(any(test, feature = "internals"))]
    pub fn describe(solid: &Solid, v: [u16; 3], radii: &[f64], backend: Threads) -> Vec<f64> {
        let voxel = solid.bits().spec().voxel_size;
        Self::describe_with(solid, v, &Self::balls_at(radii, voxel, backend), backend)
    }

    /// The descriptor of voxel `v` from `balls`; the levels it reads are
    /// built with `backend`.
    pub fn describe_with(solid: &Solid, v: [u16; 3], balls: &[Ball], backend: Threads) -> Vec<f64> {
        balls
            .iter()
            .map(|b| {
                if b.level() > 0 {
                    solid.level(b.level(), backend);
                }
                let (inside, all) = b.count(solid, v);
                inside as f64 / all as f64
            })
            .collect()
    }
}

impl OnionDescriptor for VolumeDescriptor<'_> {
    type State = VolumeState;
    type Value = u64;

    fn name(&self) -> &'static str {
        "volume"
    }

    fn layers(&self) -> usize {
        self.balls.len()
    }

    fn radius(&self, layer: usize) -> f64 {
        self.radii[layer]
    }

    fn threshold(&self) -> f64 {
        self.threshold
    }

    fn start(&self, _point: u32, anchors: Anchors) -> VolumeState {
        VolumeState {
            alive: anchors & all_anchors(self.templates.len()),
            ..VolumeState::default()
        }
    }

    fn anchors(&self, state: &VolumeState) -> Anchors {
        state.alive
    }

    fn prepare<'b>(
        &'b self,
        layer: usize,
        points: &'b [u32],
        batch: &'b dyn LayerBatch,
    ) -> LocalFuture<'b, Option<Vec<u64>>> {
        Box::pin(async move {
            let voxels = self.batch.voxels_to_compute(points, self.points)?;
            let counts = batch.ball_counts(&self.balls[layer], &voxels).await;
            self.batch.accept(counts, points.len())
        })
    }

    fn batch_failure(&self) -> Option<String> {
        self.batch.reason()
    }

    fn extend(&self, point: u32, layer: usize, state: &mut VolumeState) -> f64 {
        let v = self.points[point as usize];
        self.compare(layer, state, || self.balls[layer].fraction(self.solid, v))
    }

    fn extend_given(&self, point: u32, layer: usize, state: &mut VolumeState, inside: u64) -> f64 {
        let v = self.points[point as usize];
        self.compare(layer, state, || {
            inside as f64 / self.balls[layer].covered(v) as f64
        })
    }
}

impl VolumeDescriptor<'_> {
    /// Adds layer `layer`, whose solid fraction `fraction` gives (read only
    /// if an anchor still compares it), to `state`; returns the running
    /// distance.
    fn compare(
        &self,
        layer: usize,
        state: &mut VolumeState,
        fraction: impl FnOnce() -> f64,
    ) -> f64 {
        let compared = state.alive & !state.excused;
        if compared != 0 {
            let f = fraction();
            for (a, template) in self.templates.iter().enumerate() {
                let bit = 1 << a;
                if compared & bit == 0 {
                    continue;
                }
                let d = f - template[layer];
                let sum = &mut state.sums[a];
                let rejected = if d > self.clutter.volume_tolerance && layer >= self.clean_layers {
                    state.excused |= bit;
                    // Compared over `layer` layers only: their share of the budget.
                    *sum > self.threshold * ClutterPolicy::volume_share(layer, self.balls.len())
                } else {
                    *sum += d.abs();
                    *sum > self.threshold
                };
                if rejected {
                    state.alive &= !bit;
                }
            }
        }
        closest(&state.sums, state.alive)
    }
}

/// The smallest running distance among the anchors `alive`, or infinity
/// when none is left: it never decreases, since each anchor's does not and
/// the set only shrinks.
pub(super) fn closest(sums: &[f64; MAX_ANCHORS], alive: Anchors) -> f64 {
    (0..MAX_ANCHORS)
        .filter(|a| alive & (1 << a) != 0)
        .map(|a| sums[a])
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vec3;
    use crate::mesh::shapes::{cuboid, uv_sphere};
    use crate::voxel::{GridSpec, fill_solid, skin, voxelize};
    use std::f64::consts::PI;

    /// A ball as the volume stage reads it.
    fn volume_ball(r: f64) -> Ball {
        Ball::at_level(r, level_for_radius(r, BLOCKS_PER_RADIUS))
    }

    #[test]
    fn a_point_on_a_large_flat_slab_sees_one_half_at_every_radius() {
        // The top face of a slab, far from its edges: half of every ball is solid.
        let slab = cuboid(Vec3::new(-4.0, -4.0, -1.0), Vec3::new(4.0, 4.0, 0.0));
        let spec = GridSpec::for_scene(slab.bounds(), 256).unwrap();
        let solid = Solid::new(voxelize(&slab, &spec, Threads::Serial));
        let top = spec.to_grid(Vec3::new(0.1, -0.2, 0.0));
        let v = skin(solid.bits(), Threads::Serial)
            .iter_ones()
            .filter(|s| s[0] as i64 == top.x as i64 && s[1] as i64 == top.y as i64)
            .max_by_key(|s| s[2])
            .unwrap();
        let radii = [0.1, 0.25, 0.5, 0.75, 0.9];
        for (r, f) in radii.iter().zip(VolumeDescriptor::describe(
            &solid,
            v,
            &radii,
            Threads::Serial,
        )) {
            // The centre's own layer of voxels tips the balance by at most
            // half a disc of the ball.
            let rv = r / spec.voxel_size;
            let disc = PI * rv * rv / (4.0 / 3.0 * PI * rv * rv * rv);
            assert!((f - 0.5).abs() <= disc * 0.6, "r {r}: {f}");
        }
    }

    /// Volume of the intersection of balls of radius `big` and `r` whose
    /// centres are `d` apart (big - r < d < big + r).
    fn lens(big: f64, r: f64, d: f64) -> f64 {
        PI * (big + r - d).powi(2)
            * (d * d + 2.0 * d * r - 3.0 * r * r + 2.0 * d * big + 6.0 * r * big - 3.0 * big * big)
            / (12.0 * d)
    }

    #[test]
    fn a_ball_inside_a_solid_is_full_and_fractions_at_a_sphere_are_analytic() {
        let big_r = 1.0;
        let m = uv_sphere(Vec3::ZERO, big_r, 128, 256);
        let spec = GridSpec::for_scene(m.bounds(), 256).unwrap();
        // The centre-sampled interior is an unbiased picture of the solid.
        let solid = Solid::new(fill_solid(&m, &spec, Threads::Serial));
        let centre = spec.to_grid(Vec3::ZERO);
        let c = [centre.x as u16, centre.y as u16, centre.z as u16];
        assert_eq!(
            VolumeDescriptor::describe(&solid, c, &[0.5], Threads::Serial)[0],
            1.0
        );
        // The topmost solid voxel above the centre, a point near the surface.
        let top = solid
            .bits()
            .iter_ones()
            .filter(|s| s[0] == c[0] && s[1] == c[1])
            .max_by_key(|s| s[2])
            .unwrap();
        let d = spec.center(top).length();
        for r in [0.1, 0.2, 0.4, 0.8] {
            let want = lens(big_r, r, d) / (4.0 / 3.0 * PI * r * r * r);
            let got = VolumeDescriptor::describe(&solid, top, &[r], Threads::Serial)[0];
            // Counting errors shrink with the radius in counting units
            // (voxels, or blocks at coarse levels).
            let ball = volume_ball(r / spec.voxel_size).for_solid(&solid, Threads::Serial);
            let tol = 0.05 / (ball.radius() / f64::from(1u32 << ball.level()));
            assert!((got - want).abs() < tol, "r {r}: {got} vs {want}");
        }
    }
}
