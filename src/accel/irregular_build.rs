//! The irregular grid's build (see [`super::irregular`] for the structure and its layout):
//! the split schedule, the top-level binning, the voxel map below every top cell built in
//! parallel straight into the final layout and assembled, and the exit-box growth of
//! `irregular_grow.rs`. Split from the structure by job, so the structure and its queries
//! import nothing of the build.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use std::sync::atomic::{AtomicU32, Ordering};

use super::axes;
use super::binning::{counting_sort, Frame};
use super::grid::{check_vertices, padded_bounds, CellRange, Grid};
use super::irregular::{
    IrrCell, IrregularConfig, IrregularGrid, IrregularPhases, IrregularStats, MAX_CELLS,
    MAX_ENTRIES, MAX_LEVELS, MAX_REFERENCES, MAX_VIRTUAL_AXIS, NODE,
};
use super::irregular_grow::{grow, Recent, Rule};
use super::irregular_occupancy::{offsets, split_lens, Occupancy};
use crate::clock::Instant;
use crate::scene::Scene;
use crate::{Error, Result};

/// Smallest cell side in f32 ulps of the largest coordinate: the traversal's boundary
/// parameters stay distinct and ordered from cell to cell.
const MIN_CELL_ULPS: f64 = 4.0;
/// Cost of one traversal step relative to one triangle test, for the split decision.
const STEP_COST: f64 = 1.0;
/// Triangles per parallel work item of the top-level binning.
const CHUNK: usize = 2048;
/// Fewer top-level (cell, triangle) pairs than this are sorted serially: the parallel
/// sort's atomics and tasks cost more than they share (the bunny's 76 k pairs: 1.0 ms on
/// two threads against 0.2 ms serially).
const SERIAL_SORT: usize = 1 << 20;
/// The voxel map's runs of top cells a thread, about: the bunny's map took 23.4-24.6 ms
/// on two threads in runs of a 64th of a thread's share, 20.5-21.0 ms in runs of a 256th
/// (its 76 k references: runs of about 150, its largest top cells 5-12 k alone).
const RUNS_PER_THREAD: usize = 256;
/// Cells a parallel task of the growth takes, one after the other (so that each has the
/// exit boxes of the cells before it at hand, [`Recent`]).
const GROW_RUN: usize = 512;
/// Nodes with at least this many triangles split their children in parallel.
const PAR_SPLIT: usize = 4096;

impl IrregularGrid {
    /// Builds the irregular grid for `scene`.
    ///
    /// Errors: [`Error::Scene`] for a non-finite vertex or an out-of-range vertex index,
    /// [`Error::Usage`] for a non-positive density or a zero `leaf_max`, and [`Error::Limit`]
    /// when the cells, the voxel map or the references exceed what f32 texels index.
    pub fn build(scene: &Scene, cfg: &IrregularConfig) -> Result<IrregularGrid> {
        build(scene, cfg)
    }
}

/// The split schedule: from a top cell of size `top`, halve every axis longer than half
/// the longest, until the longest cell side is `finest` or `MAX_LEVELS` or the virtual
/// resolution cap is reached.
fn schedule(top: DVec3, top_res: [u32; 3], finest: f64) -> (Vec<[bool; 3]>, [u32; 3]) {
    let mut size = top;
    let mut shift = [0u32; 3];
    let mut levels = Vec::new();
    while levels.len() < MAX_LEVELS && size.max_element() > finest {
        let longest = size.max_element();
        let mask = [0, 1, 2]
            .map(|a| 2.0 * size[a] > longest && (top_res[a] << (shift[a] + 1)) <= MAX_VIRTUAL_AXIS);
        if !mask.contains(&true) {
            break;
        }
        for a in 0..3 {
            if mask[a] {
                size[a] *= 0.5;
                shift[a] += 1;
            }
        }
        levels.push(mask);
    }
    (levels, shift)
}

/// Voxel-map subtrees laid out as the final tables lay them out (a node's child block
/// before its children's blocks, cells and references in leaf order), with indices local to
/// these tables: entries `NODE | block` count from the start of `vmap`, cells from the start
/// of `cells`, reference offsets from the start of `refs`. Built straight into this layout,
/// so there is no tree of per-node lists to flatten (and free) afterwards.
#[derive(Default)]
struct Flat {
    /// Each top cell's entry, for a run of top cells built one after the other.
    top: Vec<u32>,
    vmap: Vec<u32>,
    /// Boxes in the virtual coordinates of every level (the unused ones are dropped when
    /// the tables are assembled).
    cells: Vec<LeafCell>,
    refs: Vec<u32>,
    /// Deepest level reached.
    depth: usize,
}

impl Flat {
    /// Appends `parts` (built on their own, in parallel), one after the other, moving
    /// their indices past what `self` holds; returns each part's `entry` moved likewise.
    /// Copied part by part in parallel into tables grown once: the parts of a node split
    /// in parallel hold all of its subtree (the bunny's whole voxel map at its top
    /// levels), which the levels above copy again.
    fn append(&mut self, parts: Vec<(Flat, u32)>) -> Vec<u32> {
        let vb = offsets(parts.iter().map(|p| p.0.vmap.len()), self.vmap.len());
        let cb = offsets(parts.iter().map(|p| p.0.cells.len()), self.cells.len());
        let rb = offsets(parts.iter().map(|p| p.0.refs.len()), self.refs.len());
        let shift = |e: u32, k: usize| {
            if e & NODE != 0 {
                NODE | ((e & !NODE) + vb[k] as u32)
            } else {
                e + cb[k] as u32
            }
        };
        let (v0, c0, r0) = (self.vmap.len(), self.cells.len(), self.refs.len());
        let n = |f: fn(&Flat) -> usize| parts.iter().map(|p| f(&p.0)).sum::<usize>();
        self.vmap.resize(v0 + n(|f| f.vmap.len()), 0);
        self.cells
            .resize(c0 + n(|f| f.cells.len()), LeafCell::default());
        self.refs.resize(r0 + n(|f| f.refs.len()), 0);
        let vmaps = split_lens(&mut self.vmap[v0..], parts.iter().map(|p| p.0.vmap.len()));
        let cells = split_lens(&mut self.cells[c0..], parts.iter().map(|p| p.0.cells.len()));
        let refs = split_lens(&mut self.refs[r0..], parts.iter().map(|p| p.0.refs.len()));
        parts
            .par_iter()
            .zip(vmaps)
            .zip(cells)
            .zip(refs)
            .enumerate()
            .for_each(|(k, (((p, vmap), cells), refs))| {
                for (d, &e) in vmap.iter_mut().zip(&p.0.vmap) {
                    *d = shift(e, k);
                }
                for (d, c) in cells.iter_mut().zip(&p.0.cells) {
                    *d = *c;
                    d.range.offset += rb[k] as u32;
                }
                refs.copy_from_slice(&p.0.refs);
            });
        self.depth = parts.iter().map(|p| p.0.depth).fold(self.depth, usize::max);
        parts
            .iter()
            .enumerate()
            .map(|(k, p)| shift(p.1, k))
            .collect()
    }
}

/// A cell as the voxel-map build makes it: its box and its references, without the exit
/// box an [`IrrCell`] carries (its own box until the growth, written when the tables are
/// assembled): 32 bytes a cell rather than 56 in tables that are written, grown and
/// copied once more (6 M cells on the 3.3 M-triangle icosphere).
#[derive(Clone, Copy, Default)]
struct LeafCell {
    lo: [u32; 3],
    hi: [u32; 3],
    range: CellRange,
}

/// Per-thread working memory of the voxel-map build, reused from node to node: the
/// triangle lists of the nodes on the current path (each node's children's lists pushed
/// after its own, popped when it is done) and each triangle's children.
#[derive(Default)]
struct Scratch {
    lists: Vec<u32>,
    masks: Vec<u8>,
}

/// What every node build needs.
struct Ctx<'a> {
    /// Every triangle's vertices, gathered once for all levels.
    tris: &'a [[Vec3; 3]],
    levels: &'a [[bool; 3]],
    min: DVec3,
    cs: DVec3,
    leaf_max: usize,
}

impl Ctx<'_> {
    #[inline]
    fn tri(&self, t: u32) -> [DVec3; 3] {
        self.tris[t as usize].map(|v| v.as_dvec3())
    }

    /// Builds the node at `level` covering `1 << rem[a]` virtual cells from `lo`, whose
    /// triangles (ascending) are `sc.lists[start..start + len]`, into `out`: returns its
    /// entry there. Leaves `sc.lists` as it found it.
    fn node(
        &self,
        lo: [u32; 3],
        rem: [u32; 3],
        level: usize,
        (start, len): (usize, usize),
        out: &mut Flat,
        sc: &mut Scratch,
    ) -> u32 {
        let hi = axes(|a| lo[a] + (1 << rem[a]));
        let leaf = |out: &mut Flat, sc: &Scratch| {
            let id = out.cells.len() as u32;
            out.cells.push(LeafCell {
                lo,
                hi,
                range: CellRange {
                    offset: out.refs.len() as u32,
                    count: len as u32,
                },
            });
            out.refs.extend_from_slice(&sc.lists[start..start + len]);
            out.depth = out.depth.max(level);
            id
        };
        if len <= self.leaf_max || level == self.levels.len() {
            return leaf(out, sc);
        }
        let mask = self.levels[level];
        let crem = axes(|a| rem[a] - mask[a] as u32);
        let n = mask.map(|m| if m { 2u32 } else { 1 });
        let v = |k: [u32; 3]| DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64);
        let lo64 = self.min + v(lo) * self.cs;
        let hi64 = self.min + v(hi) * self.cs;
        let ccs = v(crem.map(|r| 1 << r)) * self.cs;
        let frame = Frame::new(lo64, ccs, n, lo64, hi64);
        let n_children = (n[0] * n[1] * n[2]) as usize;
        // Each triangle's children as a bit set (a node has at most 8), counted; then the
        // children's lists pushed after this node's, each ascending as this one is.
        let mask_base = sc.masks.len();
        let mut counts = [0usize; 8];
        for k in start..start + len {
            let mut m = 0u8;
            frame.bin_each(self.tri(sc.lists[k]), |c| {
                m |= 1 << c;
                counts[c as usize] += 1;
            });
            sc.masks.push(m);
        }
        // Split only when it is expected to pay (the surface-area heuristic of the grid
        // and kd-tree literature): a ray through the node tests `n` triangles as a leaf;
        // split, it steps through about `STEP_COST * 2` children and tests each child's
        // triangles with the probability that it crosses that child, its share of the
        // node's surface area. Triangles larger than the children gain nothing (they are
        // in every child they cross), which keeps big or crossing triangles from splitting
        // the map down to its last level.
        let share = surface_share(ccs, hi64 - lo64);
        let split_cost = 2.0 * STEP_COST + share * counts.iter().sum::<usize>() as f64;
        // And not when two or more children would each keep every triangle: then the
        // triangles all pass through one line or plane (zero-area or coincident
        // triangles, the line where planes meet), splitting never separates them, and the
        // cost estimate alone would split along it level after level (8 x 2^levels
        // cells). One child keeping them all is a small object in a large node: the split
        // isolates empty space and the next levels separate.
        let full = counts[..n_children].iter().filter(|&&c| c == len).count();
        if split_cost >= len as f64 || full >= 2 {
            sc.masks.truncate(mask_base);
            return leaf(out, sc);
        }
        // The children's lists side by side after this node's, at their counted sizes,
        // filled in one pass over the triangles.
        let list_base = sc.lists.len();
        let mut ranges = [(0usize, 0usize); 8];
        let mut cursor = [0usize; 8];
        let mut at = list_base;
        for i in 0..n_children {
            ranges[i] = (at, counts[i]);
            cursor[i] = at;
            at += counts[i];
        }
        sc.lists.resize(at, 0);
        for k in 0..len {
            let t = sc.lists[start + k];
            let mut m = sc.masks[mask_base + k];
            while m != 0 {
                let i = m.trailing_zeros() as usize;
                sc.lists[cursor[i]] = t;
                cursor[i] += 1;
                m &= m - 1;
            }
        }
        sc.masks.truncate(mask_base);
        let child_lo = |i: usize| {
            let i = i as u32;
            let b = [i % n[0], (i / n[0]) % n[1], i / (n[0] * n[1])];
            axes(|a| lo[a] + (b[a] << crem[a]))
        };
        let block = out.vmap.len();
        out.vmap.resize(block + n_children, 0);
        if len >= PAR_SPLIT {
            // Each child into tables of its own, in parallel, then appended in block order:
            // the layout the serial build makes.
            let built: Vec<(Flat, u32)> = ranges[..n_children]
                .par_iter()
                .enumerate()
                .map(|(i, &(s, l))| {
                    let mut sub = Scratch {
                        lists: sc.lists[s..s + l].to_vec(),
                        masks: Vec::new(),
                    };
                    let mut f = Flat::default();
                    let e = self.node(child_lo(i), crem, level + 1, (0, l), &mut f, &mut sub);
                    (f, e)
                })
                .collect();
            let entries = out.append(built);
            out.vmap[block..block + n_children].copy_from_slice(&entries);
        } else {
            for (i, &r) in ranges[..n_children].iter().enumerate() {
                out.vmap[block + i] = self.node(child_lo(i), crem, level + 1, r, out, sc);
            }
        }
        sc.lists.truncate(list_base);
        NODE | block as u32
    }
}

/// The probability that a ray crossing a box of extent `node` crosses a box of extent
/// `child` inside it: the ratio of their surface areas (half of each, which cancels).
fn surface_share(child: DVec3, node: DVec3) -> f64 {
    let sa = |e: DVec3| e.x * e.y + e.y * e.z + e.z * e.x;
    sa(child) / sa(node)
}

/// Sorts the `(top cell, triangle)` pairs by cell in parallel: per-cell ranges and the
/// list. Within a cell the order depends on the threads; the voxel-map build sorts each
/// cell's triangles ascending, which makes it that of [`counting_sort`] (a triangle meets
/// a cell once).
fn sort_pairs(n_top: usize, chunks: &[Vec<(u32, u32)>]) -> (Vec<CellRange>, Vec<AtomicU32>) {
    let count: Vec<AtomicU32> = (0..n_top)
        .into_par_iter()
        .map(|_| AtomicU32::new(0))
        .collect();
    chunks.par_iter().for_each(|c| {
        for &(cell, _) in c {
            count[cell as usize].fetch_add(1, Ordering::Relaxed);
        }
    });
    let mut total = 0u32;
    let ranges: Vec<CellRange> = count
        .iter()
        .map(|n| {
            let n = n.load(Ordering::Relaxed);
            let r = CellRange {
                offset: total,
                count: n,
            };
            total += n;
            r
        })
        .collect();
    // Reused as each cell's write cursor.
    count
        .par_iter()
        .zip(&ranges)
        .for_each(|(c, r)| c.store(r.offset, Ordering::Relaxed));
    let list: Vec<AtomicU32> = (0..total as usize)
        .into_par_iter()
        .map(|_| AtomicU32::new(0))
        .collect();
    chunks.par_iter().for_each(|c| {
        for &(cell, t) in c {
            let slot = count[cell as usize].fetch_add(1, Ordering::Relaxed);
            list[slot as usize].store(t, Ordering::Relaxed);
        }
    });
    (ranges, list)
}

fn build(scene: &Scene, cfg: &IrregularConfig) -> Result<IrregularGrid> {
    let start = Instant::now();
    let mut phases = IrregularPhases::default();
    let mut lap = Instant::now();
    let mut phase = |ms: &mut f64| {
        *ms += lap.elapsed().as_secs_f64() * 1e3;
        lap = Instant::now();
    };
    if !(cfg.top_density > 0.0 && cfg.top_density.is_finite()) {
        return Err(Error::Usage(format!(
            "irregular grid top density must be a positive finite number, got {}",
            cfg.top_density
        )));
    }
    if cfg.leaf_max == 0 {
        return Err(Error::Usage(
            "irregular grid leaf size must be at least 1 triangle".into(),
        ));
    }
    check_vertices(scene)?;
    let n_tris = scene.triangles.len();
    if n_tris >= MAX_REFERENCES {
        return Err(Error::Limit(format!(
            "{n_tris} triangles: the irregular grid indexes fewer than {MAX_REFERENCES}; \
             --accel bvh (CPU) has no such limit"
        )));
    }
    phase(&mut phases.setup_ms);
    // Gathered once: the bounds, the top level and every voxel-map level read the same
    // triangles (kept in f32; the conversion to f64 on use is exact).
    let tris: Vec<[Vec3; 3]> = (0..n_tris)
        .into_par_iter()
        .map(|t| scene.triangle_vertices(t))
        .collect();
    // Those of `Scene::bounds`, in parallel: minima and maxima of finite numbers are the
    // same in any order (but for the sign of a zero, which no later step can tell).
    let bounds = tris
        .par_iter()
        .map(|t| (t[0].min(t[1]).min(t[2]), t[0].max(t[1]).max(t[2])))
        .reduce_with(|a, b| (a.0.min(b.0), a.1.max(b.1)));
    phase(&mut phases.convert_ms);
    let (min, max, top_res) = match bounds {
        None => (Vec3::splat(-1.0), Vec3::splat(1.0), [1, 1, 1]),
        Some((lo, hi)) => {
            let (min, max) = padded_bounds(scene, lo, hi)?;
            let r = Grid::auto_resolution(max - min, n_tris, cfg.top_density);
            (min, max, r)
        }
    };
    let n_top = top_res.iter().map(|&r| r as usize).product::<usize>();
    check_top(n_top)?;
    let top_cs = (max - min).as_dvec3()
        / DVec3::new(top_res[0] as f64, top_res[1] as f64, top_res[2] as f64);
    let finest = finest_side(min, max);
    let (levels, shift) = schedule(top_cs, top_res, finest);
    let fine_res = axes(|a| top_res[a] << shift[a]);
    let fine_cs =
        (max - min) / Vec3::new(fine_res[0] as f32, fine_res[1] as f32, fine_res[2] as f32);
    let min64 = min.as_dvec3();
    let cs64 = fine_cs.as_dvec3();
    phase(&mut phases.setup_ms);

    // Top level: which top cells each triangle touches, chunk by chunk in triangle order.
    let top_frame = Frame::new(min64, top_cs, top_res, min64, max.as_dvec3());
    let chunks: Vec<Vec<(u32, u32)>> = tris
        .par_chunks(CHUNK)
        .enumerate()
        .map(|(k, ts)| {
            let mut pairs = Vec::with_capacity(ts.len() * 2);
            let mut cells = Vec::new();
            for (i, t) in ts.iter().enumerate() {
                cells.clear();
                top_frame.bin(t.map(|v| v.as_dvec3()), &mut cells);
                let t = (k * CHUNK + i) as u32;
                pairs.extend(cells.iter().map(|&c| (c, t)));
            }
            pairs
        })
        .collect();
    phase(&mut phases.top_bin_ms);
    let n_pairs: usize = chunks.iter().map(Vec::len).sum();
    let (top_ranges, top_list) = if rayon::current_num_threads() == 1 || n_pairs < SERIAL_SORT {
        // One thread, or few pairs: the serial sort, no atomics (the same order the sort
        // below leaves).
        let (r, l) = counting_sort(n_top, chunks.iter().flatten().copied());
        (r, l.into_iter().map(AtomicU32::new).collect())
    } else {
        sort_pairs(n_top, &chunks)
    };
    drop(chunks);
    phase(&mut phases.sort_ms);

    // Voxel map below every top cell, in parallel runs of top cells, each run built
    // straight into its own tables in the final layout; then the runs' tables assembled in
    // top-cell order.
    let ctx = Ctx {
        tris: &tris,
        levels: &levels,
        min: min64,
        cs: cs64,
        leaf_max: cfg.leaf_max as usize,
    };
    // Runs cut by references, not top cells, so a top cell holding much of the mesh (the
    // bunny beside a floor) is a run of its own that starts as soon as a thread is free;
    // and fine enough that the threads end together (RUNS_PER_THREAD).
    let per_run = (top_list.len() / (rayon::current_num_threads() * RUNS_PER_THREAD)).max(1);
    let mut cuts = vec![0];
    let mut acc = 0;
    for (i, r) in top_ranges.iter().enumerate() {
        acc += r.count as usize;
        if acc >= per_run {
            cuts.push(i + 1);
            acc = 0;
        }
    }
    if *cuts.last().expect("starts at 0") != n_top {
        cuts.push(n_top);
    }
    let runs: Vec<Flat> = cuts
        .par_windows(2)
        .map(|w| {
            let mut out = Flat::default();
            let mut sc = Scratch::default();
            for (j, r) in top_ranges[w[0]..w[1]].iter().enumerate() {
                let i = (w[0] + j) as u32;
                let t = [
                    i % top_res[0],
                    (i / top_res[0]) % top_res[1],
                    i / (top_res[0] * top_res[1]),
                ];
                let lo = axes(|a| t[a] << shift[a]);
                sc.lists.clear();
                sc.lists.extend(
                    top_list[r.offset as usize..(r.offset + r.count) as usize]
                        .iter()
                        .map(|t| t.load(Ordering::Relaxed)),
                );
                sc.lists.sort_unstable();
                let len = sc.lists.len();
                let e = ctx.node(lo, shift, 0, (0, len), &mut out, &mut sc);
                out.top.push(e);
            }
            out
        })
        .collect();
    drop(top_list);
    drop(tris);
    phase(&mut phases.voxel_map_ms);

    let n_vmap = n_top + runs.iter().map(|f| f.vmap.len()).sum::<usize>();
    let n_cells = runs.iter().map(|f| f.cells.len()).sum::<usize>();
    let n_refs = runs.iter().map(|f| f.refs.len()).sum::<usize>();
    check_sizes(n_tris, n_cells, n_vmap, n_refs)?;
    // Levels no node reached only make the virtual grid finer: drop them, scaling the
    // virtual coordinates down as the cells are written (every box is a multiple of the
    // dropped resolution; the world boundaries stay the same numbers, the cell size scaling
    // by powers of two).
    let deepest = runs.iter().map(|f| f.depth).max().unwrap_or(0);
    let mut levels = levels;
    levels.truncate(deepest);
    let used = axes(|a| levels.iter().filter(|m| m[a]).count() as u32);
    let dropped = axes(|a| shift[a] - used[a]);
    // Each run's stretch of the tables, in run order; filled in parallel.
    let vmap_at = offsets(runs.iter().map(|f| f.vmap.len()), n_top);
    let cell_at = offsets(runs.iter().map(|f| f.cells.len()), 0);
    let ref_at = offsets(runs.iter().map(|f| f.refs.len()), 0);
    let move_entry = |e: u32, k: usize| {
        if e & NODE != 0 {
            NODE | ((e & !NODE) + vmap_at[k] as u32)
        } else {
            e + cell_at[k] as u32
        }
    };
    let mut vmap = vec![0u32; n_vmap];
    // Written once, in parallel, straight into the table's room: `vec!` would write a
    // blank struct's copies on one thread first (zeros it gets from the allocator
    // untouched, as for the integer tables), a parallel blank fill one pass more.
    let mut cells: Vec<IrrCell> = Vec::with_capacity(n_cells);
    let mut list = vec![0u32; n_refs];
    let (top, below) = vmap.split_at_mut(n_top);
    let tops = split_lens(top, runs.iter().map(|f| f.top.len()));
    let belows = split_lens(below, runs.iter().map(|f| f.vmap.len()));
    let cell_runs = split_lens(
        &mut cells.spare_capacity_mut()[..n_cells],
        runs.iter().map(|f| f.cells.len()),
    );
    let list_runs = split_lens(&mut list, runs.iter().map(|f| f.refs.len()));
    let drop_box = |b: [u32; 3]| axes(|a| b[a] >> dropped[a]);
    runs.par_iter()
        .zip(tops)
        .zip(belows)
        .zip(cell_runs)
        .zip(list_runs)
        .enumerate()
        .for_each(|(k, ((((f, top), below), cells), list))| {
            for (d, &e) in top.iter_mut().zip(&f.top) {
                *d = move_entry(e, k);
            }
            for (d, &e) in below.iter_mut().zip(&f.vmap) {
                *d = move_entry(e, k);
            }
            for (d, c) in cells.iter_mut().zip(&f.cells) {
                let (lo, hi) = (drop_box(c.lo), drop_box(c.hi));
                d.write(IrrCell {
                    lo,
                    hi,
                    exit_lo: lo,
                    exit_hi: hi,
                    range: CellRange {
                        offset: c.range.offset + ref_at[k] as u32,
                        count: c.range.count,
                    },
                });
            }
            list.copy_from_slice(&f.refs);
        });
    // SAFETY: the runs' stretches tile the first `n_cells` places (their lengths sum to
    // it), and each run wrote every place of its stretch (one a cell of its table).
    unsafe { cells.set_len(n_cells) };
    drop(runs);
    phase(&mut phases.flatten_ms);

    let shift = used;
    let res = axes(|a| top_res[a] << shift[a]);
    let cell_size = (max - min) / Vec3::new(res[0] as f32, res[1] as f32, res[2] as f32);
    let mut g = IrregularGrid {
        min,
        max,
        top_res,
        levels,
        shift,
        res,
        cell_size,
        vmap,
        cells,
        tri_indices: list,
        stats: IrregularStats {
            build_ms: 0.0,
            expand_ms: 0.0,
            phases: IrregularPhases::default(),
            bytes: 0,
            bytes_per_triangle: 0.0,
            top_cells: n_top,
            vmap_entries: 0,
            levels: 0,
            cells: 0,
            empty_cells: 0,
            references: 0,
            mean_per_nonempty: 0.0,
            max_per_cell: 0,
            mean_growth: 0.0,
        },
    };
    let expand_start = Instant::now();
    let occ = Occupancy::new(&g);
    phase(&mut phases.occupancy_ms);
    // Every cell grows: an empty one over cells without triangles, one with triangles over
    // cells holding none but its own (`Rule::Within`). The latter is what a large triangle
    // needs: the equal-work view's 4x4 floor lies in thousands of cells, one of its two
    // triangles in each, and a ray grazing it stepped and tested cell after cell (25.3
    // steps per floor pixel, 9.07 cells and 10.6 tests per ray over the view); grown over
    // the cells of the same triangle, 11.0 steps, 5.67 cells and 7.57 tests, the H100's
    // kernel 8.80 -> 6.72 ms (docs/performance.md). Over empty neighbours alone (the
    // paper's expansion) it changed the bunny's 11.0 cells per ray by 0.1. Exit boxes are
    // written in place: the queries read the voxel map, the occupancy tables and the
    // cells' lists (`ranges`, copied), never the cell table, so it is taken out of the
    // grid while they ask.
    let ranges: Vec<CellRange> = g.cells.par_iter().map(|c| c.range).collect();
    let mut cells = std::mem::take(&mut g.cells);
    cells.par_chunks_mut(GROW_RUN).for_each(|run| {
        let mut recent = Recent::new(&occ);
        for c in run.iter_mut() {
            if c.range.count == 0 {
                (c.exit_lo, c.exit_hi) = grow(&g, &occ, c, &recent, Rule::Empty);
                recent.push(c.exit_lo, c.exit_hi);
            } else {
                let own = &g.tri_indices
                    [c.range.offset as usize..(c.range.offset + c.range.count) as usize];
                (c.exit_lo, c.exit_hi) = grow(
                    &g,
                    &occ,
                    c,
                    &recent,
                    Rule::Within {
                        ranges: &ranges,
                        own,
                    },
                );
            }
        }
    });
    drop(ranges);
    g.cells = cells;
    drop(occ);
    let vol = |lo: [u32; 3], hi: [u32; 3]| (0..3).map(|a| (hi[a] - lo[a]) as f64).product::<f64>();
    // The mean growth's logarithms summed in fixed runs of cells, then the runs in cell
    // order: the same figure on any thread count.
    let log_sum: f64 = g
        .cells
        .par_chunks(4096)
        .map(|run| {
            // A cell that kept its own box adds a logarithm of 0 (nothing, bit for bit),
            // so only the grown cells pay for `ln`.
            run.iter()
                .filter(|c| (c.exit_lo, c.exit_hi) != (c.lo, c.hi))
                .map(|c| (vol(c.exit_lo, c.exit_hi) / vol(c.lo, c.hi)).ln())
                .sum::<f64>()
        })
        .collect::<Vec<f64>>()
        .iter()
        .sum();
    let expand_ms = expand_start.elapsed().as_secs_f64() * 1e3;
    phase(&mut phases.grow_ms);

    let n_cells = g.cells.len();
    let (empty, max_per_cell) = g
        .cells
        .par_iter()
        .map(|c| ((c.range.count == 0) as usize, c.range.count))
        .reduce(|| (0, 0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    let refs = g.tri_indices.len();
    let growth = (log_sum / n_cells.max(1) as f64).exp();
    let bytes = g.vmap.len() * 4 + n_cells * 32 + refs * 4;
    phase(&mut phases.finish_ms);
    g.stats = IrregularStats {
        build_ms: start.elapsed().as_secs_f64() * 1e3,
        expand_ms,
        phases,
        bytes,
        bytes_per_triangle: if n_tris == 0 {
            0.0
        } else {
            bytes as f64 / n_tris as f64
        },
        top_cells: n_top,
        vmap_entries: g.vmap.len(),
        levels: g.levels.len(),
        cells: n_cells,
        empty_cells: empty,
        references: refs,
        mean_per_nonempty: if n_cells == empty {
            0.0
        } else {
            refs as f64 / (n_cells - empty) as f64
        },
        max_per_cell,
        mean_growth: growth,
    };
    Ok(g)
}

/// The finest cell side the split schedule may reach for a grid over `min..max`: the split
/// stops by triangle count long before this in a sane mesh; the floor keeps degenerate
/// clusters (many triangles through one point) from splitting down to nothing. The larger
/// of 2^-20 of the longest side and `MIN_CELL_ULPS` f32 ulps of the largest coordinate.
fn finest_side(min: Vec3, max: Vec3) -> f64 {
    let mag = min.abs().max(max.abs()).max_element() as f64;
    ((max - min).as_dvec3().max_element() * 2f64.powi(-20))
        .max(MIN_CELL_ULPS * mag * f32::EPSILON as f64)
}

/// Refuses a top grid of more than `MAX_ENTRIES` cells (the voxel map's first entries).
/// `Grid::auto_resolution` caps its grids at `MAX_AUTO_CELLS` (today the same number), so
/// this holds the line should either constant move.
fn check_top(n_top: usize) -> Result<()> {
    if n_top > MAX_ENTRIES {
        return Err(Error::Limit(format!(
            "{n_top} top cells, at most {MAX_ENTRIES}"
        )));
    }
    Ok(())
}

/// Refuses a structure whose cells, voxel-map entries or references exceed what its
/// entries and offsets hold (`MAX_CELLS`, `MAX_ENTRIES`, `MAX_REFERENCES`), before any
/// table is allocated. (What the GPU indexes is checked where it is packed.)
fn check_sizes(n_tris: usize, n_cells: usize, n_vmap: usize, n_refs: usize) -> Result<()> {
    if n_cells > MAX_CELLS || n_vmap > MAX_ENTRIES || n_refs > MAX_REFERENCES {
        return Err(Error::Limit(format!(
            "the irregular grid of {n_tris} triangles needs {n_cells} cells, {n_vmap} \
             voxel-map entries and {n_refs} triangle references, more than its {MAX_CELLS}, \
             {MAX_ENTRIES} and {MAX_REFERENCES}; a lower --grid-density, or --accel bvh (CPU)"
        )));
    }
    Ok(())
}

#[cfg(test)]
#[path = "irregular_tests.rs"]
mod tests;
