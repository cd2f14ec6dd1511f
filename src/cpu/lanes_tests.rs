//! Tests of `cpu/lanes.rs`: every lane operation of both units against the scalar f32
//! operation (or plain indexing) it stands for, lane by lane and bit for bit, on special
//! values (signed zeros, infinities, NaN, subnormals) and random bits. The packet walks'
//! bit-identity tests (`traverse_packet_tests.rs`) use only what the walks use, and only as
//! the walks combine it (`mor` of disjoint masks, no `eq`); these pin each operation's
//! documented contract. They also reach the `unsafe fn`s (`load`, `store`, `gather_rows`,
//! `store_u32`, `rows8`), which cargo-mutants does not mutate. The masks are read and made
//! here from their registers (`mask_lanes`, `mask`), not through `bits`/`from_bits`, which
//! are under test.

use crate::testing::Rng;

/// Special f32 values first, then random bit patterns.
fn values(rng: &mut Rng, n: usize) -> Vec<f32> {
    let mut v = vec![
        0.0,
        -0.0,
        1.0,
        -1.0,
        0.5,
        -2.0,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::NAN,
        -f32::NAN,
        f32::MIN_POSITIVE,
        -f32::MIN_POSITIVE,
        f32::from_bits(1),
        f32::from_bits(0x8000_0001),
        f32::MAX,
        f32::MIN,
        3.0,
        3.0,
    ];
    while v.len() < n {
        let r = rng.next_u64();
        // Half of them small numbers, so that pairs compare both ways and tie.
        v.push(if r & 1 == 0 {
            f32::from_bits((r >> 32) as u32)
        } else {
            ((r >> 40) % 9) as f32 - 4.0
        });
    }
    v
}

/// Bits of a result, every NaN as one (the payload of a NaN made by an operation is not
/// part of the contract).
fn canon(x: f32) -> u32 {
    if x.is_nan() {
        u32::MAX
    } else {
        x.to_bits()
    }
}

macro_rules! lane_tests {
    ($unit:ident, $feature:tt) => {
        mod $unit {
            use super::{canon, values};
            use crate::cpu::lanes::$unit::*;
            use crate::testing::{test_seed, Rng};
            use std::mem::{size_of, transmute_copy};

            /// Whether this CPU has the unit (the tests print and pass when it has not).
            fn present() -> bool {
                let yes = std::arch::is_x86_feature_detected!($feature);
                if !yes {
                    println!(
                        "{}: no {} on this CPU, not tested",
                        stringify!($unit),
                        $feature
                    );
                }
                yes
            }

            /// The lanes of `v`.
            fn lanes(v: V) -> [f32; W] {
                // SAFETY: V is W f32.
                unsafe { transmute_copy(&v) }
            }

            /// The vector of lanes `a`.
            fn vector(a: &[f32]) -> V {
                let a: [f32; W] = a[..W].try_into().unwrap();
                // SAFETY: V is W f32.
                unsafe { transmute_copy(&a) }
            }

            /// The lanes set in `m`, read from the register: the mask register's bits on
            /// AVX-512; on AVX2 each lane must be all ones or all zeros.
            fn mask_lanes(m: M) -> u32 {
                if size_of::<M>() == 2 {
                    // SAFETY: M is a u16.
                    u32::from(unsafe { transmute_copy::<M, u16>(&m) })
                } else {
                    // SAFETY: M is W u32 lanes.
                    let l: [u32; W] = unsafe { transmute_copy(&m) };
                    l.iter().enumerate().fold(0, |b, (i, &x)| {
                        assert!(x == 0 || x == u32::MAX, "lane {i} of a mask: {x:#x}");
                        b | (u32::from(x != 0) << i)
                    })
                }
            }

            /// The mask of lanes `b`, made in the register.
            fn mask(b: u32) -> M {
                if size_of::<M>() == 2 {
                    // SAFETY: M is a u16.
                    unsafe { transmute_copy::<u16, M>(&(b as u16)) }
                } else {
                    let l: [u32; W] =
                        std::array::from_fn(|i| if b >> i & 1 != 0 { u32::MAX } else { 0 });
                    // SAFETY: M is W u32 lanes.
                    unsafe { transmute_copy(&l) }
                }
            }

            /// Every lane bit of the unit.
            const ALL: u32 = if W == 32 { u32::MAX } else { (1 << W) - 1 };

            #[target_feature(enable = $feature)]
            fn arithmetic_and_compares(xs: &[f32], ys: &[f32]) {
                let (a, b) = (vector(xs), vector(ys));
                type Bin = unsafe fn(V, V) -> V;
                let bins: [(&str, Bin, fn(f32, f32) -> f32); 4] = [
                    ("add", add, |x, y| x + y),
                    ("sub", sub, |x, y| x - y),
                    ("mul", mul, |x, y| x * y),
                    ("div", div, |x, y| x / y),
                ];
                for (name, op, f) in bins {
                    // SAFETY: the unit is present (this function's feature).
                    let got = lanes(unsafe { op(a, b) });
                    for i in 0..W {
                        let want = f(xs[i], ys[i]);
                        assert_eq!(canon(got[i]), canon(want), "{name}({}, {})", xs[i], ys[i]);
                    }
                }
                // Selections: the chosen operand's bits, NaN payloads and zero signs too.
                let sels: [(&str, Bin, fn(f32, f32) -> f32); 2] = [
                    ("max", max, |x, y| if x > y { x } else { y }),
                    ("min", min, |x, y| if x < y { x } else { y }),
                ];
                for (name, op, f) in sels {
                    // SAFETY: the unit is present (this function's feature).
                    let got = lanes(unsafe { op(a, b) });
                    for i in 0..W {
                        let want = f(xs[i], ys[i]);
                        assert_eq!(
                            got[i].to_bits(),
                            want.to_bits(),
                            "{name}({}, {})",
                            xs[i],
                            ys[i]
                        );
                    }
                }
                let (ab, ng) = (lanes(abs(a)), lanes(neg(a)));
                for i in 0..W {
                    let x = xs[i].to_bits();
                    assert_eq!(ab[i].to_bits(), x & !(1 << 31), "abs({})", xs[i]);
                    assert_eq!(ng[i].to_bits(), x ^ (1 << 31), "neg({})", xs[i]);
                }
                type Cmp = unsafe fn(V, V) -> M;
                let cmps: [(&str, Cmp, fn(f32, f32) -> bool); 4] = [
                    ("lt", lt, |x, y| x < y),
                    ("gt", gt, |x, y| x > y),
                    ("le", le, |x, y| x <= y),
                    ("eq", eq, |x, y| x == y),
                ];
                for (name, op, f) in cmps {
                    let want = (0..W).fold(0, |m, i| m | (u32::from(f(xs[i], ys[i])) << i));
                    // SAFETY: the unit is present (this function's feature).
                    let got = unsafe { op(a, b) };
                    assert_eq!(mask_lanes(got), want, "{name}: {xs:?} {ys:?}");
                }
                let s = xs[0];
                assert!(lanes(splat(s)).iter().all(|x| x.to_bits() == s.to_bits()));
            }

            #[target_feature(enable = $feature)]
            fn masks(p: u32, q: u32, xs: &[f32], ys: &[f32]) {
                let (mp, mq) = (mask(p), mask(q));
                assert_eq!(mask_lanes(mand(mp, mq)), p & q, "mand {p:#x} {q:#x}");
                assert_eq!(mask_lanes(mor(mp, mq)), p | q, "mor {p:#x} {q:#x}");
                assert_eq!(
                    mask_lanes(mandnot(mp, mq)),
                    !p & q & ALL,
                    "mandnot {p:#x} {q:#x}"
                );
                assert_eq!(bits(mp), p, "bits {p:#x}");
                assert_eq!(mask_lanes(from_bits(p)), p, "from_bits {p:#x}");
                let got = lanes(select(mp, vector(xs), vector(ys)));
                for i in 0..W {
                    let want = if p >> i & 1 != 0 { xs[i] } else { ys[i] };
                    assert_eq!(got[i].to_bits(), want.to_bits(), "select {p:#x} lane {i}");
                }
            }

            /// The arithmetic, compares and selections, lane by lane against f32 (the
            /// special values against each other in every lane, then random ones).
            #[test]
            fn operations_are_the_scalar_operations() {
                if !present() {
                    return;
                }
                let seed = test_seed(concat!("lane operations ", $feature), 0x1A4E_0001);
                let mut rng = Rng::new(seed);
                let v = values(&mut rng, 4000);
                let specials = &v[..18];
                // Every ordered pair of special values, W pairs at a time.
                let n = specials.len();
                let pairs: Vec<(f32, f32)> = (0..n * n)
                    .map(|k| (specials[k / n], specials[k % n]))
                    .collect();
                for c in pairs.chunks(W) {
                    let at = |i: usize| c[i.min(c.len() - 1)];
                    let xs: Vec<f32> = (0..W).map(|i| at(i).0).collect();
                    let ys: Vec<f32> = (0..W).map(|i| at(i).1).collect();
                    // SAFETY: the unit is present.
                    unsafe { arithmetic_and_compares(&xs, &ys) };
                }
                for c in v.chunks_exact(2 * W) {
                    // SAFETY: the unit is present.
                    unsafe { arithmetic_and_compares(&c[..W], &c[W..]) };
                }
            }

            /// The mask operations on random lane masks, and `bits`/`from_bits` on every
            /// mask of the unit.
            #[test]
            fn masks_are_lane_bits() {
                if !present() {
                    return;
                }
                let seed = test_seed(concat!("lane masks ", $feature), 0x1A4E_0002);
                let mut rng = Rng::new(seed);
                let v = values(&mut rng, 2 * W);
                let (xs, ys) = v.split_at(W);
                let mut pairs = vec![(0, 0), (ALL, ALL), (ALL, 0), (0, ALL), (0b0110, 0b0011)];
                for _ in 0..200 {
                    let r = rng.next_u64();
                    pairs.push((r as u32 & ALL, (r >> 32) as u32 & ALL));
                }
                for (p, q) in pairs {
                    // SAFETY: the unit is present.
                    unsafe { masks(p, q, xs, ys) };
                }
                for p in 0..=ALL {
                    // SAFETY: the unit is present.
                    unsafe {
                        assert_eq!(bits(mask(p)), p);
                        assert_eq!(mask_lanes(from_bits(p)), p);
                    }
                }
            }

            #[target_feature(enable = $feature)]
            fn memory(v: &[f32]) {
                // `load` and `store`: the W f32 at an unaligned offset.
                let mut out = vec![0.0f32; W + 3];
                // SAFETY: 1 + W <= v.len() and 3 + W <= out.len().
                unsafe { store(out.as_mut_ptr().add(3), load(v.as_ptr().add(1))) };
                for i in 0..W {
                    assert_eq!(
                        out[3 + i].to_bits(),
                        v[1 + i].to_bits(),
                        "load/store lane {i}"
                    );
                }
                // `gather_rows`: lane i is p[min(i, last) * stride].
                for stride in [1, 3, 8, 11] {
                    for last in 0..W + 2 {
                        assert!(last * stride < v.len());
                        // SAFETY: p[j * stride] for j in 0..=last lies in `v` (above).
                        let got = unsafe { gather_rows(v.as_ptr(), stride, last) };
                        let got = lanes(got);
                        for i in 0..W {
                            let want = v[i.min(last) * stride];
                            assert_eq!(
                                got[i].to_bits(),
                                want.to_bits(),
                                "gather_rows stride {stride} last {last} lane {i}"
                            );
                        }
                    }
                }
                // `rows8`: n records of eight f32 (every n; W takes AVX-512's transpose).
                for n in 1..=W {
                    let recs = &v[5..5 + 8 * n];
                    // SAFETY: `recs` holds 8 n f32.
                    let r = unsafe { rows8(recs.as_ptr(), n) };
                    for (k, vk) in r.iter().enumerate() {
                        let got = lanes(*vk);
                        for i in 0..W {
                            let want = recs[8 * i.min(n - 1) + k];
                            assert_eq!(
                                got[i].to_bits(),
                                want.to_bits(),
                                "rows8 n {n} field {k} lane {i}"
                            );
                        }
                    }
                }
                // `store_u32`: whole numbers to integers, up to the last f32 below 2^31.
                let whole: Vec<f32> = [0.0, 1.0, 2.0, 16_777_216.0, 2_147_483_520.0]
                    .into_iter()
                    .chain(v.iter().map(|x| (x.to_bits() >> 9) as f32))
                    .take(W)
                    .collect();
                let mut ints = vec![7u32; W + 1];
                // SAFETY: W u32 writable.
                unsafe { store_u32(ints.as_mut_ptr(), vector(&whole)) };
                for i in 0..W {
                    assert_eq!(ints[i], whole[i] as u32, "store_u32 lane {i}");
                }
                assert_eq!(ints[W], 7, "store_u32 writes W lanes only");
            }

            /// `load`, `store`, `gather_rows`, `rows8` and `store_u32` against indexing.
            #[test]
            fn memory_operations_are_indexing() {
                if !present() {
                    return;
                }
                let seed = test_seed(concat!("lane memory ", $feature), 0x1A4E_0003);
                let mut rng = Rng::new(seed);
                // Distinct values, so that a lane read from the wrong place shows.
                let v: Vec<f32> = (0..400)
                    .map(|_| (rng.next_u64() >> 40) as f32 + 0.5)
                    .collect();
                // SAFETY: the unit is present.
                unsafe { memory(&v) };
            }
        }
    };
}

lane_tests!(avx512, "avx512f");
lane_tests!(avx2, "avx2");
