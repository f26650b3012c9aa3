//! Anchors: the template points a scene point is compared against. A
//! descriptor keeps, per point, the set it still matches; the cascade only
//! passes the set along.

/// The anchors a point still matches, bit `a` for anchor `a`.
pub type Anchors = u8;

/// The most anchors a template may have.
pub const MAX_ANCHORS: usize = 4;

/// Every anchor of a template of `count` anchors.
pub fn all_anchors(count: usize) -> Anchors {
    assert!((1..=MAX_ANCHORS).contains(&count), "{count} anchors");
    ((1u16 << count) - 1) as Anchors
}
