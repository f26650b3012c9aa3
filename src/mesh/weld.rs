//! Welding: vertices at the same position become one.
//!
//! Files split vertices along texture and normal seams; connectivity (shells
//! for the solid fill, neighbourhoods for curvature) needs them joined.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

/// Maps every vertex to a dense id shared by all vertices at exactly the same
/// position; returns the ids and how many distinct positions there are.
pub fn weld_vertices(positions: &[[f32; 3]]) -> (Vec<u32>, usize) {
    let mut first: HashMap<[u32; 3], u32, BuildHasherDefault<FxHasher>> =
        HashMap::with_capacity_and_hasher(positions.len(), Default::default());
    let ids = positions
        .iter()
        .map(|p| {
            // +0.0 turns -0.0 into 0.0 so that both weld.
            let key = p.map(|c| (c + 0.0).to_bits());
            let next = first.len() as u32;
            *first.entry(key).or_insert(next)
        })
        .collect();
    (ids, first.len())
}

/// The multiply-rotate hash of rustc (FxHash): fast on small integer keys,
/// which is all the pipeline hashes.
#[derive(Default)]
pub(crate) struct FxHasher(u64);

impl Hasher for FxHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u64(b as u64);
        }
    }
    fn write_u32(&mut self, v: u32) {
        self.write_u64(v as u64);
    }
    fn write_u64(&mut self, v: u64) {
        self.0 = (self.0.rotate_left(5) ^ v).wrapping_mul(0x51_7c_c1_b7_27_22_0a_95);
    }
    fn write_usize(&mut self, v: usize) {
        self.write_u64(v as u64);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_positions_share_an_id() {
        let p = [
            [0.0, 1.0, 2.0],
            [3.0, 4.0, 5.0],
            [0.0, 1.0, 2.0],
            [-0.0, 1.0, 2.0],
        ];
        let (ids, n) = weld_vertices(&p);
        assert_eq!(ids, vec![0, 1, 0, 0]);
        assert_eq!(n, 2);
    }
}
