//! Panoramas for headsets (`rig::projection`): the twin method equals the
//! independent renders bit for bit for every projection, mono and stereo;
//! the geometry of the images (each sphere where the projection's formula
//! puts it, ODS's angular disparity, the pole merge, the seam, the
//! fisheye's circle).

use crate::common;

use common::*;
use twinray::math::Vec3;
use twinray::render::{Filter, RenderOutput, Sampling, ViewMethod};
use twinray::rig::{Camera, PoleMerge, Projection, Rig, View};
use twinray::{Image, World};

const ODS: Projection = Projection::Ods(PoleMerge {
    from_deg: 60.0,
    to_deg: 75.0,
});

/// Eyes at `-ipd/2` and `+ipd/2`, parallel (a panorama's rig); one eye at
/// the centre for `None`.
fn eyes(ipd: Option<f32>) -> Rig {
    match ipd {
        None => Rig::mono(),
        Some(b) => Rig {
            views: vec![
                View {
                    offset: -b / 2.0,
                    shift: 0,
                },
                View {
                    offset: b / 2.0,
                    shift: 0,
                },
            ],
            convergence: None,
            effective_convergence: None,
        },
    }
}

/// Random spheres, mirrors, glass and polygons all around the camera at
/// the origin (looking along +y, z up), lit by two lights.
fn surrounding_scene(seed: u64) -> String {
    let mut g = fastrand::Rng::with_seed(seed);
    let mut s = String::from(
        "b 0.2 0.3 0.5\nv\nfrom 0 0 0\nat 0 1 0\nup 0 0 1\nangle 60\nhither 0.001\n\
         resolution 64 32\nl 4 3 6\nl -5 -2 3 0.6 0.6 0.6\n",
    );
    let mut r = |a: f32, b: f32| a + (b - a) * g.f32();
    for k in 0..14 {
        let (az, el, d) = (r(-3.2, 3.2), r(-1.4, 1.4), r(0.6, 6.0));
        let (x, y, z) = (
            d * el.cos() * az.sin(),
            d * el.cos() * az.cos(),
            d * el.sin(),
        );
        let (cr, cg, cb) = (r(0.2, 1.0), r(0.2, 1.0), r(0.2, 1.0));
        let material = match k % 4 {
            0 => format!("f {cr} {cg} {cb} 0.3 0.7 30 0 1"),
            1 => format!("f {cr} {cg} {cb} 0.1 0.2 60 0.8 1.5"),
            _ => format!("f {cr} {cg} {cb} 0.9 0.1 10 0 1"),
        };
        s += &format!("{material}\ns {x} {y} {z} {}\n", r(0.05, 0.5));
    }
    // A floor and a tilted polygon.
    s += "f 0.8 0.8 0.7 0.8 0.2 5 0 1\np 4\n-20 -20 -1.5\n20 -20 -1.5\n20 20 -1.5\n-20 20 -1.5\n";
    s += &format!(
        "f 0.9 0.4 0.3 0.7 0 0 0 1\np 3\n{} {} 2\n{} {} 3\n{} {} 1\n",
        r(-4.0, 4.0),
        r(-4.0, 4.0),
        r(-4.0, 4.0),
        r(-4.0, 4.0),
        r(-4.0, 4.0),
        r(-4.0, 4.0)
    );
    s
}

fn pano_camera(world: &World, projection: Projection, width: u32, height: u32) -> Camera {
    Camera::new(&world.scene.viewpoint, width, height).with_projection(projection)
}

fn render_as(
    world: &World,
    cam: &Camera,
    rig: &Rig,
    method: ViewMethod,
    sampling: Sampling,
) -> RenderOutput {
    run(world, cam, rig, &options(method, sampling))
}

fn assert_bits_equal(a: &Image, b: &Image, what: &str) {
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}");
    let differing = a
        .pixels
        .iter()
        .zip(&b.pixels)
        .filter(|(p, q)| p.to_array().map(f32::to_bits) != q.to_array().map(f32::to_bits))
        .count();
    assert_eq!(differing, 0, "{what}: {differing} pixels differ");
}

#[test]
fn twin_equals_independent_for_every_projection_mono_and_stereo() {
    let samplings = [
        Sampling::Centers,
        Sampling::Stratified {
            samples: 4,
            filter: Filter::Tent,
            seed: 3,
        },
        Sampling::Adaptive {
            threshold: 1.0 / 32.0,
            max_samples: 16,
        },
    ];
    let mut compared = 0;
    for seed in 0..3 {
        let world = nff_world(&surrounding_scene(seed));
        for (projection, (w, h)) in [
            (Projection::Equirect, (72, 36)),
            (ODS, (72, 36)),
            (Projection::Vr180, (36, 36)),
            (Projection::Vr180Fisheye, (36, 36)),
        ] {
            let cam = pano_camera(&world, projection, w, h);
            let ipds: &[Option<f32>] = match projection {
                Projection::Equirect => &[None],
                _ => &[None, Some(0.064), Some(0.9)],
            };
            for &ipd in ipds {
                let rig = eyes(ipd);
                let sampling = samplings[compared % samplings.len()];
                let reference = render_as(&world, &cam, &rig, ViewMethod::Independent, sampling);
                let twin = render_as(&world, &cam, &rig, ViewMethod::twin(), sampling);
                for (v, (a, b)) in reference.images.iter().zip(&twin.images).enumerate() {
                    let what =
                        format!("seed {seed} {projection:?} ipd {ipd:?} {sampling:?} view {v}");
                    assert_bits_equal(a, b, &what);
                }
                // The pair's eyes go down together: fewer descents than rays.
                if ipd.is_some() {
                    let c = &twin.counts;
                    assert!(
                        c.eye_traversals * 3 < c.rays.eye,
                        "{projection:?}: {} descents for {} eye rays",
                        c.eye_traversals,
                        c.rays.eye
                    );
                }
                compared += 1;
            }
        }
    }
    assert_eq!(compared, 30);
}

#[test]
fn ods_of_one_eye_is_the_equirectangular_image() {
    let world = nff_world(&surrounding_scene(7));
    let a = render_as(
        &world,
        &pano_camera(&world, Projection::Equirect, 64, 32),
        &Rig::mono(),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    let b = render_as(
        &world,
        &pano_camera(&world, ODS, 64, 32),
        &Rig::mono(),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    assert_bits_equal(&a.images[0], &b.images[0], "ODS mono vs equirect");
}

/// Small white spheres on black at (azimuth, elevation) degrees and
/// distance, lit from the camera.
fn spheres_at(places: &[(f64, f64, f64)], radius: f64) -> String {
    let mut s = String::from(
        "b 0 0 0\nv\nfrom 0 0 0\nat 0 1 0\nup 0 0 1\nangle 60\nhither 0.001\n\
         resolution 64 32\nl 0 0 0\nf 1 1 1 1 0 0 0 1\n",
    );
    for &(az, el, d) in places {
        let p = sphere_centre(az, el, d);
        s += &format!("s {} {} {} {radius}\n", p.x, p.y, p.z);
    }
    s
}

fn sphere_centre(az: f64, el: f64, d: f64) -> Vec3 {
    let (az, el) = (az.to_radians(), el.to_radians());
    Vec3::new(
        (d * el.cos() * az.sin()) as f32,
        (d * el.cos() * az.cos()) as f32,
        (d * el.sin()) as f32,
    )
}

/// The centroid of the lit pixels within `reach` of (`x`, `y`), columns
/// taken around the seam.
fn blob(img: &Image, x: f64, y: f64, reach: i64) -> Option<(f64, f64)> {
    let (mut n, mut sx, mut sy) = (0.0, 0.0, 0.0);
    let w = img.width as i64;
    for j in (y.round() as i64 - reach)..=(y.round() as i64 + reach) {
        for i in (x.round() as i64 - reach)..=(x.round() as i64 + reach) {
            if j < 0 || j >= img.height as i64 {
                continue;
            }
            if img.get(i.rem_euclid(w) as u32, j as u32).element_sum() > 0.0 {
                n += 1.0;
                sx += i as f64;
                sy += j as f64;
            }
        }
    }
    (n > 0.0).then(|| (sx / n, sy / n))
}

/// The ODS formula, written out: the eye `s` (signed, half the IPD) sees a
/// point at azimuth `az`, elevation `el` and distance `d` along the ray
/// tangent to its circle: azimuth `az - asin(s / ρ)` with `ρ = d cos el`,
/// elevation `atan(z / sqrt(ρ² - s²))`.
fn ods_pixel(az: f64, el: f64, d: f64, s: f64, w: u32, h: u32) -> (f64, f64) {
    let (az, el) = (az.to_radians(), el.to_radians());
    let rho = d * el.cos();
    let lon = az - (s / rho).asin();
    let lat = (d * el.sin()).atan2((rho * rho - s * s).sqrt());
    (
        (lon / std::f64::consts::TAU + 0.5) * w as f64 - 0.5,
        (0.5 - lat / std::f64::consts::PI) * h as f64 - 0.5,
    )
}

#[test]
fn each_sphere_lands_where_the_ods_formula_puts_it_in_each_eye() {
    let places = [
        (0.0, 0.0, 2.0),
        (40.0, 10.0, 1.2),
        (-75.0, -20.0, 3.0),
        (130.0, 30.0, 0.8),
        (-150.0, 5.0, 5.0),
        (95.0, -45.0, 1.5),
    ];
    let world = nff_world(&spheres_at(&places, 0.03));
    let (w, h) = (1024, 512);
    let ipd = 0.064f32;
    let cam = pano_camera(&world, ODS, w, h);
    let out = render_as(
        &world,
        &cam,
        &eyes(Some(ipd)),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    let mut measured = Vec::new();
    for &(az, el, d) in &places {
        let mut columns = [0.0; 2];
        for (v, s) in [(0, -ipd as f64 / 2.0), (1, ipd as f64 / 2.0)] {
            let (x, y) = ods_pixel(az, el, d, s, w, h);
            let (bx, by) = blob(&out.images[v], x, y, 12)
                .unwrap_or_else(|| panic!("no sphere near ({x:.1}, {y:.1}) in eye {v}"));
            assert!(
                (bx - x).abs() <= 0.5 && (by - y).abs() <= 0.5,
                "sphere ({az}, {el}, {d}) eye {v}: formula ({x:.2}, {y:.2}), image ({bx:.2}, {by:.2})"
            );
            columns[v] = bx;
        }
        measured.push(((az, el, d), columns));
    }
    // At the equator, the eyes' disparity is 2·asin(r/d), in pixels of
    // W/2π each.
    let ((_, _, d), [left, right]) = measured[0];
    let expected = 2.0 * (ipd as f64 / 2.0 / d).asin() * w as f64 / std::f64::consts::TAU;
    assert!(
        ((left - right) - expected).abs() <= 0.5,
        "disparity {:.3} px, formula {expected:.3} px",
        left - right
    );
    // And a near sphere's disparity is larger than a far one's.
    assert!(measured[3].1[0] - measured[3].1[1] > measured[4].1[0] - measured[4].1[1]);
}

#[test]
fn each_sphere_lands_where_vr180_projections_put_it() {
    let places = [
        (0.0, 0.0, 2.0),
        (40.0, 10.0, 1.2),
        (-60.0, -30.0, 3.0),
        (20.0, 50.0, 0.9),
    ];
    let world = nff_world(&spheres_at(&places, 0.03));
    let ipd = 0.064f32;
    for projection in [Projection::Vr180, Projection::Vr180Fisheye] {
        let cam = pano_camera(&world, projection, 512, 512);
        let out = render_as(
            &world,
            &cam,
            &eyes(Some(ipd)),
            ViewMethod::twin(),
            Sampling::Centers,
        );
        for &(az, el, d) in &places {
            for (v, s) in [(0, -ipd / 2.0), (1, ipd / 2.0)] {
                // The formula, written out from the eye at `s` on the right axis.
                let p = sphere_centre(az, el, d) - Vec3::new(s, 0.0, 0.0);
                let (x, y, z) = (p.x as f64, p.y as f64, p.z as f64);
                let (px, py) = match projection {
                    Projection::Vr180 => {
                        let lon = x.atan2(y);
                        let lat = z.atan2(x.hypot(y));
                        (
                            (lon / std::f64::consts::PI + 0.5) * 512.0 - 0.5,
                            (0.5 - lat / std::f64::consts::PI) * 512.0 - 0.5,
                        )
                    }
                    _ => {
                        let theta = (y / (x * x + y * y + z * z).sqrt()).acos();
                        let rho = theta / std::f64::consts::FRAC_PI_2;
                        let phi = z.atan2(x);
                        (
                            (rho * phi.cos() + 1.0) * 256.0 - 0.5,
                            (1.0 - rho * phi.sin()) * 256.0 - 0.5,
                        )
                    }
                };
                let (bx, by) = blob(&out.images[v], px, py, 12)
                    .unwrap_or_else(|| panic!("{projection:?}: no sphere near ({px:.1}, {py:.1})"));
                assert!(
                    (bx - px).abs() <= 0.5 && (by - py).abs() <= 0.5,
                    "{projection:?} sphere ({az}, {el}, {d}) eye {v}: formula ({px:.2}, {py:.2}), image ({bx:.2}, {by:.2})"
                );
            }
        }
    }
}

#[test]
fn pole_merging_makes_the_eyes_one_beyond_the_merge_latitude() {
    let world = nff_world(&surrounding_scene(11));
    let (w, h) = (96, 48);
    let cam = pano_camera(&world, ODS, w, h);
    let out = render_as(
        &world,
        &cam,
        &eyes(Some(0.3)),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    let (left, right) = (&out.images[0], &out.images[1]);
    let lat = |row: u32| 90.0 - (row as f64 + 0.5) * 180.0 / h as f64;
    let mut merged_rows = 0;
    let mut differing_rows = 0;
    for row in 0..h {
        let same = (0..w).all(|x| left.get(x, row) == right.get(x, row));
        if lat(row).abs() > 75.0 {
            assert!(same, "row {row} at latitude {:.1} differs", lat(row));
            merged_rows += 1;
        } else if !same {
            differing_rows += 1;
        }
    }
    assert!(merged_rows >= 6, "{merged_rows}");
    assert!(
        differing_rows > 20,
        "the eyes differ below 60°: {differing_rows} rows"
    );
    // Later latitudes of merging make the polar rows differ again.
    let late = PoleMerge {
        from_deg: 85.0,
        to_deg: 89.9,
    };
    let cam = pano_camera(&world, Projection::Ods(late), w, h);
    let out = render_as(
        &world,
        &cam,
        &eyes(Some(0.3)),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    let row = 2; // latitude 84.4°
    assert!((0..w).any(|x| out.images[0].get(x, row) != out.images[1].get(x, row)));
}

#[test]
fn an_object_across_the_seam_is_continuous() {
    // One sphere straight behind the camera, one in front: the same disc.
    let world = nff_world(&spheres_at(&[(180.0, 10.0, 2.0), (0.0, 10.0, 2.0)], 0.2));
    let (w, h) = (256u32, 128u32);
    let cam = pano_camera(&world, ODS, w, h);
    let out = render_as(
        &world,
        &cam,
        &eyes(Some(0.064)),
        ViewMethod::twin(),
        Sampling::Centers,
    );
    for img in &out.images {
        let lit = |x: u32, y: u32| img.get(x, y).element_sum() > 0.0;
        let count = |x0: u32, x1: u32| {
            (0..h)
                .flat_map(|y| (x0..x1).map(move |x| (x, y)))
                .filter(|&(x, y)| lit(x, y))
                .count()
        };
        // The disc behind is split between the two edges, the one in front
        // whole in the middle.
        let behind = count(0, w / 4) + count(3 * w / 4, w);
        let front = count(w / 4, 3 * w / 4);
        assert!(
            count(0, 1) > 0 && count(w - 1, w) > 0,
            "the seam cuts the disc"
        );
        assert!(
            behind.abs_diff(front) <= 2,
            "behind {behind} px, in front {front} px"
        );
        // Column 0 continues column W-1: the same rows lit on both sides.
        for y in 0..h {
            assert_eq!(lit(0, y), lit(w - 1, y), "row {y}");
        }
    }
}

#[test]
fn fisheye_pixels_outside_the_circle_are_black() {
    let world = nff_world(&surrounding_scene(5)); // a blue-grey background
    let (w, h) = (40u32, 40u32);
    let cam = pano_camera(&world, Projection::Vr180Fisheye, w, h);
    for sampling in [
        Sampling::Centers,
        Sampling::Adaptive {
            threshold: 1.0 / 32.0,
            max_samples: 16,
        },
    ] {
        let out = render_as(
            &world,
            &cam,
            &eyes(Some(0.064)),
            ViewMethod::twin(),
            sampling,
        );
        for img in &out.images {
            for y in 0..h {
                for x in 0..w {
                    // The pixel's nearest point to the centre, in units of the radius.
                    let near = |c: u32, n: u32| {
                        let (lo, hi) = (
                            c as f64 / n as f64 * 2.0 - 1.0,
                            (c + 1) as f64 / n as f64 * 2.0 - 1.0,
                        );
                        if lo <= 0.0 && hi >= 0.0 {
                            0.0
                        } else {
                            lo.abs().min(hi.abs())
                        }
                    };
                    let far = |c: u32, n: u32| {
                        let (lo, hi) = (
                            c as f64 / n as f64 * 2.0 - 1.0,
                            (c + 1) as f64 / n as f64 * 2.0 - 1.0,
                        );
                        lo.abs().max(hi.abs())
                    };
                    let p = img.get(x, y);
                    if near(x, w).hypot(near(y, h)) > 1.0 {
                        assert_eq!(p.element_sum(), 0.0, "({x}, {y}) outside, {sampling:?}");
                    } else if far(x, w).hypot(far(y, h)) < 1.0 {
                        assert!(p.element_sum() > 0.0, "({x}, {y}) inside is black");
                    }
                }
            }
        }
    }
}
