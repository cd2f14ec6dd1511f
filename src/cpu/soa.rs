//! A structure-of-arrays copy of the triangles in the order of a structure's reference list
//! (`tri_indices`): reference `r` of every cell is the triangle `list[r]`, its vertex
//! coordinates stored at index `r` of nine f32 arrays, so the vectorised triangle tests
//! (`cpu/simd.rs`) load 8 (AVX2) or 4 (SSE2) consecutive references of a cell with one
//! unaligned load per coordinate, no gather. Not a GLSL twin: only the vectorised CPU path
//! reads it.
//!
//! The arrays are padded by [`PAD`] entries so that a load starting at a cell's last
//! reference stays in bounds; the lanes past a cell's count are masked off by the kernels.
//! The ray-independent part of the watertight test, whether the triangle has zero area in
//! f32 (its normal `(p1 - p0) x (p2 - p0)`, computed as `intersect.rs` computes it, has zero
//! squared length), is decided once here, so the kernels do not repeat it per ray.

use super::real::V3;

/// Entries of padding after the last reference (one full AVX2 load).
pub const PAD: usize = 8;

/// The triangles of a reference list as nine coordinate arrays and a usable flag.
#[derive(Clone, Debug)]
pub struct SoaTris {
    /// `v[k][a][r]`: coordinate `a` (x, y, z) of vertex `k` of reference `r`'s triangle.
    pub v: [[Vec<f32>; 3]; 3],
    /// All bits set when reference `r`'s triangle has non-zero area in f32 (it can be hit),
    /// zero when it has zero area or `r` is padding. Stored as f32 bits, to be and-ed with
    /// comparison masks.
    pub ok: Vec<f32>,
    /// References (without the padding).
    pub len: usize,
    /// Reference `r`'s triangle in one record at index `r` (no padding), for the packet
    /// walk (`cpu/traverse_packet.rs`), which tests one triangle at a time against many
    /// rays: its nine coordinates in one or two cache lines instead of nine. Empty until
    /// [`SoaTris::pack`].
    pub packed: Vec<PackedTri>,
}

/// One triangle of [`SoaTris`] in one record: `v[k][a]` is coordinate `a` of vertex `k`,
/// `ok` as [`SoaTris::ok`].
#[derive(Clone, Copy, Debug, Default)]
#[repr(C, align(16))]
pub struct PackedTri {
    /// The vertices.
    pub v: [[f32; 3]; 3],
    /// As [`SoaTris::ok`].
    pub ok: f32,
}

impl SoaTris {
    /// Copies `tris` (in load order) into reference order `list`.
    pub fn new(tris: &[[V3<f32>; 3]], list: &[u32]) -> SoaTris {
        let n = list.len() + PAD;
        let mut v: [[Vec<f32>; 3]; 3] = std::array::from_fn(|_| {
            std::array::from_fn(|_| {
                let mut a = Vec::with_capacity(n);
                a.resize(list.len(), 0.0);
                a
            })
        });
        let mut ok = vec![0.0f32; n];
        let all = f32::from_bits(u32::MAX);
        for (r, &t) in list.iter().enumerate() {
            let p = &tris[t as usize];
            for k in 0..3 {
                for a in 0..3 {
                    v[k][a][r] = p[k][a];
                }
            }
            // Exactly the zero-area rejection of `intersect_watertight`.
            let nrm = (p[1] - p[0]).cross(p[2] - p[0]);
            if nrm.dot(nrm) != 0.0 {
                ok[r] = all;
            }
        }
        // Padding: finite zeros (never read as a hit: `ok` is zero there).
        for k in v.iter_mut() {
            for a in k.iter_mut() {
                a.resize(n, 0.0);
            }
        }
        SoaTris {
            v,
            ok,
            len: list.len(),
            packed: Vec::new(),
        }
    }

    /// Fills [`SoaTris::packed`] from the arrays.
    pub fn pack(&mut self) {
        self.packed = (0..self.len)
            .map(|r| PackedTri {
                v: std::array::from_fn(|k| std::array::from_fn(|a| self.v[k][a][r])),
                ok: self.ok[r],
            })
            .collect();
    }

    /// Bytes held (for the stats).
    pub fn bytes(&self) -> usize {
        (self.v.len() * 3 + 1) * self.ok.len() * 4
    }
}
