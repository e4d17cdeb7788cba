//! Where the hierarchy build of a mesh spends its time: the whole
//! `World::new` (what `--stats`' `build_s` reports), and apart from it the
//! public pieces — the binned SAH build with its eight-wide collapse
//! (`bvh::build`), the collapse alone, and the triangle blocks. Wall time and the
//! process's CPU time (both cores' work), medians over the rounds.
//!
//!   cargo bench -p twinray-bench --bench build_phases -- FILE [ROUNDS]
//!
//! FILE: any scene twinray loads (`bench/make_terrain_gltf.py terrain.glb`
//! makes the 1M-triangle terrain of `bench/mesh-load.sh`). A program, not a
//! criterion bench (see Cargo.toml). Under `perf record` it profiles the build
//! alone: loading is done once, the rounds are builds.

use std::path::Path;
use std::time::Instant;

use twinray::bvh::{self, Bvh};
use twinray::loaders::{load_scene, LoadOptions};
use twinray::math::Aabb;
use twinray::World;

/// This process's CPU time in seconds: every thread's run time from
/// /proc/self/task/*/schedstat (nanoseconds; rayon's threads live as long as
/// the process, so none of the build's work is lost with an ended thread).
fn cpu_seconds() -> f64 {
    let Ok(tasks) = std::fs::read_dir("/proc/self/task") else {
        return 0.0;
    };
    tasks
        .flatten()
        .filter_map(|t| std::fs::read_to_string(t.path().join("schedstat")).ok())
        .filter_map(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .sum::<f64>()
        * 1e-9
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// `f`'s wall and CPU seconds, and its result.
fn timed<T>(f: impl FnOnce() -> T) -> (f64, f64, T) {
    let (w, c) = (Instant::now(), cpu_seconds());
    let out = f();
    (w.elapsed().as_secs_f64(), cpu_seconds() - c, out)
}

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let Some(file) = args.first() else {
        eprintln!("usage: build_phases FILE [ROUNDS]");
        std::process::exit(2);
    };
    let rounds: usize = args.get(1).and_then(|r| r.parse().ok()).unwrap_or(5);
    let scene = match load_scene(Path::new(file), &LoadOptions::default()) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{file}: {e}");
            std::process::exit(1);
        }
    };
    let boxes: Vec<Aabb> = scene.shapes.iter().map(|s| s.bounds()).collect();
    let opts = bvh::BuildOptions::triangle_blocks();
    println!(
        "{} primitives, {} rayon threads, {rounds} rounds",
        boxes.len(),
        rayon::current_num_threads()
    );
    let names = [
        "World::new (build_s)",
        "bvh::build (both trees)",
        "  eight-wide collapse",
        "  triangle blocks",
    ];
    let mut wall = vec![Vec::new(); names.len()];
    let mut cpu = vec![Vec::new(); names.len()];
    let mut record = |i: usize, w: f64, c: f64| {
        wall[i].push(w);
        cpu[i].push(c);
    };
    for _ in 0..rounds {
        let (w, c, world) = timed(|| World::new(scene.clone()));
        record(0, w, c);
        let (w, c, tree): (_, _, Bvh) = timed(|| bvh::build(&boxes, &opts));
        record(1, w, c);
        let (w, c, wide) = timed(|| bvh::collapse(&tree.nodes));
        record(2, w, c);
        assert_eq!(wide, tree.wide);
        let mut blocks = world.bvh.clone();
        let (w, c, ()) = timed(|| blocks.attach_blocks(&world.scene.shapes));
        record(3, w, c);
        drop((world, tree, blocks));
    }
    println!("{:<26} {:>8} {:>8}", "phase", "wall_s", "cpu_s");
    for (i, name) in names.iter().enumerate() {
        println!(
            "{name:<26} {:>8.3} {:>8.3}",
            median(wall[i].clone()),
            median(cpu[i].clone())
        );
    }
}
