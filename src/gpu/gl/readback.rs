//! Reading GPU buffers back while the GPU works on: a ring of two persistently mapped
//! staging buffers (`GL_ARB_buffer_storage`, GL 4.4). Each band's output is copied into a
//! slot on the GPU and fenced; the host takes the slot's bytes once its fence has passed,
//! while the next band is already being traced. Nothing is mapped or unmapped per band and
//! no call waits for more than the copy it needs. The fragment kernels' framebuffers come
//! back the same way ([`ReadbackRing::read_pixels`]: `glReadPixels` into a slot bound as
//! the pixel-pack buffer, a copy the GPU makes on its own, where reading into client
//! memory makes the driver copy on the host).

use glow::HasContext;

use super::{check_gl_error, BufferKind, GlKind, Owned, StorageBuffer};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;

/// Fence sync objects.
#[derive(Debug)]
pub enum SyncKind {}
impl GlKind for SyncKind {
    type Name = glow::Fence;
    unsafe fn delete(gl: &glow::Context, name: glow::Fence) {
        gl.delete_sync(name);
    }
}

/// One staging buffer, mapped for reading for its whole life.
struct Slot {
    buf: Owned<BufferKind>,
    ptr: *const u8,
    /// The copy in flight into it, and its length.
    pending: Option<(Owned<SyncKind>, usize)>,
}

/// Two persistently mapped staging buffers of `bytes` bytes each.
pub struct ReadbackRing {
    slots: [Slot; 2],
    bytes: usize,
    next: usize,
}

/// Whether the context can map buffers persistently (GL 4.4 or `GL_ARB_buffer_storage`).
pub fn has_buffer_storage(gl: &glow::Context) -> bool {
    let v = gl.version();
    (v.major, v.minor) >= (4, 4) || gl.supported_extensions().contains("GL_ARB_buffer_storage")
}

impl ReadbackRing {
    /// Two slots of `bytes` bytes; `Err` where the context lacks persistent mapping.
    pub fn new(ctx: &GlContext, bytes: usize) -> Result<Self> {
        let gl = ctx.gl();
        if !has_buffer_storage(gl) {
            return Err(Error::GlUnavailable(
                "persistently mapped buffers need GL 4.4 or GL_ARB_buffer_storage".into(),
            ));
        }
        let bytes = bytes.max(16);
        let size = i32::try_from(bytes).map_err(|_| {
            Error::Limit(format!("a staging buffer of {bytes} bytes exceeds 2 GiB"))
        })?;
        let flags = glow::MAP_READ_BIT | glow::MAP_PERSISTENT_BIT | glow::MAP_COHERENT_BIT;
        let slot = || -> Result<Slot> {
            // SAFETY: the context is current; the buffer is created, given immutable storage
            // and mapped here, and stays mapped until it is deleted.
            unsafe {
                let buf = Owned::<BufferKind>::new(
                    ctx,
                    gl.create_buffer()
                        .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?,
                );
                gl.bind_buffer(glow::COPY_WRITE_BUFFER, Some(buf.name()));
                gl.buffer_storage(glow::COPY_WRITE_BUFFER, size, None, flags);
                let ptr = gl.map_buffer_range(glow::COPY_WRITE_BUFFER, 0, size, flags);
                gl.bind_buffer(glow::COPY_WRITE_BUFFER, None);
                check_gl_error(gl, "mapping a staging buffer")?;
                if ptr.is_null() {
                    return Err(Error::Internal("glMapBufferRange returned null".into()));
                }
                Ok(Slot {
                    buf,
                    ptr: ptr.cast_const(),
                    pending: None,
                })
            }
        };
        Ok(ReadbackRing {
            slots: [slot()?, slot()?],
            bytes,
            next: 0,
        })
    }

    /// Bytes one slot holds: what one [`ReadbackRing::copy`] may move.
    pub fn slot_bytes(&self) -> usize {
        self.bytes
    }

    /// Queues a GPU copy of `len` bytes of `src` from byte `offset` on into the next slot
    /// (which must have been taken) and returns the slot. Shader writes to `src` before
    /// this call are made visible to the copy.
    pub fn copy(
        &mut self,
        ctx: &GlContext,
        src: &StorageBuffer,
        offset: usize,
        len: usize,
    ) -> Result<usize> {
        let gl = ctx.gl();
        let k = self.next;
        assert!(len <= self.bytes, "copy past the staging buffer");
        assert!(self.slots[k].pending.is_none(), "slot {k} not taken yet");
        let offset = i32::try_from(offset).map_err(|_| {
            Error::Limit(format!("a staging copy from byte {offset} is past 2 GiB"))
        })?;
        // SAFETY: the context is current; both buffers are alive, `len` fits the slot and
        // the caller's range lies in `src` (GL refuses it otherwise: checked below).
        unsafe {
            gl.memory_barrier(glow::BUFFER_UPDATE_BARRIER_BIT);
            gl.bind_buffer(glow::COPY_READ_BUFFER, Some(src.name()));
            gl.bind_buffer(glow::COPY_WRITE_BUFFER, Some(self.slots[k].buf.name()));
            gl.copy_buffer_sub_data(
                glow::COPY_READ_BUFFER,
                glow::COPY_WRITE_BUFFER,
                offset,
                0,
                len as i32,
            );
            gl.bind_buffer(glow::COPY_READ_BUFFER, None);
            gl.bind_buffer(glow::COPY_WRITE_BUFFER, None);
        }
        check_gl_error(gl, "copying to a staging buffer")?;
        self.fence(ctx, k, len)
    }

    /// Fences the copy just queued into slot `k` (`len` bytes), submits it and moves on to
    /// the other slot; returns `k`.
    fn fence(&mut self, ctx: &GlContext, k: usize, len: usize) -> Result<usize> {
        let gl = ctx.gl();
        // SAFETY: the context is current (GL 3.2 fences: `new` refused the ring without
        // buffer storage); the fence is owned at once, so it is deleted with its slot.
        let fence = unsafe {
            let f = gl
                .fence_sync(glow::SYNC_GPU_COMMANDS_COMPLETE, 0)
                .map_err(|e| Error::Internal(format!("glFenceSync: {e}")))?;
            // Submit now, so the wait in `take` cannot wait on commands never sent.
            gl.flush();
            Owned::<SyncKind>::new(ctx, f)
        };
        self.slots[k].pending = Some((fence, len));
        self.next = 1 - k;
        Ok(k)
    }

    /// Queues `glReadPixels` of the bound read framebuffer's `w` x `h` RGBA8 pixels from
    /// `attachment` into the next slot (which must have been taken) and returns the slot.
    pub fn read_pixels(
        &mut self,
        ctx: &GlContext,
        attachment: u32,
        w: u32,
        h: u32,
    ) -> Result<usize> {
        let gl = ctx.gl();
        let k = self.next;
        let len = w as usize * h as usize * 4;
        assert!(len <= self.bytes, "read past the staging buffer");
        assert!(self.slots[k].pending.is_none(), "slot {k} not taken yet");
        // SAFETY: the context is current; the slot is alive and holds `len` bytes, rows of
        // 4-byte pixels meet any pack alignment, and offset 0 is inside the bound buffer.
        unsafe {
            gl.bind_buffer(glow::PIXEL_PACK_BUFFER, Some(self.slots[k].buf.name()));
            gl.read_buffer(attachment);
            gl.read_pixels(
                0,
                0,
                w as i32,
                h as i32,
                glow::RGBA,
                glow::UNSIGNED_BYTE,
                glow::PixelPackData::BufferOffset(0),
            );
            gl.bind_buffer(glow::PIXEL_PACK_BUFFER, None);
        }
        check_gl_error(gl, "reading pixels into a staging buffer")?;
        self.fence(ctx, k, len)
    }

    /// Waits for slot `k`'s copy and passes its bytes to `take`.
    pub fn take<R>(
        &mut self,
        ctx: &GlContext,
        k: usize,
        take: impl FnOnce(&[u8]) -> R,
    ) -> Result<R> {
        let gl = ctx.gl();
        let (fence, len) = self.slots[k]
            .pending
            .take()
            .ok_or_else(|| Error::Internal(format!("staging slot {k} has no copy")))?;
        // SAFETY: the context is current and the fence, taken out of its slot, lives until
        // the end of this function; waiting reads no host memory.
        let status = unsafe {
            let mut s = gl.client_wait_sync(fence.name(), glow::SYNC_FLUSH_COMMANDS_BIT, 0);
            while s == glow::TIMEOUT_EXPIRED {
                s = gl.client_wait_sync(fence.name(), 0, 1_000_000_000);
            }
            s
        };
        if status == glow::WAIT_FAILED {
            check_gl_error(gl, "waiting for a staging copy")?;
            return Err(Error::Internal("glClientWaitSync failed".into()));
        }
        // SAFETY: the mapping is coherent and the copy into it has completed (its fence
        // passed); it stays mapped while the ring lives and holds `len <= bytes` bytes.
        let bytes = unsafe { std::slice::from_raw_parts(self.slots[k].ptr, len) };
        Ok(take(bytes))
    }
}
