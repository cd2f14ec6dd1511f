//! The ray tree of a batch (`CpuRenderer::shade_hits`), split from `render.rs` by job:
//! each depth's hits shaded breadth first, the direct lighting 16 hits at a time
//! (`shade_lanes.rs`), the shadow rays of each light and then the reflected and refracted
//! rays as one batch each for the walker; instanced hits placed as flattening places
//! them. `render.rs` keeps the bands, the primary rays and the pixels.

use super::super::real::{Real, V3};
use super::super::shade::{
    albedo, geometric_normal, offset_origin_with, secondary, specular, SurfacePoint,
};
use super::super::shade_lanes::{Lane, Shadows, SurfaceIn, Surfaces, LANES, V3L};
use super::super::texture::{self, Cone};
use super::super::traverse::{Hit, Ray, Trace, Work};
use super::{CpuRenderer, Tally};
use crate::scene::texture::TriTex;
use crate::scene::Material;

/// The buffers of one depth of the ray tree, kept from batch to batch by a band (the
/// lanes are large: allocating and clearing them per batch cost a tenth of the shading).
pub(super) struct Scratch<T> {
    lanes: Vec<HitLanes<T>>,
    rays_of: Vec<Shadows<T>>,
    add: Vec<[bool; LANES]>,
    shadows: Vec<Ray<T>>,
    lit: Vec<(usize, usize)>,
    occluded: Vec<bool>,
}

impl<T> Default for Scratch<T> {
    fn default() -> Self {
        Scratch {
            lanes: Vec::new(),
            rays_of: Vec::new(),
            add: Vec::new(),
            shadows: Vec::new(),
            lit: Vec::new(),
            occluded: Vec::new(),
        }
    }
}

/// [`LANES`] hits of a batch being shaded (`base..base + LANES`): their surfaces,
/// materials, albedos and the colours summed so far, one lane each.
#[derive(Clone)]
struct HitLanes<T> {
    /// The batch index of lane 0.
    base: usize,
    s: Surfaces<T>,
    /// True where the lane holds a hit (false for a miss and past the batch's end).
    live: [bool; LANES],
    /// Each lane's material index.
    mat: [u32; LANES],
    alb: V3L<T>,
    color: V3L<T>,
    /// Each lane's diffuse coefficient.
    kd: Lane<T>,
    /// True where the material has a specular highlight.
    has_spec: [bool; LANES],
}

impl<T: Real> HitLanes<T> {
    /// No hit in any lane.
    fn zero() -> Self {
        HitLanes {
            base: 0,
            s: Surfaces::zero(),
            live: [false; LANES],
            mat: [0; LANES],
            alb: V3L::zero(),
            color: V3L::zero(),
            kd: [T::ZERO; LANES],
            has_spec: [false; LANES],
        }
    }

    /// Lane `k`'s material.
    #[inline]
    fn material<'s, W>(&self, r: &CpuRenderer<'s, T, W>, k: usize) -> &'s Material {
        &r.scene.materials[self.mat[k] as usize]
    }
}

/// A hit's triangle on an instance, placed (`CpuRenderer::placed`).
struct Placed<T> {
    /// Its vertices.
    v: [V3<T>; 3],
    /// Its unit geometric normal.
    ng: V3<T>,
    /// Its vertex normals, if it has them.
    n: Option<[V3<T>; 3]>,
    /// The hit's barycentric weights on it.
    b: [T; 3],
    /// Its material.
    material: u32,
}

impl<'a, T: Real, W: Trace<T>> CpuRenderer<'a, T, W> {
    /// The radiance along each of `rays` (unit directions, all at recursion depth
    /// `depth`) into `out`: the rays traced as one batch ([`Trace::closest_hits`]), then
    /// shaded by [`CpuRenderer::shade_hits`].
    fn radiance_batch(
        &self,
        rays: &[Ray<T>],
        cones: &[Cone<T>],
        depth: u32,
        tally: &mut Tally,
        scratch: &mut Vec<Scratch<T>>,
        out: &mut Vec<V3<T>>,
    ) {
        let mut hits = vec![None; rays.len()];
        let mut work = vec![Work::default(); rays.len()];
        self.walker.closest_hits(rays, &mut hits, &mut work);
        for wk in &work {
            tally.work.cells += wk.cells;
            tally.work.tests += wk.tests;
        }
        self.shade_hits(rays, cones, &hits, depth, tally, scratch, out, None);
    }

    /// Whitted shading of a batch of hits of `rays` at recursion depth `depth` (`None` for
    /// a miss, which gets the background) into `out`, and each hit's geometric normal into
    /// `normals` when given (zero for a miss). The whole ray tree is walked breadth first:
    /// the shadow rays to each light as one batch ([`Trace::any_hits`]), then the
    /// reflected and refracted rays of all hits as the next depth's batch. The direct
    /// lighting runs [`LANES`] hits at a time (`shade_lanes.rs`, every bit the scalar
    /// functions'). Each colour is the depth-first recursion's bit for bit: the same terms
    /// added in the same order (ambient, each light in turn, then the reflected child and
    /// the refracted one).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn shade_hits(
        &self,
        rays: &[Ray<T>],
        cones: &[Cone<T>],
        hits: &[Option<Hit<T>>],
        depth: u32,
        tally: &mut Tally,
        scratch: &mut Vec<Scratch<T>>,
        out: &mut Vec<V3<T>>,
        normals: Option<&mut Vec<V3<T>>>,
    ) {
        if scratch.len() <= depth as usize {
            scratch.resize_with(depth as usize + 1, Scratch::default);
        }
        let mut sc = std::mem::take(&mut scratch[depth as usize]);
        let Scratch {
            lanes: lanes_buf,
            shadows,
            lit,
            occluded,
            rays_of,
            add,
        } = &mut sc;
        let no_cone = Cone {
            width: T::ZERO,
            spread: T::ZERO,
        };
        let n = rays.len();
        let mut at_hit = vec![no_cone; if self.textured { n } else { 0 }];
        let chunks = n.div_ceil(LANES);
        if lanes_buf.len() < chunks {
            lanes_buf.resize_with(chunks, HitLanes::zero);
        }
        let lanes = &mut lanes_buf[..chunks];
        for (c, h) in lanes.iter_mut().enumerate() {
            self.begin_lanes(rays, hits, c * LANES, h);
        }
        // Albedo (checker, texture, vertex colour) and the ambient term, per hit.
        for (c, h) in lanes.iter_mut().enumerate() {
            for k in (0..LANES).filter(|&k| h.live[k]) {
                let i = c * LANES + k;
                let (hit, m) = (hits[i].as_ref().expect("a live lane"), h.material(self, k));
                let cone = cones.get(i).copied().unwrap_or(no_cone);
                let (alb, cone) = self.albedo_at(m, &h.s.point(k, h.mat[k]), &rays[i], hit, cone);
                if self.textured {
                    at_hit[i] = cone;
                }
                h.alb.set(k, alb);
                h.color
                    .set(k, alb.mul_elem(self.ambient) * T::from_f32(m.ka));
                h.kd[k] = T::from_f32(m.kd);
                h.has_spec[k] = m.ks.max_element() > 0.0;
            }
        }
        if let Some(normals) = normals {
            normals.clear();
            normals.extend((0..n).map(|i| {
                let h = &lanes[i / LANES];
                let k = i % LANES;
                if h.live[k] {
                    h.s.ng.get(k)
                } else {
                    V3::splat(T::ZERO)
                }
            }));
        }
        if rays_of.len() < chunks {
            rays_of.resize_with(chunks, Shadows::zero);
        }
        let rays_of = &mut rays_of[..chunks];
        for light in &self.scene.lights {
            let lp = V3::<T>::from_vec3(light.position);
            for (h, out) in lanes.iter().zip(rays_of.iter_mut()) {
                self.dispatch
                    .shadows(&h.s, &h.live, lp, self.techniques, out);
            }
            shadows.clear();
            lit.clear();
            for (c, sh) in rays_of.iter().enumerate() {
                for k in (0..LANES).filter(|&k| sh.cast[k]) {
                    shadows.push(Ray {
                        o: sh.o.get(k),
                        d: sh.l.get(k),
                        t_min: T::ZERO,
                        t_max: sh.dist[k],
                    });
                    lit.push((c, k));
                }
            }
            tally.shadow += shadows.len() as u64;
            occluded.clear();
            occluded.resize(shadows.len(), false);
            self.walker.any_hits(shadows, occluded, &mut tally.work);
            let radiance = V3::from_vec3(light.radiance());
            add.clear();
            add.resize(chunks, [false; LANES]);
            for (&(c, k), &blocked) in lit.iter().zip(occluded.iter()) {
                add[c][k] = !blocked;
            }
            for ((h, sh), add) in lanes.iter_mut().zip(rays_of.iter()).zip(add.iter()) {
                if !add.contains(&true) {
                    continue;
                }
                let mut spec = V3L::zero();
                for k in (0..LANES).filter(|&k| add[k] && h.has_spec[k]) {
                    let m = h.material(self, k);
                    let v = -rays[h.base + k].d;
                    spec.set(k, specular(m, h.s.ns.get(k), sh.l.get(k), v));
                }
                let (alb, kd, has_spec) = (h.alb, h.kd, h.has_spec);
                self.dispatch.add_light(
                    &mut h.color,
                    &h.s,
                    &sh.l,
                    &alb,
                    &kd,
                    &spec,
                    &has_spec,
                    add,
                    radiance,
                );
            }
        }
        // The children: for each hit in order, the reflected ray, then the refracted one
        // (the order the GPU walks the tree in), each with its weight and parent.
        let mut children = Vec::new();
        let mut child_cones = Vec::new();
        let mut parents = Vec::new();
        if depth < self.max_depth {
            for (i, ray) in rays.iter().enumerate() {
                let (h, k) = (&lanes[i / LANES], i % LANES);
                if !h.live[k] {
                    continue;
                }
                let m = h.material(self, k);
                if !(m.reflects() || m.refracts()) {
                    continue;
                }
                let sp = h.s.point(k, h.mat[k]);
                let sec = secondary(m, &sp, ray.d);
                for (kw, dir, refracted) in [
                    (sec.kr, sec.reflected, false),
                    (sec.kt, sec.refracted, true),
                ] {
                    if kw.max_elem() > T::ZERO {
                        if refracted {
                            tally.refracted += 1;
                        } else {
                            tally.reflected += 1;
                        }
                        children.push(Ray {
                            o: offset_origin_with(&sp, dir, self.techniques.offset),
                            d: dir,
                            t_min: T::ZERO,
                            t_max: T::BIG,
                        });
                        parents.push((i, kw));
                        if self.textured {
                            let tri = hits[i].as_ref().expect("a live lane").tri as usize;
                            child_cones.push(self.child_cone(&sp, m, tri, at_hit[i], refracted));
                        }
                    }
                }
            }
        }
        out.clear();
        out.extend((0..n).map(|i| {
            let (h, k) = (&lanes[i / LANES], i % LANES);
            if h.live[k] {
                h.color.get(k)
            } else {
                self.background
            }
        }));
        if !children.is_empty() {
            let mut radiance = Vec::with_capacity(children.len());
            scratch[depth as usize] = sc;
            self.radiance_batch(
                &children,
                &child_cones,
                depth + 1,
                tally,
                scratch,
                &mut radiance,
            );
            for (&(i, kw), r) in parents.iter().zip(&radiance) {
                out[i] = out[i] + r.mul_elem(kw);
            }
        } else {
            scratch[depth as usize] = sc;
        }
    }

    /// The surfaces of the hits `base..base + LANES` of a batch (fewer at its end) into
    /// `out` (all zero before).
    fn begin_lanes(
        &self,
        rays: &[Ray<T>],
        hits: &[Option<Hit<T>>],
        base: usize,
        out: &mut HitLanes<T>,
    ) {
        let mut inp = SurfaceIn::zero();
        let HitLanes { live, mat, .. } = out;
        // The buffer is reused: only `live` and `mat` are read where no hit wrote them.
        *live = [false; LANES];
        *mat = [0; LANES];
        let count = LANES.min(hits.len().saturating_sub(base));
        // The hits' triangles are scattered over memory: ask for all of their records
        // first, so that the lanes' cache misses overlap instead of coming one by one.
        #[cfg(target_arch = "x86_64")]
        for h in hits[base..base + count].iter().flatten() {
            use std::arch::x86_64::{_mm_prefetch, _MM_HINT_T0};
            let tri = h.tri as usize;
            if let (Some(v), Some(t)) = (self.walker.tris().get(tri), self.scene.triangles.get(tri))
            {
                // SAFETY: prefetching reads nothing and cannot fault; the addresses are of
                // live elements anyway.
                unsafe {
                    _mm_prefetch::<_MM_HINT_T0>(v.as_ptr() as *const i8);
                    _mm_prefetch::<_MM_HINT_T0>(t as *const _ as *const i8);
                }
            }
        }
        for k in 0..count {
            let Some(h) = &hits[base + k] else { continue };
            live[k] = true;
            let tri = h.tri as usize;
            let mut b = h.b;
            if tri >= self.ng.len() {
                let g = self.placed(h);
                for (lane, v) in inp.v.iter_mut().zip(g.v) {
                    lane.set(k, v);
                }
                inp.ng.set(k, g.ng);
                if let Some(n) = g.n {
                    inp.has_normals[k] = true;
                    for (lane, n) in inp.n.iter_mut().zip(n) {
                        lane.set(k, n);
                    }
                }
                b = g.b;
                mat[k] = g.material;
            } else {
                for (a, v) in self.walker.tris()[tri].iter().enumerate() {
                    inp.v[a].set(k, *v);
                }
                inp.ng.set(k, self.ng[tri]);
                let t = &self.scene.triangles[tri];
                if t.has_normals() {
                    inp.has_normals[k] = true;
                    for a in 0..3 {
                        inp.n[a].set(k, V3::from_vec3(self.scene.normals[t.n[a] as usize]));
                    }
                }
                mat[k] = t.material;
            }
            for (lane, b) in inp.b.iter_mut().zip(b) {
                lane[k] = b;
            }
            inp.d.set(k, rays[base + k].d);
        }
        out.base = base;
        self.dispatch.surfaces(&inp, &mut out.s);
    }

    /// The triangle of a hit on an instance (an id past the walker's own triangles),
    /// placed as `Scene::flattened` places it, and the hit's barycentrics on it: in f64,
    /// rounded to `T` once, so that f32 shades on the flattened scene's f32 vertices and
    /// f64 on the very triangle the object-space test met (rounding it to f32 first would
    /// move it off that triangle by far more than f64's offsets lift a secondary ray's
    /// origin: acne); the winding reversed under a mirroring placement, the barycentrics
    /// with it. (Its texture record: `TriTex::of`, at the hit.)
    fn placed(&self, hit: &Hit<T>) -> Placed<T> {
        let inst = &self.scene.instancing;
        let (k, j) = inst.locate(hit.tri);
        let place = &inst.instances[k];
        let g = &inst.meshes[place.mesh as usize].geometry;
        let t = &g.triangles[j];
        let mut v =
            t.v.map(|i| V3::from_dvec3(place.point_f64(g.positions[i as usize])));
        let mut n = t.has_normals().then(|| {
            t.n.map(|i| V3::from_dvec3(place.normal_f64(g.normals[i as usize])))
        });
        let mut b = hit.b;
        if place.mirrors() {
            v.swap(1, 2);
            if let Some(n) = &mut n {
                n.swap(1, 2);
            }
            b.swap(1, 2);
        }
        Placed {
            ng: geometric_normal(&v),
            v,
            n,
            b,
            material: t.material,
        }
    }

    /// The albedo of a hit of `ray` (with cone `cone`) at surface point `sp` of material
    /// `m` (checker, texture and vertex colour applied), and the ray's cone at the hit.
    #[inline]
    fn albedo_at(
        &self,
        m: &Material,
        sp: &SurfacePoint<T>,
        ray: &Ray<T>,
        hit: &Hit<T>,
        cone: Cone<T>,
    ) -> (V3<T>, Cone<T>) {
        let mut alb = albedo(m, sp.p);
        let mut at_hit = cone;
        if !(self.textured || self.coloured) {
            return (alb, at_hit);
        }
        let tri = hit.tri as usize;
        // An instance's record is worked out here, on the triangle the flattened scene
        // stores (`TriTex::of`): the mesh is stored once, its records not per placement.
        let placed;
        let (rec, b) = match self.tex.get(tri) {
            Some(rec) if tri < self.ng.len() => (rec, hit.b),
            _ => {
                placed = TriTex::of(self.scene, tri);
                // The object-space barycentrics in the placed winding (`placed`).
                let inst = &self.scene.instancing;
                let mut b = hit.b;
                if inst.instances[inst.locate(hit.tri).0].mirrors() {
                    b.swap(1, 2);
                }
                (&placed, b)
            }
        };
        if self.textured {
            at_hit.width = cone.width + cone.spread * hit.t;
        }
        if let Some(k) = m.diffuse_map {
            let t = &self.scene.textures[k as usize];
            let lod = texture::lod(T::from_f32(rec.lod_bias), at_hit.width, sp.nf.dot(ray.d));
            let level = texture::level_of(lod, t.levels.len());
            let (u, v) = texture::uv_at(rec, b);
            alb = alb.mul_elem(texture::bilinear(t, level, u, v));
        }
        alb = alb.mul_elem(texture::vertex_color(self.scene, self.coloured, tri, b));
        (alb, at_hit)
    }

    /// The cone of the reflected (or, with `refracted`, the refracted) child of a hit on
    /// triangle `tri` whose ray's cone there is `cone`.
    #[inline]
    fn child_cone(
        &self,
        sp: &SurfacePoint<T>,
        m: &Material,
        tri: usize,
        cone: Cone<T>,
        refracted: bool,
    ) -> Cone<T> {
        // An instance's curvature on the triangle the flattened scene stores, as its
        // record (`TriTex::of`).
        let k = match self.tex.get(tri) {
            Some(rec) if tri < self.ng.len() => rec.curvature,
            _ => TriTex::of(self.scene, tri).curvature,
        };
        let k = T::from_f32(k);
        let k = if sp.flipped { -k } else { k };
        let eta = refracted.then(|| {
            let ior = T::from_f32(m.ior);
            if sp.entering {
                T::ONE / ior
            } else {
                ior / T::ONE
            }
        });
        texture::child_cone(cone.width, cone.spread, k, eta)
    }
}
