//! Closest-hit and any-hit traversal of the two-level grid ([`TwoLevelGrid`]), generic over
//! precision like `cpu/traverse.rs`, with the same per-cell semantics.
//!
//! The walk is two nested 3D-DDAs of the kind `cpu/traverse.rs` runs: the top-level DDA
//! over the top grid (boundaries recomputed from the cell index, ties to the lower axis),
//! and, in each non-empty top cell entered at `t_in` and left at `t_out`, a DDA over that
//! cell's sub-grid: `[t_in, t_out]` is clipped to the sub-grid's box (a miss skips the top
//! cell), the walk starts at the leaf holding `o + d * t0` for the clipped start `t0`
//! (clamped into the sub-grid) and stops once a leaf's exit reaches `t_out` or the index
//! leaves the sub-grid. Each leaf is decided as `closest_hit` in `cpu/traverse.rs` decides
//! a cell: the leaf's closest hit (ties within `TIE_EPS` to the lower index) is accepted
//! only if it is within `min(leaf exit, t_out)` plus `gamma(8)` relative slack.
//! `Work::cells` counts top cells and leaf cells alike.
//!
//! # Mapping to the GLSL 1.20 multipass kernel (GeForce 6/7: 4 draw buffers)
//!
//! The loop does one DDA step per iteration and keeps no state beyond what fits in the
//! four RGBA32F ray-state textures the uniform kernel already uses:
//! - `s0 = (origin, state)`, `s1 = (direction, t_max)` as today;
//! - `s2 = (top cell, leaf cell, list index, list end)`, both cells as flat indices
//!   (`x + rx * (y + ry * z)`, exact below 2^24, decoded with `floor`/`mod`), the leaf
//!   index relative to the sub-grid's `leaf_base`;
//! - `s3 = (t_best, tri_best, steps, spare)`.
//!
//! No t value needs storing: the top exit is recomputed from the top cell index, a leaf's
//! exit from the leaf index and the sub-grid's stored corner and cell size, and `t_in`
//! (the previous top exit, or the grid entry) and the box clip are only needed in the pass
//! that enters a top cell.
//! States: `TRAVERSING_TOP` (one top DDA step; on entering a non-empty top cell, compute
//! the start leaf and go to `TESTING` or `TRAVERSING_LEAF`), `TRAVERSING_LEAF` (one leaf
//! DDA step; leaving the sub-grid or reaching the top exit goes back to `TRAVERSING_TOP`),
//! `TESTING` (one triangle test; at the list end accept the leaf's best hit if it is
//! within the exit limit, else back to `TRAVERSING_LEAF`), plus `DONE`/`INVALID` as today.
//! Textures read: the top table (one float per top cell: sub-grid index or -1), the
//! sub-grid table (three texels each: `leaf_base, r`; `lo`; `sub`), the
//! leaf table (`offset, count`, two leaves per texel), the triangle list (four per texel)
//! and the triangles, as the uniform kernel reads its cell table, list and triangles.

use super::intersect::RayShear;
use super::real::{Real, V3};
use super::traverse::{any_of, brute_force, cell_list, clip_box, closest_of, Hit, Ray, Work};
use crate::accel::two_level::{SubGrid, TwoLevelGrid, EMPTY_TOP};
use crate::accel::CellRange;
use crate::scene::Scene;
use crate::technique::Techniques;

/// A scene and its two-level grid converted to precision `T` once per render.
pub struct TwoLevelWalker<'a, T> {
    /// Vertices of every triangle, in load order.
    pub tris: Vec<[V3<T>; 3]>,
    /// Top grid lower corner.
    pub min: V3<T>,
    /// Top grid upper corner.
    pub max: V3<T>,
    /// Top cell size per axis.
    pub cs: V3<T>,
    /// Top cells per axis.
    pub res: [i32; 3],
    /// Per top cell: index into `subgrids` or `EMPTY_TOP`.
    pub top: &'a [u32],
    /// Per non-empty top cell: leaf base and sub-grid frame.
    pub subgrids: &'a [SubGrid],
    /// Per leaf: range of `list`.
    pub leaves: &'a [CellRange],
    /// Flat triangle-index list.
    pub list: &'a [u32],
    /// Intersection test and t bound used by every query.
    pub techniques: Techniques,
}

/// Smallest of three boundaries and its axis; ties go to the lower axis.
#[inline(always)]
fn min_axis<T: Real>(tn: &[T; 3]) -> (T, usize) {
    if tn[0] <= tn[1] && tn[0] <= tn[2] {
        (tn[0], 0)
    } else if tn[1] <= tn[2] {
        (tn[1], 1)
    } else {
        (tn[2], 2)
    }
}

/// Parameter of the far boundary of cell `c` of a frame starting at `lo` with cell size
/// `cs` along `axis`; `BIG` when d is ±0. The same expression for both levels.
#[inline(always)]
fn far_boundary<T: Real>(ray: &Ray<T>, lo: T, cs: T, axis: usize, c: i32) -> T {
    let d = ray.d[axis];
    if d == T::ZERO {
        return T::BIG;
    }
    let k = if d > T::ZERO { c + 1 } else { c };
    (lo + T::from_f32(k as f32) * cs - ray.o[axis]) / d
}

/// Cell of a frame (`lo`, `cs`, `res`) holding the ray's point at `t`, clamped.
#[inline(always)]
fn cell_at<T: Real>(ray: &Ray<T>, t: T, lo: &[T; 3], cs: &[T; 3], res: &[i32; 3]) -> [i32; 3] {
    let mut c = [0i32; 3];
    for (a, ca) in c.iter_mut().enumerate() {
        let p = ray.o[a] + ray.d[a] * t;
        let f = ((p - lo[a]) / cs[a]).floor().to_f64();
        *ca = (f.max(0.0) as i64).min(res[a] as i64 - 1) as i32;
    }
    c
}

impl<'a, T: Real> TwoLevelWalker<'a, T> {
    /// Prepares `scene` and its two-level grid for traversal in precision `T`.
    pub fn new(scene: &Scene, grid: &'a TwoLevelGrid, techniques: Techniques) -> Self {
        let tris = (0..scene.triangles.len())
            .map(|i| scene.triangle_vertices(i).map(V3::from_vec3))
            .collect();
        TwoLevelWalker {
            tris,
            min: V3::from_vec3(grid.min),
            max: V3::from_vec3(grid.max),
            cs: V3::from_vec3(grid.cell_size),
            res: grid.res.map(|r| r as i32),
            top: &grid.top,
            subgrids: &grid.subgrids,
            leaves: &grid.leaves,
            list: &grid.tri_indices,
            techniques,
        }
    }

    /// Clips the ray to the grid box: (t_enter, t_exit) or `None` when it misses.
    #[inline(always)]
    fn clip(&self, ray: &Ray<T>) -> Option<(T, T)> {
        clip_box(ray, self.min, self.max)
    }

    /// Runs the nested DDA, calling `visit(leaf_range, exit_limit)` for each leaf in order
    /// until it returns true (stop) or the ray leaves the grid or its interval.
    #[inline(always)]
    fn walk(&self, ray: &Ray<T>, work: &mut Work, mut visit: impl FnMut(CellRange, T) -> bool) {
        let Some((t_enter, t_leave)) = self.clip(ray) else {
            return;
        };
        let min = [self.min.x, self.min.y, self.min.z];
        let cs = [self.cs.x, self.cs.y, self.cs.z];
        let mut c = cell_at(ray, t_enter, &min, &cs, &self.res);
        let mut tn = [0, 1, 2].map(|a| far_boundary(ray, min[a], cs[a], a, c[a]));
        let mut t_in = t_enter;
        loop {
            work.cells += 1;
            let (t_out, axis) = min_axis(&tn);
            let top = self.top[(c[0] + self.res[0] * (c[1] + self.res[1] * c[2])) as usize];
            if top != EMPTY_TOP {
                let sub = &self.subgrids[top as usize];
                if self.walk_leaves(ray, sub, t_in, t_out, work, &mut visit) {
                    return;
                }
            }
            if t_out >= t_leave {
                return;
            }
            c[axis] += if ray.d[axis] > T::ZERO { 1 } else { -1 };
            if c[axis] < 0 || c[axis] >= self.res[axis] {
                return;
            }
            tn[axis] = far_boundary(ray, min[axis], cs[axis], axis, c[axis]);
            t_in = t_out;
        }
    }

    /// The sub-grid DDA of a top cell over `[t_in, t_out]`; true when `visit` stopped.
    #[inline(always)]
    fn walk_leaves(
        &self,
        ray: &Ray<T>,
        top: &SubGrid,
        t_in: T,
        t_out: T,
        work: &mut Work,
        visit: &mut impl FnMut(CellRange, T) -> bool,
    ) -> bool {
        let r = top.res.map(|v| v as i32);
        let lo = [0, 1, 2].map(|a| T::from_f32(top.lo[a]));
        let cs = [0, 1, 2].map(|a| T::from_f32(top.sub[a]));
        // Clip [t_in, t_out] to the sub-grid box lo .. lo + r * cs.
        let mut t0 = t_in;
        let mut t1 = t_out;
        for a in 0..3 {
            let hi = lo[a] + T::from_f32(r[a] as f32) * cs[a];
            let d = ray.d[a];
            if d == T::ZERO {
                if ray.o[a] < lo[a] || ray.o[a] > hi {
                    return false;
                }
                continue;
            }
            let mut n = (lo[a] - ray.o[a]) / d;
            let mut f = (hi - ray.o[a]) / d;
            if n > f {
                std::mem::swap(&mut n, &mut f);
            }
            t0 = t0.max(n);
            t1 = t1.min(f);
        }
        if t0 > t1 {
            return false;
        }
        let mut l = cell_at(ray, t0, &lo, &cs, &r);
        let mut tn = [0, 1, 2].map(|a| far_boundary(ray, lo[a], cs[a], a, l[a]));
        loop {
            work.cells += 1;
            let (t_exit, axis) = min_axis(&tn);
            let idx = top.leaf_base as i32 + l[0] + r[0] * (l[1] + r[1] * l[2]);
            if visit(self.leaves[idx as usize], t_exit.min(t_out)) {
                return true;
            }
            if t_exit >= t_out {
                return false;
            }
            l[axis] += if ray.d[axis] > T::ZERO { 1 } else { -1 };
            if l[axis] < 0 || l[axis] >= r[axis] {
                return false;
            }
            tn[axis] = far_boundary(ray, lo[axis], cs[axis], axis, l[axis]);
        }
    }

    /// Closest hit in (t_min, t_max), with the per-cell rule of
    /// [`GridWalker::closest_hit`](super::traverse::GridWalker::closest_hit) applied per leaf
    /// (see the module docs).
    pub fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        let shear = RayShear::new(ray.d);
        let mut found: Option<Hit<T>> = None;
        let slack = T::gamma(8);
        let mut tests = 0u64;
        self.walk(ray, work, |range, t_exit| {
            let limit = t_exit + t_exit.abs() * slack;
            let cell = cell_list(self.list, range).iter().copied();
            match closest_of(ray, &shear, &self.tris, cell, &self.techniques, &mut tests) {
                Some(h) if h.t <= limit => {
                    found = Some(h);
                    true
                }
                _ => false,
            }
        });
        work.tests += tests;
        found
    }

    /// True when anything is hit in (t_min, t_max): the shadow-ray query.
    pub fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        let shear = RayShear::new(ray.d);
        let mut tests = 0u64;
        let mut found = false;
        self.walk(ray, work, |range, _| {
            let cell = cell_list(self.list, range).iter().copied();
            found = any_of(ray, &shear, &self.tris, cell, &self.techniques, &mut tests);
            found
        });
        work.tests += tests;
        found
    }

    /// Brute-force closest hit over all triangles with the same tie rule: the oracle.
    pub fn brute_force(&self, ray: &Ray<T>) -> Option<Hit<T>> {
        brute_force(ray, &self.tris, &self.techniques)
    }
}

#[cfg(test)]
#[path = "traverse_two_level_tests.rs"]
pub(crate) mod tests;
