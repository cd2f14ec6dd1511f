//! The CPU renderer's traversal over whichever structure was built: a closed enum over the
//! uniform-grid and irregular-grid walkers, so the renderer's inner loop dispatches with
//! one predictable branch instead of a virtual call.

use super::real::{Real, V3};
use super::traverse::{GridWalker, Hit, Ray, Work};
use super::traverse_irregular::IrregularWalker;
use crate::accel::AccelRef;
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

    /// Vertices of every triangle, in load order, in precision `T`.
    pub fn tris(&self) -> &[[V3<T>; 3]] {
        match self {
            Walker::Uniform(w) => &w.tris,
            Walker::Irregular(w) => &w.tris,
        }
    }

    /// Closest hit in (t_min, t_max).
    #[inline]
    pub fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        match self {
            Walker::Uniform(w) => w.closest_hit(ray, work),
            Walker::Irregular(w) => w.closest_hit(ray, work),
        }
    }

    /// True when anything is hit in (t_min, t_max).
    #[inline]
    pub fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        match self {
            Walker::Uniform(w) => w.any_hit(ray, work),
            Walker::Irregular(w) => w.any_hit(ray, work),
        }
    }
}
