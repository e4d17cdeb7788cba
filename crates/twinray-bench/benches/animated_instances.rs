//! Per-frame cost of an animated glTF scene made ready to trace, two ways,
//! in one process with the rounds interleaved so that the machine's load hits
//! both alike:
//!
//! * whole: the file read at the frame's time and the whole hierarchy built
//!   (`Job::load_at` and the plan's `World::new`: what every frame cost
//!   before the two-level hierarchy);
//! * two-level: `Animation::loaded_at`, the file kept in memory, only the
//!   moving instances' triangles made and their trees built, the top tree
//!   built and the trees spliced.
//!
//! `cargo bench -p twinray-bench --bench animated_instances -- [--frames N] [--rounds R] [--threads T] SCENE.glb`
//!
//! Prints the median over the rounds of the seconds of CPU time of this
//! process per frame (frames 1..=N, after frame 0 readied the two-level
//! hierarchy's kept state), the ratio, the first frame's cost, and what the
//! two-level build rebuilt.

use std::path::PathBuf;
use std::time::Instant;

use twinray::animation::Animation;
use twinray::job::{Job, JobSpec};

/// This process's CPU time in seconds (user + system, all threads), from
/// /proc/self/stat; other processes' load does not inflate it.
fn cpu_seconds() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/stat").ok()?;
    let rest = &s[s.rfind(')')? + 2..];
    let f: Vec<&str> = rest.split_whitespace().collect();
    let ticks: f64 = f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?;
    Some(ticks / 100.0)
}

/// (CPU seconds, wall seconds) of `f`.
fn timed(f: impl FnOnce()) -> (f64, f64) {
    let (w, c) = (Instant::now(), cpu_seconds().unwrap_or(0.0));
    f();
    (cpu_seconds().unwrap_or(0.0) - c, w.elapsed().as_secs_f64())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    let (mut frames, mut rounds, mut threads, mut scene) = (8u32, 3usize, 1usize, None);
    while let Some(a) = args.next() {
        let mut value = || args.next().expect("a value after the flag");
        match a.as_str() {
            "--frames" => frames = value().parse().expect("--frames N"),
            "--rounds" => rounds = value().parse().expect("--rounds R"),
            "--threads" => threads = value().parse().expect("--threads T"),
            _ => scene = Some(PathBuf::from(a)),
        }
    }
    let scene = scene.expect("a glTF file with an animation");
    let fps = 24.0;
    let mut spec = JobSpec::new(&scene, "/tmp/unused_####.png");
    spec.camera.size = Some([64, 48]);
    spec.trace.threads = Some(threads);
    spec.animation.frames = Some(format!("0..{frames}"));
    spec.animation.fps = fps;
    let job = Job::check({
        let mut s = spec.clone();
        s.animation = Default::default();
        s
    })
    .expect("a valid job");
    let (mut whole, mut two, mut first) = (Vec::new(), Vec::new(), Vec::new());
    let mut counts = None;
    for round in 0..rounds {
        // Two-level: frame 0 readies the kept state; frames 1..=N timed.
        let animation = Animation::check(spec.clone()).expect("a valid animation");
        let (c0, _) = timed(|| {
            animation.loaded_at(0).expect("frame 0");
        });
        first.push(c0);
        let (c, w) = timed(|| {
            for f in 1..=frames {
                let loaded = animation.loaded_at(f).expect("a frame").expect("animated");
                counts = loaded.built_world().and_then(|w| w.instances);
            }
        });
        two.push(c / f64::from(frames));
        // Whole: the file read and the hierarchy built at every frame.
        let (cw, ww) = timed(|| {
            for f in 1..=frames {
                let loaded = job
                    .load_at(Some((f64::from(f) / fps) as f32))
                    .expect("a frame");
                let world = loaded.world(job.pool());
                assert!(world.instances.is_none());
            }
        });
        whole.push(cw / f64::from(frames));
        eprintln!(
            "round {round}: whole {:.4} s/frame ({:.3} s wall), two-level {:.4} s/frame ({:.3} s wall), two-level frame 0 {:.3} s",
            cw / f64::from(frames),
            ww,
            c / f64::from(frames),
            w,
            c0
        );
    }
    let (w, t) = (median(whole), median(two));
    println!(
        "{}: {frames} frames x {rounds} rounds, {threads} thread(s), CPU s/frame (median): whole {w:.4}, two-level {t:.4}, whole / two-level {:.1}x; two-level frame 0 {:.3} s; last frame {counts:?}",
        scene.display(),
        w / t,
        median(first)
    );
}
