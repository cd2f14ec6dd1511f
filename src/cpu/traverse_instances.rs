//! The walk of the two-level BVH (`accel/instances.rs`) of a scene with instances: the
//! scene's own triangles by their BVH, then the top tree over the instances, nearest
//! first; at each instance met, the ray taken into the mesh's object space (in f64, the
//! direction not renormalised, so the parameter t is the same in both spaces and the
//! hit's t and barycentrics need no conversion) and the mesh's own BVH walked by
//! [`BvhWalker`] (scalar, or in f32 vectorised). GLSL twin: `glsl120/instance.glsl`, the
//! compute kernel's walk of the same top tree with the same tie rule over each mesh's
//! uniform grid (`accel/grid_instances.rs`).
//!
//! The tie rule, as the one-level walk's: a hit closer than the held one by more than
//! [`TIE_EPS`](crate::accel::TIE_EPS) replaces it; within the margin the lower primitive id
//! wins, ids running over the scene's own triangles, then the instances in file order, then
//! each mesh's triangles in order (`scene/instance.rs`). Within a mesh the mesh's walk
//! decides (the one-level rule); between two instances (or an instance and the scene's
//! own triangles) the later one's hit is compared on t with the earlier's tie limit, as
//! brute force over the flattened scene would, up to the t's rounding in each space.
//!
//! Batches: the scene's own triangles walk as the one-level walk's batches (packets on the
//! packet path); the top level and the meshes one ray at a time (each mesh's walk
//! vectorised in f32): the packet path's speed on instances is the single-ray walk's.

use super::closest::Closest;
use super::real::{Real, V3};
use super::traverse::{Hit, Ray, Trace, Work};
use super::traverse_bvh::BvhWalker;
use crate::accel::bvh::Bvh;
use crate::accel::instances::TwoLevel;
use crate::scene::{Instance, Scene};
use crate::technique::Techniques;

/// The two levels walked in precision `T`.
pub struct InstanceWalker<'a, T> {
    /// The scene's own triangles.
    own: BvhWalker<'a, T>,
    /// The top tree (its own triangle list empty: its leaves are instances).
    top: BvhWalker<'a, T>,
    /// The top tree's references: instance indices.
    top_list: &'a [u32],
    /// One walker per mesh, in object space.
    meshes: Vec<BvhWalker<'a, T>>,
    /// The placements.
    instances: &'a [Instance],
}

impl<'a, T: Real> InstanceWalker<'a, T> {
    /// Prepares `scene`'s `levels`: `own` walks the scene's own triangles (built over
    /// `levels.own`), `mesh(geometry, bvh)` makes each mesh's walker.
    pub fn new(
        scene: &'a Scene,
        levels: &'a TwoLevel,
        techniques: Techniques,
        own: BvhWalker<'a, T>,
        mesh: impl Fn(&'a Scene, &'a Bvh) -> BvhWalker<'a, T>,
    ) -> Self {
        let inst = &scene.instancing;
        let nothing = Scene::empty(scene.camera);
        InstanceWalker {
            own,
            top: BvhWalker::new(&nothing, &levels.top, techniques),
            top_list: &levels.top.tri_indices,
            meshes: inst
                .meshes
                .iter()
                .zip(&levels.meshes)
                .map(|(m, b)| mesh(&m.geometry, b))
                .collect(),
            instances: &inst.instances,
        }
    }

    /// The walker of the scene's own triangles.
    pub fn own(&self) -> &BvhWalker<'a, T> {
        &self.own
    }

    /// `ray` in instance `inst`'s object space, its interval ending at `t_max`.
    #[inline]
    fn object_ray(inst: &Instance, ray: &Ray<T>, t_max: T) -> Ray<T> {
        let (o, d) = inst.ray_to_object(ray.o.to_dvec3(), ray.d.to_dvec3());
        Ray {
            o: V3::from_dvec3(o),
            d: V3::from_dvec3(d),
            t_min: ray.t_min,
            t_max,
        }
    }

    /// The top level's walk after the scene's own triangles left `best`.
    fn closest_instances(&self, ray: &Ray<T>, work: &mut Work, best: &mut Closest<T>) {
        let mut inner = Work::default();
        self.top.closest_leaves(
            ray,
            work,
            |off, n, best: &mut Closest<T>, _tests: &mut u64| {
                for r in off..off + n {
                    let inst = &self.instances[self.top_list[r] as usize];
                    let bound = best.bound(ray.t_max);
                    let oray = Self::object_ray(inst, ray, bound);
                    let Some(h) = self.meshes[inst.mesh as usize].closest_hit(&oray, &mut inner)
                    else {
                        continue;
                    };
                    let id = inst.first + h.tri;
                    let held_t = best.hit.map_or(h.t, |b| b.t);
                    // The later of the pair passes when its t is below the earlier's tie
                    // limit: brute force's comparison, on the t each space gave.
                    let later = |cand: bool, hi: T| if cand { h.t < hi } else { held_t < hi };
                    if best.takes(h.t, id, later) {
                        best.hit = Some(Hit {
                            t: h.t,
                            tri: id,
                            b: h.b,
                        });
                    }
                }
            },
            best,
        );
        work.cells += inner.cells;
        work.tests += inner.tests;
    }

    /// Whether an instance is hit.
    fn any_instance(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        let mut inner = Work::default();
        let found = self.top.any_leaves(ray, work, |off, n, _tests: &mut u64| {
            (off..off + n).any(|r| {
                let inst = &self.instances[self.top_list[r] as usize];
                let oray = Self::object_ray(inst, ray, ray.t_max);
                self.meshes[inst.mesh as usize].any_hit(&oray, &mut inner)
            })
        });
        work.cells += inner.cells;
        work.tests += inner.tests;
        found
    }

    /// The hit held after the scene's own triangles gave `own`.
    #[inline]
    fn seeded(ray: &Ray<T>, own: Option<Hit<T>>) -> Closest<T> {
        let mut best = Closest::new(ray.t_max);
        if let Some(h) = own {
            best.hit = Some(h);
            best.t_low = h.t;
        }
        best
    }
}

impl<T: Real> Trace<T> for InstanceWalker<'_, T> {
    /// The scene's own triangles only: an instanced triangle's vertices are placed where
    /// its hit is shaded (`cpu/render.rs`).
    fn tris(&self) -> &[[V3<T>; 3]] {
        self.own.tris()
    }

    fn closest_hit(&self, ray: &Ray<T>, work: &mut Work) -> Option<Hit<T>> {
        let mut best = Self::seeded(ray, self.own.closest_hit(ray, work));
        self.closest_instances(ray, work, &mut best);
        best.hit
    }

    fn any_hit(&self, ray: &Ray<T>, work: &mut Work) -> bool {
        self.own.any_hit(ray, work) || self.any_instance(ray, work)
    }

    fn closest_hits(&self, rays: &[Ray<T>], hits: &mut [Option<Hit<T>>], work: &mut [Work]) {
        self.own.closest_hits(rays, hits, work);
        for ((ray, hit), w) in rays.iter().zip(hits.iter_mut()).zip(work.iter_mut()) {
            let mut best = Self::seeded(ray, *hit);
            self.closest_instances(ray, w, &mut best);
            *hit = best.hit;
        }
    }

    fn any_hits(&self, rays: &[Ray<T>], hit: &mut [bool], work: &mut Work) {
        self.own.any_hits(rays, hit, work);
        for (ray, h) in rays.iter().zip(hit.iter_mut()) {
            if !*h {
                *h = self.any_instance(ray, work);
            }
        }
    }
}
