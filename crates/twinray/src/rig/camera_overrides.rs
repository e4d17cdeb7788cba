//! Choosing the viewpoint of a render: one of the file's cameras by name or
//! index (`--camera`), then the command line's `--from/--at/--up/--fov` on top.
//! A file without a camera has been framed by its loader (`Scene::frame_bounds`).

use crate::error::{Error, Result};
use crate::math::Vec3;
use crate::scene::{AngleSpan, Scene, Viewpoint};

/// What the command line asks of the viewpoint; `None` keeps the file's.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct CameraOverrides {
    /// A camera of the file: its name, or its index among the file's cameras.
    pub camera: Option<String>,
    pub from: Option<Vec3>,
    pub at: Option<Vec3>,
    pub up: Option<Vec3>,
    /// Vertical field of view in degrees, top image edge to bottom edge.
    pub fov_deg: Option<f32>,
}

/// Applies `o` to `scene.viewpoint`, checking that the result is a camera.
pub fn apply(scene: &mut Scene, o: &CameraOverrides) -> Result<()> {
    let (viewpoint, given) = resolve(scene, o)?;
    scene.viewpoint = viewpoint;
    scene.viewpoint_given = given;
    Ok(())
}

/// The viewpoint `o` asks of `scene` (its current viewpoint, or one of its
/// cameras, with the overrides on top), checked, and whether it is one the
/// file or the overrides chose (rather than the loader's framing). The scene
/// is left as it is, so one loaded scene serves many viewpoints.
pub fn resolve(scene: &Scene, o: &CameraOverrides) -> Result<(Viewpoint, bool)> {
    let mut given = scene.viewpoint_given;
    let mut vp = scene.viewpoint.clone();
    if let Some(wanted) = &o.camera {
        let names: Vec<&str> = scene.cameras.iter().map(|c| c.name.as_str()).collect();
        if names.is_empty() {
            return Err(Error::Invalid(format!(
                "--camera {wanted}: the scene has no cameras"
            )));
        }
        let found = scene
            .cameras
            .iter()
            .position(|c| c.name == *wanted)
            .or_else(|| wanted.parse::<usize>().ok().filter(|&i| i < names.len()));
        let Some(i) = found else {
            return Err(Error::Invalid(format!(
                "--camera {wanted}: no such camera; the scene has {} ({})",
                names.len(),
                names
                    .iter()
                    .enumerate()
                    .map(|(i, n)| format!("{i}: '{n}'"))
                    .collect::<Vec<_>>()
                    .join(", ")
            )));
        };
        vp = scene.cameras[i].viewpoint.clone();
        given = true;
    }
    for (name, v) in [("--from", o.from), ("--at", o.at), ("--up", o.up)] {
        if v.is_some_and(|v| !v.is_finite()) {
            return Err(Error::Invalid(format!("{name} must be finite numbers")));
        }
    }
    if let Some(from) = o.from {
        vp.from = from;
    }
    if let Some(at) = o.at {
        vp.at = at;
    }
    if let Some(up) = o.up {
        vp.up = up;
    }
    if let Some(fov) = o.fov_deg {
        if !(fov > 0.0 && fov < 180.0) {
            return Err(Error::Invalid(format!(
                "--fov must be an angle between 0 and 180 degrees, got {fov}"
            )));
        }
        vp.angle_deg = fov;
        vp.angle_span = AngleSpan::ImageHeight;
    }
    let forward = vp.at - vp.from;
    if forward.length().is_nan() || forward.length() <= 0.0 {
        return Err(Error::Invalid(
            "the camera's position (--from) and target (--at) are the same point".into(),
        ));
    }
    if forward
        .normalize()
        .cross(vp.up.normalize_or_zero())
        .length()
        < 1e-6
    {
        return Err(Error::Invalid(
            "the camera's up direction (--up) is zero or parallel to the viewing direction".into(),
        ));
    }
    Ok((vp, given))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{NamedCamera, Viewpoint};

    fn scene_with_cameras() -> Scene {
        let mut s = Scene::new();
        for (name, x) in [("left", -1.0), ("right", 1.0)] {
            s.cameras.push(NamedCamera {
                name: name.into(),
                viewpoint: Viewpoint {
                    from: Vec3::new(x, 0.0, 5.0),
                    ..Viewpoint::default()
                },
            });
        }
        s.viewpoint = s.cameras[0].viewpoint.clone();
        s
    }

    #[test]
    fn camera_by_name_or_index() {
        let mut s = scene_with_cameras();
        let by = |c: &str| CameraOverrides {
            camera: Some(c.into()),
            ..CameraOverrides::default()
        };
        apply(&mut s, &by("right")).unwrap();
        assert_eq!(s.viewpoint.from.x, 1.0);
        apply(&mut s, &by("0")).unwrap();
        assert_eq!(s.viewpoint.from.x, -1.0);
        let e = apply(&mut s, &by("2")).unwrap_err().to_string();
        assert!(e.contains("0: 'left', 1: 'right'"), "{e}");
        let e = apply(&mut Scene::new(), &by("x")).unwrap_err().to_string();
        assert!(e.contains("no cameras"), "{e}");
    }

    #[test]
    fn overrides_and_their_checks() {
        let mut s = scene_with_cameras();
        let o = CameraOverrides {
            from: Some(Vec3::new(0.0, 0.0, 10.0)),
            fov_deg: Some(30.0),
            ..CameraOverrides::default()
        };
        apply(&mut s, &o).unwrap();
        assert_eq!(s.viewpoint.from.z, 10.0);
        assert_eq!(s.viewpoint.angle_span, AngleSpan::ImageHeight);
        for bad in [
            CameraOverrides {
                at: Some(Vec3::new(-1.0, 0.0, 5.0)),
                ..CameraOverrides::default()
            },
            CameraOverrides {
                up: Some(Vec3::new(1.0, 0.0, -5.0)),
                ..CameraOverrides::default()
            },
            CameraOverrides {
                fov_deg: Some(180.0),
                ..CameraOverrides::default()
            },
        ] {
            assert!(apply(&mut scene_with_cameras(), &bad).is_err(), "{bad:?}");
        }
    }
}
