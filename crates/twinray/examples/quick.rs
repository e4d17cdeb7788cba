use std::time::Instant;
use twinray::camera::Camera;
use twinray::loaders::{load_scene, LoadOptions};
use twinray::render::{render, Method, RenderOptions, Sampling, TraceSettings};
use twinray::rig::Rig;
use twinray::World;

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let path = &args[1];
    let out = &args[2];
    let size: u32 = args.get(3).map(|s| s.parse().unwrap()).unwrap_or(512);
    let stereo: f32 = args.get(4).map(|s| s.parse().unwrap()).unwrap_or(-1.0);
    let t = Instant::now();
    let scene = load_scene(path.as_ref(), &LoadOptions::default()).unwrap();
    let load = t.elapsed().as_secs_f64();
    let cam = Camera::new(&scene.viewpoint, size, size);
    let world = World::new(scene);
    println!(
        "load {:.3}s build {:.3}s prims {} nodes {} depth {}",
        load,
        world.build_seconds,
        world.scene.shapes.len(),
        world.bvh.nodes.len(),
        world.bvh.depth()
    );
    let spd = std::env::var("SPD").is_ok();
    let mut opts = RenderOptions {
        trace: TraceSettings {
            spd,
            min_weight: if spd { 0.0 } else { 1.0 / 256.0 },
            ..Default::default()
        },
        method: Method::Independent,
        sampling: if spd {
            Sampling::Corners
        } else {
            Sampling::Centers
        },
    };
    let rig = if stereo >= 0.0 {
        Rig::stereo(&cam, stereo, None)
    } else {
        Rig::mono()
    };
    let mut r = render(&world, &cam, &rig, &opts, &|_, _| {}).unwrap();
    let reps: usize = std::env::var("REPS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(1);
    if stereo >= 0.0 && reps > 1 {
        let mut ti = vec![];
        let mut tt = vec![];
        for _ in 0..reps {
            opts.method = Method::Independent;
            ti.push(
                render(&world, &cam, &rig, &opts, &|_, _| {})
                    .unwrap()
                    .seconds,
            );
            opts.method = Method::Twin;
            tt.push(
                render(&world, &cam, &rig, &opts, &|_, _| {})
                    .unwrap()
                    .seconds,
            );
        }
        ti.sort_by(f64::total_cmp);
        tt.sort_by(f64::total_cmp);
        println!(
            "median indep {:.4} twin {:.4} ratio {:.3}",
            ti[reps / 2],
            tt[reps / 2],
            tt[reps / 2] / ti[reps / 2]
        );
        opts.method = Method::Independent;
        r = render(&world, &cam, &rig, &opts, &|_, _| {}).unwrap();
    }
    println!(
        "independent render {:.3}s rays {:?} nodes {} prims {}",
        r.seconds, r.counts.rays, r.counts.nodes, r.counts.prim_tests
    );
    if stereo >= 0.0 {
        opts.method = Method::Twin;
        let r2 = render(&world, &cam, &rig, &opts, &|_, _| {}).unwrap();
        println!(
            "twin render {:.3}s ratio {:.3} rays {:?} nodes {} prims {} shared {}",
            r2.seconds,
            r2.seconds / r.seconds,
            r2.counts.rays,
            r2.counts.nodes,
            r2.counts.prim_tests,
            r2.counts.shared_secondary
        );
        for v in 0..2 {
            println!("view {v} equal: {}", r.images[v] == r2.images[v]);
        }
    }
    let img = &r.images[0];
    let mut buf = image::RgbImage::new(img.width, img.height);
    for (i, p) in img.pixels.iter().enumerate() {
        let c = p.clamp(glam::Vec3::ZERO, glam::Vec3::ONE) * 255.0 + 0.5;
        buf.put_pixel(
            i as u32 % img.width,
            i as u32 / img.width,
            image::Rgb([c.x as u8, c.y as u8, c.z as u8]),
        );
    }
    buf.save(out).unwrap();
}
