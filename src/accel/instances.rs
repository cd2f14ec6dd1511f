//! The two-level BVH of a scene with instances (`scene/instance.rs`), for the CPU
//! backend's `--accel bvh`: a BVH over the scene's own triangles, one per instanced mesh
//! in its object space (each built once, however many times the mesh is placed), and a
//! top BVH over the instances' local-space boxes. The walk (`cpu/traverse_instances.rs`)
//! takes rays into object space at each instance it meets. Memory grows with the meshes'
//! triangles and the number of instances, not with the triangles they place.

use glam::Vec3;
use std::time::Instant;

use super::bvh::{Bvh, BvhStats};
use crate::scene::Scene;
use crate::Result;

/// SAH cost of a top-level node visit, in instance walks: an instance costs a walk of its
/// mesh's tree (several node visits and triangle tests), so the top level splits down to
/// one or two instances per leaf.
const TOP_NODE_COST: f32 = 0.1;

/// The two levels.
#[derive(Clone, Debug)]
pub struct TwoLevel {
    /// Over the scene's own triangles ([`Scene::triangles`]).
    pub own: Bvh,
    /// One per instanced mesh, in its object space.
    pub meshes: Vec<Bvh>,
    /// Over the instances' boxes: its leaves' indices are instance indices.
    pub top: Bvh,
    /// Each instance's local-space box (what the top level was built over), tested before
    /// a ray is taken into its object space.
    pub boxes: Vec<(Vec3, Vec3)>,
    /// Triangles the instances place (each mesh counted once per instance).
    pub placed: u64,
    /// Build figures of all levels together (nodes, references, bytes summed; the depth
    /// the top's plus the deepest mesh's).
    pub stats: BvhStats,
}

impl TwoLevel {
    /// Builds the levels of `scene` (meshes in parallel with the scene's own tree).
    pub fn build(scene: &Scene) -> Result<TwoLevel> {
        let t0 = Instant::now();
        let inst = &scene.instancing;
        let (own, meshes) = rayon::join(
            || Bvh::build(scene),
            || {
                inst.meshes
                    .iter()
                    .map(|m| Bvh::build(&m.geometry))
                    .collect::<Result<Vec<_>>>()
            },
        );
        let (own, meshes) = (own?, meshes?);
        let boxes: Vec<(Vec3, Vec3)> = inst
            .instances
            .iter()
            .map(|i| {
                let b = &meshes[i.mesh as usize];
                i.bounds(b.min, b.max)
            })
            .collect();
        let top = Bvh::over_boxes(&boxes, TOP_NODE_COST)?;
        let all = std::iter::once(&own)
            .chain(&meshes)
            .chain(std::iter::once(&top));
        let mut stats = BvhStats::default();
        for b in all {
            stats.nodes += b.stats.nodes;
            stats.leaves += b.stats.leaves;
            stats.references += b.stats.references;
            stats.bytes += b.stats.bytes;
        }
        stats.bytes += boxes.len() * 24 + inst.bytes();
        stats.depth = top.stats.depth
            + meshes
                .iter()
                .map(|m| m.stats.depth)
                .max()
                .unwrap_or(0)
                .max(own.stats.depth);
        stats.mean_per_leaf = stats.references as f64 / stats.leaves.max(1) as f64;
        stats.sah_cost = own.stats.sah_cost;
        stats.build_ms = t0.elapsed().as_secs_f64() * 1e3;
        Ok(TwoLevel {
            own,
            meshes,
            top,
            boxes,
            placed: inst.triangles(),
            stats,
        })
    }

    /// What the levels hold (`AccelSummary::instanced`).
    pub fn holds(&self) -> String {
        let stored = self.own.tri_indices.len()
            + self
                .meshes
                .iter()
                .map(|m| m.tri_indices.len())
                .sum::<usize>();
        crate::scene::Instancing::holds(self.boxes.len(), self.meshes.len(), stored, self.placed)
    }

    /// The stats line: the levels' figures, and what instancing holds.
    pub fn detail(&self, scene_instances: usize) -> String {
        let s = &self.stats;
        format!(
            "two levels: {} instances of {} meshes over {} own triangles; {} nodes, {:.1} MB, built in {:.1} ms",
            scene_instances,
            self.meshes.len(),
            self.own.tri_indices.len(),
            s.nodes,
            s.bytes as f64 / 1e6,
            s.build_ms
        )
    }
}
