//! The CPU renderer's traversal over whichever structure was built: a closed enum over the
//! uniform-grid and irregular-grid walkers, so the renderer's inner loop dispatches with
//! one predictable branch instead of a virtual call. Its queries (`closest_hit`, `any_hit`,
//! `brute_force`) come from [`CellWalk`], like every walker's.

use super::real::{Real, V3};
use super::traverse::{CellWalk, GridWalker, Ray, Work};
use super::traverse_irregular::IrregularWalker;
use crate::accel::{AccelRef, CellRange};
use crate::scene::Scene;
use crate::technique::Techniques;

/// A walker over the render's acceleration structure.
pub enum Walker<'a, T> {
    /// 3D-DDA over the uniform grid.
    Uniform(GridWalker<'a, T>),
    /// Cell-by-cell walk of the irregular grid.
    Irregular(IrregularWalker<'a, T>),
}

impl<'a, T: Real> Walker<'a, T> {
    /// Prepares `scene` and `accel` for traversal in precision `T`.
    pub fn new(scene: &Scene, accel: AccelRef<'a>, techniques: Techniques) -> Self {
        match accel {
            AccelRef::Uniform(g) => {
                Walker::Uniform(GridWalker::with_techniques(scene, g, techniques))
            }
            AccelRef::Irregular(g) => Walker::Irregular(IrregularWalker::new(scene, g, techniques)),
        }
    }
}

impl<T: Real> CellWalk<T> for Walker<'_, T> {
    fn tris(&self) -> &[[V3<T>; 3]] {
        match self {
            Walker::Uniform(w) => w.tris(),
            Walker::Irregular(w) => w.tris(),
        }
    }

    fn list(&self) -> &[u32] {
        match self {
            Walker::Uniform(w) => w.list(),
            Walker::Irregular(w) => w.list(),
        }
    }

    fn techniques(&self) -> &Techniques {
        match self {
            Walker::Uniform(w) => w.techniques(),
            Walker::Irregular(w) => w.techniques(),
        }
    }

    #[inline(always)]
    fn walk(&self, ray: &Ray<T>, work: &mut Work, visit: impl FnMut(CellRange, T) -> bool) {
        match self {
            Walker::Uniform(w) => w.walk(ray, work, visit),
            Walker::Irregular(w) => w.walk(ray, work, visit),
        }
    }
}
