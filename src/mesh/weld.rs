//! Welding: vertices at the same position become one.
//!
//! Files split vertices along texture and normal seams; connectivity (shells
//! for the solid fill, neighbourhoods for curvature) needs them joined.

use std::collections::HashMap;
use std::hash::{BuildHasherDefault, Hasher};

use crate::exec::Threads;

/// Maps every vertex to a dense id shared by all vertices at exactly the same
/// position, numbered in order of first appearance; returns the ids and how
/// many distinct positions there are. By sorting, on `backend`'s threads:
/// the same ids as [`weld_vertices`]'s hash map, and faster on a whole
/// scene even on one thread (crowd-rocker's components 63-70 -> 27-28 ms).
pub fn weld_vertices_on(positions: &[[f32; 3]], backend: Threads) -> (Vec<u32>, usize) {
    let key = |p: [f32; 3]| p.map(|c| (c + 0.0).to_bits());
    let mut keyed: Vec<([u32; 3], u32)> =
        backend.map(positions.len(), |i| (key(positions[i]), i as u32));
    backend.sort_unstable(&mut keyed);
    // Each run of equal keys: its first vertex (lowest index) gets the id.
    let mut first = vec![0u32; positions.len()];
    let mut is_first = vec![false; positions.len()];
    for run in keyed.chunk_by(|a, b| a.0 == b.0) {
        is_first[run[0].1 as usize] = true;
        for &(_, i) in run {
            first[i as usize] = run[0].1;
        }
    }
    drop(keyed);
    let mut id_of_first = vec![0u32; positions.len()];
    let mut count = 0;
    for (i, &f) in is_first.iter().enumerate() {
        if f {
            id_of_first[i] = count;
            count += 1;
        }
    }
    let ids = backend.map(positions.len(), |i| id_of_first[first[i] as usize]);
    (ids, count as usize)
}

/// The ids of [`weld_vertices_on`], on one thread with a hash map (a
/// part's shells, an STL file's corners: no faster by sorting there).
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

    #[test]
    fn both_backends_give_the_same_ids() {
        // Many repeats in scrambled order; a position's repeats carry both
        // signs of zero, which must weld.
        let p: Vec<[f32; 3]> = (0..20_000u32)
            .map(|i| {
                let j = (i * 7919) % 3001;
                let z = if i % 2 == 0 { -0.0 } else { 0.0 };
                [j as f32 * 0.5, (j % 13) as f32, z]
            })
            .collect();
        let serial = weld_vertices_on(&p, Threads::Serial);
        assert_eq!(serial.1, 3001);
        assert_eq!(serial, weld_vertices_on(&p, Threads::Parallel));
    }
}
