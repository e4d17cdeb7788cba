//! twinray's own hierarchy against the `obvhs` crate: build time on 1M triangles,
//! nearest-hit throughput on a ~100k-triangle mesh, and the cost of tracing a
//! stereo pair as one two-lane packet.
//!
//! All data is generated here from a small LCG (no files). The meshes are height
//! fields: a bumpy terrain over a regular grid, two triangles per cell.
//!
//! Run: `cargo bench -p twinray-bench --bench bvh` (see docs/decisions.md).
//!
//! Tracing is timed on one thread (rays/s per core); builds use every core
//! (rayon's global pool, which both twinray and obvhs's `parallel` feature use).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, SamplingMode, Throughput};
use glam::Vec3A;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::bvh2::Bvh2;
use obvhs::cwbvh::builder::build_cwbvh;
use obvhs::cwbvh::CwBvh;
use obvhs::rt_triangle::RtTriangle;
use obvhs::BvhBuildParams;
use twinray::bvh::{build, BuildOptions, Bvh, Node, Packet, PacketHits, TraversalStats};
use twinray::math::{Aabb, Ray, Vec3};
use twinray::shapes::{Triangle, TriangleNormals};
use twinray_bench::{camera_rays, random_rays, terrain};

fn twin_tris(tris: &[[Vec3; 3]]) -> Vec<Triangle> {
    tris.iter()
        .map(|&[a, b, c]| {
            let n = (b - a).cross(c - a).normalize_or_zero();
            Triangle::new(a, b, c, n, TriangleNormals::Flat)
        })
        .collect()
}

fn twin_boxes(tris: &[[Vec3; 3]]) -> Vec<Aabb> {
    tris.iter().map(|t| Aabb::from_points(t)).collect()
}

fn obvhs_boxes(tris: &[[Vec3; 3]]) -> Vec<obvhs::aabb::Aabb> {
    tris.iter()
        .map(|t| obvhs::aabb::Aabb::from_points(&t.map(Vec3A::from)))
        .collect()
}

fn obvhs_tris(tris: &[[Vec3; 3]]) -> Vec<RtTriangle> {
    tris.iter()
        .map(|&[a, b, c]| RtTriangle::new(a.into(), b.into(), c.into()))
        .collect()
}

/// Nearest hit with twinray's traversal, one ray per packet: `(prim, t)`.
#[inline(always)]
fn twin_closest(bvh: &Bvh, tris: &[Triangle], ray: &Ray, st: &mut TraversalStats) -> (u32, f32) {
    let p = Packet::ray(ray.origin, ray.dir);
    let h = bvh.closest(&p, st, |prim: u32, _: usize, t_max: f32| {
        tris[prim as usize].intersect(ray, 0.0, t_max)
    });
    (h.prim[0], h.hit[0].t)
}

fn to_obvhs_ray(r: &Ray) -> obvhs::ray::Ray {
    obvhs::ray::Ray::new_inf(r.origin.into(), r.dir.into())
}

fn obvhs2_closest(bvh: &Bvh2, tris: &[RtTriangle], ray: &Ray) -> (u32, f32) {
    let mut hit = obvhs::ray::RayHit::none();
    if bvh.ray_traverse(to_obvhs_ray(ray), &mut hit, |r, id| {
        tris[bvh.primitive_indices[id] as usize].intersect(r)
    }) {
        (bvh.primitive_indices[hit.primitive_id as usize], hit.t)
    } else {
        (u32::MAX, f32::INFINITY)
    }
}

fn cw_closest(bvh: &CwBvh, tris: &[RtTriangle], ray: &Ray) -> (u32, f32) {
    let mut hit = obvhs::ray::RayHit::none();
    if bvh.ray_traverse(to_obvhs_ray(ray), &mut hit, |r, id| {
        tris[bvh.primitive_indices[id] as usize].intersect(r)
    }) {
        (bvh.primitive_indices[hit.primitive_id as usize], hit.t)
    } else {
        (u32::MAX, f32::INFINITY)
    }
}

/// obvhs's PLOC tree re-laid as a twinray `Bvh` (same node layout: siblings
/// adjacent). Boxes are padded as twinray's builder pads them, and each inner
/// node gets the axis its children are most apart on, low child first.
fn obvhs_to_twinray(b: &Bvh2) -> Bvh {
    let mut nodes: Vec<Node> = b
        .nodes
        .iter()
        .map(|n| {
            let bx = Aabb {
                min: Vec3::from(n.aabb.min),
                max: Vec3::from(n.aabb.max),
            }
            .padded();
            Node {
                min: bx.min.into(),
                first: n.first_index,
                max: bx.max.into(),
                meta: n.prim_count,
            }
        })
        .collect();
    for i in 0..nodes.len() {
        if nodes[i].is_leaf() {
            continue;
        }
        let f = nodes[i].first as usize;
        let (c0, c1) = (nodes[f].bounds().center(), nodes[f + 1].bounds().center());
        let axis = (c1 - c0).abs().max_position();
        if c0[axis] > c1[axis] {
            nodes.swap(f, f + 1);
        }
        nodes[i].meta = (axis as u32) << 30;
    }
    Bvh {
        wide: twinray::bvh::collapse(&nodes),
        nodes,
        order: b.primitive_indices.clone(),
        ..Bvh::default()
    }
}

/// SAH cost (box test = primitive test = 1), relative to the root's area.
fn sah_twin(b: &Bvh) -> f64 {
    let root = b.nodes[0].bounds().half_area() as f64;
    b.nodes
        .iter()
        .map(|n| {
            let a = n.bounds().half_area() as f64 / root;
            if n.is_leaf() {
                a * n.count() as f64
            } else {
                a
            }
        })
        .sum()
}

fn sah_bvh2(b: &Bvh2) -> f64 {
    let root = b.nodes[0].aabb.half_area() as f64;
    b.nodes
        .iter()
        .map(|n| {
            let a = n.aabb.half_area() as f64 / root;
            if n.is_leaf() {
                a * n.prim_count as f64
            } else {
                a
            }
        })
        .sum()
}

fn params_medium() -> BvhBuildParams {
    BvhBuildParams::medium_build()
}

fn bench_build(c: &mut Criterion) {
    // 1000 x 500 cells = 1,000,000 triangles.
    let tris = terrain(1000, 500, 2.0, 1.0, 7);
    assert_eq!(tris.len(), 1_000_000);
    let boxes = twin_boxes(&tris);
    let oboxes = obvhs_boxes(&tris);

    let ours = build(&boxes, &BuildOptions::default());
    let theirs = build_bvh2(&oboxes, params_medium(), &mut Duration::default());
    let leaves = |b: &Bvh| b.nodes.iter().filter(|n| n.is_leaf()).count();
    eprintln!(
        "build 1M: twinray {} nodes, {} leaves, depth {}, SAH {:.1}; \
         obvhs bvh2 (medium) {} nodes, depth {}, SAH {:.1}; rayon threads {}",
        ours.nodes.len(),
        leaves(&ours),
        ours.depth(),
        sah_twin(&ours),
        theirs.nodes.len(),
        theirs.depth(0),
        sah_bvh2(&theirs),
        rayon::current_num_threads(),
    );
    drop((ours, theirs));

    let mut g = c.benchmark_group("build/1M-triangles");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(4));
    g.bench_function("twinray-binned-sah", |b| {
        b.iter(|| build(black_box(&boxes), &BuildOptions::default()))
    });
    g.bench_function("obvhs-bvh2-ploc-medium", |b| {
        b.iter(|| {
            build_bvh2(
                black_box(&oboxes),
                params_medium(),
                &mut Duration::default(),
            )
        })
    });
    g.bench_function("obvhs-bvh2-ploc-fast", |b| {
        b.iter(|| {
            build_bvh2(
                black_box(&oboxes),
                BvhBuildParams::fast_build(),
                &mut Duration::default(),
            )
        })
    });
    g.bench_function("obvhs-cwbvh-ploc-medium", |b| {
        b.iter(|| {
            build_cwbvh(
                black_box(&oboxes),
                params_medium(),
                &mut Duration::default(),
            )
        })
    });
    g.finish();
}

/// Asserts that two traversals find the same nearest hit for `n` rays spread
/// evenly over the set (every `len / n`-th):
/// both miss, or both hit at the same distance (to 1e-4 relative: the two
/// triangle tests round differently) and, but for a ray through a shared edge,
/// on the same triangle. Returns how many hit, and how many differed in triangle.
fn check_same(
    name: &str,
    rays: &[Ray],
    n: usize,
    a: impl Fn(&Ray) -> (u32, f32),
    b: impl Fn(&Ray) -> (u32, f32),
) -> (usize, usize) {
    let (mut hits, mut other_prim) = (0, 0);
    for (i, r) in rays.iter().step_by(rays.len() / n).take(n).enumerate() {
        let ((pa, ta), (pb, tb)) = (a(r), b(r));
        assert_eq!(
            pa == u32::MAX,
            pb == u32::MAX,
            "{name}: ray {i} hit/miss differs: {pa} {ta} vs {pb} {tb}"
        );
        if pa == u32::MAX {
            continue;
        }
        hits += 1;
        assert!(
            (ta - tb).abs() <= 1e-4 * ta.max(1.0),
            "{name}: ray {i} nearest distance differs: {pa} {ta} vs {pb} {tb}"
        );
        if pa != pb {
            other_prim += 1;
        }
    }
    assert!(other_prim * 1000 <= n, "{name}: {other_prim} of {n} differ");
    (hits, other_prim)
}

fn bench_trace(c: &mut Criterion) {
    // 224 x 224 cells = 100,352 triangles.
    let raw = terrain(224, 224, 1.0, 1.0, 11);
    let tris = twin_tris(&raw);
    let otris = obvhs_tris(&raw);
    let ours = build(&twin_boxes(&raw), &BuildOptions::default());
    let oboxes = obvhs_boxes(&raw);
    let bvh2 = build_bvh2(&oboxes, params_medium(), &mut Duration::default());
    let cw = build_cwbvh(&oboxes, params_medium(), &mut Duration::default());
    let hybrid = obvhs_to_twinray(&bvh2);
    eprintln!(
        "trace mesh: {} triangles; SAH twinray {:.1}, obvhs bvh2 (medium) {:.1}",
        tris.len(),
        sah_twin(&ours),
        sah_bvh2(&bvh2)
    );

    let sets = [
        ("coherent", camera_rays(1000, 1000)),
        ("incoherent", random_rays(1_000_000, 99)),
    ];
    for (kind, rays) in &sets {
        let twin = |r: &Ray| twin_closest(&ours, &tris, r, &mut TraversalStats::default());
        let n = 10_000;
        let (hits, d1) = check_same(kind, rays, n, twin, |r| obvhs2_closest(&bvh2, &otris, r));
        let (_, d2) = check_same(kind, rays, n, twin, |r| cw_closest(&cw, &otris, r));
        let (_, d3) = check_same(kind, rays, n, twin, |r| {
            twin_closest(&hybrid, &tris, r, &mut TraversalStats::default())
        });
        let mut st = TraversalStats::default();
        let all_hits = rays
            .iter()
            .filter(|r| twin_closest(&ours, &tris, r, &mut st).0 != u32::MAX)
            .count();
        eprintln!(
            "{kind}: {all_hits} of {} rays hit; {n} sampled rays agree ({hits} hits; \
             other triangle on a shared edge: bvh2 {d1}, cwbvh {d2}, ploc+twinray {d3}); \
             twinray per ray: {:.1} nodes, {:.1} box tests, {:.2} prim tests",
            rays.len(),
            st.nodes as f64 / rays.len() as f64,
            st.box_tests as f64 / rays.len() as f64,
            st.prim_tests as f64 / rays.len() as f64,
        );
    }

    let mut g = c.benchmark_group("trace/closest");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for (kind, rays) in &sets {
        g.throughput(Throughput::Elements(rays.len() as u64));
        g.bench_function(format!("{kind}/twinray"), |b| {
            b.iter(|| {
                let mut st = TraversalStats::default();
                let mut sum = 0.0f32;
                for r in rays {
                    let (_, t) = twin_closest(&ours, &tris, r, &mut st);
                    sum += t.min(1e3);
                }
                black_box(sum)
            })
        });
        g.bench_function(format!("{kind}/obvhs-bvh2"), |b| {
            b.iter(|| {
                let mut sum = 0.0f32;
                for r in rays {
                    sum += obvhs2_closest(&bvh2, &otris, r).1.min(1e3);
                }
                black_box(sum)
            })
        });
        g.bench_function(format!("{kind}/obvhs-cwbvh"), |b| {
            b.iter(|| {
                let mut sum = 0.0f32;
                for r in rays {
                    sum += cw_closest(&cw, &otris, r).1.min(1e3);
                }
                black_box(sum)
            })
        });
        g.bench_function(format!("{kind}/obvhs-ploc-tree+twinray-traversal"), |b| {
            b.iter(|| {
                let mut st = TraversalStats::default();
                let mut sum = 0.0f32;
                for r in rays {
                    sum += twin_closest(&hybrid, &tris, r, &mut st).1.min(1e3);
                }
                black_box(sum)
            })
        });
    }
    g.finish();

    // Stereo pair: the same direction from two origins 0.05 apart along x, as one
    // two-lane packet or as two one-lane packets. Lanes must match bit for bit
    // (checked on every 100th pair).
    let offset = Vec3::new(0.05, 0.0, 0.0);
    let pair = |r: &Ray, st: &mut TraversalStats| -> PacketHits<2> {
        let p = Packet {
            origins: [r.origin, r.origin + offset],
            dirs: [r.dir; 2],
            t_min: 0.0,
            t_max: [f32::INFINITY; 2],
            mask: 0b11,
        };
        let rr = [*r, Ray::new(r.origin + offset, r.dir)];
        ours.closest(&p, st, |prim: u32, lane: usize, t_max: f32| {
            tris[prim as usize].intersect(&rr[lane], 0.0, t_max)
        })
    };
    let mut g = c.benchmark_group("trace/stereo-pair");
    g.sampling_mode(SamplingMode::Flat)
        .sample_size(10)
        .warm_up_time(Duration::from_secs(1))
        .measurement_time(Duration::from_secs(3));
    for (kind, rays) in &sets {
        let mut st = TraversalStats::default();
        for r in rays.iter().step_by(100) {
            let h = pair(r, &mut st);
            let right = Ray::new(r.origin + offset, r.dir);
            for (l, ray) in [*r, right].iter().enumerate() {
                let (p, t) = twin_closest(&ours, &tris, ray, &mut st);
                assert_eq!(h.prim[l], p, "{kind}: lane {l}");
                assert_eq!(h.hit[l].t.to_bits(), t.to_bits(), "{kind}: lane {l}");
            }
        }
        let (mut s1, mut s2) = (TraversalStats::default(), TraversalStats::default());
        for r in rays.iter().step_by(10) {
            pair(r, &mut s2);
            twin_closest(&ours, &tris, r, &mut s1);
            twin_closest(&ours, &tris, &Ray::new(r.origin + offset, r.dir), &mut s1);
        }
        eprintln!(
            "{kind} stereo, every 10th of the pairs: two singles {} nodes / {} box tests / {} prim tests; \
             one packet {} nodes / {} box tests / {} prim tests",
            s1.nodes, s1.box_tests, s1.prim_tests, s2.nodes, s2.box_tests, s2.prim_tests
        );

        g.throughput(Throughput::Elements(2 * rays.len() as u64));
        g.bench_function(format!("{kind}/packet-of-2"), |b| {
            b.iter(|| {
                let mut st = TraversalStats::default();
                let mut sum = 0.0f32;
                for r in rays {
                    let h = pair(r, &mut st);
                    sum += h.hit[0].t.min(1e3) + h.hit[1].t.min(1e3);
                }
                black_box(sum)
            })
        });
        g.bench_function(format!("{kind}/two-singles"), |b| {
            b.iter(|| {
                let mut st = TraversalStats::default();
                let mut sum = 0.0f32;
                for r in rays {
                    let right = Ray::new(r.origin + offset, r.dir);
                    sum += twin_closest(&ours, &tris, r, &mut st).1.min(1e3);
                    sum += twin_closest(&ours, &tris, &right, &mut st).1.min(1e3);
                }
                black_box(sum)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench_build, bench_trace);
criterion_main!(benches);
