//! The ray-packet walk of the BVH (`--cpu-path packet`, the default) against the single-ray
//! paths on every shipped scene: rendered small in f32 by packets of every unit this CPU
//! runs (AVX-512's 16 lanes, AVX2's 8), by the single-ray vectorised walk with every kernel
//! it runs (AVX2, SSE2) and by the scalar walk, each unit forced through
//! `BvhWalker::with_packets` / `BvhWalker::vectorised`, the images, depths, primitive ids
//! and normals are bit-identical (the `steps` AOV and the work counters may differ: a
//! packet counts what each lane was active for), and so are the rays traced. The whole
//! Whitted tree walks as packets (primary rays, each light's shadow rays, each depth's
//! reflected and refracted rays), so this covers the any-hit packets too. The front door
//! (`render_cpu` with `--cpu-path packet`) is checked to take the packets and give the same
//! image. The query-level comparison on random rays is in `src/cpu/traverse_packet_tests.rs`.

mod common;
use common::shipped_scenes;
use fragtrace::accel::{AccelKind, Bvh};
use fragtrace::cpu::simd::Isa;
use fragtrace::cpu::traverse_bvh::BvhWalker;
use fragtrace::cpu::traverse_packet::PacketIsa;
use fragtrace::cpu::{CpuOutput, CpuRenderer};
use fragtrace::options::{CpuPath, Precision, RenderOptions};
use fragtrace::render::render_cpu;
use fragtrace::scene::Scene;

/// Image size of the renders (small: 13 scenes, 5 paths each, on 2 cores).
const W: u32 = 64;
const H: u32 = 48;

/// A CPU path forced to one unit: the packet unit (none: one ray at a time) and the
/// single-ray kernel.
#[derive(Clone, Copy, Debug)]
struct Path {
    packets: Option<PacketIsa>,
    isa: Isa,
}

/// Every path this CPU runs: packets on each packet unit, the single-ray vectorised walk
/// on each kernel, the scalar walk (the reference, last).
fn paths() -> Vec<Path> {
    let mut v = Vec::new();
    for p in [PacketIsa::Avx512, PacketIsa::Avx2] {
        if p.available() {
            v.push(Path {
                packets: Some(p),
                isa: Isa::detect(),
            });
        }
    }
    for isa in [Isa::Avx2, Isa::Sse2] {
        if isa.available() {
            v.push(Path { packets: None, isa });
        }
    }
    v.push(Path {
        packets: None,
        isa: Isa::Scalar,
    });
    v
}

/// `scene` rendered in f32 over `bvh` by `path`, W x H at `spp`.
fn render(scene: &Scene, bvh: &Bvh, path: Path, spp: u32) -> CpuOutput {
    let o = RenderOptions::for_scene(scene);
    let tech = o.techniques;
    let walker = match path.packets {
        Some(p) => BvhWalker::with_packets(scene, bvh, tech, path.isa, p),
        None => BvhWalker::vectorised(scene, bvh, tech, path.isa),
    };
    assert_eq!(walker.packets(), path.packets, "{path:?}");
    assert_eq!(walker.isa(), path.isa, "{path:?}");
    CpuRenderer::<f32, _>::with_walker(scene, walker, o.max_depth, tech).render(W, H, spp)
}

/// The image's bits, and each pixel's depth, primitive id and normal bits.
type Bits = (Vec<u32>, Vec<(u32, u32, [u32; 3])>);

fn bits(out: &CpuOutput) -> Bits {
    let image = out.image.data.iter().map(|x| x.to_bits()).collect();
    let aov = out
        .aov
        .pixels
        .iter()
        .map(|p| {
            (
                p.depth.to_bits(),
                p.primid.to_bits(),
                p.normal.map(f32::to_bits),
            )
        })
        .collect();
    (image, aov)
}

/// Where two renders differ: the first differing pixel of the image and of the AOVs.
fn first_difference(a: &Bits, b: &Bits) -> String {
    let px = |x: Option<usize>| x.map(|i| (i % W as usize, i / W as usize));
    let image = px(a
        .0
        .iter()
        .zip(&b.0)
        .position(|(x, y)| x != y)
        .map(|i| i / 3));
    let aov = px(a.1.iter().zip(&b.1).position(|(x, y)| x != y));
    format!("first pixel of another colour {image:?}, of another primary hit {aov:?}")
}

/// Every shipped scene (the built-in one, and the builtin also at 2 spp) by every path:
/// the scalar walk's image and primary AOVs, bit for bit, and its ray counts.
#[test]
fn packets_render_every_shipped_scene_as_single_rays() {
    let paths = paths();
    println!("paths: {paths:?}");
    let reference = *paths.last().unwrap();
    assert!(
        paths.iter().any(|p| p.packets.is_some()) || !Isa::Avx2.available(),
        "a CPU with AVX2 runs packets"
    );
    let mut cases: Vec<(String, Scene, u32)> = shipped_scenes()
        .into_iter()
        .map(|(name, scene)| (name, scene, 1))
        .collect();
    cases.push(("builtin".into(), fragtrace::scene::builtin_scene(), 2));
    let mut fails = Vec::new();
    for (name, scene, spp) in &cases {
        let bvh = Bvh::build(scene).unwrap();
        let want = render(scene, &bvh, reference, *spp);
        let want_bits = bits(&want);
        let lit = want.image.data.iter().filter(|&&x| x > 0.0).count();
        let hits = want.aov.pixels.iter().filter(|p| p.primid >= 0.0).count();
        for &path in &paths[..paths.len() - 1] {
            let got = render(scene, &bvh, path, *spp);
            let label = format!("{name} at {spp} spp by {path:?}");
            let got_bits = bits(&got);
            if got_bits != want_bits {
                fails.push(format!(
                    "{label}: {}",
                    first_difference(&got_bits, &want_bits)
                ));
            }
            if got.rays != want.rays {
                fails.push(format!("{label}: rays {:?}, not {:?}", got.rays, want.rays));
            }
        }
        println!(
            "{name:>10} {spp} spp: {hits} of {} primary hits, {lit} lit values, {} rays ({} shadow, {} secondary)",
            W * H,
            want.rays.total,
            want.rays.shadow,
            want.rays.reflected + want.rays.refracted
        );
        // Every scene is seen by the camera (no test of an empty picture).
        assert!(hits > 0 && lit > 0, "{name}: nothing rendered");
    }
    assert!(fails.is_empty(), "packets render otherwise: {fails:#?}");
}

/// The front door: `--cpu-path packet` is the default, takes the widest packet unit (the
/// device string says so) and renders the built-in scene as `--cpu-path scalar`.
#[test]
fn the_default_cpu_path_walks_packets() {
    assert_eq!(CpuPath::default(), CpuPath::Packet);
    let scene = fragtrace::scene::builtin_scene();
    let render = |path| {
        let mut o = RenderOptions::for_scene(&scene);
        (o.width, o.height) = (W, H);
        o.precision = Precision::F32;
        o.accel = AccelKind::Bvh.into();
        o.cpu_path = path;
        render_cpu(&scene, &o).unwrap()
    };
    let (packet, scalar) = (render(CpuPath::Packet), render(CpuPath::Scalar));
    match PacketIsa::detect() {
        Some(p) => assert!(
            packet
                .stats
                .device
                .contains(&format!("{} packets", p.name())),
            "{}",
            packet.stats.device
        ),
        None => assert!(!packet.stats.device.contains("packets")),
    }
    assert!(
        !scalar.stats.device.contains("packets"),
        "{}",
        scalar.stats.device
    );
    let b = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert!(
        b(&packet.image.data) == b(&scalar.image.data),
        "images differ"
    );
    assert_eq!(packet.stats.rays, scalar.stats.rays);
}
