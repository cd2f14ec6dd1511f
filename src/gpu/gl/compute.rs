//! What the compute kernel adds to the GL objects (GL 4.3): compute programs compiled with
//! source-mapped errors, shader storage buffers, and binding a texture as an image.

use glow::HasContext;

use super::program::{create_program, keep_binary, parse_error_line, start_shader, Program};
use super::{check_gl_error, BufferKind, Owned, ShaderKind, Texture};
use crate::error::{Error, Result};
use crate::gpu::context::GlContext;

/// Compiles and links a compute program from `src` (GLSL 4.30). Errors as
/// [`super::compile_program`]'s: [`Error::Shader`] with the driver's log and the first error
/// line mapped to its `(file, line)` by `line_map`.
pub fn compile_compute(
    ctx: &GlContext,
    pass: &str,
    src: &str,
    line_map: &dyn Fn(usize) -> (String, usize),
) -> Result<Program> {
    start_compute(ctx, pass, src)?.finish(ctx, line_map)
}

/// A compute program handed to the driver to compile and link, whose outcome nobody has
/// asked for yet: a driver with `GL_KHR_parallel_shader_compile` (or the ARB one) works on
/// it on threads of its own while the caller renders with another kernel, and says when it
/// is done ([`PendingCompute::is_complete`]) without waiting (issue 52: the cold start).
#[derive(Debug)]
pub struct PendingCompute {
    program: Program,
    shader: Owned<ShaderKind>,
}

/// Starts compiling and linking the program [`compile_compute`] builds, without waiting
/// for either (no status is queried until [`PendingCompute::finish`]).
pub fn start_compute(ctx: &GlContext, pass: &str, src: &str) -> Result<PendingCompute> {
    let gl = ctx.gl();
    // SAFETY: the context is current; every name used is created and owned here.
    unsafe {
        let shader = start_shader(ctx, glow::COMPUTE_SHADER, src)?;
        let program = create_program(ctx, pass)?;
        let p = program.name();
        gl.attach_shader(p, shader.name());
        keep_binary(ctx, p);
        gl.link_program(p);
        Ok(PendingCompute { program, shader })
    }
}

impl PendingCompute {
    /// Whether the driver has finished compiling and linking (`GL_COMPLETION_STATUS`),
    /// without waiting. A context without the parallel-compile extension has no way to
    /// say so: there the answer is true, and [`PendingCompute::finish`] waits.
    pub fn is_complete(&self, ctx: &GlContext) -> bool {
        if !has_parallel_compile(ctx) {
            return true;
        }
        // SAFETY: the context is current and offers the query (its extension); the
        // program is this value's.
        unsafe { ctx.gl().get_program_completion_status(self.program.name()) }
    }

    /// Gives the compile up. Where the driver is still at it, its program and shader are
    /// deleted once it is done (the next scene in this context asks) or when the context
    /// goes, rather than now: NVIDIA's driver makes a delete wait for the compile to end
    /// (300-330 ms after the looped frame of a cold start on the H100, for a program the
    /// render no longer needs; docs/performance.md).
    pub fn abandon(self, ctx: &GlContext) {
        if self.is_complete(ctx) {
            return;
        }
        self.program.delete_when(|gl, p| {
            // SAFETY: asked with the owning context current (`GlShared::reap`), which
            // offers the query (a compile still runs only under the extension).
            unsafe { gl.get_program_completion_status(p) }
        });
        self.shader.delete_when(|gl, s| {
            // SAFETY: as for the program.
            unsafe { gl.get_shader_completion_status(s) }
        });
    }

    /// Waits for the link and returns the program, or [`compile_compute`]'s error.
    pub fn finish(
        self,
        ctx: &GlContext,
        line_map: &dyn Fn(usize) -> (String, usize),
    ) -> Result<Program> {
        let gl = ctx.gl();
        let pass = self.program.pass.clone();
        let shader_error = |(file, line): (String, usize), log: String| Error::Shader {
            pass: pass.clone(),
            file,
            line,
            log: log.trim_end().to_string(),
        };
        // SAFETY: the context is current; the shader and the program are this value's.
        unsafe {
            let p = self.program.name();
            if !gl.get_program_link_status(p) {
                if !gl.get_shader_compile_status(self.shader.name()) {
                    let log = gl.get_shader_info_log(self.shader.name());
                    let at = match parse_error_line(&log) {
                        Some(n) => line_map(n),
                        None => ("<compute shader>".to_string(), 0),
                    };
                    return Err(shader_error(at, log));
                }
                let log = gl.get_program_info_log(p);
                let line = parse_error_line(&log).unwrap_or(0);
                return Err(shader_error(("<link>".into(), line), log));
            }
            // The shader is only needed until link; detached (and dropped) the driver
            // frees it now.
            gl.detach_shader(p, self.shader.name());
            check_gl_error(gl, &format!("building the `{pass}` program"))?;
        }
        Ok(self.program)
    }
}

/// Whether the context's driver may compile on threads of its own and answers
/// `GL_COMPLETION_STATUS` (`GL_KHR_parallel_shader_compile` or the ARB one).
pub fn has_parallel_compile(ctx: &GlContext) -> bool {
    ctx.info.has_extension("GL_KHR_parallel_shader_compile")
        || ctx.info.has_extension("GL_ARB_parallel_shader_compile")
}

/// A shader storage buffer; deleted when dropped.
#[derive(Debug)]
pub struct StorageBuffer {
    obj: Owned<BufferKind>,
    bytes: usize,
}

impl StorageBuffer {
    /// A buffer holding `data` (at least 16 bytes are allocated: GL refuses empty ones and
    /// an unsized array in a block still needs a binding).
    pub fn new(ctx: &GlContext, data: &[u8]) -> Result<Self> {
        let mut padded = data.to_vec();
        padded.resize(data.len().max(16), 0);
        // SAFETY: `create` calls this with the context current and the new buffer bound;
        // GL copies `padded`, which outlives the call, and reads no more than its length.
        Self::create(ctx, padded.len(), |gl| unsafe {
            gl.buffer_data_u8_slice(glow::SHADER_STORAGE_BUFFER, &padded, glow::DYNAMIC_COPY)
        })
    }

    /// A buffer holding `words`, uploaded from them without a copy on the host (one of at
    /// least 16 bytes is made for fewer, as [`StorageBuffer::new`] does).
    pub fn from_u32(ctx: &GlContext, words: &[u32]) -> Result<Self> {
        // SAFETY: every initialised u32 is four initialised bytes and u8 has alignment 1,
        // so the view covers exactly the words' memory, which `words` keeps alive.
        let bytes: &[u8] = unsafe {
            std::slice::from_raw_parts(words.as_ptr().cast::<u8>(), std::mem::size_of_val(words))
        };
        Self::from_bytes(ctx, bytes)
    }

    /// A buffer holding `values` (native byte order), uploaded from them without a copy on
    /// the host: a scene's largest textures as storage buffers.
    pub fn from_f32(ctx: &GlContext, values: &[f32]) -> Result<Self> {
        // SAFETY: every initialised f32 is four initialised bytes and u8 has alignment 1,
        // so the view covers exactly the values' memory, which `values` keeps alive.
        let bytes: &[u8] = unsafe {
            std::slice::from_raw_parts(values.as_ptr().cast::<u8>(), std::mem::size_of_val(values))
        };
        Self::from_bytes(ctx, bytes)
    }

    /// A buffer holding `bytes`, copied by GL alone where there are 16 or more.
    fn from_bytes(ctx: &GlContext, bytes: &[u8]) -> Result<Self> {
        if bytes.len() < 16 {
            return Self::new(ctx, bytes);
        }
        // SAFETY: `create` calls this with the context current and the new buffer bound;
        // GL copies `bytes`, which outlive the call, and reads no more than their length.
        Self::create(ctx, bytes.len(), |gl| unsafe {
            gl.buffer_data_u8_slice(glow::SHADER_STORAGE_BUFFER, bytes, glow::DYNAMIC_COPY)
        })
    }

    /// A buffer of `n` zeroed `u32`s.
    pub fn zeroed_u32(ctx: &GlContext, n: usize) -> Result<Self> {
        Self::new(ctx, &vec![0u8; n * 4])
    }

    /// A buffer of `bytes` bytes whose contents the GPU writes first (nothing uploaded).
    pub fn uninit(ctx: &GlContext, bytes: usize) -> Result<Self> {
        let bytes = bytes.max(16);
        let size = i32::try_from(bytes).map_err(|_| {
            Error::Limit(format!(
                "a storage buffer of {bytes} bytes exceeds GL's 2 GiB size argument"
            ))
        })?;
        // SAFETY: `create` calls this with the context current and the new buffer bound;
        // GL allocates `size` bytes and reads no host memory.
        Self::create(ctx, bytes, |gl| unsafe {
            gl.buffer_data_size(glow::SHADER_STORAGE_BUFFER, size, glow::DYNAMIC_COPY)
        })
    }

    /// A new buffer of `bytes` bytes whose storage `fill` specifies while it is bound.
    fn create(ctx: &GlContext, bytes: usize, fill: impl FnOnce(&glow::Context)) -> Result<Self> {
        let gl = ctx.gl();
        // SAFETY: the context is current; the buffer is created and owned here.
        let obj = unsafe {
            let obj = Owned::new(
                ctx,
                gl.create_buffer()
                    .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?,
            );
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(obj.name()));
            fill(gl);
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, None);
            obj
        };
        check_gl_error(gl, "allocating a storage buffer")?;
        Ok(StorageBuffer { obj, bytes })
    }

    /// Reads the first `out.len()` floats of the buffer into `out` through a
    /// host-side staging buffer: one DMA copy on the GPU, then a parallel copy out of the
    /// mapped staging memory. On the H200 this read a 4096x4096 render's 448 MB of outputs
    /// in 176 ms where `glGetBufferSubData` on the device buffer took 731 ms
    /// (docs/performance.md).
    pub fn read_f32_staged(&self, ctx: &GlContext, out: &mut [f32]) -> Result<()> {
        use rayon::prelude::*;
        let gl = ctx.gl();
        let bytes = out.len() * 4;
        assert!(bytes <= self.bytes, "read past the buffer");
        if bytes == 0 {
            return Ok(());
        }
        // SAFETY: the context is current; the staging buffer is `bytes` long and mapped
        // for reading while the copy runs; f32 accepts any bit pattern.
        unsafe {
            let staging = Owned::<BufferKind>::new(
                ctx,
                gl.create_buffer()
                    .map_err(|e| Error::Internal(format!("glGenBuffers: {e}")))?,
            );
            gl.memory_barrier(glow::BUFFER_UPDATE_BARRIER_BIT);
            gl.bind_buffer(glow::COPY_READ_BUFFER, Some(self.obj.name()));
            gl.bind_buffer(glow::COPY_WRITE_BUFFER, Some(staging.name()));
            gl.buffer_data_size(glow::COPY_WRITE_BUFFER, bytes as i32, glow::STREAM_READ);
            gl.copy_buffer_sub_data(
                glow::COPY_READ_BUFFER,
                glow::COPY_WRITE_BUFFER,
                0,
                0,
                bytes as i32,
            );
            let ptr =
                gl.map_buffer_range(glow::COPY_WRITE_BUFFER, 0, bytes as i32, glow::MAP_READ_BIT);
            if ptr.is_null() {
                gl.bind_buffer(glow::COPY_READ_BUFFER, None);
                gl.bind_buffer(glow::COPY_WRITE_BUFFER, None);
                check_gl_error(gl, "mapping a staging buffer")?;
                return Err(Error::Internal("glMapBufferRange returned null".into()));
            }
            let src = std::slice::from_raw_parts(ptr.cast::<f32>().cast_const(), out.len());
            out.par_chunks_mut(1 << 16)
                .zip(src.par_chunks(1 << 16))
                .for_each(|(d, s)| d.copy_from_slice(s));
            gl.unmap_buffer(glow::COPY_WRITE_BUFFER);
            gl.bind_buffer(glow::COPY_READ_BUFFER, None);
            gl.bind_buffer(glow::COPY_WRITE_BUFFER, None);
        }
        check_gl_error(gl, "reading a storage buffer")
    }

    /// The raw name.
    pub fn name(&self) -> glow::Buffer {
        self.obj.name()
    }

    /// Overwrites the buffer's first bytes with `data` (which must fit).
    pub fn write(&self, gl: &glow::Context, data: &[u8]) -> Result<()> {
        assert!(data.len() <= self.bytes, "write past the storage buffer");
        // SAFETY: the context is current; `data` fits the buffer.
        unsafe {
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(self.obj.name()));
            gl.buffer_sub_data_u8_slice(glow::SHADER_STORAGE_BUFFER, 0, data);
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, None);
        }
        check_gl_error(gl, "writing a storage buffer")
    }

    /// Binds the buffer to storage-block binding `index`.
    pub fn bind(&self, gl: &glow::Context, index: u32) {
        // SAFETY: the context is current and the buffer is alive.
        unsafe { gl.bind_buffer_base(glow::SHADER_STORAGE_BUFFER, index, Some(self.obj.name())) };
    }

    /// Reads the whole buffer back as `u32`s (after the writes it waits for).
    pub fn read_u32(&self, gl: &glow::Context) -> Result<Vec<u32>> {
        let mut bytes = vec![0u8; self.bytes];
        // SAFETY: the context is current; `bytes` is exactly the buffer's size.
        unsafe {
            gl.memory_barrier(glow::BUFFER_UPDATE_BARRIER_BIT);
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, Some(self.obj.name()));
            gl.get_buffer_sub_data(glow::SHADER_STORAGE_BUFFER, 0, &mut bytes);
            gl.bind_buffer(glow::SHADER_STORAGE_BUFFER, None);
        }
        check_gl_error(gl, "reading a storage buffer")?;
        Ok(bytes
            .chunks_exact(4)
            .map(|b| u32::from_ne_bytes([b[0], b[1], b[2], b[3]]))
            .collect())
    }
}

/// Binds level 0 of RGBA32F `tex` to image unit `unit` for reading and writing.
pub fn bind_image(gl: &glow::Context, unit: u32, tex: &Texture) {
    // SAFETY: the context is current and the texture is alive.
    unsafe {
        gl.bind_image_texture(
            unit,
            Some(tex.name()),
            0,
            false,
            0,
            glow::READ_WRITE,
            glow::RGBA32F,
        )
    };
}

/// Runs `program` over `groups` work groups (x, y, z) and makes its writes visible to
/// every later command (`glMemoryBarrier(GL_ALL_BARRIER_BITS)`); leaves it the current
/// program. The buffers, images and textures it reads must be bound.
pub fn dispatch(gl: &glow::Context, program: &Program, groups: [u32; 3]) {
    let [x, y, z] = groups;
    // SAFETY: the context is current and `program` a linked program of it; the call hands
    // GL no host memory, and the shader reaches only the objects bound to it, which the
    // caller sized by the contract's layouts (gpu::contract::compute).
    unsafe {
        gl.use_program(Some(program.name()));
        gl.dispatch_compute(x, y, z);
        gl.memory_barrier(glow::ALL_BARRIER_BITS);
    }
}

/// The current context's storage-block limits for compute shaders:
/// `GL_MAX_COMPUTE_SHADER_STORAGE_BLOCKS` and `GL_MAX_SHADER_STORAGE_BLOCK_SIZE` (capped
/// at what GL's 32-bit sizes express); 0 where the context has no compute shaders.
pub fn storage_limits(gl: &glow::Context) -> (u32, u64) {
    // SAFETY: the context is current; both names are single-valued queries (an unknown
    // name in an older context is a GL error and leaves the zero).
    unsafe {
        (
            gl.get_parameter_i32(glow::MAX_COMPUTE_SHADER_STORAGE_BLOCKS)
                .max(0) as u32,
            (gl.get_parameter_i64(glow::MAX_SHADER_STORAGE_BLOCK_SIZE)
                .max(0) as u64)
                .min(i32::MAX as u64),
        )
    }
}
