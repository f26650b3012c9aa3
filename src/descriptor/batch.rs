//! What a stage keeps of its batch (a GPU): why it failed, if it did. The
//! values a batch computes go straight back to the cascade, in the live
//! points' order ([`super::OnionDescriptor::prepare`]).

use std::sync::Mutex;

/// Why a stage's batch failed: once it has, no later layer goes to it (the
/// stage computes them itself, with the same results).
pub(crate) struct BatchFailure(Mutex<Option<String>>);

impl BatchFailure {
    pub(crate) fn new() -> Self {
        BatchFailure(Mutex::new(None))
    }

    /// The voxels of `points` (indices into `voxels`) for the batch to
    /// compute a layer at, or `None` when there is nothing to ask (no
    /// points, or the batch failed before).
    pub(crate) fn voxels_to_compute(
        &self,
        points: &[u32],
        voxels: &[[u16; 3]],
    ) -> Option<Vec<[u16; 3]>> {
        if points.is_empty() || self.reason().is_some() {
            return None;
        }
        Some(points.iter().map(|&p| voxels[p as usize]).collect())
    }

    /// The batch's values for `expected` points, or `None` (and the reason
    /// kept) when it failed or returned another number of them.
    pub(crate) fn accept<T>(
        &self,
        values: Result<Vec<T>, String>,
        expected: usize,
    ) -> Option<Vec<T>> {
        let reason = match values {
            Ok(values) if values.len() == expected => return Some(values),
            Ok(values) => format!(
                "a batch returned {} values for {expected} points",
                values.len()
            ),
            Err(reason) => reason,
        };
        *self.0.lock().unwrap_or_else(|p| p.into_inner()) = Some(reason);
        None
    }

    /// Why the batch failed, if it did.
    pub(crate) fn reason(&self) -> Option<String> {
        self.0.lock().unwrap_or_else(|p| p.into_inner()).clone()
    }
}
