//! 3D-DDA grid traversal after Amanatides & Woo (1987), closest-hit and any-hit.
//! GLSL twins: `glsl120/traverse_init.frag`, `glsl120/traverse_step.frag` and
//! `glsl120/intersect.frag`, which run one step of this loop per pass.
//!
//! Deviation from the thesis, on purpose: the boundary parameter tMax of an axis is
//! recomputed from the cell index, `(min + (c + [d > 0]) * size - o) / d`, instead of
//! being accumulated with tDelta. Accumulation drifts by about one ulp per step, which after
//! hundreds of cells exceeds the conservative padding of the binning and lets hits on cell
//! faces be rejected; recomputation keeps the error to a few ulps at every step.

use super::intersect::{intersect_with, RayShear};
use super::real::{Real, V3};
use crate::accel::{CellRange, Grid};
use crate::technique::Techniques;

pub use crate::accel::TIE_EPS;

/// Clips the ray's interval to the box `min..max` (slabs): (t_enter, t_exit), or `None`
/// when it misses. A ±0 direction component makes its slab unbounded when the origin is
/// inside it. Every structure's walk starts with it (GLSL twin: `clip_grid`).
#[inline(always)]
pub fn clip_box<T: Real>(ray: &Ray<T>, min: V3<T>, max: V3<T>) -> Option<(T, T)> {
    let mut t0 = ray.t_min;
    let mut t1 = ray.t_max;
    for a in 0..3 {
        let d = ray.d[a];
        if d == T::ZERO {
            if ray.o[a] < min[a] || ray.o[a] > max[a] {
                return None;
            }
            continue;
        }
        let mut n = (min[a] - ray.o[a]) / d;
        let mut f = (max[a] - ray.o[a]) / d;
        if n > f {
            std::mem::swap(&mut n, &mut f);
        }
        t0 = t0.max(n);
        t1 = t1.min(f);
    }
    if t0 > t1 {
        None
    } else {
        Some((t0, t1))
    }
}

/// Upper bound for the next triangle test once a hit at `t_best` is held.
#[inline(always)]
pub fn tie_limit<T: Real>(t_best: T) -> T {
    t_best - t_best.abs() * T::from_f64(TIE_EPS)
}

/// A ray with its open parameter interval (t_min, t_max).
#[derive(Clone, Copy, Debug)]
pub struct Ray<T> {
    /// Origin.
    pub o: V3<T>,
    /// Direction (need not be unit length).
    pub d: V3<T>,
    /// Lower bound of the parameter interval.
    pub t_min: T,
    /// Upper bound of the parameter interval.
    pub t_max: T,
}

/// The closest hit of a ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit<T> {
    /// Ray parameter.
    pub t: T,
    /// Triangle index (load order).
    pub tri: u32,
    /// Barycentric weights of the triangle's vertices.
    pub b: [T; 3],
}

/// Work counters of one or more traversals (the `steps` AOV and the stats).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Work {
    /// Grid cells visited.
    pub cells: u64,
    /// Ray-triangle tests run.
    pub tests: u64,
}

/// Walks rays through the uniform grid (3D-DDA) and tests the triangles of each cell: the
/// scene's geometry and grid converted to the renderer's precision once per render. (Not an
/// acceleration structure of its own: it traverses [`crate::accel::Grid`].)
pub struct GridWalker<'a, T> {
    /// Vertices of every triangle, in load order.
    pub tris: Vec<[V3<T>; 3]>,
    /// Grid lower corner.
    pub min: V3<T>,
    /// Grid upper corner.
    pub max: V3<T>,
    /// Cell size per axis.
    pub cs: V3<T>,
    /// Cells per axis.
    pub res: [i32; 3],
    /// Per-cell (offset, count) table.
    pub cells: &'a [CellRange],
    /// Flat triangle-index list.
    pub list: &'a [u32],
    /// Intersection test and t bound used by every query.
    pub techniques: Techniques,
}

impl<'a, T: Real> GridWalker<'a, T> {
    /// Prepares a scene and its grid for traversal in precision `T`, default techniques.
    pub fn new(scene: &crate::scene::Scene, grid: &'a Grid) -> Self {
        Self::with_techniques(scene, grid, Techniques::default())
    }

    /// [`GridWalker::new`] with the intersection test and t bound of `techniques`.
    pub fn with_techniques(
        scene: &crate::scene::Scene,
        grid: &'a Grid,
        techniques: Techniques,
    ) -> Self {
        let tris = (0..scene.triangles.len())
            .map(|i| scene.triangle_vertices(i).map(V3::from_vec3))
            .collect();
        GridWalker {
            tris,
            min: V3::from_vec3(grid.min),
            max: V3::from_vec3(grid.max),
            cs: V3::from_vec3(grid.cell_size),
            res: grid.res.map(|r| r as i32),
            cells: &grid.cells,
            list: &grid.tri_indices,
            techniques,
        }
    }

    /// Parameter of the far boundary of cell `c` along `axis`; `BIG` when d is ±0.
    #[inline(always)]
    pub fn boundary(&self, ray: &Ray<T>, axis: usize, c: i32) -> T {
        let d = ray.d[axis];
        if d == T::ZERO {
            return T::BIG;
        }
        let k = if d > T::ZERO { c + 1 } else { c };
        (self.min[axis] + T::from_f32(k as f32) * self.cs[axis] - ray.o[axis]) / d
    }

    /// Clips the ray to the grid box: (t_enter, t_exit) or `None` when it misses.
    /// A ±0 direction component makes the slab unbounded when the origin is inside it.
    #[inline(always)]
    pub fn clip(&self, ray: &Ray<T>) -> Option<(T, T)> {
        clip_box(ray, self.min, self.max)
    }

    /// Starting cell of a ray entering at `t_enter`, clamped into the grid.
    #[inline(always)]
    pub fn start_cell(&self, ray: &Ray<T>, t_enter: T) -> [i32; 3] {
        let mut c = [0i32; 3];
        for (a, ca) in c.iter_mut().enumerate() {
            let p = ray.o[a] + ray.d[a] * t_enter;
            let f = ((p - self.min[a]) / self.cs[a]).floor().to_f64();
            *ca = (f.max(0.0) as i64).min(self.res[a] as i64 - 1) as i32;
        }
        c
    }
}

/// A cell-by-cell walk of an acceleration structure: everything a structure's walker
/// supplies ([`CellWalk::walk`] and its triangles, lists and techniques), from which the
/// queries every backend needs follow once, with one per-cell rule for all structures:
/// [`CellWalk::closest_hit`], [`CellWalk::any_hit`] and the brute-force oracle
/// [`CellWalk::brute_force`]. Implemented by [`GridWalker`], the irregular grid's
/// [`IrregularWalker`](super::traverse_irregular::IrregularWalker) and the renderer's
/// [`Walker`](super::walker::Walker), which dispatches to either.
pub trait CellWalk<T: Real> {
    /// Vertices of every triangle, in load order, in precision `T`.
    fn tris(&self) -> &[[V3<T>; 3]];

    /// The flat triangle-index list the cells' ranges point into.
    fn list(&self) -> &[u32];

    /// Intersection test and t bound used by every query.
    fn techniques(&self) -> &Techniques;

    /// Runs the walk, calling `visit(cell_range, t_exit)` for each cell in order until it
    /// returns true (stop) or the ray leaves the structure or its interval. Adds the cells
    /// visited to `work`.
    fn walk(&self, ray: &Ray<T>, work: &mut Work, visit: impl FnMut(CellRange, T) -> bool);

    /// Closest hit in (t_min, t_max). Per cell, the closest hit among the cell's triangles
    /// is found first (ties within [`TIE_EPS`] go to the lower index), then accepted only if
    /// it is not beyond the cell's exit (plus `gamma(8)` relative slack, which conservative
    /// binning covers); otherwise it is forgotten and the walk goes on, since a closer hit
    /// may lie in the next cell. Deciding on the cell's closest hit, not hit by hit, keeps
    /// coplanar duplicates from straddling the exit test differently on different backends.
    #[inline]
    fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        scalar_closest_hit(self, ray, work)
    }

    /// True when anything is hit in (t_min, t_max): the shadow-ray query.
    #[inline]
    fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        scalar_any_hit(self, ray, work)
    }

    /// The closest hit of each of `rays` into `hits`, each ray's work added to `work` (all
    /// three the same length): [`CellWalk::closest_hit`] ray after ray. A walker may step
    /// the rays as a stream instead, with the same results.
    fn closest_hits(&self, rays: &[Ray<T>], hits: &mut [Option<Hit<T>>], work: &mut [Work]) {
        for ((ray, hit), w) in rays.iter().zip(hits.iter_mut()).zip(work.iter_mut()) {
            *hit = self.closest_hit(ray, w);
        }
    }

    /// Whether each of `rays` hits anything, into `hit` (the same length), the work of all
    /// added to `work`: [`CellWalk::any_hit`] ray after ray, or a stream with the same
    /// results.
    fn any_hits(&self, rays: &[Ray<T>], hit: &mut [bool], work: &mut Work) {
        for (ray, h) in rays.iter().zip(hit.iter_mut()) {
            *h = self.any_hit(ray, work);
        }
    }

    /// Brute-force closest hit over all triangles with the same tie rule: the oracle for
    /// tests.
    fn brute_force(&self, ray: &Ray<T>) -> Option<Hit<T>> {
        brute_force(ray, self.tris(), self.techniques())
    }
}

/// The queries a renderer asks of whatever structure it renders over: the closest hit and
/// whether anything is hit, one ray or a batch at a time, and the triangles hits index.
/// The grids' walkers answer them through [`CellWalk`] (the renderer's
/// [`Walker`](super::walker::Walker) and the vectorised
/// [`SimdWalker`](super::simd_walk::SimdWalker)); the BVH's
/// [`BvhWalker`](super::traverse_bvh::BvhWalker), which has no cells to walk, directly.
pub trait Trace<T: Real>: Sync {
    /// Vertices of every triangle, in load order, in precision `T` (what `Hit::tri`
    /// indexes).
    fn tris(&self) -> &[[V3<T>; 3]];

    /// The closest hit in (t_min, t_max), its work added to `work`.
    fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>>;

    /// Whether anything is hit in (t_min, t_max): the shadow-ray query.
    fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool;

    /// The closest hit of each of `rays` into `hits`, each ray's work into `work` (all
    /// three the same length).
    fn closest_hits(&self, rays: &[Ray<T>], hits: &mut [Option<Hit<T>>], work: &mut [Work]) {
        for ((ray, hit), w) in rays.iter().zip(hits.iter_mut()).zip(work.iter_mut()) {
            *hit = self.closest_hit(ray, w);
        }
    }

    /// Whether each of `rays` hits anything, into `hit`, the work of all added to `work`.
    fn any_hits(&self, rays: &[Ray<T>], hit: &mut [bool], work: &mut Work) {
        for (ray, h) in rays.iter().zip(hit.iter_mut()) {
            *h = self.any_hit(ray, work);
        }
    }
}

/// [`Trace`] for a [`CellWalk`] type `$t` in precision `$real`: its own queries. Invoked
/// beside each walker the renderer takes (`walker.rs`, `simd_walk.rs`), so that this file
/// need not import them.
#[macro_export]
#[doc(hidden)]
macro_rules! trace_by_cell_walk {
    ($t:ty, $real:ty $(, $gen:ident)?) => {
        impl<$($gen: $crate::cpu::real::Real)?> $crate::cpu::traverse::Trace<$real> for $t {
            #[inline(always)]
            fn tris(&self) -> &[[$crate::cpu::real::V3<$real>; 3]] {
                $crate::cpu::traverse::CellWalk::tris(self)
            }
            #[inline(always)]
            fn closest_hit(
                &self,
                ray: &$crate::cpu::traverse::Ray<$real>,
                work: &mut $crate::cpu::traverse::Work,
            ) -> Option<$crate::cpu::traverse::Hit<$real>> {
                $crate::cpu::traverse::CellWalk::closest_hit(self, ray, work)
            }
            #[inline(always)]
            fn any_hit(
                &self,
                ray: &$crate::cpu::traverse::Ray<$real>,
                work: &mut $crate::cpu::traverse::Work,
            ) -> bool {
                $crate::cpu::traverse::CellWalk::any_hit(self, ray, work)
            }
            #[inline(always)]
            fn closest_hits(
                &self,
                rays: &[$crate::cpu::traverse::Ray<$real>],
                hits: &mut [Option<$crate::cpu::traverse::Hit<$real>>],
                work: &mut [$crate::cpu::traverse::Work],
            ) {
                $crate::cpu::traverse::CellWalk::closest_hits(self, rays, hits, work)
            }
            #[inline(always)]
            fn any_hits(
                &self,
                rays: &[$crate::cpu::traverse::Ray<$real>],
                hit: &mut [bool],
                work: &mut $crate::cpu::traverse::Work,
            ) {
                $crate::cpu::traverse::CellWalk::any_hits(self, rays, hit, work)
            }
        }
    };
}

/// [`CellWalk::closest_hit`] with the scalar per-cell step (`closest_of`): the default,
/// and what a walker overriding it (the vectorised one) falls back to.
#[inline(always)]
pub fn scalar_closest_hit<T: Real, W: CellWalk<T> + ?Sized>(
    w: &W,
    ray: &Ray<T>,
    work: &mut Work,
) -> Option<Hit<T>> {
    let shear = RayShear::new(ray.d);
    let (tris, list, techniques) = (w.tris(), w.list(), w.techniques());
    let mut found: Option<Hit<T>> = None;
    let slack = T::gamma(8);
    let mut tests = 0u64;
    w.walk(ray, work, |range, t_exit| {
        let limit = t_exit + t_exit.abs() * slack;
        let cell = cell_list(list, range).iter().copied();
        match closest_of(ray, &shear, tris, cell, techniques, &mut tests) {
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

/// [`CellWalk::any_hit`] with the scalar per-cell step (`any_of`).
#[inline(always)]
pub fn scalar_any_hit<T: Real, W: CellWalk<T> + ?Sized>(
    w: &W,
    ray: &Ray<T>,
    work: &mut Work,
) -> bool {
    let shear = RayShear::new(ray.d);
    let (tris, list, techniques) = (w.tris(), w.list(), w.techniques());
    let mut tests = 0u64;
    let mut found = false;
    w.walk(ray, work, |range, _| {
        let cell = cell_list(list, range).iter().copied();
        found = any_of(ray, &shear, tris, cell, techniques, &mut tests);
        found
    });
    work.tests += tests;
    found
}

impl<T: Real> CellWalk<T> for GridWalker<'_, T> {
    fn tris(&self) -> &[[V3<T>; 3]] {
        &self.tris
    }

    fn list(&self) -> &[u32] {
        self.list
    }

    fn techniques(&self) -> &Techniques {
        &self.techniques
    }

    /// Runs the DDA, calling `visit(cell_range, t_exit)` for each cell in order until it
    /// returns true (stop) or the ray leaves the grid or its interval.
    #[inline(always)]
    fn walk(&self, ray: &Ray<T>, work: &mut Work, mut visit: impl FnMut(CellRange, T) -> bool) {
        let Some((t_enter, t_leave)) = self.clip(ray) else {
            return;
        };
        let mut c = self.start_cell(ray, t_enter);
        let mut tn = [0, 1, 2].map(|a| self.boundary(ray, a, c[a]));
        loop {
            work.cells += 1;
            let t_exit = tn[0].min(tn[1]).min(tn[2]);
            let idx = c[0] + self.res[0] * (c[1] + self.res[1] * c[2]);
            if visit(self.cells[idx as usize], t_exit) {
                return;
            }
            if t_exit >= t_leave {
                return;
            }
            // Smallest boundary; ties go to the lower axis, as in the GLSL twin.
            let axis = if tn[0] <= tn[1] && tn[0] <= tn[2] {
                0
            } else if tn[1] <= tn[2] {
                1
            } else {
                2
            };
            c[axis] += if ray.d[axis] > T::ZERO { 1 } else { -1 };
            if c[axis] < 0 || c[axis] >= self.res[axis] {
                return;
            }
            tn[axis] = self.boundary(ray, axis, c[axis]);
        }
    }
}

/// The triangle indices of one cell's range of `list`.
#[inline(always)]
pub(crate) fn cell_list(list: &[u32], range: CellRange) -> &[u32] {
    &list[range.offset as usize..(range.offset + range.count) as usize]
}

/// The closest hit among triangles `cell` (indices into `tris`) in (t_min, t_max), ties
/// within [`TIE_EPS`] going to the earlier index: the per-cell step of every walker's
/// `closest_hit`. Adds the tests run to `tests`.
#[inline(always)]
pub(crate) fn closest_of<T: Real>(
    ray: &Ray<T>,
    shear: &RayShear<T>,
    tris: &[[V3<T>; 3]],
    cell: impl IntoIterator<Item = u32>,
    techniques: &Techniques,
    tests: &mut u64,
) -> Option<Hit<T>> {
    let mut best: Option<Hit<T>> = None;
    let mut t_best = ray.t_max;
    for tri in cell {
        *tests += 1;
        let hi = if best.is_some() {
            tie_limit(t_best)
        } else {
            t_best
        };
        if let Some(h) = intersect_with(
            ray.o,
            ray.d,
            shear,
            &tris[tri as usize],
            ray.t_min,
            hi,
            techniques,
        ) {
            t_best = h.t;
            best = Some(Hit {
                t: h.t,
                tri,
                b: h.b,
            });
        }
    }
    best
}

/// Whether any of triangles `cell` is hit in (t_min, t_max): the per-cell step of every
/// walker's `any_hit`. Adds the tests run to `tests`.
#[inline(always)]
pub(crate) fn any_of<T: Real>(
    ray: &Ray<T>,
    shear: &RayShear<T>,
    tris: &[[V3<T>; 3]],
    cell: impl IntoIterator<Item = u32>,
    techniques: &Techniques,
    tests: &mut u64,
) -> bool {
    for tri in cell {
        *tests += 1;
        let t = &tris[tri as usize];
        if intersect_with(ray.o, ray.d, shear, t, ray.t_min, ray.t_max, techniques).is_some() {
            return true;
        }
    }
    false
}

/// Brute-force closest hit over all of `tris` with the walkers' tie rule: the oracle.
pub fn brute_force<T: Real>(
    ray: &Ray<T>,
    tris: &[[V3<T>; 3]],
    techniques: &Techniques,
) -> Option<Hit<T>> {
    let shear = RayShear::new(ray.d);
    closest_of(ray, &shear, tris, 0..tris.len() as u32, techniques, &mut 0)
}

#[cfg(test)]
#[path = "traverse_tests.rs"]
mod tests;
