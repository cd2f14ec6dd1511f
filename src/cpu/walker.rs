//! The CPU renderer's traversal over whichever grid was built: a closed enum over the
//! uniform-grid and irregular-grid walkers (the BVH has its own, `traverse_bvh.rs`), so the renderer's inner loop dispatches with
//! one predictable branch instead of a virtual call. Its queries (`closest_hit`, `any_hit`,
//! `brute_force`) come from [`CellWalk`], like every walker's.

use super::real::{Real, V3};
use super::traverse::{CellWalk, GridWalker, Ray, Work};
use super::traverse_irregular::IrregularWalker;
use crate::accel::{CellRange, GridRef};
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
    /// Prepares `scene` and `grid` for traversal in precision `T`.
    pub fn new(scene: &Scene, grid: impl Into<GridRef<'a>>, techniques: Techniques) -> Self {
        match grid.into() {
            GridRef::Uniform(g) => {
                Walker::Uniform(GridWalker::with_techniques(scene, g, techniques))
            }
            GridRef::Irregular(g) => Walker::Irregular(IrregularWalker::new(scene, g, techniques)),
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

crate::trace_by_cell_walk!(Walker<'_, T>, T, T);

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::accel::{Accel, AccelKind, GridConfig, IrregularConfig};
    use crate::technique::{IntersectMethod, TBound};
    use crate::testing::{random_rays, ray_of, scene_of, sphere, test_seed, Rng};

    /// The walker hands the queries the structure built: its triangles, its reference
    /// lists, the techniques asked for, and its walk (every closest hit that of brute force
    /// over the same triangles, on a closed sphere, where no two triangles tie).
    #[test]
    fn walker_queries_the_structure_built() {
        let seed = test_seed("walker dispatch", 0x3A1C_0001);
        let mut rng = Rng::new(seed);
        let s = scene_of(&sphere(Vec3::new(0.2, -0.1, 0.3), 2.5, 16));
        let tech = Techniques {
            intersect: IntersectMethod::MollerTrumbore,
            t_bound: TBound::Off,
            ..Techniques::default()
        };
        let rays = random_rays(&mut rng, 400, 3.0);
        for kind in [AccelKind::Uniform, AccelKind::Irregular] {
            let accel = Accel::build(
                &s,
                kind,
                &GridConfig::default(),
                &IrregularConfig::default(),
            )
            .unwrap();
            let grid = accel.as_ref().grid().unwrap();
            let w = Walker::<f32>::new(&s, grid, tech);
            assert_eq!(w.techniques(), &tech, "{kind:?}");
            assert_eq!(w.tris().len(), s.triangles.len(), "{kind:?}");
            assert_eq!(w.list(), grid.tri_indices(), "{kind:?}");
            let mut hits = 0;
            for (i, &(o, d, t_max)) in rays.iter().enumerate() {
                let ray = ray_of::<f32>(o, d, t_max);
                let got = w.closest_hit(&ray, &mut Work::default());
                assert_eq!(got, w.brute_force(&ray), "seed {seed} {kind:?} ray {i}");
                hits += usize::from(got.is_some());
            }
            // Measured: 194 of 400 rays hit, on both structures.
            assert!(hits > 100, "seed {seed} {kind:?}: {hits} hits");
        }
    }
}
