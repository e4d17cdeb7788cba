//! Camera motion over a shot: a turntable about the `at` point (`--orbit`)
//! or keyframes of from/at/up/fov read from a file (`--path`) and
//! interpolated by a Catmull-Rom spline.
//!
//! Path files have one keyframe a line: the frame number, then `from X,Y,Z`
//! and `at X,Y,Z` and optionally `up X,Y,Z` and `fov DEGREES`, in any order;
//! `#` starts a comment. A key left out of every keyframe keeps the scene's
//! value. Frames before the first keyframe or after the last hold it.

use std::path::{Path, PathBuf};

use crate::math::Vec3;
use crate::scene::Viewpoint;
use crate::{Error, Result};

/// The camera of one frame: what it overrides of the scene's.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FrameCamera {
    pub from: Option<Vec3>,
    pub at: Option<Vec3>,
    pub up: Option<Vec3>,
    pub fov: Option<f32>,
}

/// How the camera moves.
#[derive(Clone, Debug, PartialEq)]
pub enum Motion {
    /// The spec's camera in every frame.
    Still,
    /// `from` turned about the `up` axis through `at`, by `degrees` over the
    /// shot: frame `i` of `n` by `degrees * i / n` (360 loops seamlessly).
    Orbit { degrees: f64 },
    /// Keyframes, interpolated.
    Path(CameraPath),
}

impl Motion {
    /// The camera of frame `index` of `count` (0-based within the shot;
    /// `frame` is its number, for keyframe times), given the scene's
    /// viewpoint with the spec's overrides.
    pub fn camera(&self, base: &Viewpoint, frame: u32, index: u32, count: u32) -> FrameCamera {
        match self {
            Motion::Still => FrameCamera::default(),
            Motion::Orbit { degrees } => FrameCamera {
                from: Some(orbit(
                    base,
                    degrees * f64::from(index) / f64::from(count.max(1)),
                )),
                ..FrameCamera::default()
            },
            Motion::Path(p) => p.at(f64::from(frame)),
        }
    }
}

/// `base.from` turned by `degrees` about the axis `base.up` through `base.at`
/// (counter-clockwise seen from above), in double precision.
pub fn orbit(base: &Viewpoint, degrees: f64) -> Vec3 {
    let d = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
    let (p, c, u) = (d(base.from), d(base.at), d(base.up));
    let len = (u[0] * u[0] + u[1] * u[1] + u[2] * u[2]).sqrt();
    let k = [u[0] / len, u[1] / len, u[2] / len];
    let v = [p[0] - c[0], p[1] - c[1], p[2] - c[2]];
    let (s, co) = degrees.to_radians().sin_cos();
    let kv = k[0] * v[0] + k[1] * v[1] + k[2] * v[2];
    let cross = [
        k[1] * v[2] - k[2] * v[1],
        k[2] * v[0] - k[0] * v[2],
        k[0] * v[1] - k[1] * v[0],
    ];
    // Rodrigues: v cos + (k x v) sin + k (k.v)(1 - cos).
    let r: Vec<f64> = (0..3)
        .map(|i| c[i] + v[i] * co + cross[i] * s + k[i] * kv * (1.0 - co))
        .collect();
    Vec3::new(r[0] as f32, r[1] as f32, r[2] as f32)
}

/// One keyframe of a path file.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Keyframe {
    pub frame: f64,
    pub from: Vec3,
    pub at: Vec3,
    pub up: Option<Vec3>,
    pub fov: Option<f32>,
}

/// Keyframes in increasing frame order.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraPath {
    pub file: PathBuf,
    pub keys: Vec<Keyframe>,
}

impl CameraPath {
    /// Reads a path file (see the module documentation); errors name the file and line.
    pub fn read(path: &Path) -> Result<CameraPath> {
        let text = crate::loaders::files::read_user_text(path, "--path")?;
        CameraPath::parse(&text, path)
    }

    /// Parses the text of a path file named `file`.
    pub fn parse(text: &str, file: &Path) -> Result<CameraPath> {
        let mut keys: Vec<Keyframe> = Vec::new();
        let at_line = |n: usize, m: String| Error::Invalid(format!("{}:{n}: {m}", file.display()));
        for (i, line) in text.lines().enumerate() {
            let n = i + 1;
            let line = line.split('#').next().unwrap_or("").trim();
            if line.is_empty() {
                continue;
            }
            let key = parse_keyframe(line).map_err(|m| at_line(n, m))?;
            if let Some(prev) = keys.last() {
                if key.frame <= prev.frame {
                    return Err(at_line(
                        n,
                        format!(
                            "keyframe {} after keyframe {}: frames must increase",
                            key.frame, prev.frame
                        ),
                    ));
                }
                if key.up.is_some() != prev.up.is_some() || key.fov.is_some() != prev.fov.is_some()
                {
                    return Err(at_line(
                        n,
                        "every keyframe gives the same keys (up and fov on all or none)".into(),
                    ));
                }
            }
            keys.push(key);
        }
        if keys.is_empty() {
            return Err(Error::Invalid(format!(
                "{}: no keyframes (lines like: 0 from 0,1,5 at 0,0,0 up 0,1,0 fov 40)",
                file.display()
            )));
        }
        Ok(CameraPath {
            file: file.to_path_buf(),
            keys,
        })
    }

    /// The camera at `frame`: a uniform Catmull-Rom spline
    /// through the keyframes, each segment parameterised by its frames; the
    /// end tangents mirror the neighbouring segment, so keyframes on a line
    /// are interpolated along it.
    pub fn at(&self, frame: f64) -> FrameCamera {
        let keys = &self.keys;
        let last = keys.len() - 1;
        let (i, t) = match keys.iter().rposition(|k| k.frame <= frame) {
            None => (0, 0.0),
            Some(i) if i == last => (last, 0.0),
            Some(i) => (
                i,
                (frame - keys[i].frame) / (keys[i + 1].frame - keys[i].frame),
            ),
        };
        if t == 0.0 {
            let k = keys[i];
            return FrameCamera {
                from: Some(k.from),
                at: Some(k.at),
                up: k.up,
                fov: k.fov,
            };
        }
        let spline = |get: &dyn Fn(&Keyframe) -> [f64; 3]| -> [f64; 3] {
            let p1 = get(&keys[i]);
            let p2 = get(&keys[i + 1]);
            let p0 = if i > 0 {
                get(&keys[i - 1])
            } else {
                std::array::from_fn(|c| 2.0 * p1[c] - p2[c])
            };
            let p3 = if i + 2 <= last {
                get(&keys[i + 2])
            } else {
                std::array::from_fn(|c| 2.0 * p2[c] - p1[c])
            };
            std::array::from_fn(|c| catmull_rom(p0[c], p1[c], p2[c], p3[c], t))
        };
        let d = |v: Vec3| [f64::from(v.x), f64::from(v.y), f64::from(v.z)];
        let v = |a: [f64; 3]| Vec3::new(a[0] as f32, a[1] as f32, a[2] as f32);
        FrameCamera {
            from: Some(v(spline(&|k| d(k.from)))),
            at: Some(v(spline(&|k| d(k.at)))),
            up: keys[i]
                .up
                .map(|_| v(spline(&|k| d(k.up.unwrap_or(Vec3::Y))))),
            fov: keys[i]
                .fov
                .map(|_| spline(&|k| [f64::from(k.fov.unwrap_or(0.0)); 3])[0] as f32),
        }
    }
}

/// The uniform Catmull-Rom spline through `p1` (t = 0) and `p2` (t = 1).
pub fn catmull_rom(p0: f64, p1: f64, p2: f64, p3: f64, t: f64) -> f64 {
    let (t2, t3) = (t * t, t * t * t);
    0.5 * (2.0 * p1
        + (p2 - p0) * t
        + (2.0 * p0 - 5.0 * p1 + 4.0 * p2 - p3) * t2
        + (3.0 * p1 - p0 - 3.0 * p2 + p3) * t3)
}

fn parse_keyframe(line: &str) -> std::result::Result<Keyframe, String> {
    let mut words = line.split_whitespace();
    let first = words.next().unwrap_or("");
    let frame: f64 = first
        .parse()
        .ok()
        .filter(|f: &f64| f.is_finite())
        .ok_or_else(|| format!("'{first}' is not a frame number (a line starts with one)"))?;
    let (mut from, mut at, mut up, mut fov) = (None, None, None, None);
    while let Some(key) = words.next() {
        let value = words
            .next()
            .ok_or_else(|| format!("'{key}' needs a value"))?;
        match key {
            "from" => from = Some(parse_vec3(value)?),
            "at" => at = Some(parse_vec3(value)?),
            "up" => up = Some(parse_vec3(value)?),
            "fov" => {
                let f: f32 = value
                    .parse()
                    .map_err(|_| format!("fov '{value}' is not a number"))?;
                if !(f > 0.0 && f < 180.0) {
                    return Err(format!("fov {f} is not between 0 and 180 degrees"));
                }
                fov = Some(f);
            }
            other => {
                return Err(format!(
                    "'{other}' is not a keyframe key (from, at, up, fov)"
                ))
            }
        }
    }
    match (from, at) {
        (Some(from), Some(at)) => Ok(Keyframe {
            frame,
            from,
            at,
            up,
            fov,
        }),
        _ => Err("a keyframe needs 'from X,Y,Z' and 'at X,Y,Z'".into()),
    }
}

fn parse_vec3(s: &str) -> std::result::Result<Vec3, String> {
    let n: Vec<f32> = s
        .split(',')
        .map(|p| p.trim().parse::<f32>())
        .collect::<std::result::Result<_, _>>()
        .map_err(|_| format!("'{s}' is not X,Y,Z"))?;
    match n[..] {
        [x, y, z] if n.iter().all(|v| v.is_finite()) => Ok(Vec3::new(x, y, z)),
        _ => Err(format!("'{s}' is not X,Y,Z (three finite numbers)")),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn viewpoint(from: Vec3, at: Vec3, up: Vec3) -> Viewpoint {
        Viewpoint {
            from,
            at,
            up,
            ..Viewpoint::default()
        }
    }

    #[test]
    fn an_orbit_turns_about_up_through_at() {
        let vp = viewpoint(Vec3::new(1.0, 5.0, 4.0), Vec3::new(1.0, 2.0, 0.0), Vec3::Y);
        // Radius 4 in the xz-plane about (1, *, 0), height kept.
        let close = |a: Vec3, b: Vec3| (a - b).length() < 1e-5;
        assert!(close(orbit(&vp, 0.0), vp.from));
        assert!(close(orbit(&vp, 90.0), Vec3::new(5.0, 5.0, 0.0)));
        assert!(close(orbit(&vp, 180.0), Vec3::new(1.0, 5.0, -4.0)));
        assert!(close(orbit(&vp, 270.0), Vec3::new(-3.0, 5.0, 0.0)));
        let m = Motion::Orbit { degrees: 360.0 };
        let f = m.camera(&vp, 10, 2, 8).from.unwrap();
        assert!(close(f, Vec3::new(5.0, 5.0, 0.0)), "{f}");
    }

    #[test]
    fn catmull_rom_passes_through_keys_and_matches_hand_values() {
        let text = "# a path\n0 from 0,0,0 at 0,0,-1 fov 40\n10 from 10,0,0 at 0,0,-1 fov 60\n20 from 10,10,0 at 0,0,-1 fov 40\n30 from 0,10,0 at 0,0,-1 fov 40\n";
        let p = CameraPath::parse(text, Path::new("p.txt")).unwrap();
        assert_eq!(p.at(10.0).from, Some(Vec3::new(10.0, 0.0, 0.0)));
        assert_eq!(p.at(-5.0).from, Some(Vec3::new(0.0, 0.0, 0.0)));
        assert_eq!(p.at(99.0).from, Some(Vec3::new(0.0, 10.0, 0.0)));
        // Midpoint of the middle segment: (-P0 + 9 P1 + 9 P2 - P3) / 16.
        let mid = p.at(15.0).from.unwrap();
        let x = (-0.0 + 9.0 * 10.0 + 9.0 * 10.0 - 0.0) / 16.0;
        let y = (-0.0 + 9.0 * 0.0 + 9.0 * 10.0 - 10.0) / 16.0;
        assert!((mid - Vec3::new(x, y, 0.0)).length() < 1e-5, "{mid}");
        // First segment, mirrored start tangent P0 = 2 P1 - P2 = (-10, 0, 0).
        let q = p.at(5.0).from.unwrap();
        let qx = (10.0 + 9.0 * 0.0 + 9.0 * 10.0 - 10.0) / 16.0;
        let qy = (0.0 + 0.0 + 0.0 - 10.0) / 16.0;
        assert!((q - Vec3::new(qx, qy, 0.0)).length() < 1e-5, "{q}");
        let fov = p.at(15.0).fov.unwrap();
        assert!((fov - (-40.0 + 9.0 * 60.0 + 9.0 * 40.0 - 40.0) / 16.0).abs() < 1e-4);
    }

    #[test]
    fn path_errors_name_file_and_line() {
        let bad = [
            (
                "0 from 0,0,0 at 1,0,0\n\n5 fromm 1,1,1 at 0,0,0\n",
                "p.txt:3:",
                "fromm",
            ),
            (
                "0 from 0,0,0 at 1,0,0\n0 from 1,0,0 at 2,0,0\n",
                "p.txt:2:",
                "increase",
            ),
            ("x from 0,0,0 at 1,0,0\n", "p.txt:1:", "frame number"),
            ("0 from 0,0 at 1,0,0\n", "p.txt:1:", "X,Y,Z"),
            ("0 from 0,0,0\n", "p.txt:1:", "'at"),
            ("0 from 0,0,0 at 1,0,0 fov 200\n", "p.txt:1:", "fov"),
            (
                "0 from 0,0,0 at 1,0,0 fov 30\n4 from 0,0,0 at 1,0,0\n",
                "p.txt:2:",
                "same keys",
            ),
            ("# nothing\n", "p.txt:", "no keyframes"),
        ];
        for (text, at, what) in bad {
            let e = CameraPath::parse(text, Path::new("p.txt"))
                .unwrap_err()
                .to_string();
            assert!(e.contains(at) && e.contains(what), "{text:?}: {e}");
        }
    }
}
