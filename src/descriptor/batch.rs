//! One layer's values computed for all live points at once (on a GPU), kept
//! for the stage's per-point `extend` to look up.

use std::sync::{Mutex, RwLock};

/// The values of the layer last prepared, by point, and why the batch
/// failed if it did (then no later layer is prepared: the stage computes
/// them itself).
pub(crate) struct PreparedLayer<T> {
    layer: RwLock<Option<Values<T>>>,
    failure: Mutex<Option<String>>,
}

struct Values<T> {
    layer: usize,
    /// Sorted, with `values` in the same order.
    points: Vec<u32>,
    values: Vec<T>,
}

impl<T: Copy> PreparedLayer<T> {
    pub(crate) fn new() -> Self {
        PreparedLayer {
            layer: RwLock::new(None),
            failure: Mutex::new(None),
        }
    }

    /// Starts a layer for `points`: forgets the previous layer's values and
    /// returns the points sorted, the order the values must come in, with
    /// their voxels in `voxels`; or `None` when there is nothing to compute
    /// (no points, or the batch failed before).
    pub(crate) fn begin(
        &self,
        points: &[u32],
        voxels: &[[u16; 3]],
    ) -> Option<(Vec<u32>, Vec<[u16; 3]>)> {
        *self.layer.write().unwrap_or_else(|p| p.into_inner()) = None;
        let failed = self
            .failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .is_some();
        if failed || points.is_empty() {
            return None;
        }
        let mut sorted = points.to_vec();
        sorted.sort_unstable();
        let at = sorted.iter().map(|&p| voxels[p as usize]).collect();
        Some((sorted, at))
    }

    /// Keeps the values the batch computed for layer `layer` at the points
    /// [`Self::begin`] returned, or why it could not.
    pub(crate) fn finish(&self, layer: usize, points: Vec<u32>, values: Result<Vec<T>, String>) {
        let values = match values {
            Ok(values) if values.len() == points.len() => values,
            Ok(values) => {
                return self.fail(format!(
                    "a batch returned {} values for {} points",
                    values.len(),
                    points.len()
                ));
            }
            Err(reason) => return self.fail(reason),
        };
        *self.layer.write().unwrap_or_else(|p| p.into_inner()) = Some(Values {
            layer,
            points,
            values,
        });
    }

    fn fail(&self, reason: String) {
        *self.failure.lock().unwrap_or_else(|p| p.into_inner()) = Some(reason);
    }

    /// The value of `point` at `layer`, if the batch computed it.
    pub(crate) fn get(&self, point: u32, layer: usize) -> Option<T> {
        let prepared = self.layer.read().unwrap_or_else(|p| p.into_inner());
        let prepared = prepared.as_ref().filter(|p| p.layer == layer)?;
        let i = prepared.points.binary_search(&point).ok()?;
        Some(prepared.values[i])
    }

    /// Why the batch failed, if it did.
    pub(crate) fn failure(&self) -> Option<String> {
        self.failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}
