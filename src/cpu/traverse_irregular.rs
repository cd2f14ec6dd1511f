//! Closest-hit and any-hit traversal of the irregular grid ([`IrregularGrid`]), generic
//! over precision like `cpu/traverse.rs`, with the same per-cell semantics.
//! GLSL twins: `irregular_start`/`irregular_next`/`irregular_exit` in
//! `glsl120/traverse.glsl`, run one step per pass by `traverse_init.frag`,
//! `traverse_step.frag` and `intersect.frag` (and unrolled or looped by the fast kernels).
//!
//! One step: the ray leaves the current cell through its exit box at
//! `t_exit = min over axes of (min + k * cell_size - o) / d` (`k` the box's far face on
//! that axis: the expression of the uniform DDA, so the same rounding), ties to the lower
//! axis. The next virtual cell is, on the exit axis, the first one beyond the face; on the
//! other axes the one holding `o + d * t_exit`, clamped into the exit box's range (the exit
//! point lies on that face, so the clamp only absorbs rounding and guarantees progress).
//! The voxel map gives the cell holding it. A cell's closest hit is accepted when it is
//! within `t_exit` plus `gamma(8)` relative slack, as [`CellWalk::closest_hit`]
//! accepts a cell's; the exit box holds no other triangle, so nothing closer can follow.
//! `Work::cells` counts steps.

use super::real::{Real, V3};
use super::traverse::{clip_box, CellWalk, Ray, Work};
use crate::accel::irregular::{IrrCell, IrregularGrid};
use crate::accel::CellRange;
use crate::scene::Scene;
use crate::technique::Techniques;

/// Most steps of one walk: a safety net, never reached by a walk that makes progress (each
/// step leaves an exit box for a cell beyond its face).
pub const MAX_STEPS: u64 = 1 << 20;

/// A scene and its irregular grid converted to precision `T` once per render.
pub struct IrregularWalker<'a, T> {
    /// Vertices of every triangle, in load order.
    pub tris: Vec<[V3<T>; 3]>,
    /// Grid lower corner.
    pub min: V3<T>,
    /// Grid upper corner.
    pub max: V3<T>,
    /// Virtual cell size.
    pub cs: V3<T>,
    /// The grid (voxel map, cells, lists).
    pub grid: &'a IrregularGrid,
    /// Intersection test and t bound used by every query.
    pub techniques: Techniques,
}

impl<'a, T: Real> IrregularWalker<'a, T> {
    /// Prepares `scene` and its irregular grid for traversal in precision `T`.
    pub fn new(scene: &Scene, grid: &'a IrregularGrid, techniques: Techniques) -> Self {
        let tris = (0..scene.triangles.len())
            .map(|i| scene.triangle_vertices(i).map(V3::from_vec3))
            .collect();
        IrregularWalker {
            tris,
            min: V3::from_vec3(grid.min),
            max: V3::from_vec3(grid.max),
            cs: V3::from_vec3(grid.cell_size),
            grid,
            techniques,
        }
    }

    /// Clips the ray to the grid box: (t_enter, t_exit) or `None` when it misses.
    #[inline(always)]
    fn clip(&self, ray: &Ray<T>) -> Option<(T, T)> {
        clip_box(ray, self.min, self.max)
    }

    /// Virtual cell of the ray's point at `t` on `axis`, clamped into `lo ..= hi`.
    #[inline(always)]
    fn virtual_at(&self, ray: &Ray<T>, t: T, axis: usize, lo: u32, hi: u32) -> u32 {
        let p = ray.o[axis] + ray.d[axis] * t;
        let f = ((p - self.min[axis]) / self.cs[axis]).floor().to_f64();
        (f.max(lo as f64) as u32).min(hi)
    }

    /// Parameter at which the ray crosses virtual boundary `k` of `axis` (d != 0): the
    /// expression of [`IrregularWalker::exit`] and of the uniform DDA.
    #[inline(always)]
    fn crossing(&self, ray: &Ray<T>, axis: usize, k: u32) -> T {
        (self.min[axis] + T::from_f32(k as f32) * self.cs[axis] - ray.o[axis]) / ray.d[axis]
    }

    /// Virtual cell on a lateral `axis` at the exit parameter `t`, within `lo ..= hi`: the
    /// cell of the exit point, then moved (at most two cells each way) until its own
    /// crossings bracket `t`, so the choice agrees with the crossing parameters the next
    /// exits are computed from. The point alone can be a cell off where rounding of
    /// `o + d * t` meets a boundary, and then two cells can hand the ray back and forth.
    #[inline(always)]
    pub(crate) fn lateral(&self, ray: &Ray<T>, t: T, axis: usize, lo: u32, hi: u32) -> u32 {
        let mut k = self.virtual_at(ray, t, axis, lo, hi);
        let d = ray.d[axis];
        if d == T::ZERO {
            return k;
        }
        // Entering boundary of cell k: its lower face when d > 0, else its upper one.
        let (enter, leave) = if d > T::ZERO { (0, 1) } else { (1, 0) };
        for _ in 0..2 {
            if d > T::ZERO && k > lo && self.crossing(ray, axis, k + enter) > t {
                k -= 1;
            } else if d < T::ZERO && k < hi && self.crossing(ray, axis, k + enter) > t {
                k += 1;
            }
        }
        for _ in 0..2 {
            if d > T::ZERO && k < hi && self.crossing(ray, axis, k + leave) <= t {
                k += 1;
            } else if d < T::ZERO && k > lo && self.crossing(ray, axis, k + leave) <= t {
                k -= 1;
            }
        }
        k
    }

    /// Exit parameter of `cell`'s exit box and the axis it leaves through (ties to the
    /// lower axis); `BIG` on an axis the ray does not move along, and `t_prev` (the
    /// previous exit) on a face the ray crossed before it: exits never go back in t, so the
    /// walk cannot cycle even where the GPU evaluates one crossing two ways (an fma here,
    /// a multiply-add there), and the ray, already past that face, leaves through it at
    /// once. Treating such a face as never crossed (`BIG`, as before) kept the walk in the
    /// cell until a later face and skipped the cells between: on the H200, whose fused
    /// multiply-add rounds `min + k * cs` otherwise than the CPU, rays starting on faces
    /// missed triangles (hard case 08/09). With the bracketed start and lateral choices
    /// no such face arises in IEEE arithmetic, so the CPU's walk is the same either way.
    #[inline(always)]
    pub fn exit(&self, ray: &Ray<T>, cell: &IrrCell, t_prev: T) -> (T, usize) {
        let tn = [0, 1, 2].map(|a| {
            let d = ray.d[a];
            if d == T::ZERO {
                return T::BIG;
            }
            let k = if d > T::ZERO {
                cell.exit_hi[a]
            } else {
                cell.exit_lo[a]
            };
            let t = (self.min[a] + T::from_f32(k as f32) * self.cs[a] - ray.o[a]) / d;
            if t < t_prev {
                t_prev
            } else {
                t
            }
        });
        if tn[0] <= tn[1] && tn[0] <= tn[2] {
            (tn[0], 0)
        } else if tn[1] <= tn[2] {
            (tn[1], 1)
        } else {
            (tn[2], 2)
        }
    }
}

impl<T: Real> CellWalk<T> for IrregularWalker<'_, T> {
    fn tris(&self) -> &[[V3<T>; 3]] {
        &self.tris
    }

    fn list(&self) -> &[u32] {
        &self.grid.tri_indices
    }

    fn techniques(&self) -> &Techniques {
        &self.techniques
    }

    /// Runs the walk, calling `visit(cell_range, t_exit)` for each cell in order until it
    /// returns true (stop) or the ray leaves the grid or its interval.
    #[inline(always)]
    fn walk(&self, ray: &Ray<T>, work: &mut Work, mut visit: impl FnMut(CellRange, T) -> bool) {
        let Some(mut st) = self.start(ray) else {
            return;
        };
        loop {
            work.cells += 1;
            let cell = &self.grid.cells[st.id as usize];
            let (t_exit, axis) = self.exit(ray, cell, st.t_prev);
            if visit(cell.range, t_exit) || !self.advance(ray, &mut st, cell, t_exit, axis) {
                return;
            }
        }
    }
}

/// Where one walk of the irregular grid stands: the cell it is in and what the next step
/// needs. The walk as resumable steps ([`IrregularWalker::start`],
/// [`IrregularWalker::advance`]), so that a stream of rays can be stepped in turn
/// (`cpu/simd_walk.rs`) by the same code as one ray's walk.
#[derive(Clone, Copy, Debug)]
pub struct WalkState<T> {
    /// The current cell.
    pub id: u32,
    /// The previous cell's exit parameter (the entry parameter at the start).
    pub t_prev: T,
    /// Where the ray leaves the grid box or its interval.
    pub t_leave: T,
    /// Steps taken.
    pub steps: u64,
}

impl<T: Real> IrregularWalker<'_, T> {
    /// The walk's first cell, or `None` when the ray misses the grid box: the one holding
    /// the virtual cell whose crossings bracket the entry parameter, chosen as after an
    /// exit (`IrregularWalker::lateral`). The entry point's own cell can be one off where
    /// the ray starts on a face (rounding of `(o - min) / cs`).
    #[inline(always)]
    pub fn start(&self, ray: &Ray<T>) -> Option<WalkState<T>> {
        let (t_enter, t_leave) = self.clip(ray)?;
        let g = self.grid;
        let k = [0, 1, 2].map(|a| self.lateral(ray, t_enter, a, 0, g.res[a] - 1));
        Some(WalkState {
            id: g.lookup(k),
            t_prev: t_enter,
            t_leave,
            steps: 0,
        })
    }

    /// Steps from `cell` (the state's current cell), left at `t_exit` through `axis`
    /// ([`IrregularWalker::exit`]), to the next one; false when the walk ends there: the
    /// ray leaves its interval or the grid, or [`MAX_STEPS`] are taken.
    #[inline(always)]
    pub fn advance(
        &self,
        ray: &Ray<T>,
        st: &mut WalkState<T>,
        cell: &IrrCell,
        t_exit: T,
        axis: usize,
    ) -> bool {
        if t_exit >= st.t_leave {
            return false;
        }
        match self.next_cell(ray, cell, t_exit, axis) {
            Some(k) => self.enter(st, k, t_exit),
            None => false,
        }
    }

    /// The virtual cell the ray enters after leaving `cell` at `t_exit` through `axis`, or
    /// `None` when it leaves the grid there.
    #[inline(always)]
    pub fn next_cell(
        &self,
        ray: &Ray<T>,
        cell: &IrrCell,
        t_exit: T,
        axis: usize,
    ) -> Option<[u32; 3]> {
        let g = self.grid;
        let mut k = [0u32; 3];
        for (a, ka) in k.iter_mut().enumerate() {
            *ka = if a != axis {
                self.lateral(ray, t_exit, a, cell.exit_lo[a], cell.exit_hi[a] - 1)
            } else if ray.d[a] > T::ZERO {
                if cell.exit_hi[a] >= g.res[a] {
                    return None;
                }
                cell.exit_hi[a]
            } else {
                if cell.exit_lo[a] == 0 {
                    return None;
                }
                cell.exit_lo[a] - 1
            };
        }
        Some(k)
    }

    /// Moves the walk into the cell holding virtual cell `k`, entered at `t_exit`; false
    /// once [`MAX_STEPS`] are taken.
    #[inline(always)]
    pub fn enter(&self, st: &mut WalkState<T>, k: [u32; 3], t_exit: T) -> bool {
        st.id = self.grid.lookup(k);
        st.t_prev = t_exit;
        st.steps += 1;
        st.steps < MAX_STEPS
    }
}

#[cfg(test)]
#[path = "traverse_irregular_tests.rs"]
mod tests;
