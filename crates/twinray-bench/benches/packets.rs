//! Side-by-side rays/s of two ways of tracing, in one process, rounds
//! interleaved so that the machine's load hits both alike:
//!
//! `cargo bench -p twinray-bench --bench packets -- [--size N] [--rounds R] [--leaves] SCENE.nff ...`
//!
//! Prints per scene and ray kind the median Mrays/s of each over the rounds and
//! the ratio second / first, on 1 thread (per second of this thread's CPU time,
//! which other processes' load does not inflate) and 2 threads (wall time).
//! By default: packets (stereo pairs, four and eight views' eye rays, pairs
//! and fours of shadow segments) with each lane alone (first) against the
//! renderer's way (second: a pair's shadow segments and packets in one
//! descent where the traversal takes them). With `--leaves`: every ray kind
//! with leaves of triangles tested one by one (first) against four at a time
//! (second). Then the build over 1M triangles and its collapse.

use std::path::Path;
use std::time::Instant;

use twinray_bench::traversal::{
    octs_pass, pair_work, pairs_pass, quads_pass, rays_pass, shadow_pairs_pass, shadow_pass,
    shadow_quads_pass, work, RaySets, Tree,
};

/// This thread's time on a CPU, in seconds (Linux: /proc/thread-self/schedstat),
/// so that one-thread runs are not charged for time other processes took; None
/// elsewhere.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// Seconds `f` took: CPU time on one thread, wall time on more.
fn timed(threads: usize, f: impl FnOnce() -> u64) -> (f64, u64) {
    let (w0, c0) = (Instant::now(), cpu_seconds());
    let r = f();
    match (threads, c0, cpu_seconds()) {
        (1, Some(a), Some(b)) => (b - a, r),
        _ => (w0.elapsed().as_secs_f64(), r),
    }
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    // `cargo bench` adds `--bench`; the rest are this program's flags and scenes.
    let mut args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| a != "--bench")
        .collect();
    let mut take = |flag: &str, default: usize| -> usize {
        match args.iter().position(|a| a == flag) {
            Some(i) if i + 1 < args.len() => {
                let v = args[i + 1].parse().unwrap_or(default);
                args.drain(i..i + 2);
                v
            }
            _ => default,
        }
    };
    let size = take("--size", 512);
    let rounds = take("--rounds", 5);
    let leaves = match args.iter().position(|a| a == "--leaves") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    let (first, second) = if leaves {
        (Tree::Scalar, Tree::Packets)
    } else {
        (Tree::Lanes, Tree::Packets)
    };
    println!(
        "{:<10} {:<10} {:>3} {:>11} {:>11} {:>6} agree",
        "scene", "rays", "thr", "first_Mr/s", "second_Mr/s", "ratio"
    );
    for path in &args {
        let sets = match RaySets::load(Path::new(path), size) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("{path}: {e}");
                continue;
            }
        };
        let name = Path::new(path)
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        for tree in [first, second] {
            let st = pair_work(&sets, tree);
            let n = 2.0 * sets.pairs.len() as f64;
            let eye = work(&sets, &sets.eye, tree);
            let e = sets.eye.len() as f64;
            println!(
                "{name:<10} {tree:?}: eye pairs {:.2} nodes, {:.2} box tests, {:.2} primitive tests per ray; eye rays {:.2}, {:.2}, {:.2}",
                st.nodes as f64 / n,
                st.box_tests as f64 / n,
                st.prim_tests as f64 / n,
                eye.nodes as f64 / e,
                eye.box_tests as f64 / e,
                eye.prim_tests as f64 / e
            );
        }
        type Run<'a> = Box<dyn Fn(Tree, usize) -> u64 + 'a>;
        let kinds: [(&str, usize, Run); 8] = [
            (
                "eye",
                sets.eye.len(),
                Box::new(|t, n| rays_pass(&sets, &sets.eye, t, n)),
            ),
            (
                "eye pair",
                2 * sets.pairs.len(),
                Box::new(|t, n| pairs_pass(&sets, t, n)),
            ),
            (
                "eye quad",
                4 * sets.quads.len(),
                Box::new(|t, n| quads_pass(&sets, t, n)),
            ),
            (
                "eye oct",
                8 * sets.octs.len(),
                Box::new(|t, n| octs_pass(&sets, t, n)),
            ),
            (
                "shadow",
                sets.shadow.len(),
                Box::new(|t, n| shadow_pass(&sets, t, n)),
            ),
            (
                "shad. pair",
                2 * sets.shadow_pairs.len(),
                Box::new(|t, n| shadow_pairs_pass(&sets, t, n)),
            ),
            (
                "shad. quad",
                4 * sets.shadow_quads.len(),
                Box::new(|t, n| shadow_quads_pass(&sets, t, n)),
            ),
            (
                "reflected",
                sets.reflected.len(),
                Box::new(|t, n| rays_pass(&sets, &sets.reflected, t, n)),
            ),
        ];
        println!("{name}: {first:?} (first) against {second:?} (second)");
        for threads in [1, 2] {
            for (kind, count, run) in &kinds {
                // A ray alone is traced alike both ways but for its leaves.
                if !leaves && !kind.contains(' ') {
                    continue;
                }
                let (mut a, mut b) = (Vec::new(), Vec::new());
                let mut agree = true;
                for _ in 0..rounds {
                    let (sa, ca) = timed(threads, || run(first, threads));
                    a.push(*count as f64 / sa / 1e6);
                    let (sb, cb) = timed(threads, || run(second, threads));
                    b.push(*count as f64 / sb / 1e6);
                    agree &= ca == cb;
                }
                let (ma, mb) = (median(a), median(b));
                println!(
                    "{name:<10} {kind:<10} {threads:>3} {ma:>11.2} {mb:>11.2} {:>6.2} {agree}",
                    mb / ma
                );
            }
        }
    }
    build_time();
}

/// The build over 1M triangles (a 1000 x 500-cell terrain, as benches/bvh.rs),
/// and how much of it the eight-wide collapse takes.
fn build_time() {
    let tris = twinray_bench::terrain(1000, 500, 1.0, 0.5, 1);
    let boxes: Vec<twinray::math::Aabb> = tris
        .iter()
        .map(|t| twinray::math::Aabb::from_points(t))
        .collect();
    let (mut build_s, mut collapse_s) = (Vec::new(), Vec::new());
    for _ in 0..3 {
        let t0 = Instant::now();
        let bvh = twinray::bvh::build(&boxes, &twinray::bvh::BuildOptions::default());
        build_s.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        let wide = twinray::bvh::collapse(&bvh.nodes);
        collapse_s.push(t0.elapsed().as_secs_f64());
        assert_eq!(wide, bvh.wide);
    }
    println!(
        "build 1M triangles: {:.3} s (wall, median of 3), of which the collapse {:.3} s",
        median(build_s),
        median(collapse_s)
    );
}
