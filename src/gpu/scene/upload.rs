//! The scene's copies on the GPU (`GpuScene`'s job of uploads): each layout packed on first
//! use for the kernel that reads it (the float one; the compute kernel's over the irregular
//! grid, dense where the float one does not fit), its textures or storage buffers uploaded on first use, and the dense
//! grid's buffers uploaded from the grid's own words.

use super::*;
use crate::error::Error;
use crate::gpu::layout::{DenseBuffer, Fetch, LayoutTarget};

impl GpuScene<'_> {
    /// The layout `target` reads, packed on first use (its size checked from the counts
    /// first: [`LayoutPlan`](crate::gpu::layout::LayoutPlan)); what packing took is charged as
    /// upload time. The compute kernel over a flat scene's irregular grid reads the float
    /// layout where it fits and the dense one where it does not
    /// ([`SceneTextures::compute_irregular`]): a float layout packed for either kernel
    /// serves both, never packed twice.
    pub fn layout(&self, target: LayoutTarget) -> Result<&SceneTextures> {
        let slot = self.slot(target);
        if let Some(l) = self.layouts[slot].get() {
            return Ok(l);
        }
        let t0 = Instant::now();
        let max_size = self.ctx.info.max_texture_size.max(0) as u32;
        let normals = self.features.smooth_normals;
        let float = || match (self.instancing, self.index_format) {
            // An instanced scene's two levels walk the uniform grid: one layout, with the
            // instancing data `inst`, serves every kernel (the dense grid is irregular only).
            (Some(gi), format) => {
                SceneTextures::pack_instanced(self.given, gi, max_size, normals, format)
            }
            (None, Some(format)) => {
                SceneTextures::pack_format(self.scene, self.accel, max_size, normals, format)
            }
            (None, None) => SceneTextures::pack_with(self.scene, self.accel, max_size, normals),
        };
        let mut l = match (self.either(target), self.accel) {
            (true, GridRef::Irregular(g)) => {
                if let Some(l) = self.layouts[FLOAT].get() {
                    let _ = self.compute_slot.set(FLOAT);
                    return Ok(l);
                }
                SceneTextures::compute_irregular(float, || {
                    // Only here is the storage-block size asked for: a context without
                    // compute shaders (GL 2.1, WebGL) answers the query with GL_INVALID_ENUM.
                    let block = block_bytes(self.ctx);
                    SceneTextures::pack_dense(self.scene, g, max_size, normals, block)
                })?
            }
            _ => float().map_err(|e| self.naming_compute(target, e))?,
        };
        let slot = if l.dense().is_some() { DENSE } else { FLOAT };
        if self.either(target) {
            let _ = self.compute_slot.set(slot);
        }
        if self.skew_faces {
            l.skew_faces();
        }
        self.charge(|c| c.upload_ms += ms_since(t0));
        Ok(self.layouts[slot].get_or_init(|| l))
    }

    /// A float layout refused for a fragment kernel on a flat scene's irregular grid names
    /// the compute kernel where the context runs it: it reads that grid through the dense
    /// layout, which holds scenes the float one does not (the dragon at a texture size of
    /// 640, the 100-sphere scene on the H100).
    fn naming_compute(&self, target: LayoutTarget, e: Error) -> Error {
        match (e, target, self.accel, self.instancing) {
            (Error::Limit(m), LayoutTarget::Float, GridRef::Irregular(_), None)
                if self.ctx.info.compute =>
            {
                Error::Limit(format!(
                    "{m}, or --kernel compute (its dense layout of the grid may fit)"
                ))
            }
            (e, ..) => e,
        }
    }

    /// Whether `target` is the compute kernel on a flat scene's irregular grid, which reads
    /// either layout ([`GpuScene::layout`] chooses).
    fn either(&self, target: LayoutTarget) -> bool {
        matches!(
            (target, self.accel, self.instancing),
            (LayoutTarget::Compute, GridRef::Irregular(_), None)
        )
    }

    /// Which of the layouts `target` reads: the float one, but for the compute kernel on a
    /// flat scene's irregular grid the one [`GpuScene::layout`] chose (the dense slot, empty,
    /// until it has chosen).
    fn slot(&self, target: LayoutTarget) -> usize {
        if self.either(target) {
            self.compute_slot.get().copied().unwrap_or(DENSE)
        } else {
            FLOAT
        }
    }

    /// The float layout's textures with their units, uploaded on first use.
    pub fn textures(&self) -> Result<&[(Unit, Texture)]> {
        self.textures_for(LayoutTarget::Float)
    }

    /// The textures of `target`'s layout with their units, uploaded on first use.
    fn textures_for(&self, target: LayoutTarget) -> Result<&[(Unit, Texture)]> {
        // The layout first: it decides the compute kernel's slot.
        let layout = self.layout(target)?;
        let slot = self.slot(target);
        if let Some(t) = self.textures[slot].get() {
            return Ok(t);
        }
        let t0 = Instant::now();
        let textures = layout
            .with_units()
            .into_iter()
            .map(|(unit, t)| {
                Ok((
                    unit,
                    Texture::new_f32(self.ctx, t.width, t.height, Some(&t.data))?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        // Waiting here charges the upload to set-up instead of to the first pass that
        // reads it.
        state::finish(self.ctx.gl());
        self.charge(|c| {
            c.upload_ms += ms_since(t0);
            c.upload_bytes += layout.bytes();
        });
        Ok(self.textures[slot].get_or_init(|| textures))
    }

    /// The compute kernel's layout's texels as storage buffers at their bindings
    /// (`Fetch::Storage`), uploaded on first use.
    fn buffers(&self) -> Result<&[(u32, StorageBuffer)]> {
        let layout = self.layout(LayoutTarget::Compute)?;
        let slot = self.slot(LayoutTarget::Compute);
        if let Some(b) = self.buffers[slot].get() {
            return Ok(b);
        }
        let t0 = Instant::now();
        let buffers = layout
            .with_units()
            .into_iter()
            .enumerate()
            .map(|(k, (_, t))| {
                Ok((
                    STORAGE_BINDING_BASE + k as u32,
                    StorageBuffer::from_f32(self.ctx, &t.data)?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        state::finish(self.ctx.gl());
        self.charge(|c| {
            c.upload_ms += ms_since(t0);
            c.upload_bytes += layout.bytes();
        });
        Ok(self.buffers[slot].get_or_init(|| buffers))
    }

    /// The dense grid's storage buffers at their bindings (none for the float layout),
    /// uploaded on first use, each from the grid's own words where it keeps them (the
    /// cells' records made one buffer at a time), so the host holds no copy of the grid.
    fn dense_buffers(&self) -> Result<&[(u32, StorageBuffer)]> {
        if let Some(b) = self.dense_buffers.get() {
            return Ok(b);
        }
        let layout = self.layout(LayoutTarget::Compute)?;
        let (Some(d), GridRef::Irregular(g)) = (layout.dense(), self.accel) else {
            return Ok(self.dense_buffers.get_or_init(Vec::new));
        };
        let t0 = Instant::now();
        let buffers = DenseBuffer::ALL
            .iter()
            .map(|&b| {
                let words = d.buffer_words(g, b);
                Ok((
                    layout.dense_binding(b),
                    StorageBuffer::from_u32(self.ctx, &words)?,
                ))
            })
            .collect::<Result<Vec<_>>>()?;
        state::finish(self.ctx.gl());
        self.charge(|c| {
            c.upload_ms += ms_since(t0);
            c.upload_bytes += layout.dense_bytes() as usize;
        });
        Ok(self.dense_buffers.get_or_init(|| buffers))
    }

    /// Uploads what the compute kernel reads through `fetch` (its layout's textures or
    /// storage buffers, and the dense grid's buffers), so that it counts in the set-up.
    pub fn upload_compute(&self, fetch: Fetch) -> Result<()> {
        match fetch {
            Fetch::Storage => drop(self.buffers()?),
            Fetch::TexelFetch | Fetch::Texture2D => drop(self.textures_for(LayoutTarget::Compute)?),
        }
        self.dense_buffers().map(drop)
    }

    /// Binds what the compute kernel reads through `fetch` (uploading it first if needed).
    pub fn bind_compute(&self, fetch: Fetch) -> Result<()> {
        match fetch {
            Fetch::Storage => {
                for (binding, buf) in self.buffers()? {
                    buf.bind(self.ctx.gl(), *binding);
                }
            }
            Fetch::TexelFetch | Fetch::Texture2D => {
                for (unit, tex) in self.textures_for(LayoutTarget::Compute)? {
                    bind_texture(self.ctx.gl(), *unit, tex);
                }
            }
        }
        for (binding, buf) in self.dense_buffers()? {
            buf.bind(self.ctx.gl(), *binding);
        }
        Ok(())
    }

    /// Binds the scene textures to their units (uploading them first if needed).
    pub fn bind_textures(&self) -> Result<()> {
        for (unit, tex) in self.textures()? {
            bind_texture(self.ctx.gl(), *unit, tex);
        }
        Ok(())
    }
}

/// [`GpuScene::layouts`]' slots.
const FLOAT: usize = 0;
const DENSE: usize = 1;

/// Environment variable that caps the storage-block size the compute kernel's dense grid
/// is sized against below the driver's GL_MAX_SHADER_STORAGE_BLOCK_SIZE (tests: the
/// fallback to the float layout past it, on a small scene); other values are ignored.
pub const DENSE_BLOCK_BYTES_ENV: &str = "FRAGTRACE_DENSE_BLOCK_BYTES";

/// The storage-block size the dense grid's buffers must fit: the driver's, or
/// [`DENSE_BLOCK_BYTES_ENV`]'s where lower.
fn block_bytes(ctx: &GlContext) -> u64 {
    if !ctx.info.compute {
        return 0;
    }
    let driver = crate::gpu::gl::storage_limits(ctx.gl()).1;
    let cap = std::env::var(DENSE_BLOCK_BYTES_ENV)
        .ok()
        .and_then(|v| v.parse::<u64>().ok());
    cap.map_or(driver, |c| c.min(driver))
}
