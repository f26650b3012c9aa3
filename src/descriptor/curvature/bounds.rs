//! A cheap interval around a layer's Gaussian curvature, from the tensor
//! of the triangles inside the ball and bounds on its area: most points
//! are rejected with it before the cut triangles are clipped.

use super::neighbourhood::full_tensor;
use crate::math::symmetric_eigen;

/// How far past the threshold a bound must lie to reject: the bound and
/// the exact value round differently, and a point must never be dropped
/// that the exact value would keep.
pub(super) const BOUND_MARGIN: f64 = 1e-6;

/// An interval that holds the Gaussian curvature of a layer whose tensor
/// is `tensor` (final) and whose area lies in `low_area..=high_area`.
/// Clipping the cut triangles' areas is the costly part of a layer, and
/// most points lie far enough from the template for this interval to
/// reject them without it. Unbounded where the area may be zero.
pub(super) fn gaussian_bounds(tensor: [f64; 6], low_area: f64, high_area: f64) -> (f64, f64) {
    if low_area <= 0.0 {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let (values, _) = symmetric_eigen(full_tensor(tensor));
    // The exact value solves the tensor divided by the area, which rounds
    // differently: widen each eigenvalue by a little of the scale.
    let slack = 1e-9 * values.iter().map(|x| x.abs()).fold(0.0, f64::max);
    let ranges = values.map(|x| (x - slack, x + slack));
    let least_magnitude = |(a, b): (f64, f64)| {
        if a <= 0.0 && b >= 0.0 {
            0.0
        } else {
            a.abs().min(b.abs())
        }
    };
    let most_magnitude = |(a, b): (f64, f64)| a.abs().max(b.abs());
    // `gaussian` drops the eigenvalue of least magnitude: any of the three
    // may be the one dropped only if it can be no larger than both others.
    let mut product = (f64::INFINITY, f64::NEG_INFINITY);
    for (k, i, j) in [(0, 1, 2), (1, 0, 2), (2, 0, 1)] {
        let others = most_magnitude(ranges[i]).min(most_magnitude(ranges[j]));
        if least_magnitude(ranges[k]) > others {
            continue;
        }
        let (a, b) = (ranges[i], ranges[j]);
        for x in [a.0 * b.0, a.0 * b.1, a.1 * b.0, a.1 * b.1] {
            product = (product.0.min(x), product.1.max(x));
        }
    }
    // Divided by the area squared, at whichever end of its range moves
    // each end of the product outward.
    let divide = |x: f64, outward_low: bool| {
        let larger_area = (x >= 0.0) == outward_low;
        x / if larger_area {
            high_area * high_area
        } else {
            low_area * low_area
        }
    };
    (divide(product.0, true), divide(product.1, false))
}
