//! Side-by-side rays/s of the four-wide and the binary traversal, in one
//! process, rounds interleaved so that the machine's load hits both alike:
//!
//! `cargo run --release -p twinray-bench --example wide_vs_binary -- [--size N] [--rounds R] SCENE.nff ...`
//!
//! Prints per scene and ray kind the median Mrays/s of each over the rounds and
//! the ratio wide / binary, on 1 and 2 threads.

use std::path::Path;
use std::time::Instant;

use twinray_bench::traversal::{pairs_pass, rays_pass, shadow_pass, RaySets, Tree};

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
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
    println!(
        "{:<10} {:<10} {:>3} {:>11} {:>11} {:>6} agree",
        "scene", "rays", "thr", "binary_Mr/s", "wide_Mr/s", "ratio"
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
        type Run<'a> = Box<dyn Fn(Tree, usize) -> u64 + 'a>;
        let kinds: [(&str, usize, Run); 4] = [
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
                "shadow",
                sets.shadow.len(),
                Box::new(|t, n| shadow_pass(&sets, t, n)),
            ),
            (
                "reflected",
                sets.reflected.len(),
                Box::new(|t, n| rays_pass(&sets, &sets.reflected, t, n)),
            ),
        ];
        for threads in [1, 2] {
            for (kind, count, run) in &kinds {
                let (mut b, mut w) = (Vec::new(), Vec::new());
                let mut agree = true;
                for _ in 0..rounds {
                    let t0 = Instant::now();
                    let cb = run(Tree::Binary, threads);
                    b.push(*count as f64 / t0.elapsed().as_secs_f64() / 1e6);
                    let t0 = Instant::now();
                    let cw = run(Tree::Wide, threads);
                    w.push(*count as f64 / t0.elapsed().as_secs_f64() / 1e6);
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
