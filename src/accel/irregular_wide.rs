//! The irregular grid's voxel map with several levels taken per hop: the same map from
//! virtual cells to cell ids as [`IrregularGrid::lookup`], in fewer dependent reads.
//!
//! The built voxel map descends one level per read, and a grid fitted to a detailed mesh
//! has many levels (the Stanford bunny on a floor: 15), so finding the next cell of a walk
//! near the mesh is a chain of up to 16 reads, each waiting on the one before. A GPU hides
//! such a chain poorly. Here consecutive levels are merged into *hops* of up to
//! `max_bits` splits: a node's child block holds `2^bits` entries, one per combination of
//! the hop's split bits, each the entry the built map reaches after the hop's levels (a
//! leaf reached earlier is repeated over the combinations below it). The cells, their ids
//! and every walk's path are those of the built grid; only the number of reads changes
//! (the bunny on a floor: 16 reads at most become 9 with 6-bit hops, 6 with 9-bit ones).
//!
//! Layout as the built map's (see [`super::irregular`]): top entries first, x fastest, then
//! child blocks, each top cell's tree together (breadth first within it); an entry is a
//! cell id or [`NODE`] plus its child block's index. In a hop with `n[a]` splits of axis
//! `a`, child `(px, py, pz)` (the hop's bits of each axis, most significant first as the
//! levels take them) sits at `px + 2^n[0] * (py + 2^n[1] * pz)`.
//!
//! Only the GPU reads it (`gpu/layout/` uploads it in place of the built map). The CPU
//! walks keep the built map: with this one the H200 host's CPU render did not get faster
//! (2 threads within the noise, 16 threads 8-15% slower: a larger map in the caches), and
//! building it inside the grid's build cost the 3.3 M-triangle icosphere 0.4 s
//! (run 7 of the notebook, `git show b97da3f:docs/performance.md`).

use rayon::prelude::*;

use super::irregular::{IrregularGrid, NODE};

/// The widest hop tried: 2^9 = 512 entries per child block.
pub const MAX_HOP_BITS: u32 = 9;

/// The voxel map in hops of several levels (module docs).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct WideMap {
    /// Top cells per axis (the built grid's).
    pub top_res: [u32; 3],
    /// Splits per axis over all levels (the built grid's).
    pub shift: [u32; 3],
    /// Splits per axis of each hop, top-down; they sum to `shift`.
    pub hops: Vec<[u32; 3]>,
    /// Entries: top entries, then child blocks.
    pub vmap: Vec<u32>,
}

impl WideMap {
    /// The map of `g` in hops of at most `max_bits` splits (a level with more splits is a
    /// hop of its own, so `max_bits` 1 descends level by level as the built map does).
    pub fn build(g: &IrregularGrid, max_bits: u32) -> WideMap {
        let spans = spans(g, max_bits);
        let tops = g.top_res.iter().map(|&r| r as usize).product::<usize>();
        // Each top node's tree on its own (in parallel), blocks numbered from 0 within it;
        // then the trees one after another in top-cell order, their node entries moved by
        // where each tree starts. The result does not depend on the thread count.
        let trees: Vec<Vec<u32>> = g.vmap[..tops]
            .par_iter()
            .map(|&e| {
                if e & NODE == 0 {
                    Vec::new()
                } else {
                    widen_tree(g, &spans, e)
                }
            })
            .collect();
        let mut vmap = g.vmap[..tops].to_vec();
        vmap.reserve(trees.iter().map(Vec::len).sum());
        for (top, tree) in trees.iter().enumerate() {
            if tree.is_empty() {
                continue;
            }
            let base = vmap.len() as u32;
            vmap[top] = NODE | base;
            vmap.extend(
                tree.iter()
                    .map(|&e| if e & NODE != 0 { e + base } else { e }),
            );
        }
        WideMap {
            top_res: g.top_res,
            shift: g.shift,
            hops: spans.into_iter().map(|(_, _, n)| n).collect(),
            vmap,
        }
    }

    /// The widest map of `g` whose entries number at most `budget`: hops of
    /// [`MAX_HOP_BITS`] splits, then narrower ones, down to one level a hop (returned
    /// whatever its size: it holds as many entries as the built map). Each width's size is
    /// counted from the built map's nodes per level before one map is built: a hop's blocks
    /// are one per built node at its first level.
    pub fn within(g: &IrregularGrid, budget: usize) -> WideMap {
        let nodes = nodes_per_level(g);
        let tops = g.top_res.iter().map(|&r| r as usize).product::<usize>();
        let size = |bits: u32| {
            tops + spans(g, bits)
                .iter()
                .map(|&(first, _, n)| nodes[first] << n.iter().sum::<u32>())
                .sum::<usize>()
        };
        let bits = (2..=MAX_HOP_BITS)
            .rev()
            .find(|&b| size(b) <= budget)
            .unwrap_or(1);
        WideMap::build(g, bits)
    }

    /// The map the GPU walks read: the widest within [`gpu_budget`] and within `capacity`
    /// entries (what the GPU's largest texture holds), so that no scene that packs with
    /// the built map fails to pack with hops.
    pub fn for_gpu(g: &IrregularGrid, capacity: usize) -> WideMap {
        WideMap::within(g, gpu_budget(g.vmap.len()).min(capacity))
    }

    /// The cell holding virtual cell `k`: [`IrregularGrid::lookup`]'s answer.
    #[inline]
    pub fn lookup(&self, k: [u32; 3]) -> u32 {
        self.descend(k).0
    }

    /// Reads of the map that [`WideMap::lookup`] makes for `k` (1 for a leaf top cell).
    pub fn reads(&self, k: [u32; 3]) -> u32 {
        self.descend(k).1
    }

    /// (cell id, reads) of the descent to virtual cell `k`.
    #[inline(always)]
    fn descend(&self, k: [u32; 3]) -> (u32, u32) {
        let mut rem = self.shift;
        let t = [0, 1, 2].map(|a| (k[a] >> rem[a]) as usize);
        let top = t[0] + self.top_res[0] as usize * (t[1] + self.top_res[1] as usize * t[2]);
        let mut e = self.vmap[top];
        let mut reads = 1;
        for n in &self.hops {
            if e & NODE == 0 {
                break;
            }
            let mut idx = e & !NODE;
            let mut stride = 0;
            for a in 0..3 {
                rem[a] -= n[a];
                idx += ((k[a] >> rem[a]) & ((1 << n[a]) - 1)) << stride;
                stride += n[a];
            }
            e = self.vmap[idx as usize];
            reads += 1;
        }
        (e, reads)
    }
}

/// Consecutive levels of `g` per hop of at most `max_bits` splits, greedily: (first level,
/// end level, splits per axis); a level with more splits is a hop of its own.
fn spans(g: &IrregularGrid, max_bits: u32) -> Vec<(usize, usize, [u32; 3])> {
    let mut spans: Vec<(usize, usize, [u32; 3])> = Vec::new();
    for (l, mask) in g.levels.iter().enumerate() {
        let bits = mask.iter().filter(|&&m| m).count() as u32;
        match spans.last_mut() {
            Some((_, end, n)) if n.iter().sum::<u32>() + bits <= max_bits => {
                *end = l + 1;
                for a in 0..3 {
                    n[a] += u32::from(mask[a]);
                }
            }
            _ => spans.push((l, l + 1, mask.map(u32::from))),
        }
    }
    spans
}

/// Built voxel-map nodes whose child block is split by level `l`, per level.
fn nodes_per_level(g: &IrregularGrid) -> Vec<usize> {
    let tops = g.top_res.iter().map(|&r| r as usize).product::<usize>();
    let mut counts = vec![0; g.levels.len()];
    let mut level: Vec<u32> = g.vmap[..tops]
        .iter()
        .copied()
        .filter(|e| e & NODE != 0)
        .collect();
    for (l, mask) in g.levels.iter().enumerate() {
        counts[l] = level.len();
        let size = 1usize << mask.iter().filter(|&&m| m).count();
        level = level
            .iter()
            .flat_map(|&e| {
                let b = (e & !NODE) as usize;
                g.vmap[b..b + size]
                    .iter()
                    .copied()
                    .filter(|e| e & NODE != 0)
            })
            .collect();
    }
    counts
}

/// The blocks below the built node entry `node` of a top cell, in hops `spans` (first
/// level, end level, splits per axis), breadth first; block indices count from 0, the
/// node's own block first.
fn widen_tree(g: &IrregularGrid, spans: &[(usize, usize, [u32; 3])], node: u32) -> Vec<u32> {
    let mut out = Vec::new();
    // (slot to point at the block, or None for the root; built node entry; hop)
    let mut queue = std::collections::VecDeque::from([(None, node, 0usize)]);
    while let Some((slot, node, hop)) = queue.pop_front() {
        let (first, end, n) = spans[hop];
        let block = out.len();
        if let Some(slot) = slot {
            out[slot] = NODE | block as u32;
        }
        let size = 1usize << n.iter().sum::<u32>();
        out.resize(block + size, 0);
        for c in 0..size {
            // The hop's bits of each axis in this combination.
            let part = [
                c & ((1 << n[0]) - 1),
                (c >> n[0]) & ((1 << n[1]) - 1),
                c >> (n[0] + n[1]),
            ];
            let mut left = n;
            let mut e = node;
            for mask in &g.levels[first..end] {
                if e & NODE == 0 {
                    break;
                }
                let mut idx = e & !NODE;
                let mut stride = 1;
                for a in 0..3 {
                    if mask[a] {
                        left[a] -= 1;
                        idx += ((part[a] as u32 >> left[a]) & 1) * stride;
                        stride *= 2;
                    }
                }
                e = g.vmap[idx as usize];
            }
            if e & NODE == 0 {
                out[block + c] = e;
            } else {
                queue.push_back((Some(block + c), e, hop + 1));
            }
        }
    }
    out
}

/// Entries the GPU's voxel map may take when its levels are merged into hops, for a built
/// map of `built` entries: sixteen times as many, at least 2^20 (4 MiB), at most 2^24 (what
/// an f32 index in the GPU's textures reaches exactly). The bunny on a floor takes 9-bit
/// hops in 8.8 times its built map's entries.
pub fn gpu_budget(built: usize) -> usize {
    (16 * built).clamp(1 << 20, 1 << 24)
}

#[cfg(test)]
#[path = "irregular_wide_tests.rs"]
mod tests;
