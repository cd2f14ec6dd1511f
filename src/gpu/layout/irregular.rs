//! The irregular grid's part of the layout ([`IrregularLayout`]): its voxel map packed in
//! hops ([`WideMap`]) and the GLSL of the descent, `irr_lookup`, generated hop by hop.

use super::packed::prev_pow2;
use super::{
    float_slot, IndexFormat, PackedTexture, LIST_PER_TEXEL, MAX_EXACT_INDEX, MAX_ROW,
    MAX_SLOT_TEXELS,
};
use crate::accel::irregular_wide::WideMap;
use crate::accel::IrregularGrid;
use crate::gpu::split_index::{align_blocks, aligned_len, MapEntry};
use crate::{Error, Result};

/// The irregular grid's part of the layout: its voxel map and the constants of the descent.
#[derive(Clone, Debug)]
pub struct IrregularLayout {
    /// Voxel map, four entries per texel.
    pub vmap: PackedTexture,
    /// Top cells per axis.
    pub top_res: [u32; 3],
    /// Splits per axis of each hop of the descent, top-down ([`WideMap`]).
    pub hops: Vec<[u32; 3]>,
    /// Splits per axis.
    pub shift: [u32; 3],
    /// Tests only: compile the walk with every face crossing moved by about an ulp
    /// (`SKEW_FACES` in `glsl120/traverse.glsl`; see [`GpuScene::with_skewed_faces`]).
    ///
    /// [`GpuScene::with_skewed_faces`]: crate::gpu::scene::GpuScene::with_skewed_faces
    pub skew_faces: bool,
    /// How node entries address their child blocks: minus (block + 1), one float (Float),
    /// or minus the block's start, an exact float split into hi * 2^24 + lo for the read
    /// ([`align_blocks`], Split).
    pub format: IndexFormat,
}

/// Exact decimal literal of 2^-n (every such power has a finite decimal expansion).
fn pow2_literal(n: u32) -> String {
    format!("{:e}", 2f64.powi(-(n as i32)))
}

impl IrregularLayout {
    /// The voxel map the GPU reads for `g`: hops as wide as a texture of this GPU holds
    /// ([`WideMap::for_gpu`]), or as [`HOP_BITS_ENV`] fixes them.
    pub(super) fn wide_map(g: &IrregularGrid, max_size: u32) -> WideMap {
        match hop_bits_override() {
            Some(bits) => WideMap::build(g, bits),
            None => {
                // Entries the largest texture of this GPU holds (as `PackedTexture::pack`
                // lays it out).
                let row = prev_pow2(max_size.min(MAX_ROW)).max(1) as usize;
                WideMap::for_gpu(g, row * max_size as usize * LIST_PER_TEXEL as usize)
            }
        }
    }

    /// The voxel map the GPU reads for `g` within `capacity` entries ([`WideMap::for_gpu`]),
    /// or as [`HOP_BITS_ENV`] fixes them.
    pub(super) fn wide_map_within(g: &IrregularGrid, capacity: usize) -> WideMap {
        match hop_bits_override() {
            Some(bits) => WideMap::build(g, bits),
            None => WideMap::for_gpu(g, capacity),
        }
    }

    /// Entries the voxel map `w` takes in `format` (the split format's blocks aligned to
    /// exact floats: [`align_blocks`]), counted before it is laid out.
    pub(super) fn entries(w: &WideMap, format: IndexFormat) -> u64 {
        match format {
            IndexFormat::Float => w.vmap.len() as u64,
            IndexFormat::Split => aligned_len(w, f32::MANTISSA_DIGITS),
        }
    }

    /// Refuses a voxel map of `entries` entries that the descent of `format` cannot read.
    pub(super) fn check_entries(entries: u64, format: IndexFormat) -> Result<()> {
        let limit = match format {
            IndexFormat::Float => MAX_EXACT_INDEX,
            // The compute kernel's integer reads (`entry_vmap_split`).
            IndexFormat::Split => MAX_SLOT_TEXELS,
        };
        if entries > limit {
            return Err(Error::Limit(format!(
                "{entries} voxel-map entries; the GPU's descent reads at most {limit}; --accel \
                 uniform, or render it with --backend cpu"
            )));
        }
        Ok(())
    }

    /// Packs `g` with its GPU voxel map `w` ([`IrregularLayout::wide_map`]), whose size
    /// the caller has checked ([`LayoutPlan`](super::LayoutPlan)).
    pub(super) fn pack(
        g: &IrregularGrid,
        w: WideMap,
        max_size: u32,
        format: IndexFormat,
    ) -> Result<Self> {
        let cell = |id: u32| float_slot(id as u64) as f32;
        let entries: Vec<f32> = match format {
            IndexFormat::Float => w
                .vmap
                .iter()
                .map(|&e| {
                    if e & crate::accel::irregular::NODE != 0 {
                        -((e & !crate::accel::irregular::NODE) as f32) - 1.0
                    } else {
                        cell(e)
                    }
                })
                .collect(),
            IndexFormat::Split => align_blocks(&w, f32::MANTISSA_DIGITS)
                .into_iter()
                .map(|e| match e {
                    MapEntry::Cell(id) => cell(id),
                    MapEntry::Node(start) => -(start as f32),
                })
                .collect(),
        };
        Self::check_entries(entries.len() as u64, format)?;
        Ok(IrregularLayout {
            vmap: PackedTexture::pack_entries("vmap", &entries, max_size)?,
            top_res: g.top_res,
            hops: w.hops,
            shift: g.shift,
            skew_faces: false,
            format,
        })
    }

    /// GLSL: the voxel-map fetch and `irr_lookup`, the descent unrolled over the hops.
    pub(super) fn glsl(&self) -> String {
        let v3 = |v: [String; 3]| format!("vec3({}, {}, {})", v[0], v[1], v[2]);
        let mut s = String::from(
            "#define ACCEL_IRREGULAR 1\n\
             // NVIDIA: no fast-math contraction, so one crossing is evaluated alike everywhere.\n\
             #pragma optionNV(fastmath off)\n\
             // Voxel-map entry i.\n\
             float vmap_entry(float i) { return entry_vmap(i); }\n\
             // Cell id of virtual cell k: the top entry, then one child block per hop of\n\
             // levels while the entry is a node (CPU twins: WideMap::lookup and\n\
             // IrregularGrid::lookup, the same cell). Every product is an integer times a power of two and\n\
             // every mod by a power of two of an integer, so exact.\n",
        );
        let float_format = self.format == IndexFormat::Float;
        if float_format {
            // The compute kernels (GLSL 4.30) descend in integers, as the dense layout does:
            // the same cell (every step exact either way), 3% off the H100's equal-work
            // kernel against the float descent (docs/performance.md).
            s += &self.glsl_lookup_uint();
            s += "#else\n";
        }
        s += "float irr_lookup(vec3 k) {\n";
        s += &format!(
            "    vec3 t = floor(k * {});\n    float e = vmap_entry(t.x + {:.1} * (t.y + {:.1} * t.z));\n",
            v3(self.shift.map(pow2_literal)),
            self.top_res[0] as f32,
            self.top_res[1] as f32
        );
        let mut rem = self.shift;
        for n in &self.hops {
            for a in 0..3 {
                rem[a] -= n[a];
            }
            let span = n.map(|b| format!("{:.1}", (1u32 << b) as f32));
            let stride = [1u32, 1 << n[0], 1 << (n[0] + n[1])].map(|v| format!("{:.1}", v as f32));
            let child = format!(
                "dot(mod(floor(k * {}), {}), {})",
                v3(rem.map(pow2_literal)),
                v3(span),
                v3(stride)
            );
            s += &match self.format {
                IndexFormat::Float => format!("    if (e < 0.0) e = vmap_entry(-e - 1.0 + {child});\n"),
                // The block's start -e, an exact float, as hi * 2^24 + lo; the child's
                // offset added in the split address arithmetic.
                IndexFormat::Split => format!(
                    "    if (e < 0.0) {{ float hi = floor(-e * {}); e = entry_vmap_split(hi, -e - hi * SPLIT_BASE, {child}); }}\n",
                    pow2_literal(24)
                ),
            };
        }
        s += "    return e;\n}\n";
        if float_format {
            s += "#endif\n";
        }
        if self.skew_faces {
            s += "#define SKEW_FACES 1\n";
        }
        s
    }

    /// `#ifdef KERNEL_COMPUTE` and the float layout's `irr_lookup` in integers: the virtual
    /// cell as a `uvec3`, each hop's child by shifts and masks, the block's start from the
    /// entry (`-e - 1`, exact), each entry read by `entry_vmap_u`.
    fn glsl_lookup_uint(&self) -> String {
        format!(
            "#ifdef KERNEL_COMPUTE\n\
             float irr_lookup(vec3 k) {{\n\
             \x20   uvec3 c = uvec3(k);\n{}",
            uint_descent(
                (self.shift, self.top_res, &self.hops),
                "float",
                "e < 0.0",
                "uint(-e - 1.0)",
                &|i| format!("entry_vmap_u({i})"),
            )
        )
    }
}

/// An integer voxel-map descent's body (GLSL 4.30; the float layout's in the compute
/// kernels, the dense layout's), after `uvec3 c` (the virtual cell) is declared: the top
/// cell's entry `e` (of `e_type`, read by `fetch` at an index), then per hop, while
/// `is_node`, the child's entry in the block starting at `block`; returns `e`. `map` is the
/// map's (shift, top resolution, hop bits per level).
pub(super) fn uint_descent(
    (shift, top_res, hops): ([u32; 3], [u32; 3], &[[u32; 3]]),
    e_type: &str,
    is_node: &str,
    block: &str,
    fetch: &dyn Fn(&str) -> String,
) -> String {
    let mut s = format!(
        "    uvec3 t = c >> uvec3({}u, {}u, {}u);\n\
         \x20   {e_type} e = {};\n",
        shift[0],
        shift[1],
        shift[2],
        fetch(&format!(
            "t.x + {}u * (t.y + {}u * t.z)",
            top_res[0], top_res[1]
        ))
    );
    let mut rem = shift;
    for n in hops {
        for a in 0..3 {
            rem[a] -= n[a];
        }
        let (q, child) = uint_hop_child(rem, *n);
        s += &format!(
            "    if ({is_node}) {{\n\
             \x20       {q}\n\
             \x20       e = {};\n\
             \x20   }}\n",
            fetch(&format!("{block} + {child}"))
        );
    }
    s += "    return e;\n}\n";
    s
}

/// One hop of an integer voxel-map descent (GLSL 4.30; the float layout's in the compute
/// kernels, the dense layout's): the declaration of `q`, the virtual cell `c`'s child
/// coordinates in the hop's block (`rem` splits left below the hop, `n` in it), and the
/// child's offset in the block from `q`.
fn uint_hop_child(rem: [u32; 3], n: [u32; 3]) -> (String, String) {
    let m = n.map(|b| (1u32 << b) - 1);
    (
        format!(
            "uvec3 q = (c >> uvec3({}u, {}u, {}u)) & uvec3({}u, {}u, {}u);",
            rem[0], rem[1], rem[2], m[0], m[1], m[2]
        ),
        format!("q.x + (q.y << {}u) + (q.z << {}u)", n[0], n[0] + n[1]),
    )
}

/// Environment variable that fixes the hop width of the GPU's voxel map (1 to
/// [`MAX_HOP_BITS`](crate::accel::irregular_wide::MAX_HOP_BITS) splits a hop; 1 uploads the
/// built map's levels one per hop) instead of [`WideMap::for_gpu`]'s choice: for
/// measuring what the hops buy. Other values are ignored.
pub const HOP_BITS_ENV: &str = "FRAGTRACE_VMAP_HOP_BITS";

fn hop_bits_override() -> Option<u32> {
    let bits: u32 = std::env::var(HOP_BITS_ENV).ok()?.parse().ok()?;
    (1..=crate::accel::irregular_wide::MAX_HOP_BITS)
        .contains(&bits)
        .then_some(bits)
}
