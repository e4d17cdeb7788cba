//! The traversals on three SPD scenes (teapot, tetra, sombrero from
//! `../shared/scenes/spd`, skipped with a notice when absent), 256² rays of
//! the file's viewpoint: eye rays alone, eye rays as stereo pairs (two-lane
//! packets), shadow rays toward the first light (any hit; alone and as the
//! pairs' two-lane packets), and the eye hits' mirror reflections; on 1 and 2
//! threads; leaves tested one by one, each lane alone, and as the renderer
//! traces them.
//!
//! Run: `cargo bench -p twinray-bench --bench traversal`. For figures under
//! load, `cargo bench -p twinray-bench --bench packets` prints two ways side
//! by side (docs/benchmarks.md).

use std::path::Path;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use twinray_bench::traversal::{
    pairs_pass, rays_pass, shadow_pairs_pass, shadow_pass, RaySets, Tree,
};

const SCENES: [&str; 3] = ["teapot", "tetra", "sombrero"];

fn traversal(c: &mut Criterion) {
    for name in SCENES {
        let path = Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../../shared/scenes/spd")
            .join(format!("{name}.nff"));
        let sets = match RaySets::load(&path, 256) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {name}: {e}");
                continue;
            }
        };
        for threads in [1, 2] {
            let mut g = c.benchmark_group(format!("traversal/{name}/{threads}t"));
            g.sample_size(10)
                .warm_up_time(Duration::from_millis(300))
                .measurement_time(Duration::from_secs(2));
            // Leaves of triangles four at a time (as the renderer tests
            // them), but for Scalar: one by one.
            for tree in [Tree::Scalar, Tree::Lanes, Tree::Packets] {
                let t = format!("{tree:?}").to_lowercase();
                g.throughput(Throughput::Elements(sets.eye.len() as u64));
                g.bench_function(format!("eye/{t}"), |b| {
                    b.iter(|| rays_pass(&sets, &sets.eye, tree, threads))
                });
                g.throughput(Throughput::Elements(2 * sets.pairs.len() as u64));
                g.bench_function(format!("eye_pair/{t}"), |b| {
                    b.iter(|| pairs_pass(&sets, tree, threads))
                });
                g.throughput(Throughput::Elements(sets.shadow.len() as u64));
                g.bench_function(format!("shadow/{t}"), |b| {
                    b.iter(|| shadow_pass(&sets, tree, threads))
                });
                g.throughput(Throughput::Elements(2 * sets.shadow_pairs.len() as u64));
                g.bench_function(format!("shadow_pair/{t}"), |b| {
                    b.iter(|| shadow_pairs_pass(&sets, tree, threads))
                });
                g.throughput(Throughput::Elements(sets.reflected.len() as u64));
                g.bench_function(format!("reflected/{t}"), |b| {
                    b.iter(|| rays_pass(&sets, &sets.reflected, tree, threads))
                });
            }
            g.finish();
        }
    }
}

criterion_group!(benches, traversal);
criterion_main!(benches);
