//! Data for twinray's benchmarks, generated from a small LCG (no files): height-field
//! terrains and the eye-like and incoherent rays that trace them.
//!
//! The benchmarks live in this crate, apart from the library, so that their
//! dependencies (criterion, obvhs) are compiled only by `cargo bench -p
//! twinray-bench`, never by the test suite.

use twinray::math::{Ray, Vec3};

/// Knuth's MMIX LCG; the top 24 bits as a float in [0, 1).
pub struct Lcg(u64);

impl Lcg {
    pub fn next_f32(&mut self) -> f32 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((self.0 >> 40) as f32) / (1u64 << 24) as f32
    }

    pub fn range(&mut self, lo: f32, hi: f32) -> f32 {
        lo + (hi - lo) * self.next_f32()
    }
}

/// A terrain of `nx * nz` cells over `[-sx, sx] x [-sz, sz]` (two triangles per
/// cell), heights from a few sines plus LCG noise, within about ±0.15.
pub fn terrain(nx: usize, nz: usize, sx: f32, sz: f32, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = Lcg(seed);
    let vx = nx + 1;
    let verts: Vec<Vec3> = (0..(nz + 1) * vx)
        .map(|i| {
            let (ix, iz) = (i % vx, i / vx);
            let x = -sx + 2.0 * sx * ix as f32 / nx as f32;
            let z = -sz + 2.0 * sz * iz as f32 / nz as f32;
            let y = 0.08 * (7.0 * x).sin() * (5.0 * z).cos()
                + 0.04 * (17.0 * x + 3.0 * z).sin()
                + 0.02 * (rng.next_f32() - 0.5);
            Vec3::new(x, y, z)
        })
        .collect();
    let mut tris = Vec::with_capacity(2 * nx * nz);
    for iz in 0..nz {
        for ix in 0..nx {
            let a = verts[iz * vx + ix];
            let b = verts[iz * vx + ix + 1];
            let c = verts[(iz + 1) * vx + ix];
            let d = verts[(iz + 1) * vx + ix + 1];
            tris.push([a, b, d]);
            tris.push([a, d, c]);
        }
    }
    tris
}

/// Primary-like rays: a 1000 x 1000 pinhole camera looking down at the terrain
/// (the top rows see sky past the far edge), in scanline order (consecutive
/// rays are neighbours).
pub fn camera_rays(w: usize, h: usize) -> Vec<Ray> {
    let eye = Vec3::new(0.0, 1.5, -2.0);
    let fwd = (Vec3::new(0.0, 0.0, 0.3) - eye).normalize();
    let right = fwd.cross(Vec3::Y).normalize();
    let up = right.cross(fwd);
    let half = (45f32.to_radians() * 0.5).tan();
    let mut rays = Vec::with_capacity(w * h);
    for j in 0..h {
        for i in 0..w {
            let u = ((i as f32 + 0.5) / w as f32 * 2.0 - 1.0) * half;
            let v = (1.0 - (j as f32 + 0.5) / h as f32 * 2.0) * half;
            rays.push(Ray::new(eye, (fwd + right * u + up * v).normalize()));
        }
    }
    rays
}

/// Incoherent rays: origins scattered over the terrain just above it, unit
/// directions uniform over the downward hemisphere (grazing ones included).
pub fn random_rays(n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Lcg(seed);
    (0..n)
        .map(|_| {
            let o = Vec3::new(
                rng.range(-0.9, 0.9),
                rng.range(0.2, 0.5),
                rng.range(-0.9, 0.9),
            );
            let d = loop {
                let d = Vec3::new(
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                    rng.range(-1.0, 1.0),
                );
                let l = d.length_squared();
                if l > 1e-4 && l <= 1.0 {
                    break d / l.sqrt();
                }
            };
            Ray::new(o, Vec3::new(d.x, -d.y.abs(), d.z))
        })
        .collect()
}
pub mod traversal;
