//! The vectorised f32 walk (`--cpu-path simd`, the default for `--precision f32`): the
//! structure's own cell walk (the [`Walker`] of either grid), with each cell's triangles
//! tested 8 or 4 at a time from a structure-of-arrays copy ([`SoaTris`], `cpu/simd.rs`).
//! Not a GLSL twin: the scalar f32 walk (`--cpu-path scalar`) stays the twin of the GLSL,
//! and this one takes the same decisions: the same cells in the same order (the walk is
//! the scalar one), the same per-cell closest hit under the same tie rule, the same
//! acceptance against the cell's exit, bit for bit the same t and barycentrics, and the
//! same work counters (tests are counted as the scalar loop runs them: every reference of a
//! cell for a closest hit, up to the first hit for an any-hit query). The tests compare
//! every query with the scalar walk on random soups, and whole renders of every shipped
//! scene image for image (`tests/cpu_simd.rs`).
//!
//! Möller-Trumbore (`--intersect moller-trumbore`) has no vector kernel: with it, and on
//! CPUs without SSE2 (not x86-64), the walker runs the scalar per-cell step and reports
//! [`Isa::Scalar`].

use super::real::{Real, V3};
use super::simd::{self, Best, Isa, RayConsts};
#[cfg(target_arch = "x86_64")]
use super::simd_step;
use super::simd_step::Lanes8;
use super::soa::SoaTris;
use super::traverse::{scalar_any_hit, scalar_closest_hit, CellWalk, Hit, Ray, Work};
use super::traverse_irregular::{IrregularWalker, WalkState};
use super::walker::Walker;
use crate::accel::irregular::IrrCell;
use crate::accel::{CellRange, GridRef};
use crate::scene::Scene;
use crate::technique::{IntersectMethod, Techniques};

/// The render's structure walked in f32 with vectorised triangle tests.
pub struct SimdWalker<'a> {
    walker: Walker<'a, f32>,
    soa: SoaTris,
    isa: Isa,
}

impl<'a> SimdWalker<'a> {
    /// Prepares `scene` and `grid` with the widest kernel this CPU runs.
    pub fn new(scene: &Scene, grid: GridRef<'a>, techniques: Techniques) -> Self {
        Self::with_isa(scene, grid, techniques, Isa::detect())
    }

    /// [`SimdWalker::new`] with kernel `isa` (tests run each one). Panics when this CPU
    /// cannot run it.
    pub fn with_isa(scene: &Scene, grid: GridRef<'a>, techniques: Techniques, isa: Isa) -> Self {
        assert!(
            isa.available(),
            "this CPU cannot run the {} kernel",
            isa.name()
        );
        let walker = Walker::new(scene, grid, techniques);
        let isa = if techniques.intersect == IntersectMethod::Watertight {
            isa
        } else {
            Isa::Scalar
        };
        let soa = if isa == Isa::Scalar {
            SoaTris::new(&[], &[])
        } else {
            SoaTris::new(walker.tris(), walker.list())
        };
        SimdWalker { walker, soa, isa }
    }

    /// The kernel the queries run.
    pub fn isa(&self) -> Isa {
        self.isa
    }

    /// The kernels' constants for `ray`.
    #[inline(always)]
    fn consts(&self, ray: &Ray<f32>) -> RayConsts {
        RayConsts::of_ray(ray, self.walker.techniques())
    }
}

impl CellWalk<f32> for SimdWalker<'_> {
    fn tris(&self) -> &[[V3<f32>; 3]] {
        self.walker.tris()
    }

    fn list(&self) -> &[u32] {
        self.walker.list()
    }

    fn techniques(&self) -> &Techniques {
        self.walker.techniques()
    }

    #[inline(always)]
    fn walk(&self, ray: &Ray<f32>, work: &mut Work, visit: impl FnMut(CellRange, f32) -> bool) {
        self.walker.walk(ray, work, visit)
    }

    /// [`CellWalk::closest_hit`], the cell's triangles tested by the vector kernel.
    #[inline]
    fn closest_hit(&self, ray: &Ray<f32>, work: &mut Work) -> Option<Hit<f32>> {
        if self.isa == Isa::Scalar {
            return scalar_closest_hit(self, ray, work);
        }
        let rc = self.consts(ray);
        let mut found = None;
        let mut tests = 0u64;
        self.walker.walk(ray, work, |range, t_exit| {
            tests += range.count as u64;
            found = self.cell_closest(&rc, range, t_exit);
            found.is_some()
        });
        work.tests += tests;
        found
    }

    /// [`CellWalk::any_hit`], the cell's triangles tested by the vector kernel.
    #[inline]
    fn any_hit(&self, ray: &Ray<f32>, work: &mut Work) -> bool {
        if self.isa == Isa::Scalar {
            return scalar_any_hit(self, ray, work);
        }
        let rc = self.consts(ray);
        let mut tests = 0u64;
        let mut found = false;
        self.walker.walk(ray, work, |range, _| {
            found = self.cell_any(&rc, range, &mut tests);
            found
        });
        work.tests += tests;
        found
    }

    /// On the irregular grid, the rays stepped as a stream ([`STREAM`] at a time, one cell
    /// each in turn); ray after ray otherwise.
    fn closest_hits(&self, rays: &[Ray<f32>], hits: &mut [Option<Hit<f32>>], work: &mut [Work]) {
        match &self.walker {
            Walker::Irregular(w) if self.isa != Isa::Scalar => {
                self.closest_stream(w, rays, hits, work)
            }
            _ => {
                for ((ray, hit), wk) in rays.iter().zip(hits.iter_mut()).zip(work.iter_mut()) {
                    *hit = self.closest_hit(ray, wk);
                }
            }
        }
    }

    /// On the irregular grid, the rays stepped as a stream; ray after ray otherwise.
    fn any_hits(&self, rays: &[Ray<f32>], hit: &mut [bool], work: &mut Work) {
        match &self.walker {
            Walker::Irregular(w) if self.isa != Isa::Scalar => self.any_stream(w, rays, hit, work),
            _ => {
                for (ray, h) in rays.iter().zip(hit.iter_mut()) {
                    *h = self.any_hit(ray, work);
                }
            }
        }
    }
}

crate::trace_by_cell_walk!(SimdWalker<'_>, f32);

/// Rays stepped together by the streams: enough independent walks for the CPU to overlap
/// one ray's dependent loads and divisions with the others'.
pub const STREAM: usize = 8;

/// One ray of a stream: its index, walk and kernel constants.
#[derive(Clone, Copy)]
struct Lane {
    i: usize,
    st: WalkState<f32>,
    rc: RayConsts,
}

impl SimdWalker<'_> {
    /// The per-cell step of [`CellWalk::closest_hit`]: the cell's closest hit when it is
    /// within `t_exit` plus `gamma(8)` relative slack.
    #[inline(always)]
    fn cell_closest(&self, rc: &RayConsts, range: CellRange, t_exit: f32) -> Option<Hit<f32>> {
        if range.count == 0 {
            return None;
        }
        let limit = t_exit + t_exit.abs() * <f32 as Real>::gamma(8);
        let mut best = Best::default();
        let (off, n) = (range.offset as usize, range.count as usize);
        simd::closest(self.isa, rc, &self.soa, off, n, &mut best);
        if !(best.found && best.t <= limit) {
            return None;
        }
        let [u, v, w, det] = best.uvwd;
        let inv = 1.0 / det;
        Some(Hit {
            t: best.t,
            tri: self.walker.list()[best.r],
            b: [u * inv, v * inv, w * inv],
        })
    }

    /// The per-cell step of [`CellWalk::any_hit`], counting tests up to the first hit.
    #[inline(always)]
    fn cell_any(&self, rc: &RayConsts, range: CellRange, tests: &mut u64) -> bool {
        let n = range.count as usize;
        match simd::first_hit(self.isa, rc, &self.soa, range.offset as usize, n) {
            Some(i) => {
                *tests += i as u64 + 1;
                true
            }
            None => {
                *tests += n as u64;
                false
            }
        }
    }

    /// The next ray of the stream from `next` on that enters the grid, as a lane; the rays
    /// passed over miss the grid box (their results stay as set: no hit, no work).
    #[inline(always)]
    fn lane(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        next: &mut usize,
    ) -> Option<Lane> {
        while *next < rays.len() {
            let i = *next;
            *next += 1;
            if let Some(st) = w.start(&rays[i]) {
                return Some(Lane {
                    i,
                    st,
                    rc: self.consts(&rays[i]),
                });
            }
        }
        None
    }

    /// [`CellWalk::closest_hits`] on the irregular grid: [`STREAM`] walks stepped in turn,
    /// each exactly as [`CellWalk::closest_hit`] walks it; with AVX2, compiled for it and
    /// stepped by `simd_step.rs`.
    fn closest_stream(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hits: &mut [Option<Hit<f32>>],
        work: &mut [Work],
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.isa == Isa::Avx2 {
            // SAFETY: the kernel was detected on this CPU.
            return unsafe { self.closest_stream_avx2(w, rays, hits, work) };
        }
        self.closest_stream_with::<false>(w, rays, hits, work)
    }

    /// [`SimdWalker::closest_stream`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn closest_stream_avx2(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hits: &mut [Option<Hit<f32>>],
        work: &mut [Work],
    ) {
        self.closest_stream_with::<true>(w, rays, hits, work)
    }

    /// The stream of [`SimdWalker::closest_stream`]; `VSTEP`: step with `simd_step.rs`.
    #[inline(always)]
    fn closest_stream_with<const VSTEP: bool>(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hits: &mut [Option<Hit<f32>>],
        work: &mut [Work],
    ) {
        hits.iter_mut().for_each(|h| *h = None);
        let mut next = 0;
        let mut lanes: [Option<Lane>; STREAM] = [None; STREAM];
        let mut soa = Lanes8::default();
        for (j, slot) in lanes.iter_mut().enumerate() {
            *slot = self.lane(w, rays, &mut next);
            sync::<VSTEP>(&mut soa, j, w, rays, slot, true);
        }
        let mut active = lanes.iter().filter(|l| l.is_some()).count();
        while active > 0 {
            let steps = step_lanes::<VSTEP>(w, rays, &lanes, &soa);
            for (j, (slot, &(t_exit, axis, k))) in lanes.iter_mut().zip(&steps).enumerate() {
                let Some(l) = slot else { continue };
                let ray = &rays[l.i];
                let wk = &mut work[l.i];
                wk.cells += 1;
                let cell = &w.grid.cells[l.st.id as usize];
                wk.tests += cell.range.count as u64;
                let done = match self.cell_closest(&l.rc, cell.range, t_exit) {
                    Some(h) => {
                        hits[l.i] = Some(h);
                        true
                    }
                    None => {
                        let more = advance::<VSTEP>(w, ray, &mut l.st, cell, t_exit, axis, k);
                        sync::<VSTEP>(&mut soa, j, w, rays, slot, false);
                        !more
                    }
                };
                if done {
                    *slot = self.lane(w, rays, &mut next);
                    sync::<VSTEP>(&mut soa, j, w, rays, slot, true);
                    if slot.is_none() {
                        active -= 1;
                    }
                }
            }
        }
    }

    /// [`CellWalk::any_hits`] on the irregular grid, as [`SimdWalker::closest_stream`].
    fn any_stream(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hit: &mut [bool],
        work: &mut Work,
    ) {
        #[cfg(target_arch = "x86_64")]
        if self.isa == Isa::Avx2 {
            // SAFETY: the kernel was detected on this CPU.
            return unsafe { self.any_stream_avx2(w, rays, hit, work) };
        }
        self.any_stream_with::<false>(w, rays, hit, work)
    }

    /// [`SimdWalker::any_stream`] compiled for AVX2.
    ///
    /// # Safety
    /// The CPU must have AVX2.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2")]
    unsafe fn any_stream_avx2(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hit: &mut [bool],
        work: &mut Work,
    ) {
        self.any_stream_with::<true>(w, rays, hit, work)
    }

    /// The stream of [`SimdWalker::any_stream`]; `VSTEP` as for the closest hits.
    #[inline(always)]
    fn any_stream_with<const VSTEP: bool>(
        &self,
        w: &IrregularWalker<'_, f32>,
        rays: &[Ray<f32>],
        hit: &mut [bool],
        work: &mut Work,
    ) {
        hit.iter_mut().for_each(|h| *h = false);
        let mut next = 0;
        let mut lanes: [Option<Lane>; STREAM] = [None; STREAM];
        let mut soa = Lanes8::default();
        for (j, slot) in lanes.iter_mut().enumerate() {
            *slot = self.lane(w, rays, &mut next);
            sync::<VSTEP>(&mut soa, j, w, rays, slot, true);
        }
        let mut active = lanes.iter().filter(|l| l.is_some()).count();
        while active > 0 {
            let steps = step_lanes::<VSTEP>(w, rays, &lanes, &soa);
            for (j, (slot, &(t_exit, axis, k))) in lanes.iter_mut().zip(&steps).enumerate() {
                let Some(l) = slot else { continue };
                let ray = &rays[l.i];
                work.cells += 1;
                let cell = &w.grid.cells[l.st.id as usize];
                let done = if self.cell_any(&l.rc, cell.range, &mut work.tests) {
                    hit[l.i] = true;
                    true
                } else {
                    let more = advance::<VSTEP>(w, ray, &mut l.st, cell, t_exit, axis, k);
                    sync::<VSTEP>(&mut soa, j, w, rays, slot, false);
                    !more
                };
                if done {
                    *slot = self.lane(w, rays, &mut next);
                    sync::<VSTEP>(&mut soa, j, w, rays, slot, true);
                    if slot.is_none() {
                        active -= 1;
                    }
                }
            }
        }
    }
}

/// One step of every lane of a stream: the exit of its cell (t_exit, axis) and, with
/// `VSTEP`, the next virtual cell already (`simd_step::step8`, eight rays in the lanes of
/// AVX2 registers); without, `None`, and [`advance`] finds it only when the walk goes on, as
/// the scalar walk does. An idle lane's entry is meaningless.
#[inline(always)]
fn step_lanes<const VSTEP: bool>(
    w: &IrregularWalker<'_, f32>,
    rays: &[Ray<f32>],
    lanes: &[Option<Lane>; STREAM],
    soa: &Lanes8,
) -> [(f32, usize, Option<[u32; 3]>); STREAM] {
    let cell = |l: &Lane| &w.grid.cells[l.st.id as usize];
    // Read only by the AVX2 step (the web page's wasm32 build warned of it unread).
    #[cfg(not(target_arch = "x86_64"))]
    let _ = soa;
    #[cfg(target_arch = "x86_64")]
    if VSTEP {
        let args = lanes
            .each_ref()
            .map(|l| l.as_ref().map(|l| (&rays[l.i], cell(l))));
        // SAFETY: `VSTEP` is set only in the AVX2 streams, run where AVX2 was detected.
        return unsafe { simd_step::step8(w, soa, &args) };
    }
    lanes.each_ref().map(|l| match l {
        Some(l) => {
            let (t_exit, axis) = w.exit(&rays[l.i], cell(l), l.st.t_prev);
            (t_exit, axis, None)
        }
        None => (0.0, 0, None),
    })
}

/// With `VSTEP`, lane `j` of `soa` follows the walk in `slot` (its ray too when `new`, a
/// walk just started); an idle lane keeps what it held.
#[inline(always)]
fn sync<const VSTEP: bool>(
    soa: &mut Lanes8,
    j: usize,
    w: &IrregularWalker<'_, f32>,
    rays: &[Ray<f32>],
    slot: &Option<Lane>,
    new: bool,
) {
    let Some(l) = slot else { return };
    if !VSTEP {
        return;
    }
    if new {
        soa.set_ray(j, &rays[l.i]);
    }
    // A walk that ended keeps its last cell: the lane idles until refilled.
    if let Some(cell) = w.grid.cells.get(l.st.id as usize) {
        soa.set_cell(j, cell, l.st.t_prev);
    }
}

/// [`IrregularWalker::advance`] with the next cell `k` of [`step_lanes`] where it gave one.
#[inline(always)]
fn advance<const VSTEP: bool>(
    w: &IrregularWalker<'_, f32>,
    ray: &Ray<f32>,
    st: &mut WalkState<f32>,
    cell: &IrrCell,
    t_exit: f32,
    axis: usize,
    k: Option<[u32; 3]>,
) -> bool {
    if !VSTEP {
        return w.advance(ray, st, cell, t_exit, axis);
    }
    if t_exit >= st.t_leave {
        return false;
    }
    match k {
        Some(k) => w.enter(st, k, t_exit),
        None => false,
    }
}

#[cfg(test)]
#[path = "simd_walk_tests.rs"]
mod tests;
