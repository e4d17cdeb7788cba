//! Side-by-side rays/s of the four-wide and the binary traversal, in one
//! process, rounds interleaved so that the machine's load hits both alike:
//!
//! `cargo bench -p twinray-bench --bench wide_vs_binary -- [--size N] [--rounds R] [--leaves | --pairs | --eight | --packets8] SCENE.nff ...`
//!
//! Prints per scene and ray kind the median Mrays/s of each over the rounds and
//! the ratio wide / binary, on 1 thread (per second of this thread's CPU time,
//! which other processes' load does not inflate) and 2 threads (wall time).
//! With `--leaves`: leaves of triangles tested four at a time against one by
//! one (block / scalar), on each tree. With `--eight`: the four-wide tree
//! (pairs and packets in one descent, as the renderer traces them on it)
//! against the eight-wide tree (every ray and segment alone). With
//! `--packets8`: packets (pairs, four and eight views' eye rays, pairs and
//! fours of shadow segments) on the eight-wide tree, each lane alone (first)
//! against a pair's lanes in one descent (second; pairs only); then the binary tree's packet
//! descent (first) against each lane alone on the eight-wide tree, and the
//! four-wide tree's (first; shadow pairs take it today) against the same.

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
    // `--pairs`: packets of eye rays only (stereo pairs and four views):
    // each ray alone on the four-wide tree (first) against one descent for
    // the packet (second), then the binary packet descent against each ray
    // alone on the four-wide tree; with the work of each.
    let pairs = match args.iter().position(|a| a == "--pairs") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    // `--eight`: the four-wide tree (first) against the eight-wide (second).
    let eight = match args.iter().position(|a| a == "--eight") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    // `--packets8`: packets on the eight-wide tree, each lane alone (first)
    // against one descent (second), then binary packets against lanes alone.
    let packets8 = match args.iter().position(|a| a == "--packets8") {
        Some(i) => {
            args.remove(i);
            true
        }
        None => false,
    };
    let compared: &[(Tree, Tree)] = if packets8 {
        &[
            (Tree::Wide8, Tree::Wide8Pair),
            (Tree::Binary, Tree::Wide8),
            (Tree::Wide, Tree::Wide8),
        ]
    } else if eight {
        &[(Tree::Wide, Tree::Wide8)]
    } else if pairs {
        &[(Tree::WideEach, Tree::Wide), (Tree::Binary, Tree::WideEach)]
    } else if leaves {
        &[
            (Tree::BinaryScalar, Tree::Binary),
            (Tree::WideScalar, Tree::Wide),
        ]
    } else {
        &[(Tree::Binary, Tree::Wide)]
    };
    println!(
        "{:<10} {:<10} {:>3} {:>11} {:>11} {:>6} agree",
        "scene", "rays", "thr", "first_Mr/s", "second_Mr/s", "ratio"
    );
    if !pairs && !packets8 {
        build_time();
    }
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
        if let Ok(only) = std::env::var("WVB_PROFILE") {
            // For a profiler: only eye rays on one tree, many passes.
            let tree = if only == "wide" {
                Tree::Wide
            } else {
                Tree::Binary
            };
            let sum = (0..30).fold(0u64, |a, _| {
                a.wrapping_add(rays_pass(&sets, &sets.eye, tree, 1))
            });
            println!("{name} {only}: {sum}");
            continue;
        }
        let pair_trees = match (pairs, packets8) {
            (true, _) => vec![Tree::WideEach, Tree::Wide],
            (_, true) => vec![Tree::Wide8, Tree::Wide8Pair],
            _ => vec![],
        };
        for tree in pair_trees {
            let st = pair_work(&sets, tree);
            let n = 2.0 * sets.pairs.len() as f64;
            println!(
                "{name:<10} pair work, {tree:?}: {:.2} nodes, {:.2} box tests, {:.2} primitive tests per ray",
                st.nodes as f64 / n,
                st.box_tests as f64 / n,
                st.prim_tests as f64 / n
            );
        }
        for tree in [Tree::Binary, Tree::Wide, Tree::Wide8] {
            let st = work(&sets, &sets.eye, tree);
            let n = sets.eye.len() as f64;
            println!(
                "{name:<10} eye work, {tree:?}: {:.2} nodes, {:.2} box tests, {:.2} primitive tests per ray",
                st.nodes as f64 / n,
                st.box_tests as f64 / n,
                st.prim_tests as f64 / n
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
                "shad. quad",
                4 * sets.shadow_quads.len(),
                Box::new(|t, n| shadow_quads_pass(&sets, t, n)),
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
                "reflected",
                sets.reflected.len(),
                Box::new(|t, n| rays_pass(&sets, &sets.reflected, t, n)),
            ),
        ];
        for &(first, second) in compared {
            println!("{name}: {first:?} (first) against {second:?} (second)");
            for threads in [1, 2] {
                for (kind, count, run) in &kinds {
                    if pairs && !kind.starts_with("eye ") {
                        continue;
                    }
                    // `--packets8` times packets only; the other modes
                    // leave out the kinds it adds.
                    let added = *kind == "eye oct" || *kind == "shad. quad";
                    if (packets8 && !kind.contains(' ')) || (!packets8 && added) {
                        continue;
                    }
                    if second == Tree::Wide8Pair && !kind.ends_with("pair") {
                        // Only pairs take the pair descent.
                        continue;
                    }
                    if leaves && kind.starts_with("sha") {
                        // Any-hit leaves are tested one by one either way.
                        continue;
                    }
                    let (mut b, mut w) = (Vec::new(), Vec::new());
                    let mut agree = true;
                    for _ in 0..rounds {
                        let (sb, cb) = timed(threads, || run(first, threads));
                        b.push(*count as f64 / sb / 1e6);
                        let (sw, cw) = timed(threads, || run(second, threads));
                        w.push(*count as f64 / sw / 1e6);
                        agree &= cb == cw;
                    }
                    let (mb, mw) = (median(b), median(w));
                    println!(
                        "{name:<10} {kind:<10} {threads:>3} {mb:>11.2} {mw:>11.2} {:>6.2} {agree}",
                        mw / mb
                    );
                }
            }
        }
    }
}

/// The build over 1M triangles (a 1000 x 500-cell terrain, as benches/bvh.rs),
/// and how much of it the four-wide and the eight-wide collapses take.
fn build_time() {
    let tris = twinray_bench::terrain(1000, 500, 1.0, 0.5, 1);
    let boxes: Vec<twinray::math::Aabb> = tris
        .iter()
        .map(|t| twinray::math::Aabb::from_points(t))
        .collect();
    let (mut build_s, mut collapse_s, mut collapse8_s) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..3 {
        let t0 = Instant::now();
        let bvh = twinray::bvh::build(&boxes, &twinray::bvh::BuildOptions::default());
        build_s.push(t0.elapsed().as_secs_f64());
        let t0 = Instant::now();
        let wide = twinray::bvh::collapse(&bvh.nodes);
        collapse_s.push(t0.elapsed().as_secs_f64());
        assert_eq!(wide, bvh.wide);
        let t0 = Instant::now();
        let wide8 = twinray::bvh::collapse8(&bvh.nodes);
        collapse8_s.push(t0.elapsed().as_secs_f64());
        assert_eq!(wide8, bvh.wide8);
    }
    println!(
        "build 1M triangles: {:.3} s (wall, median of 3), of which the four-wide collapse {:.3} s and the eight-wide {:.3} s",
        median(build_s),
        median(collapse_s),
        median(collapse8_s)
    );
}
