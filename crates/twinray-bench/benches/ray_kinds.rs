//! Rays of three kinds, each traced alone on the eight-wide tree as the
//! renderer traces a ray that has no packet: the eye rays of a scene's
//! viewpoint (coherent), the mirror reflections at their hits and the shadow
//! segments from their hits toward the first light (incoherent, the rays
//! that dominate mirror scenes), timed by this thread's CPU time:
//!
//! `cargo bench -p twinray-bench --bench ray_kinds -- [--size N] [--rounds R] [--out DIR] SCENE.nff ...`
//!
//! Prints per scene and kind the rays, the hits (blocked segments for
//! shadows), the nodes visited and primitives tested per ray, and the
//! Mrays/s of each round. With `--out`, each kind's rays are
//! written to `DIR/NAME.KIND.f32` (per ray seven little-endian `f32`: origin,
//! direction, far end; `inf` for rays) so that another tracer can take the
//! same rays: `bench/vs-embree-rays.py` does, with Intel Embree.

use std::io::Write;
use std::path::{Path, PathBuf};

use twinray::math::{Ray, Vec3};
use twinray_bench::traversal::{
    closest, rays_pass, shadow_blocked, shadow_pass, shadow_work, work, RaySets, Tree,
};

/// This thread's time on a CPU, in seconds (Linux: /proc/thread-self/schedstat).
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

/// CPU seconds `f` took on this thread (wall seconds where that is unknown).
fn timed(f: impl Fn() -> u64) -> (f64, u64) {
    let (w0, c0) = (std::time::Instant::now(), cpu_seconds());
    let r = f();
    match (c0, cpu_seconds()) {
        (Some(a), Some(b)) => (b - a, r),
        _ => (w0.elapsed().as_secs_f64(), r),
    }
}

/// Writes `rays` (origin, direction, far end) to `path`.
fn write_rays(path: &Path, rays: impl Iterator<Item = (Vec3, Vec3, f32)>) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(std::fs::File::create(path)?);
    for (o, d, t) in rays {
        for x in [o.x, o.y, o.z, d.x, d.y, d.z, t] {
            out.write_all(&x.to_le_bytes())?;
        }
    }
    out.flush()
}

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let (mut size, mut rounds, mut out, mut scenes) = (512usize, 3usize, None, Vec::new());
    while let Some(a) = args.next() {
        let mut value = |what: &str| {
            args.next()
                .unwrap_or_else(|| panic!("{what} needs a value"))
        };
        match a.as_str() {
            "--size" => size = value("--size").parse().expect("--size N"),
            "--rounds" => rounds = value("--rounds").parse().expect("--rounds R"),
            "--out" => out = Some(PathBuf::from(value("--out"))),
            _ => scenes.push(PathBuf::from(a)),
        }
    }
    println!(
        "scene      kind        rays     hits  nodes  prims  Mrays/s per round (1 thread, CPU time)"
    );
    for path in scenes {
        let name = path
            .file_stem()
            .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
        let sets = match RaySets::load(&path, size) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {}: {e}", path.display());
                continue;
            }
        };
        let as_segment = |r: &Ray| (r.origin, r.dir, f32::INFINITY);
        if let Some(dir) = &out {
            let file = |kind: &str| dir.join(format!("{name}.{kind}.f32"));
            let written = write_rays(&file("eye"), sets.eye.iter().map(as_segment))
                .and_then(|()| {
                    write_rays(&file("reflected"), sets.reflected.iter().map(as_segment))
                })
                .and_then(|()| write_rays(&file("shadow"), sets.shadow.iter().copied()));
            if let Err(e) = written {
                eprintln!("{}: {e}", dir.display());
                std::process::exit(1);
            }
        }
        let world = &sets.world;
        // Hits (blocked segments) counted once, for the other tracer to agree with.
        let hits = |rays: &[Ray]| {
            rays.iter()
                .filter(|r| {
                    let (p, _) =
                        closest(&world.bvh, world, r, Tree::Wide8, &mut Default::default());
                    p != u32::MAX
                })
                .count()
        };
        let kinds: [(&str, usize, usize); 3] = [
            ("eye", sets.eye.len(), hits(&sets.eye)),
            ("reflected", sets.reflected.len(), hits(&sets.reflected)),
            ("shadow", sets.shadow.len(), {
                let blocked = sets.shadow.iter();
                blocked
                    .filter(|s| shadow_blocked(world, s, Tree::Wide8))
                    .count()
            }),
        ];
        for (kind, n, hit) in kinds {
            let mut rates = Vec::new();
            let pass = || match kind {
                "eye" => rays_pass(&sets, &sets.eye, Tree::Wide8, 1),
                "reflected" => rays_pass(&sets, &sets.reflected, Tree::Wide8, 1),
                _ => shadow_pass(&sets, Tree::Wide8, 1),
            };
            for _ in 0..rounds {
                // Passes until a quarter second of CPU: the thread's clock
                // ticks in milliseconds.
                let (mut seconds, mut passes) = (0.0, 0u32);
                while seconds < 0.25 {
                    seconds += timed(pass).0;
                    passes += 1;
                }
                let rate = f64::from(passes) * n as f64 / seconds / 1e6;
                rates.push(format!("{rate:.2}"));
            }
            // The descent's work per ray: nodes, and primitives tested.
            let work = match kind {
                "eye" => work(&sets, &sets.eye, Tree::Wide8),
                "reflected" => work(&sets, &sets.reflected, Tree::Wide8),
                _ => shadow_work(&sets, Tree::Wide8),
            };
            let per = |x: u64| x as f64 / n.max(1) as f64;
            println!(
                "{name:<10} {kind:<9} {n:>8} {hit:>8} {:>6.2} {:>6.2}  {}",
                per(work.nodes),
                per(work.prim_tests),
                rates.join(" ")
            );
        }
    }
}
