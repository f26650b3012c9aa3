//! One memory budget for a scene and every search on it.
//!
//! Each large structure is estimated from sizes known before it is built
//! (grid dimensions, radii in voxels, candidate counts) and reserved in a
//! [`Budget`] first: an input that would need too much stops with
//! [`crate::Error::OverBudget`], naming the structure and what to change,
//! instead of aborting the process or trapping the wasm module halfway
//! through. The byte estimates live with the structures they size
//! (`crate::voxel`'s estimates, `crate::cascade::candidate_bytes`,
//! `crate::mesh::mesh_bytes`, the welded surface's `surface_bytes`); what a
//! user can change when one does not fit lives here, with its [`Item`], so
//! that no check site writes its own advice. This module names nothing
//! else in the crate, so that the error type can carry an estimate.

use std::fmt;

/// What a search or a scene needs, item by item.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MemoryEstimate {
    items: Vec<(&'static str, u64)>,
}

impl MemoryEstimate {
    /// Adds `bytes` for `what`.
    fn add(&mut self, what: &'static str, bytes: u64) {
        if bytes > 0 {
            match self.items.iter_mut().find(|(w, _)| *w == what) {
                Some((_, b)) => *b = b.saturating_add(bytes),
                None => self.items.push((what, bytes)),
            }
        }
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

/// What the template's structures grow with, for their advice.
#[derive(Clone, Copy, Debug)]
pub(crate) struct TemplateReach {
    /// The template's outer radius in voxels.
    pub outer_voxels: f64,
    /// The grid's resolution.
    pub resolution: u32,
    /// Whether the template is a sphere picked in the scene.
    pub selection: bool,
}

/// The template's structures that grow with its radius.
#[derive(Clone, Copy, Debug)]
pub(crate) enum TemplatePiece {
    /// Its surface, sampled for the pose refinement.
    Surface,
    /// Its voxel grids.
    Grids,
    /// Its grids turned, for its anchor's test.
    Turned,
    /// The run tables of the volume and verification balls.
    BallTables,
}

/// A structure that takes memory, with what its advice needs to know.
pub(crate) enum Item<'a> {
    /// The scene's mesh.
    Mesh { triangles: usize },
    /// The largest part's grids at scene load; `fitting` finds the highest
    /// resolution that would fit, asked only when this one does not.
    LargestPartGrids {
        resolution: u32,
        fitting: &'a dyn Fn() -> Option<u32>,
    },
    /// One part's grids.
    PartGrids {
        triangles: usize,
        dims: [usize; 3],
        resolution: u32,
    },
    /// The mesh a large part's windows are cut from.
    WindowMesh { selection: bool },
    /// One window's grids.
    WindowGrids { selection: bool },
    /// The parts searched in the same wave.
    OtherParts,
    /// The cascade's state per candidate, or (`kept`) the copy kept for
    /// further anchors.
    Candidates {
        candidates: usize,
        resolution: u32,
        kept: bool,
    },
    /// The cells near the template's vertices a part's candidates keep to.
    NearCells { resolution: u32 },
    /// A template model's mesh.
    TemplateMesh { triangles: usize },
    /// The template's structures that grow with its radius in voxels.
    Template(TemplatePiece, TemplateReach),
    /// A welded surface for the curvature descriptor.
    Surface { triangles: usize },
    /// The curvature search's state per scene vertex.
    SurfaceCandidates { vertices: usize },
    /// The list of a large part's windows.
    WindowList {
        extent: String,
        extent_voxels: f64,
        windows: f64,
        most: usize,
    },
}

impl Item<'_> {
    /// The structure's name in a message.
    fn label(&self) -> &'static str {
        match self {
            Item::Mesh { .. } => "the mesh",
            Item::LargestPartGrids { .. } => "the largest part's voxel grids and count pyramid",
            Item::PartGrids { .. } => "a part's voxel grids and count pyramid",
            Item::WindowMesh { .. } => "a large part's mesh for its windows",
            Item::WindowGrids { selection: true } => {
                "the selection's voxel grids and count pyramid"
            }
            Item::WindowGrids { selection: false } => "a window's voxel grids and count pyramid",
            Item::OtherParts => "the other parts searched beside it",
            Item::Candidates { kept: false, .. } => "candidate state",
            Item::Candidates { kept: true, .. } => "candidates kept",
            Item::NearCells { .. } => "cells near vertices",
            Item::TemplateMesh { .. } => "the template's mesh",
            Item::Template(TemplatePiece::Surface, _) => "the template's surface",
            Item::Template(TemplatePiece::Grids, _) => "the template's voxel grids",
            Item::Template(TemplatePiece::Turned, _) => "the template turned (its anchor's test)",
            Item::Template(TemplatePiece::BallTables, _) => "ball tables",
            Item::Surface { .. } => "welded surface",
            Item::SurfaceCandidates { .. } => "candidate state",
            Item::WindowList { .. } => "the list of a large part's windows",
        }
    }

    /// What a user can change for the item to fit.
    fn advice(&self) -> String {
        match self {
            Item::Mesh { triangles } => format!(
                "the scene's mesh of {triangles} triangles passes the budget alone: simplify the mesh, or raise the memory budget"
            ),
            Item::LargestPartGrids {
                resolution,
                fitting,
            } => match fitting() {
                Some(r) => format!(
                    "lower the resolution to at most {r} (now {resolution}), or raise the memory budget"
                ),
                None => "no resolution fits: raise the memory budget, or split the scene".into(),
            },
            Item::PartGrids {
                triangles,
                dims,
                resolution,
            } => format!(
                "a part of {triangles} triangles needs {} x {} x {} voxels at resolution {resolution}: lower the resolution, or raise the memory budget",
                dims[0], dims[1], dims[2]
            ),
            Item::WindowMesh { selection: true } | Item::WindowGrids { selection: true } => {
                "the selection's window does not fit: pick a smaller sphere, or raise the memory budget".into()
            }
            Item::WindowMesh { selection: false } | Item::WindowGrids { selection: false } => {
                "a large part's window does not fit beside the search: raise the memory budget"
                    .into()
            }
            Item::OtherParts => {
                "the parts searched side by side do not fit: raise the memory budget".into()
            }
            Item::Candidates {
                candidates,
                resolution,
                ..
            } => format!(
                "a part has {candidates} candidate points at resolution {resolution}: lower the resolution (they fall with its square), raise the candidate spacing, or raise the memory budget"
            ),
            Item::NearCells { resolution } => format!(
                "the cells near the template's vertices do not fit at resolution {resolution}: lower the resolution, or raise the memory budget"
            ),
            Item::TemplateMesh { triangles } => format!(
                "the template has {triangles} triangles: simplify it, or raise the memory budget"
            ),
            Item::Template(_, reach) => format!(
                "the {} outer radius is {:.0} voxels at resolution {}: lower the resolution, pick a smaller {}, or raise the memory budget",
                if reach.selection { "selection's" } else { "template's" },
                reach.outer_voxels,
                reach.resolution,
                if reach.selection { "sphere" } else { "template" },
            ),
            Item::Surface { triangles } => format!(
                "a surface of {triangles} triangles does not fit: simplify the mesh, or raise the memory budget"
            ),
            Item::SurfaceCandidates { vertices } => format!(
                "the scene has {vertices} vertices to search: simplify the mesh, or raise the memory budget"
            ),
            Item::WindowList {
                extent,
                extent_voxels,
                windows,
                most,
            } => format!(
                "a part {extent} across is {extent_voxels:.0} voxels wide at the template's voxel size and needs {windows:.3e} windows, over the {most} a list may hold: the template is tiny next to it; lower --template-voxels, search a region of the scene (a selection), or raise the memory budget"
            ),
        }
    }
}

/// An item that did not fit: the estimate so far, the budget and the
/// item's advice. `crate::Error` turns it into `OverBudget`.
#[derive(Debug)]
pub(crate) struct Exceeded {
    pub estimate: MemoryEstimate,
    pub budget: u64,
    pub advice: String,
}

/// The memory a scene or a search holds, checked as each item is reserved.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Budget {
    limit: u64,
    held: MemoryEstimate,
}

impl Budget {
    /// Nothing held yet, `limit` bytes in all.
    pub(crate) fn new(limit: u64) -> Budget {
        Budget {
            limit,
            held: MemoryEstimate::default(),
        }
    }

    /// Holds `bytes` for `item`, or fails with the item's advice when the
    /// sum passes the limit.
    pub(crate) fn reserve(&mut self, item: Item<'_>, bytes: u64) -> Result<&mut Self, Exceeded> {
        self.held.add(item.label(), bytes);
        if self.held.total() <= self.limit {
            return Ok(self);
        }
        Err(Exceeded {
            estimate: self.held.clone(),
            budget: self.limit,
            advice: item.advice(),
        })
    }

    /// Holds `bytes` for `item` unchecked: for what a plan already sized
    /// to fit, which the next reservation checks with the rest.
    pub(crate) fn hold(&mut self, item: Item<'_>, bytes: u64) {
        self.held.add(item.label(), bytes);
    }

    /// What `bytes` for `item` alone would need: the refusal of something
    /// that cannot be built whatever the budget.
    pub(crate) fn refuse(&self, item: Item<'_>, bytes: u64) -> Exceeded {
        let mut estimate = MemoryEstimate::default();
        estimate.add(item.label(), bytes);
        Exceeded {
            estimate,
            budget: self.limit,
            advice: item.advice(),
        }
    }

    /// The bytes left.
    pub(crate) fn free(&self) -> u64 {
        self.limit.saturating_sub(self.held.total())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn over_budget_names_the_largest_item_and_the_advice_of_the_one_that_tipped() {
        let reach = TemplateReach {
            outer_voxels: 90.0,
            resolution: 256,
            selection: false,
        };
        let mut budget = Budget::new(1 << 30);
        budget
            .reserve(Item::Mesh { triangles: 12 }, 1 << 20)
            .unwrap();
        let e = budget
            .reserve(Item::Template(TemplatePiece::BallTables, reach), 3 << 30)
            .unwrap_err();
        let text = e.estimate.to_string();
        assert_eq!(text, "ball tables 3072 MiB, the mesh 1 MiB");
        assert!(
            e.advice.contains("outer radius is 90 voxels"),
            "{}",
            e.advice
        );
        let mut roomy = Budget::new(4 << 30);
        assert!(
            roomy
                .reserve(Item::Template(TemplatePiece::Grids, reach), 3 << 30)
                .is_ok()
        );
    }

    #[test]
    fn the_same_item_adds_up_and_the_free_bytes_shrink() {
        let mut budget = Budget::new(100);
        budget.hold(Item::OtherParts, 30);
        budget.hold(Item::OtherParts, 30);
        assert_eq!(budget.free(), 40);
        assert!(budget.reserve(Item::OtherParts, 41).is_err());
    }
}
