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

    /// Computes layer `layer` for `points` with `compute`, which gets the
    /// points sorted and returns one value per point in that order.
    pub(crate) fn fill(
        &self,
        layer: usize,
        points: &[u32],
        compute: impl FnOnce(&[u32]) -> Result<Vec<T>, String>,
    ) {
        let mut prepared = self.layer.write().unwrap_or_else(|p| p.into_inner());
        *prepared = None;
        let mut failure = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        if failure.is_some() || points.is_empty() {
            return;
        }
        let mut sorted = points.to_vec();
        sorted.sort_unstable();
        match compute(&sorted) {
            Ok(values) if values.len() == sorted.len() => {
                *prepared = Some(Values {
                    layer,
                    points: sorted,
                    values,
                })
            }
            Ok(values) => {
                *failure = Some(format!(
                    "a batch returned {} values for {} points",
                    values.len(),
                    sorted.len()
                ))
            }
            Err(reason) => *failure = Some(reason),
        }
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
