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

use twinray::bvh::TraversalStats;
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

/// The three kinds of rays, each traced alone.
#[derive(Clone, Copy)]
enum Kind {
    Eye,
    Reflected,
    Shadow,
}

impl Kind {
    const ALL: [Kind; 3] = [Kind::Eye, Kind::Reflected, Kind::Shadow];

    fn name(self) -> &'static str {
        match self {
            Kind::Eye => "eye",
            Kind::Reflected => "reflected",
            Kind::Shadow => "shadow",
        }
    }

    /// The rays of this kind as segments (origin, direction, far end).
    fn segments(self, sets: &RaySets) -> Vec<(Vec3, Vec3, f32)> {
        let as_segment = |r: &Ray| (r.origin, r.dir, f32::INFINITY);
        match self {
            Kind::Eye => sets.eye.iter().map(as_segment).collect(),
            Kind::Reflected => sets.reflected.iter().map(as_segment).collect(),
            Kind::Shadow => sets.shadow.clone(),
        }
    }

    /// The rays, for the nearest-hit kinds.
    fn rays(self, sets: &RaySets) -> &[Ray] {
        match self {
            Kind::Eye => &sets.eye,
            Kind::Reflected => &sets.reflected,
            Kind::Shadow => &[],
        }
    }

    /// How many rays there are.
    fn len(self, sets: &RaySets) -> usize {
        match self {
            Kind::Shadow => sets.shadow.len(),
            _ => self.rays(sets).len(),
        }
    }

    /// How many rays hit something (segments: are blocked).
    fn hits(self, sets: &RaySets) -> usize {
        let world = &sets.world;
        match self {
            Kind::Shadow => sets
                .shadow
                .iter()
                .filter(|s| shadow_blocked(world, s, Tree::Packets))
                .count(),
            _ => self
                .rays(sets)
                .iter()
                .filter(|r| {
                    let (p, _) =
                        closest(&world.bvh, world, r, Tree::Packets, &mut Default::default());
                    p != u32::MAX
                })
                .count(),
        }
    }

    /// One pass over every ray on one thread: a checksum of the hits.
    fn pass(self, sets: &RaySets) -> u64 {
        match self {
            Kind::Shadow => shadow_pass(sets, Tree::Packets, 1),
            _ => rays_pass(sets, self.rays(sets), Tree::Packets, 1),
        }
    }

    /// The descent's work over every ray.
    fn work(self, sets: &RaySets) -> TraversalStats {
        match self {
            Kind::Shadow => shadow_work(sets, Tree::Packets),
            _ => work(sets, self.rays(sets), Tree::Packets),
        }
    }
}

/// What the command line asks: ray sets of `size`², `rounds` timings, the
/// rays written under `out`, the scenes.
struct Args {
    size: usize,
    rounds: usize,
    out: Option<PathBuf>,
    scenes: Vec<PathBuf>,
}

fn parse_args() -> Result<Args, String> {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let mut parsed = Args {
        size: 512,
        rounds: 3,
        out: None,
        scenes: Vec::new(),
    };
    while let Some(a) = args.next() {
        let mut value = |what: &str| args.next().ok_or(format!("{what} needs a value"));
        match a.as_str() {
            "--size" => {
                parsed.size = value("--size")?
                    .parse()
                    .map_err(|_| "--size takes a number of pixels")?
            }
            "--rounds" => {
                parsed.rounds = value("--rounds")?
                    .parse()
                    .map_err(|_| "--rounds takes a number")?
            }
            "--out" => parsed.out = Some(PathBuf::from(value("--out")?)),
            _ => parsed.scenes.push(PathBuf::from(a)),
        }
    }
    Ok(parsed)
}

fn main() {
    let args = match parse_args() {
        Ok(a) => a,
        Err(e) => {
            eprintln!("ray_kinds: {e}\nusage: ray_kinds [--size N] [--rounds R] [--out DIR] SCENE.nff ...");
            std::process::exit(2);
        }
    };
    println!(
        "scene      kind        rays     hits  nodes  prims  Mrays/s per round (1 thread, CPU time)"
    );
    for path in &args.scenes {
        let name = path
            .file_stem()
            .map_or_else(|| "scene".to_string(), |s| s.to_string_lossy().into_owned());
        let sets = match RaySets::load(path, args.size) {
            Ok(s) => s,
            Err(e) => {
                eprintln!("skipping {}: {e}", path.display());
                continue;
            }
        };
        for kind in Kind::ALL {
            if let Some(dir) = &args.out {
                let file = dir.join(format!("{name}.{}.f32", kind.name()));
                if let Err(e) = write_rays(&file, kind.segments(&sets).into_iter()) {
                    eprintln!("{}: {e}", file.display());
                    std::process::exit(1);
                }
            }
            let n = kind.len(&sets);
            let mut rates = Vec::new();
            for _ in 0..args.rounds {
                // Passes until a quarter second of CPU: the thread's clock
                // ticks in milliseconds.
                let (mut seconds, mut passes) = (0.0, 0u32);
                while seconds < 0.25 {
                    let (s, sum) = timed(|| kind.pass(&sets));
                    std::hint::black_box(sum);
                    seconds += s;
                    passes += 1;
                }
                let rate = f64::from(passes) * n as f64 / seconds / 1e6;
                rates.push(format!("{rate:.2}"));
            }
            // The descent's work per ray: nodes, and primitives tested.
            let work = kind.work(&sets);
            let per = |x: u64| x as f64 / n.max(1) as f64;
            println!(
                "{name:<10} {:<9} {n:>8} {:>8} {:>6.2} {:>6.2}  {}",
                kind.name(),
                kind.hits(&sets),
                per(work.nodes),
                per(work.prim_tests),
                rates.join(" ")
            );
        }
    }
}
