//! The split index format: how the GPU layout writes indices once a scene's texels or
//! references pass 2^24, what one f32 counts exactly ([`IndexFormat`], `SPLIT_INDEX` in the
//! GLSL), the CPU twins of its address arithmetic (GLSL twin: `glsl120/split_index.glsl`,
//! held to these on the driver by `tests/glsl_twins/split_index.rs`), the float slots that
//! keep the irregular grid's cell ids and the triangle ids one exact float (triangle
//! records stay dense: [`slot_record`]), the voxel map's blocks aligned to exact floats
//! ([`align_blocks`]), and the limits that remain, each refused in one line. `layout/`
//! packs with it and re-exports it.

use crate::accel::irregular_wide::WideMap;
use crate::accel::GridRef;
use crate::scene::Scene;
use crate::{Error, Result};

/// Largest index stored in a float that is still exact.
pub const MAX_EXACT_INDEX: u64 = 1 << 24;
/// The base of a split index: hi * `SPLIT_BASE` + lo with lo below it.
pub const SPLIT_BASE: u64 = 1 << 24;
/// Environment variable that, set to `1`, packs every scene in [`IndexFormat::Split`]
/// (tests, and measuring what the split path costs); other values are ignored.
pub const SPLIT_INDEX_ENV: &str = "FRAGTRACE_SPLIT_INDICES";

/// How the scene's textures write indices and offsets, and so how the GLSL reads them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum IndexFormat {
    /// One float per index, exact below 2^24: what every scene that fits takes.
    Float,
    /// `SPLIT_INDEX`: list offsets as hi * 2^24 + lo over two channels, the cursor counted
    /// from the cell's first reference, records fetched by (record, texel).
    Split,
}

impl IndexFormat {
    /// The format a scene of `texels` texels in its largest record texture and `refs`
    /// references needs; [`IndexFormat::Split`] when [`SPLIT_INDEX_ENV`] asks for it.
    pub fn needed(texels: u64, refs: u64) -> IndexFormat {
        let forced = std::env::var(SPLIT_INDEX_ENV).is_ok_and(|v| v == "1");
        if forced || texels > MAX_EXACT_INDEX || refs > MAX_EXACT_INDEX {
            IndexFormat::Split
        } else {
            IndexFormat::Float
        }
    }

    /// Texels per irregular cell.
    pub fn irregular_cell_texels(self) -> u32 {
        match self {
            IndexFormat::Float => 2,
            IndexFormat::Split => 3,
        }
    }

    /// The GLSL of the format: its `#define`s and, split, the exact address arithmetic
    /// every texture's fetches use (the list cursor's macros are the layout's:
    /// `SceneTextures::glsl_with`).
    pub(crate) fn glsl(self) -> String {
        match self {
            IndexFormat::Float => String::new(),
            IndexFormat::Split => format!(
                "#define SPLIT_INDEX 1
                 #define SPLIT_BASE {base:.1}
                 {}{}",
                include_str!("../../glsl120/split_index.glsl"),
                slot_glsl(),
                base = SPLIT_BASE as f32,
            ),
        }
    }
}

/// `(hi, lo)` of a split index: `e = hi * SPLIT_BASE + lo`, each exact in an f32.
pub fn split(e: u64) -> (f32, f32) {
    ((e / SPLIT_BASE) as f32, (e % SPLIT_BASE) as f32)
}

/// CPU twin of `rec_coord` (`glsl120/split_index.glsl`): the (column, row) of texel `k` of
/// record `item` of `per` texels in rows `w` wide (a power of two), with the GLSL's f32
/// operations in its order.
pub fn rec_coord(item: f32, per: f32, k: f32, w: f32) -> (f32, f32) {
    let inv_w = 1.0 / w;
    let a = (item * inv_w).floor();
    let c = per * (item - a * w) + k;
    let r = (c * inv_w).floor();
    (c - r * w, per * a + r)
}

/// CPU twin of `split_coord` (`glsl120/split_index.glsl`): (texel column, row, component)
/// of list entry `hi * 2^24 + lo + j` in rows of `w` texels of four entries.
pub fn split_coord(hi: f32, lo: f32, j: f32, w: f32) -> (f32, f32, f32) {
    let inv_r = 0.25 / w;
    let r = 4.0 * w;
    let lr = (lo * inv_r).floor();
    let c = lo - lr * r + j;
    let cr = (c * inv_r).floor();
    let e = c - cr * r;
    let x = (e * 0.25).floor();
    (x, hi * (SPLIT_BASE as f32 * inv_r) + lr + cr, e - x * 4.0)
}
/// Bands of float slots past 2^24 that triangle ids may take ([`float_slot`]; band b holds
/// 2^23 ids, 2^b apart): the GLSL decodes a slot with one comparison per band, so this
/// bounds the triangles the GPU kernels carry ([`MAX_GPU_TRIANGLES`]).
pub const TRI_SLOT_BANDS: u64 = 16;
/// Most triangles the GPU kernels carry: 2^24 ids, then [`TRI_SLOT_BANDS`] bands of 2^23.
pub const MAX_GPU_TRIANGLES: u64 = MAX_EXACT_INDEX + TRI_SLOT_BANDS * (1 << 23);

/// Refuses a scene of more triangles than the GPU kernels index: the ray state, the hit
/// records and the cell lists carry a triangle's id in one float, its [`float_slot`] (the
/// index itself below 2^24, exact floats past it, up to [`MAX_GPU_TRIANGLES`]); the
/// triangle records stay dense ([`slot_record`]). Checked before a structure is built for
/// the GPU, and again as it is packed.
pub fn check_triangles(n: usize) -> Result<()> {
    if n as u64 > MAX_GPU_TRIANGLES {
        return Err(Error::Limit(format!(
            "{n} triangles; the GPU kernels carry a triangle's id in one float, exact for up \
             to {MAX_GPU_TRIANGLES} triangles; render it with --backend cpu (the BVH has no \
             such limit)"
        )));
    }
    Ok(())
}

/// The record (dense index) of float slot `s`, the inverse of [`float_slot`]: `s` itself up
/// to 2^24, else, in band b (s in (2^(23+b), 2^(24+b)], 2^b apart), 2^23 (b + 1) + s / 2^b -
/// 2^23. CPU twin of `slot_record` in the split GLSL (`IndexFormat::glsl`), which decodes
/// the band with the same comparisons (a slot 2^(24+b) read as band b + 1 gives the same
/// record).
pub fn slot_record(s: f32) -> u64 {
    let (b1, inv_p) = slot_band(s);
    if b1 == 0.0 {
        return s as u64;
    }
    (b1 as u64) * (1 << 23) + (s * inv_p - (1u64 << 23) as f32) as u64
}

/// (b + 1, 2^-b) of slot `s` past 2^24 as the GLSL finds them, (0, 1) up to 2^24.
fn slot_band(s: f32) -> (f32, f32) {
    if s <= MAX_EXACT_INDEX as f32 {
        return (0.0, 1.0);
    }
    let (mut b1, mut inv_p) = (2.0f32, 0.5f32);
    for b in 2..=TRI_SLOT_BANDS {
        if s >= (1u64 << (23 + b)) as f32 {
            b1 = (b + 1) as f32;
            inv_p *= 0.5;
        }
    }
    (b1, inv_p)
}

/// CPU twin of `slot_coord` (the GLSL of [`IndexFormat::Split`]): the (column, row) of texel
/// `k` of the record of float slot `s` (records of `per` texels stored densely in rows `w`
/// wide), with the GLSL's f32 operations in its order.
pub fn slot_coord(s: f32, per: f32, k: f32, w: f32) -> (f32, f32) {
    let (b1, inv_p) = slot_band(s);
    if b1 == 0.0 {
        return rec_coord(s, per, k, w);
    }
    let half = (1u64 << 23) as f32;
    let (x, y) = rec_coord(s * inv_p - half, per, k, w);
    (x, y + per * b1 * (half * (1.0 / w)))
}

/// GLSL of the slot decoding: `slot_band` (as [`slot_band`]), `slot_coord` (Texture2D) and
/// `slot_record` (GLSL 1.30+, an unsigned record index), one comparison per band unrolled
/// (the multipass kernel's programs have no loops).
fn slot_glsl() -> String {
    let mut bands = String::new();
    for b in 2..=TRI_SLOT_BANDS {
        bands += &format!(
            "    if (s >= {:.1}) {{ b1 = {:.1}; inv_p = {:e}; }}\n",
            (1u64 << (23 + b)) as f32,
            (b + 1) as f32,
            2f64.powi(-(b as i32))
        );
    }
    format!(
        "// Triangle ids are float slots (exact floats, 2^b apart in band b past 2^24) over\n\
         // records stored densely: (b + 1, 2^-b) of slot s past 2^24 (CPU twin: slot_band).\n\
         vec2 slot_band(float s) {{\n\
         \x20   float b1 = 2.0;\n\
         \x20   float inv_p = 0.5;\n\
         {bands}\
         \x20   return vec2(b1, inv_p);\n\
         }}\n\
         // (column, row) of texel k of slot s's record (CPU twin: slot_coord).\n\
         vec2 slot_coord(float s, float per, float k, float w, float inv_w) {{\n\
         \x20   if (s <= SPLIT_BASE) return rec_coord(s, per, k, w, inv_w);\n\
         \x20   vec2 b = slot_band(s);\n\
         \x20   vec2 c = rec_coord(s * b.y - 0.5 * SPLIT_BASE, per, k, w, inv_w);\n\
         \x20   return vec2(c.x, c.y + per * b.x * (0.5 * SPLIT_BASE * inv_w));\n\
         }}\n\
         #if __VERSION__ >= 130\n\
         // Record index of slot s (CPU twin: slot_record).\n\
         uint slot_record(float s) {{\n\
         \x20   if (s <= SPLIT_BASE) return uint(s);\n\
         \x20   vec2 b = slot_band(s);\n\
         \x20   return uint(b.x) * 8388608u + uint(s * b.y - 0.5 * SPLIT_BASE);\n\
         }}\n\
         #endif\n"
    )
}

/// Refuses, with one line naming what is needed, the limit and what to do instead, a scene
/// whose triangle indices or cell ids do not fit the one float the ray state and hit records
/// carry them in (exact below 2^24): the limits the split format leaves (the voxel map's is
/// checked as it is packed).
pub(crate) fn check_indices(scene: &Scene, accel: GridRef<'_>) -> Result<()> {
    let advice = "render it with --backend cpu (the BVH has no such limit)";
    check_triangles(scene.triangles.len())?;
    match accel {
        GridRef::Uniform(g) if g.cells.len() as u64 > MAX_EXACT_INDEX => {
            Err(Error::Limit(format!(
                "{} grid cells; the GPU's uniform grid indexes its cells with one float, exact \
                 up to {MAX_EXACT_INDEX} cells; a coarser --grid or a lower --grid-density, \
                 or {advice}",
                g.cells.len()
            )))
        }
        GridRef::Irregular(g) if !g.cells.is_empty() => {
            let texels = irregular_cell_texels(g.cells.len() as u64, IndexFormat::Split);
            if texels > MAX_SLOT_TEXELS {
                return Err(Error::Limit(format!(
                    "{} grid cells; the GPU's irregular grid addresses them through {texels} \
                     texels, more than its {MAX_SLOT_TEXELS}; a lower --grid-density, \
                     --accel uniform, or {advice}",
                    g.cells.len()
                )));
            }
            Ok(())
        }
        _ => Ok(()),
    }
}

/// A voxel-map entry as the split format writes it ([`align_blocks`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapEntry {
    /// A cell id (written as its [`float_slot`]).
    Cell(u32),
    /// A node: its child block starts at this entry (written as minus it; never 0, since the
    /// top entries come first).
    Node(u64),
}

/// The voxel map `w` relaid for the split format: every child block that starts past
/// 2^`bits` (2^24 for f32) starts at a multiple of the spacing of floats of `bits`
/// significant bits there, so that its start is one exact float, which the descent splits
/// into hi * 2^24 + lo and adds the child's offset to in the split address arithmetic
/// (`entry_vmap_split`); blocks below keep their places. The padding left between blocks is
/// under one spacing per block (2 entries past 2^24, 4 past 2^25, ...). Lookups through the
/// result reach the cells `w`'s do (`bits` is a parameter so that tests reach the regime
/// with few entries).
pub fn align_blocks(w: &WideMap, bits: u32) -> Vec<MapEntry> {
    use crate::accel::irregular::NODE;
    let (blocks, new_start, pos) = aligned_blocks(w, bits);
    let tops = w.top_res.iter().map(|&r| r as usize).product::<usize>();
    let size = |hop: usize| 1usize << w.hops[hop].iter().sum::<u32>();
    let moved = |old: u32| {
        let k = blocks
            .binary_search_by_key(&(old as usize), |b| b.0)
            .expect("a node entry points at a child block");
        MapEntry::Node(new_start[k])
    };
    let entry = |e: u32| {
        if e & NODE != 0 {
            moved(e & !NODE)
        } else {
            MapEntry::Cell(e)
        }
    };
    let mut out = vec![MapEntry::Cell(0); pos as usize];
    for (o, &e) in out.iter_mut().zip(&w.vmap[..tops]) {
        *o = entry(e);
    }
    for (&(old, hop), &new) in blocks.iter().zip(&new_start) {
        for (o, &e) in out[new as usize..]
            .iter_mut()
            .zip(&w.vmap[old..old + size(hop)])
        {
            *o = entry(e);
        }
    }
    out
}

/// Entries of the map [`align_blocks`] lays out, counted without laying it out: what the
/// layout's size check ([`LayoutPlan`](super::layout::LayoutPlan)) reads before anything
/// of the voxel map's texture is allocated.
pub fn aligned_len(w: &WideMap, bits: u32) -> u64 {
    aligned_blocks(w, bits).2
}

/// Every child block of `w` as (old start, hop), sorted by old start; the new start of
/// each, aligned as [`align_blocks`] says; and the relaid map's length.
#[allow(clippy::type_complexity)]
fn aligned_blocks(w: &WideMap, bits: u32) -> (Vec<(usize, usize)>, Vec<u64>, u64) {
    use crate::accel::irregular::NODE;
    let tops = w.top_res.iter().map(|&r| r as usize).product::<usize>();
    let size = |hop: usize| 1usize << w.hops[hop].iter().sum::<u32>();
    // Every child block: (old start, hop), found from the top entries down.
    let mut blocks: Vec<(usize, usize)> = Vec::new();
    let mut stack: Vec<(usize, usize)> = w.vmap[..tops]
        .iter()
        .filter(|&&e| e & NODE != 0)
        .map(|&e| ((e & !NODE) as usize, 0))
        .collect();
    while let Some((start, hop)) = stack.pop() {
        blocks.push((start, hop));
        for &e in &w.vmap[start..start + size(hop)] {
            if e & NODE != 0 {
                stack.push(((e & !NODE) as usize, hop + 1));
            }
        }
    }
    blocks.sort_unstable();
    let exact = 1u64 << bits;
    let align = |pos: u64| {
        if pos <= exact {
            return pos;
        }
        let step = 1u64 << (63 - pos.leading_zeros() - (bits - 1));
        pos.div_ceil(step) * step
    };
    let mut new_start = Vec::with_capacity(blocks.len());
    let mut pos = tops as u64;
    for &(_, hop) in &blocks {
        pos = align(pos);
        new_start.push(pos);
        pos += size(hop) as u64;
    }
    (blocks, new_start, pos)
}

/// Texels of the irregular grid's cell texture: cell k at its [`float_slot`], `format`'s
/// texels per cell, the slots between left empty; as
/// [`SceneTextures::pack`](super::layout::SceneTextures::pack) lays it out. Past 2^24 cells
/// it grows faster than the cells (twice as fast per cell every 2^23 more).
pub fn irregular_cell_texels(cells: u64, format: IndexFormat) -> u64 {
    let slots = cells.checked_sub(1).map_or(0, |k| float_slot(k) + 1);
    slots * format.irregular_cell_texels() as u64
}

/// Most texels a record texture addressed by float slots may take: what the 32-bit
/// integer arithmetic of the compute kernel's fetches reaches.
pub const MAX_SLOT_TEXELS: u64 = 1 << 31;

/// The float id of the k-th record when ids must be exact f32 values: k itself up to 2^24,
/// then every integer an f32 holds exactly (2^24 + 2, + 4, ... to 2^25; then steps of 4 to
/// 2^26, ...). Ids stay one float (the ray state and the voxel map carry a cell's in one
/// channel) and ordered as the records are; the texture leaves the slots between them empty,
/// and `rec_coord` addresses any exact integer.
pub fn float_slot(k: u64) -> u64 {
    if k <= MAX_EXACT_INDEX {
        return k;
    }
    let m = k - MAX_EXACT_INDEX - 1;
    let band = 1 + m / (1 << 23);
    let i = m % (1 << 23);
    (1u64 << (23 + band)) + ((i + 1) << band)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Float slots are exact f32 values, strictly increasing (so the lowest-index tie rule
    /// keeps its order), the identity up to 2^24, and dense within each band.
    #[test]
    fn float_slots_are_exact_increasing_and_dense() {
        let near = MAX_EXACT_INDEX;
        let band = 1u64 << 23;
        let ks = (0..8u64).chain(near - 4..near + 8).chain([
            near + band - 1,
            near + band,
            near + band + 1,
            near + 5 * band + 3,
        ]);
        let mut last = None;
        for k in ks {
            let s = float_slot(k);
            assert_eq!(s as f32 as u64, s, "slot {s} of {k} is not an exact f32");
            if k <= near {
                assert_eq!(s, k);
            }
            if let Some((lk, ls)) = last {
                assert!(s > ls, "{k}: {s} after {lk}: {ls}");
                if lk + 1 == k && k > near + 1 {
                    // Consecutive records sit at consecutive exact floats.
                    assert_eq!(s - ls, (ls as f32).next_up() as u64 - ls, "{k}");
                }
            }
            last = Some((k, s));
        }
        assert_eq!(float_slot(near + band), 1 << 25);
        assert_eq!(float_slot(near + band + 1), (1 << 25) + 4);
    }

    /// Triangle ids k near every band boundary up to the last id the GPU carries, and a
    /// seeded spread.
    pub(crate) fn slot_ids() -> Vec<u64> {
        let mut v: Vec<u64> = (0..4).collect();
        for b in 0..=TRI_SLOT_BANDS {
            let edge = MAX_EXACT_INDEX + b * (1 << 23);
            v.extend(edge.saturating_sub(3)..edge + 4);
        }
        let mut x = 0x53u64;
        for _ in 0..2000 {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            v.push(x % MAX_GPU_TRIANGLES);
        }
        v.retain(|&k| k < MAX_GPU_TRIANGLES);
        v
    }

    /// A triangle's float slot decodes to its own record, and `slot_coord` addresses that
    /// record's texels, for ids around 2^24, every band edge and the last id carried.
    #[test]
    fn slots_decode_to_their_dense_record() {
        for k in slot_ids() {
            let s = float_slot(k);
            assert_eq!(s as f32 as u64, s, "slot of {k} is not exact");
            assert_eq!(slot_record(s as f32), k, "slot {s}");
            for (w, per, j) in [
                (4096u64, 3u64, 0u64),
                (16384, 3, 2),
                (4096, 3, 1),
                (1, 3, 2),
            ] {
                let t = per * k + j;
                if t / w >= 1 << 24 {
                    continue;
                }
                let want = ((t % w) as f32, (t / w) as f32);
                let got = slot_coord(s as f32, per as f32, j as f32, w as f32);
                assert_eq!(got, want, "slot {s} of {k}, w {w}, texel {j}");
            }
        }
        assert!(check_triangles(MAX_GPU_TRIANGLES as usize).is_ok());
        let e = check_triangles(MAX_GPU_TRIANGLES as usize + 1).unwrap_err();
        assert!(e.to_string().contains("--backend cpu"), "{e}");
    }

    /// `slot_record` (GLSL 4.30, the compute kernel's record index of a triangle's slot,
    /// which `fetch_tri_at` and `fetch_nrm_at` take under texel fetches and storage
    /// buffers) on the driver gives its CPU twin's record, the id itself, for every id of
    /// `slot_ids` (around 2^24, every band edge, the last id carried).
    #[test]
    fn slot_record_on_the_driver_is_the_cpu_twins() {
        use crate::gpu::context::with_test_context;
        use crate::gpu::gl::{compile_compute, dispatch, StorageBuffer};
        let ids = slot_ids();
        let slots: Vec<f32> = ids.iter().map(|&k| float_slot(k) as f32).collect();
        let src = format!(
            "#version 430\n{}\nlayout(local_size_x = 64) in;\n\
             layout(std430, binding = 0) readonly buffer In {{ float s[]; }};\n\
             layout(std430, binding = 1) writeonly buffer Out {{ uint r[]; }};\n\
             void main() {{\n\
             \x20   uint i = gl_GlobalInvocationID.x;\n\
             \x20   if (i < {n}u) r[i] = slot_record(s[i]);\n\
             }}\n",
            IndexFormat::Split.glsl(),
            n = slots.len()
        );
        let got = with_test_context(|ctx| {
            if !ctx.info.compute {
                println!("skipped: no compute shaders on this context");
                return None;
            }
            let p = compile_compute(ctx, "slot_record", &src, &|n| ("test".into(), n)).unwrap();
            let bytes: Vec<u8> = slots.iter().flat_map(|v| v.to_le_bytes()).collect();
            let input = StorageBuffer::new(ctx, &bytes).unwrap();
            let out = StorageBuffer::zeroed_u32(ctx, slots.len()).unwrap();
            input.bind(ctx.gl(), 0);
            out.bind(ctx.gl(), 1);
            dispatch(ctx.gl(), &p, [slots.len().div_ceil(64) as u32, 1, 1]);
            Some(out.read_u32(ctx.gl()).unwrap())
        });
        let Some(got) = got else { return };
        for ((&k, &s), &g) in ids.iter().zip(&slots).zip(&got) {
            assert_eq!(slot_record(s), k);
            assert_eq!(g as u64, k, "slot {s}");
        }
        println!("slot_record: {} ids on the driver", ids.len());
    }

    /// `tri_slot` (GLSL 4.30, the compute kernel's float id of a triangle index read from
    /// the dense grid's references) on the driver gives `float_slot`'s value, bit for bit,
    /// for every id of `slot_ids` (around 2^24, every band edge, the last id carried).
    #[test]
    fn tri_slot_on_the_driver_is_float_slot() {
        use crate::gpu::context::with_test_context;
        use crate::gpu::gl::{compile_compute, dispatch, StorageBuffer};
        let ids: Vec<u32> = slot_ids().into_iter().map(|k| k as u32).collect();
        let src = format!(
            "#version 430\n{}\nlayout(local_size_x = 64) in;\n\
             layout(std430, binding = 0) readonly buffer In {{ uint k[]; }};\n\
             layout(std430, binding = 1) writeonly buffer Out {{ float r[]; }};\n\
             void main() {{\n\
             \x20   uint i = gl_GlobalInvocationID.x;\n\
             \x20   if (i < {n}u) r[i] = tri_slot(k[i]);\n\
             }}\n",
            crate::gpu::layout::dense::tri_slot_glsl(),
            n = ids.len()
        );
        let got = with_test_context(|ctx| {
            if !ctx.info.compute {
                println!("skipped: no compute shaders on this context");
                return None;
            }
            let p = compile_compute(ctx, "tri_slot", &src, &|n| ("test".into(), n)).unwrap();
            let input = StorageBuffer::from_u32(ctx, &ids).unwrap();
            let out = StorageBuffer::zeroed_u32(ctx, ids.len()).unwrap();
            input.bind(ctx.gl(), 0);
            out.bind(ctx.gl(), 1);
            dispatch(ctx.gl(), &p, [ids.len().div_ceil(64) as u32, 1, 1]);
            Some(out.read_u32(ctx.gl()).unwrap())
        });
        let Some(got) = got else { return };
        for (&k, &g) in ids.iter().zip(&got) {
            let want = float_slot(k as u64) as f32;
            assert_eq!(f32::from_bits(g), want, "triangle {k}");
        }
        println!("tri_slot: {} ids on the driver", ids.len());
    }

    /// A voxel map relaid by `align_blocks` with 10 significant bits (so that blocks pass
    /// the "exact" bound at 1024 entries) leads every virtual cell to its cell, as
    /// the map it came from; every block past the bound starts at a multiple of the spacing.
    #[test]
    fn aligned_voxel_map_keeps_every_lookup() {
        use crate::accel::irregular_wide::WideMap;
        use crate::accel::{IrregularConfig, IrregularGrid};
        use glam::Vec3;
        // Two icospheres apart: a map several levels deep with empty space between.
        let (p, _, t) = crate::scene::shapes::sphere(3);
        let mut tris = Vec::new();
        for (c, r) in [(Vec3::ZERO, 1.0), (Vec3::new(3.0, 0.5, 0.0), 0.5)] {
            tris.extend(t.iter().map(|f| f.map(|i| c + p[i as usize] * r)));
        }
        let s = crate::testing::scene_of(&tris);
        let g = IrregularGrid::build(&s, &IrregularConfig::default()).unwrap();
        for hop_bits in [1, 3] {
            let w = WideMap::build(&g, hop_bits);
            let bits = 10;
            let a = align_blocks(&w, bits);
            assert_eq!(aligned_len(&w, bits), a.len() as u64);
            assert!(
                a.len() >= w.vmap.len() && w.vmap.len() > 2 << bits,
                "{}",
                w.vmap.len()
            );
            let tops = w.top_res.iter().map(|&r| r as usize).product::<usize>();
            let res = [0, 1, 2].map(|k| w.top_res[k] << w.shift[k]);
            let mut past = 0;
            for z in 0..res[2] {
                for y in 0..res[1] {
                    for x in 0..res[0] {
                        let k = [x, y, z];
                        let mut rem = w.shift;
                        let t = [0, 1, 2].map(|a| (k[a] >> rem[a]) as usize);
                        let top =
                            t[0] + w.top_res[0] as usize * (t[1] + w.top_res[1] as usize * t[2]);
                        let mut e = a[top];
                        for n in &w.hops {
                            let MapEntry::Node(start) = e else { break };
                            if start > 1 << bits {
                                let step = 1u64 << (63 - start.leading_zeros() - (bits - 1));
                                assert_eq!(start % step, 0, "block at {start}");
                                past += 1;
                            }
                            assert!(start >= tops as u64);
                            let mut idx = start as usize;
                            let mut stride = 0;
                            for ax in 0..3 {
                                rem[ax] -= n[ax];
                                idx += ((k[ax] as usize >> rem[ax]) & ((1 << n[ax]) - 1)) << stride;
                                stride += n[ax];
                            }
                            e = a[idx];
                        }
                        assert_eq!(e, MapEntry::Cell(w.lookup(k)), "{k:?}");
                    }
                }
            }
            assert!(past > 0, "no block past the bound");
        }
    }

    /// The CPU twins of the split address arithmetic against u64 for indices around 2^24
    /// and far past it (the GLSL is held to these in `tests/glsl_twins/split_index.rs`).
    #[test]
    fn split_arithmetic_is_exact_past_2_pow_24() {
        for e in [
            0u64,
            1,
            (1 << 24) - 1,
            1 << 24,
            (1 << 24) + 1,
            1 << 31,
            (1 << 32) + 3,
        ] {
            for w in [1u32, 4096, 16384] {
                for j in [0u64, 1, 999] {
                    if j > e || e / (4 * w as u64) >= 1 << 24 {
                        continue;
                    }
                    let (hi, lo) = split(e - j);
                    let t = e / 4;
                    let want = ((t % w as u64) as f32, (t / w as u64) as f32, (e % 4) as f32);
                    assert_eq!(split_coord(hi, lo, j as f32, w as f32), want, "{e} {j} {w}");
                }
            }
        }
        for item in [0u64, 5, (1 << 24) - 1, 1 << 24, 1 << 25, 3 << 26] {
            for (per, k) in [(3u64, 2u64), (2, 1), (7, 6)] {
                let w = 4096u64;
                let t = item * per + k;
                let want = ((t % w) as f32, (t / w) as f32);
                assert_eq!(rec_coord(item as f32, per as f32, k as f32, w as f32), want);
            }
        }
    }
}
