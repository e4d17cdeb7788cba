//! A job's panorama (`--projection`): its checks, its image size, and its
//! pair of eyes (`rig::panorama_rig`).

use super::check::invalid;
use super::spec::{JobSpec, LayoutSpec, MethodName};
use super::stages::Plan;
use crate::output::layouts::separate_paths;
use crate::output::panorama_meta::{tag_jpeg_file, GPano};
use crate::render::MAX_PANORAMA_VIEWS;
use crate::rig::choice::Interaxial;
use crate::rig::panorama_rig::{self, PanoramaRig, UnitsKnown, DEFAULT_ANGULAR_BUDGET_DEG};
use crate::rig::{Camera, PoleMerge, Projection, ProjectionName, Rig, View};
use crate::world::World;
use crate::Result;
use std::path::Path;

/// The projection a spec asks for, its flags checked against the rest.
pub(super) fn check(spec: &JobSpec, views: usize) -> Result<Projection> {
    let (camera, rig, method) = (&spec.camera, &spec.rig, &spec.method);
    let name = camera.projection;
    let merge = match camera.pole_merge {
        None => PoleMerge::default(),
        Some([from, to]) => {
            if name != ProjectionName::Ods {
                return Err(invalid("--pole-merge applies to --projection ods"));
            }
            if !(0.0..=90.0).contains(&from) || !(from..=90.0).contains(&to) {
                return Err(invalid(format!(
                    "--pole-merge {from},{to}: two latitudes in degrees, 0 <= FROM <= TO <= 90"
                )));
            }
            PoleMerge {
                from_deg: from,
                to_deg: to,
            }
        }
    };
    let projection = name.projection(merge);
    if !projection.is_panorama() {
        if rig.angular_budget.is_some() || rig.units.is_some() {
            return Err(invalid(
                "--angular-budget and --units apply to panoramas (--projection ods, vr180, vr180-fisheye)",
            ));
        }
        return Ok(projection);
    }
    if let Some(b) = rig.angular_budget {
        if !(b.is_finite() && b > 0.0 && b <= 10.0) {
            return Err(invalid(format!(
                "--angular-budget {b}: degrees, more than 0 and at most 10"
            )));
        }
    }
    if views > MAX_PANORAMA_VIEWS {
        return Err(invalid(format!(
            "--projection {name} renders one view or a stereo pair, not {views}"
        )));
    }
    if views == 2 && projection == Projection::Equirect {
        return Err(invalid(
            "--projection equirect is one eye's 360°: --projection ods for a stereo 360°",
        ));
    }
    if views < 2 && (rig.angular_budget.is_some() || rig.units.is_some()) {
        return Err(invalid(
            "--angular-budget and --units choose a pair's IPD: add --stereo",
        ));
    }
    let flat_only = [
        (
            rig.convergence.is_some(),
            "--convergence (a panorama's eyes converge at infinity)",
        ),
        (
            rig.depth_budget.is_some(),
            "--depth-budget (a panorama's is --angular-budget)",
        ),
        (rig.view_cone.is_some(), "--view-cone"),
        (rig.floating_window, "--floating-window"),
        (
            camera.fov.is_some(),
            "--fov (a panorama's is its projection's)",
        ),
        (
            method.name == MethodName::Fast,
            "--fast (the twin method is exact and as fast)",
        ),
        (
            method.merge_secondary || method.reproject.is_some() || method.cut.is_some(),
            "the paper's techniques (--merge-secondary, --reproject, --cut-*)",
        ),
        (
            matches!(
                spec.output.layout,
                LayoutSpec::Quilt | LayoutSpec::Interlace | LayoutSpec::Multiview
            ),
            "--layout quilt, interlace or multiview",
        ),
        (spec.output.squeeze, "--squeeze"),
        (spec.output.depth, "--depth"),
    ];
    if let Some((_, what)) = flat_only.iter().find(|(given, _)| *given) {
        return Err(invalid(format!("{what}: not with --projection {name}")));
    }
    Ok(projection)
}

/// A panorama's image size where none is given: the scene's height, and
/// twice it across for 360°.
pub(super) fn default_size(projection: Projection, height: u32) -> (u32, u32) {
    let (across, _) = projection.span_deg();
    match across > 180.0 {
        true => (height.saturating_mul(2), height),
        false => (height, height),
    }
}

/// The eyes of a panorama's pair, `ipd` apart (given or fitted, see
/// `panorama_rig::settle`), parallel, with the disparity report.
pub(super) fn pair(
    spec: &JobSpec,
    interaxial: Option<Interaxial>,
    world: &World,
    camera: &Camera,
    at_distance: f64,
) -> Result<(Rig, PanoramaRig)> {
    let given = match interaxial {
        Some(Interaxial::Distance(b)) => Some(f64::from(b)),
        Some(Interaxial::Auto) | None => None,
    };
    let units = match spec.rig.units {
        Some(u) => UnitsKnown::Given(u),
        None => match spec.scene.extension().and_then(|e| e.to_str()) {
            Some(e) if e.eq_ignore_ascii_case("gltf") || e.eq_ignore_ascii_case("glb") => {
                UnitsKnown::Guessed(panorama_rig::SceneUnits::M)
            }
            _ => UnitsKnown::Unknown,
        },
    };
    let budget = spec
        .rig
        .angular_budget
        .unwrap_or(DEFAULT_ANGULAR_BUDGET_DEG);
    let settled = panorama_rig::settle(world, camera, given, budget, units, at_distance);
    let half = (settled.ipd * 0.5) as f32;
    if !(half.is_finite() && half > 0.0) {
        return Err(invalid(format!(
            "a panorama's IPD must be a distance > 0, got {}",
            settled.ipd
        )));
    }
    let rig = Rig {
        views: vec![
            View {
                offset: -half,
                shift: 0,
            },
            View {
                offset: half,
                shift: 0,
            },
        ],
        convergence: None,
        effective_convergence: None,
    };
    Ok((rig, settled))
}

/// Gives a panorama's JPEG files the GPano XMP photo viewers read: each
/// eye's file of `--layout separate` (or the one file of one eye), the
/// left eye's carrying the right eye's JPEG (Google's VR180 and Cardboard
/// Camera photos). Fisheyes, and layouts that pack both eyes in one
/// picture, are not equirectangular panoramas: their files are left as
/// they are.
pub(super) fn tag_jpegs(spec: &JobSpec, plan: &Plan, views: usize) -> Result<()> {
    let projection = plan.camera.projection;
    let out = &spec.output;
    let is_jpeg = |p: &Path| {
        p.extension()
            .and_then(|e| e.to_str())
            .is_some_and(|e| e.eq_ignore_ascii_case("jpg") || e.eq_ignore_ascii_case("jpeg"))
    };
    if out.layout != LayoutSpec::Separate || !is_jpeg(&out.path) {
        return Ok(());
    }
    let (w, h) = (plan.width, plan.rows.len() as u32);
    let pano = match projection {
        Projection::Equirect | Projection::Ods(_) if spec.tile.is_none() => GPano::full(w, h),
        Projection::Vr180 if spec.tile.is_none() => GPano::half(w, h),
        _ => return Ok(()),
    };
    if views == 1 {
        return tag_jpeg_file(&out.path, &pano, None);
    }
    // The right eye first: the left eye carries it as written.
    let (left, right) = separate_paths(&out.path);
    tag_jpeg_file(&right, &pano, None)?;
    tag_jpeg_file(&left, &pano, Some(&right))
}
