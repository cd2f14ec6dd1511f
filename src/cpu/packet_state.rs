//! What a packet walk of `cpu/traverse_packet.rs` keeps while it runs: the packet of rays
//! lane by lane with their box and triangle constants (`Packet`), the stack of children
//! met with their lanes (`Stack`, `Entry`) and a triangle test's lane values
//! (`Lanes`); and where a ray's fields lie, for the set-up that gathers them. Apart from
//! the walks (a macro instantiated per vector unit) so that each file holds one job.

use super::traverse::Ray;

/// Most rays of a packet (AVX-512's 16 f32 lanes).
pub const MAX_W: usize = 16;

/// Up to [`MAX_W`] rays lane by lane: the single-ray walks' box constants
/// (`traverse_bvh::BoxRay`) and triangle constants (`simd::RayConsts`). Lanes past the
/// rays given repeat the last ray and are not live.
#[derive(Clone, Copy)]
#[repr(C, align(64))]
pub(super) struct Packet {
    /// Origin, per axis.
    pub(super) o: [[f32; MAX_W]; 3],
    /// Reciprocal direction, per axis.
    pub(super) inv: [[f32; MAX_W]; 3],
    /// Origin on the shear axes kx, ky, kz.
    pub(super) ok: [[f32; MAX_W]; 3],
    /// Shear constants sx, sy, sz.
    pub(super) s: [[f32; MAX_W]; 3],
    /// Interval start.
    pub(super) t_min: [f32; MAX_W],
    /// Interval end.
    pub(super) t_max: [f32; MAX_W],
    /// Per axis, the lanes whose reciprocal direction is negative (then a slab's near
    /// plane is the box's upper bound).
    pub(super) neg: [u32; 3],
    /// `axis[j][c]`: the lanes whose shear axis j (kx, ky, kz) is axis c.
    pub(super) axis: [[u32; 3]; 3],
    /// The lanes holding rays.
    pub(super) live: u32,
}

impl Packet {
    /// A packet of `n` live lanes (the first `n`), every value zero, for the set-up to fill.
    #[cfg(target_arch = "x86_64")]
    pub(super) fn empty(n: usize) -> Packet {
        Packet {
            o: [[0.0; MAX_W]; 3],
            inv: [[0.0; MAX_W]; 3],
            ok: [[0.0; MAX_W]; 3],
            s: [[0.0; MAX_W]; 3],
            t_min: [0.0; MAX_W],
            t_max: [0.0; MAX_W],
            neg: [0; 3],
            axis: [[0; 3]; 3],
            live: (1u32 << n) - 1,
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
impl Packet {
    /// The packet of `rays` ray by ray, from the single-ray walks' own constructors: the
    /// reference the vectorised `packet` of each unit is tested against.
    pub(super) fn new(rays: &[Ray<f32>]) -> Packet {
        use super::simd::RayConsts;
        debug_assert!(!rays.is_empty() && rays.len() <= MAX_W);
        let mut p = Packet::empty(rays.len());
        for i in 0..MAX_W {
            let ray = &rays[i.min(rays.len() - 1)];
            // The t bound is the walk's switch, not the packet's: any value here.
            let rc = RayConsts::of_ray(ray, &Default::default());
            for a in 0..3 {
                p.o[a][i] = ray.o[a];
                // `BoxRay::new`: 1 / -0 is -inf, negative as the zero's sign says.
                p.inv[a][i] = 1.0 / ray.d[a];
                if p.inv[a][i] < 0.0 {
                    p.neg[a] |= 1 << i;
                }
                p.ok[a][i] = rc.o[a];
                p.s[a][i] = rc.s[a];
                p.axis[a][rc.k[a]] |= 1 << i;
            }
            p.t_min[i] = ray.t_min;
            p.t_max[i] = ray.t_max;
        }
        p
    }
}

/// `Ray<f32>`'s size in f32, for gathering a field of a slice of rays.
#[cfg(target_arch = "x86_64")]
const RAY_STRIDE: usize = std::mem::size_of::<Ray<f32>>() / 4;

/// Where each field the packet gathers lies in a `Ray<f32>`, in f32 from its start:
/// origin x, y, z, direction x, y, z, `t_min`, `t_max`.
#[cfg(target_arch = "x86_64")]
const RAY_FIELDS: [usize; 8] = {
    use super::real::V3;
    use std::mem::offset_of;
    let (o, d) = (offset_of!(Ray<f32>, o), offset_of!(Ray<f32>, d));
    let (x, y, z) = (
        offset_of!(V3<f32>, x),
        offset_of!(V3<f32>, y),
        offset_of!(V3<f32>, z),
    );
    let b = [
        o + x,
        o + y,
        o + z,
        d + x,
        d + y,
        d + z,
        offset_of!(Ray<f32>, t_min),
        offset_of!(Ray<f32>, t_max),
    ];
    let mut f = [0; 8];
    let mut k = 0;
    while k < 8 {
        assert!(b[k] % 4 == 0, "f32 fields lie on f32 boundaries");
        f[k] = b[k] / 4;
        k += 1;
    }
    f
};

// `rows8` reads a ray as its eight f32 in this order.
#[cfg(target_arch = "x86_64")]
const _: () = {
    let mut k = 0;
    while k < 8 {
        assert!(
            RAY_FIELDS[k] == k && RAY_STRIDE == 8,
            "a ray is eight f32 in order"
        );
        k += 1;
    }
};

/// Stack entries: three per level of the deepest tree the build makes, and a node's four.
pub(super) const STACK: usize = 3 * crate::accel::bvh::MAX_DEPTH + crate::accel::bvh::WIDTH + 1;

/// A child met by some lanes: node (or leaf range when `count > 0`), the lanes and each
/// lane's entry distance.
#[derive(Clone, Copy)]
pub(super) struct Entry {
    pub(super) child: u32,
    pub(super) count: u32,
    pub(super) mask: u32,
    pub(super) near: [f32; MAX_W],
}

/// The walk's stack, left uninitialised (14 KB: zeroing it per packet would cost more
/// than the stack's use).
pub(super) struct Stack {
    pub(super) items: [std::mem::MaybeUninit<Entry>; STACK],
    pub(super) len: usize,
}

impl Stack {
    #[inline(always)]
    pub(super) fn with(first: Entry) -> Self {
        let mut s = Stack {
            items: [const { std::mem::MaybeUninit::uninit() }; STACK],
            len: 0,
        };
        s.push(first);
        s
    }

    #[inline(always)]
    pub(super) fn push(&mut self, e: Entry) {
        // Indexing checks the bound: the build's depth limit keeps it unreachable.
        self.items[self.len].write(e);
        self.len += 1;
    }

    #[inline(always)]
    pub(super) fn pop(&mut self) -> Option<Entry> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: every slot below `len` was written by `push`.
        Some(unsafe { self.items[self.len].assume_init() })
    }
}

/// A triangle test's lane values, for the candidates' acceptance.
#[derive(Clone, Copy, Default)]
#[repr(C, align(64))]
pub(super) struct Lanes {
    pub(super) tt: [f32; MAX_W],
    pub(super) det_abs: [f32; MAX_W],
    pub(super) t: [f32; MAX_W],
    pub(super) u: [f32; MAX_W],
    pub(super) v: [f32; MAX_W],
    pub(super) w: [f32; MAX_W],
    pub(super) det: [f32; MAX_W],
}
