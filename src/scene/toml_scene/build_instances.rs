//! The scene builder's instances (`toml_scene/build.rs`, split from it by job): an
//! object's `instances` turned into placements, its mesh stored once (with its texture
//! coordinates and colours), glTF nodes that share a mesh mapped onto it, and the placed
//! copies where an object is stored flat.

use super::*;

impl Builder<'_> {
    /// The placements of an object's `instances`, each with its span and index.
    pub(super) fn instance_placements(
        &self,
        i: usize,
        list: &[S<InstanceDef>],
    ) -> Result<Vec<(Placement, Range<usize>, usize)>> {
        let mut placements = Vec::with_capacity(list.len());
        for (k, inst) in list.iter().enumerate() {
            let f = |key: &str| format!("objects[{i}].instances[{k}].{key}");
            let d = inst.get_ref();
            let p = self.placement(&d.scale, &d.rotate, &d.translate, &f)?;
            placements.push((p, inst.span(), k));
        }
        Ok(placements)
    }

    /// The meshes of `loaded` that several glTF nodes place (`ObjMesh::shared`), each
    /// stored once as an instanced mesh and placed by every node's transform, then the
    /// object's `placement`, then each of `outer` (the object's instances, or the
    /// identity).
    pub(super) fn shared_meshes(
        &mut self,
        i: usize,
        o: &S<ObjectDef>,
        loaded: &ObjMesh,
        placement: Placement,
        outer: &[(Placement, Range<usize>, usize)],
        material: &dyn Fn(u32) -> u32,
    ) -> Result<()> {
        for (s, shared) in loaded.shared.iter().enumerate() {
            // The mesh's own vertices, renumbered from 0.
            let mut vmap = HashMap::new();
            let mut nmap = HashMap::new();
            let mut umap = HashMap::new();
            let mut mesh = Scene::empty(self.scene.camera);
            mesh.source = format!("objects[{i}].mesh (shared mesh {s})");
            let uvs = shared.tri_uvs.iter().any(|t| t[0] != NO_UV);
            for (j, t) in shared.triangles.iter().enumerate() {
                let v = t.v.map(|k| {
                    *vmap.entry(k).or_insert_with(|| {
                        mesh.positions.push(loaded.positions[k as usize]);
                        if let Some(&c) = loaded.colors.get(k as usize) {
                            mesh.colors.push(c);
                        }
                        mesh.positions.len() as u32 - 1
                    })
                });
                if uvs {
                    let uv = shared.tri_uvs[j];
                    mesh.tri_uvs.push(if uv[0] == NO_UV {
                        uv
                    } else {
                        uv.map(|k| {
                            *umap.entry(k).or_insert_with(|| {
                                mesh.uvs.push(loaded.uvs[k as usize]);
                                mesh.uvs.len() as u32 - 1
                            })
                        })
                    });
                }
                let n = if t.has_normals() {
                    t.n.map(|k| {
                        *nmap.entry(k).or_insert_with(|| {
                            mesh.normals.push(loaded.normals[k as usize]);
                            mesh.normals.len() as u32 - 1
                        })
                    })
                } else {
                    [NO_NORMAL; 3]
                };
                mesh.triangles.push(Triangle {
                    v,
                    n,
                    material: material(t.material),
                });
            }
            let m = self.scene.instancing.meshes.len() as u32;
            for (outer, span, k) in outer {
                for node in &shared.placements {
                    let node = Placement {
                        linear: DMat3::from_mat4(*node),
                        translate: node.w_axis.truncate(),
                    };
                    let p = outer.then(placement.then(node));
                    let inst = Instance::new(m, p.linear, p.translate).ok_or_else(|| {
                        let field = match &o.get_ref().instances {
                            Some(_) => format!("objects[{i}].instances[{k}]"),
                            None => format!("objects[{i}].mesh"),
                        };
                        self.ctx.err(
                            span.clone(),
                            field,
                            "a placement of a shared glTF mesh is not invertible or not finite",
                        )
                    })?;
                    self.scene.instancing.instances.push(inst);
                }
            }
            self.scene.instancing.meshes.push(Mesh {
                name: mesh.source.clone(),
                geometry: mesh,
            });
        }
        Ok(())
    }

    /// A placement's `scale`, `rotate` and `translate` (the object's, or an instance's,
    /// named by `f`).
    pub(super) fn placement(
        &self,
        scale: &Option<S<Numbers>>,
        rotate: &Option<S<super::super::schema::Triple>>,
        translate: &Option<S<super::super::schema::Triple>>,
        f: &dyn Fn(&str) -> String,
    ) -> Result<Placement> {
        let ctx = self.ctx;
        let scale = match scale {
            None => DVec3::ONE,
            Some(s) => {
                let v = numbers(ctx, s, &f("scale"), 3)?;
                if v.contains(&0.0) {
                    return Err(ctx.err(s.span(), f("scale"), "scale factors must be non-zero (a flat object has no inside and its normals are undefined)"));
                }
                DVec3::from_array([v[0], v[1], v[2]])
            }
        };
        let rotate = match rotate {
            Some(r) => ctx.vec3(r, &f("rotate"))?.as_dvec3(),
            None => DVec3::ZERO,
        };
        let translate = match translate {
            // f64 as written: a far translation keeps its digits until the local origin is
            // subtracted.
            Some(t) => {
                ctx.vec3(t, &f("translate"))?;
                triple_f64(t)
            }
            None => DVec3::ZERO,
        };
        Ok(Placement::new(scale, rotate, translate))
    }

    /// Object `i`'s `geometry` (placed by its own placement) placed once per entry of
    /// `list`: stored once as an instanced mesh, with its texture coordinates and vertex
    /// colours.
    pub(super) fn instances(
        &mut self,
        i: usize,
        list: &[S<InstanceDef>],
        placements: Vec<(Placement, Range<usize>, usize)>,
        geometry: Geometry,
        material: &dyn Fn(u32) -> u32,
    ) -> Result<()> {
        let ctx = self.ctx;
        if list.is_empty() {
            self.warnings.push(format!(
                "{}: objects[{i}].instances is empty, so the object is not placed",
                ctx.name
            ));
            return Ok(());
        }
        if geometry.triangles.is_empty() {
            // (A glTF whose meshes are all shared: placed by `shared_meshes`.)
            return Ok(());
        }
        let mut mesh = Scene::empty(self.scene.camera);
        mesh.source = format!("objects[{i}]");
        mesh.positions = geometry.positions;
        mesh.normals = geometry.normals;
        mesh.uvs = geometry.uvs;
        mesh.tri_uvs = geometry.tri_uvs;
        mesh.colors = geometry.colors;
        mesh.triangles = geometry
            .triangles
            .into_iter()
            .map(|t| Triangle {
                material: material(t.material),
                ..t
            })
            .collect();
        let m = self.scene.instancing.meshes.len() as u32;
        let bounds = mesh.bounds();
        for (p, span, k) in placements {
            let inst = Instance::new(m, p.linear, p.translate).ok_or_else(|| {
                ctx.err(
                    span.clone(),
                    format!("objects[{i}].instances[{k}]"),
                    "the placement is not invertible or not finite",
                )
            })?;
            // The placed box must be finite in f32, as a placed vertex must.
            if let Some((lo, hi)) = bounds {
                let (a, b) = inst.bounds(lo, hi);
                if !(a.is_finite() && b.is_finite()) {
                    return Err(ctx.err(
                        span,
                        format!("objects[{i}].instances[{k}]"),
                        "a placed vertex is not finite; scale or translate is too large",
                    ));
                }
            }
            self.scene.instancing.instances.push(inst);
        }
        self.scene.instancing.meshes.push(Mesh {
            name: format!("objects[{i}]"),
            geometry: mesh,
        });
        Ok(())
    }
}
