//! The compute kernel's integer layout of the irregular grid ([`DenseIrregular`], issue 53):
//! its cells, voxel map and triangle references as `u32` in storage buffers, stored densely,
//! where the fragment kernels' float layout keeps ids that one f32 holds exactly (float
//! slots, which leave most texels of the cell texture empty past 2^24 cells: the
//! 100-sphere scene's 61.5 M cells took 2.14 G texels, 34 GB). Here a cell id is its index,
//! so the limits are the GPU's: [`GL_MAX_SHADER_STORAGE_BLOCK_SIZE`](DenseIrregular::check)
//! per buffer and memory. `DENSE_GRID` in the GLSL (`glsl120/traverse.glsl`,
//! `glsl120/step.glsl`) compiles this layout's reads in, in the compute kernels only.
//!
//! | buffer | per item | contents |
//! |---|---|---|
//! | `dense_cell_lo` | 16 bytes per cell | `uvec4`: exit box lower corner, first reference |
//! | `dense_cell_hi` | 16 bytes per cell | `uvec4`: exit box upper corner, reference count |
//! | `dense_vmap` | 4 bytes per entry | the voxel map in hops ([`WideMap`]): a cell id, or [`NODE`] + its child block's start |
//! | `dense_refs` | 4 bytes per reference | triangle indices |
//!
//! The ray state still carries a triangle as its float id ([`float_slot`](super::float_slot),
//! `tri_slot` here, exact to [`MAX_GPU_TRIANGLES`](super::MAX_GPU_TRIANGLES)), the same value
//! the fragment kernels carry, so that both find, order and report hits alike; a cell's id
//! never leaves the compute kernel's registers.

use std::borrow::Cow;

use super::irregular::uint_descent;
use super::packed::prev_pow2;
use super::{MAX_EXACT_INDEX, MAX_ROW};
use crate::accel::irregular::NODE;
use crate::accel::irregular_wide::WideMap;
use crate::accel::IrregularGrid;
use crate::{Error, Result};

/// Environment variable that, set to `1`, uploads the dense grid's references after 2^24
/// unused words, so that the compute kernel reads every reference past 2^24 on a scene CI
/// can afford (tests, as `FRAGTRACE_SPLIT_INDICES` forces the split format); other values
/// are ignored.
pub const DENSE_PAST_2_24_ENV: &str = "FRAGTRACE_DENSE_PAST_2_24";

/// The storage buffers of the layout, in binding order (after the scene textures' own
/// storage blocks: [`SceneTextures::storage_blocks`](super::SceneTextures::storage_blocks)).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DenseBuffer {
    /// Exit box lower corners and first references, one `uvec4` per cell.
    CellLo,
    /// Exit box upper corners and reference counts, one `uvec4` per cell.
    CellHi,
    /// The voxel map in hops, one `uint` per entry.
    Vmap,
    /// Triangle indices, one `uint` per reference.
    Refs,
}

impl DenseBuffer {
    /// Every buffer, in binding order.
    pub const ALL: [DenseBuffer; 4] = [
        DenseBuffer::CellLo,
        DenseBuffer::CellHi,
        DenseBuffer::Vmap,
        DenseBuffer::Refs,
    ];

    /// The GLSL name of its array (and the name in refusals and the plan).
    pub fn name(self) -> &'static str {
        match self {
            DenseBuffer::CellLo => "dense_cell_lo",
            DenseBuffer::CellHi => "dense_cell_hi",
            DenseBuffer::Vmap => "dense_vmap",
            DenseBuffer::Refs => "dense_refs",
        }
    }

    /// The GLSL type of one element.
    fn glsl_type(self) -> &'static str {
        match self {
            DenseBuffer::CellLo | DenseBuffer::CellHi => "uvec4",
            DenseBuffer::Vmap | DenseBuffer::Refs => "uint",
        }
    }

    /// Bytes of one element.
    pub fn element_bytes(self) -> u64 {
        match self {
            DenseBuffer::CellLo | DenseBuffer::CellHi => 16,
            DenseBuffer::Vmap | DenseBuffer::Refs => 4,
        }
    }

    /// Elements of a grid of `cells` cells, `refs` references and `entries` voxel-map
    /// entries.
    pub fn elements(self, cells: u64, refs: u64, entries: u64) -> u64 {
        match self {
            DenseBuffer::CellLo | DenseBuffer::CellHi => cells,
            DenseBuffer::Vmap => entries,
            DenseBuffer::Refs => refs,
        }
    }
}

/// The irregular grid's integer layout: the voxel map as the GPU reads it and the
/// constants of the descent; the cells and references are read from the grid when the
/// buffers are uploaded ([`DenseIrregular::buffer_words`]), so the host keeps no second copy.
#[derive(Clone, Debug)]
pub struct DenseIrregular {
    /// The voxel map in hops.
    pub map: WideMap,
    /// Cells.
    pub cells: u64,
    /// Triangle references.
    pub refs: u64,
    /// Unused words before the first reference in `dense_refs` (0; 2^24 under
    /// [`DENSE_PAST_2_24_ENV`], so that every read of a reference indexes past 2^24).
    pub ref_base: u32,
    /// Tests only: every face crossing moved by about an ulp (`SKEW_FACES`, as
    /// [`IrregularLayout::skew_faces`](super::IrregularLayout::skew_faces)).
    pub skew_faces: bool,
}

impl DenseIrregular {
    /// The voxel map the compute kernel reads for `g`: hops as wide as the float layout's
    /// on a GPU of `max_size` textures (the same map, so the same reads per lookup), within
    /// one storage block of `block_bytes`; or as
    /// [`HOP_BITS_ENV`](super::HOP_BITS_ENV) fixes them.
    pub(super) fn wide_map(g: &IrregularGrid, max_size: u32, block_bytes: u64) -> WideMap {
        let row = prev_pow2(max_size.min(MAX_ROW)).max(1) as u64;
        let texture = row * max_size as u64 * super::LIST_PER_TEXEL as u64;
        let block = block_bytes / DenseBuffer::Vmap.element_bytes();
        super::IrregularLayout::wide_map_within(g, texture.min(block) as usize)
    }

    /// Refuses, in one line naming the need, the limit and the options that exist, a
    /// buffer of `cells`, `refs` and `entries` past `block_bytes`
    /// (GL_MAX_SHADER_STORAGE_BLOCK_SIZE), a voxel map whose node entries cannot hold its
    /// length, or a cell whose count is past what the ray state's float cursor counts
    /// exactly (`max_count`).
    pub fn check(
        cells: u64,
        refs: u64,
        entries: u64,
        max_count: u64,
        block_bytes: u64,
    ) -> Result<()> {
        for b in DenseBuffer::ALL {
            let bytes = b.elements(cells, refs, entries) * b.element_bytes();
            if bytes > block_bytes {
                return Err(Error::Limit(format!(
                    "the irregular grid's buffer `{}` needs {bytes} bytes ({cells} cells, {refs} \
                     references, {entries} voxel-map entries), but GL_MAX_SHADER_STORAGE_BLOCK_SIZE \
                     is {block_bytes}; render it with --accel uniform, or --backend cpu",
                    b.name()
                )));
            }
        }
        if entries >= NODE as u64 {
            return Err(Error::Limit(format!(
                "{entries} voxel-map entries; a node entry of the compute kernel's voxel map \
                 addresses at most {NODE}; --accel uniform, or render it with --backend cpu"
            )));
        }
        if max_count > MAX_EXACT_INDEX {
            return Err(Error::Limit(format!(
                "an irregular cell of {max_count} triangle references; the GPU's walk counts \
                 a cell's references in one float, exact to {MAX_EXACT_INDEX}; render it with \
                 --backend cpu"
            )));
        }
        Ok(())
    }

    /// The words of buffer `b` for `g` (cells' records and references from the grid, the
    /// voxel map from [`DenseIrregular::map`]), made when it is uploaded.
    pub fn buffer_words<'a>(&'a self, g: &'a IrregularGrid, b: DenseBuffer) -> Cow<'a, [u32]> {
        let base = self.ref_base;
        match b {
            DenseBuffer::CellLo => Cow::Owned(
                g.cells
                    .iter()
                    .flat_map(|c| {
                        [
                            c.exit_lo[0],
                            c.exit_lo[1],
                            c.exit_lo[2],
                            base + c.range.offset,
                        ]
                    })
                    .collect(),
            ),
            DenseBuffer::CellHi => Cow::Owned(
                g.cells
                    .iter()
                    .flat_map(|c| [c.exit_hi[0], c.exit_hi[1], c.exit_hi[2], c.range.count])
                    .collect(),
            ),
            DenseBuffer::Vmap => Cow::Borrowed(&self.map.vmap),
            DenseBuffer::Refs if base == 0 => Cow::Borrowed(&g.tri_indices),
            DenseBuffer::Refs => {
                let mut v = vec![0; base as usize];
                v.extend_from_slice(&g.tri_indices);
                Cow::Owned(v)
            }
        }
    }

    /// The references' words as uploaded: [`DenseIrregular::ref_base`] of padding, then the
    /// references.
    pub fn ref_words(&self) -> u64 {
        self.ref_base as u64 + self.refs
    }

    /// [`DENSE_PAST_2_24_ENV`]'s padding: 2^24 where it is `1`, else none.
    pub(super) fn ref_base_from_env() -> u32 {
        let on = std::env::var(DENSE_PAST_2_24_ENV).is_ok_and(|v| v == "1");
        if on {
            MAX_EXACT_INDEX as u32
        } else {
            0
        }
    }

    /// GLSL: the buffers (at bindings from `first_binding` on), `tri_slot` and the integer
    /// descent `irr_lookup`, unrolled hop by hop with each hop's splits as constants (CPU
    /// twin: [`WideMap::lookup`]).
    pub(super) fn glsl(&self, first_binding: u32) -> String {
        let mut s = String::from(
            "#define ACCEL_IRREGULAR 1\n\
             #define DENSE_GRID 1\n\
             // NVIDIA: no fast-math contraction, so one crossing is evaluated alike everywhere.\n\
             #pragma optionNV(fastmath off)\n",
        );
        for (k, b) in DenseBuffer::ALL.iter().enumerate() {
            s += &format!(
                "layout(std430, binding = {}) readonly buffer Buf_{n} {{ {t} {n}[]; }};\n",
                first_binding + k as u32,
                n = b.name(),
                t = b.glsl_type(),
            );
        }
        s += &tri_slot_glsl();
        s +=
            "// Cell id of virtual cell k: the top entry, then one child block per hop while the\n\
              // entry is a node (CPU twin: WideMap::lookup).\n\
              uint irr_lookup(vec3 k) {\n\
              \x20   uvec3 c = uvec3(k);\n";
        let m = &self.map;
        s += &uint_descent(
            (m.shift, m.top_res, &m.hops),
            "uint",
            &format!("e >= {NODE}u"),
            &format!("e - {NODE}u"),
            &|i| format!("dense_vmap[{i}]"),
        );
        if self.skew_faces {
            s += "#define SKEW_FACES 1\n";
        }
        s
    }
}

/// GLSL 4.30 `tri_slot(k)`: the float id of triangle k as the fragment kernels carry it
/// (CPU twin: [`float_slot`](super::float_slot)): k up to 2^24, then 2^band (2^23 + i + 1),
/// an integer below 2^24 times a power of two built from its bits, so exact.
pub(crate) fn tri_slot_glsl() -> String {
    format!(
        "// The float id of triangle k (CPU twin: float_slot).\n\
         float tri_slot(uint k) {{\n\
         \x20   if (k <= {exact}u) return float(k);\n\
         \x20   uint m = k - {exact}u - 1u;\n\
         \x20   uint band = 1u + (m >> 23u);\n\
         \x20   return float(8388608u + (m & 8388607u) + 1u) * uintBitsToFloat((127u + band) << 23u);\n\
         }}\n",
        exact = MAX_EXACT_INDEX,
    )
}

#[cfg(test)]
#[path = "dense_tests.rs"]
mod tests;
