//! One memory budget for a scene and every search on it.
//!
//! Each large structure is estimated from sizes known before it is built
//! (grid dimensions, radii in voxels, candidate counts), and the sum is
//! checked against the budget first: an input that would need too much
//! stops with [`crate::Error::OverBudget`], naming the structure and what
//! to change, instead of aborting the process or trapping the wasm module
//! halfway through. Each estimate lives with the structure it sizes
//! (`crate::voxel`'s estimates, `crate::cascade::candidate_bytes`,
//! `crate::mesh::mesh_bytes`, the welded surface's `surface_bytes`); this
//! module holds only the sum they add to. It names nothing else in the
//! crate, so that the error type can carry an estimate.

use std::fmt;

/// What a search or a scene needs, item by item.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MemoryEstimate {
    items: Vec<(&'static str, u64)>,
}

impl MemoryEstimate {
    /// An empty estimate.
    pub(crate) fn new() -> MemoryEstimate {
        MemoryEstimate::default()
    }

    /// Adds `bytes` for `what`.
    pub(crate) fn add(&mut self, what: &'static str, bytes: u64) -> &mut Self {
        if bytes > 0 {
            match self.items.iter_mut().find(|(w, _)| *w == what) {
                Some((_, b)) => *b = b.saturating_add(bytes),
                None => self.items.push((what, bytes)),
            }
        }
        self
    }

    /// The sum.
    pub fn total(&self) -> u64 {
        self.items
            .iter()
            .fold(0u64, |s, (_, b)| s.saturating_add(*b))
    }

    /// The largest item.
    pub fn largest(&self) -> Option<(&'static str, u64)> {
        self.items.iter().copied().max_by_key(|&(_, b)| b)
    }
}

/// Items largest first, in MiB.
impl fmt::Display for MemoryEstimate {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut items = self.items.clone();
        items.sort_by_key(|&(_, b)| std::cmp::Reverse(b));
        for (i, (what, bytes)) in items.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{what} {}", mib(*bytes))?;
        }
        Ok(())
    }
}

/// Bytes in MiB for messages: "12 MiB", or "a few EiB" for nonsense.
pub(crate) fn mib(bytes: u64) -> String {
    if bytes == u64::MAX {
        "more than 16 EiB".into()
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn over_budget_names_the_largest_item() {
        let mut e = MemoryEstimate::new();
        e.add("ball tables", 3 << 30).add("bit grids", 1 << 20);
        let err = e.check(1 << 30, || "lower the radius".into()).unwrap_err();
        let text = err.to_string();
        assert!(text.contains("ball tables 3072 MiB"), "{text}");
        assert!(text.contains("lower the radius"), "{text}");
        assert!(e.check(4 << 30, String::new).is_ok());
    }
}
