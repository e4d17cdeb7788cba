//! Outputs beyond the layouts of `main.rs`: Looking Glass quilts, and views
//! with their `Z` and `disparity` channels (`--depth`).

use std::path::{Path, PathBuf};

use anyhow::{bail, Result};

use twinray::camera::Camera;
use twinray::output::{self, DepthChannels, QuiltSpec, WriteOptions};
use twinray::rig::Rig;
use twinray::{Image, World};

/// The quilt file for `out` (`NAME_qsCxRaA.ext`), checked: format, size
/// limits, directory, a target that may be replaced.
pub fn quilt_target(out: &Path, spec: &QuiltSpec, width: u32, height: u32) -> Result<PathBuf> {
    let path = output::quilt_path(out, spec.layout, width, height);
    let (w, h) = spec.layout.size(width, height);
    if w > u64::from(u32::MAX) || h > u64::from(u32::MAX) {
        bail!("a {w}x{h} quilt is too large");
    }
    output::check_image_target(&path, w, h)?;
    Ok(path)
}

/// Composes the views as a quilt and writes it to `path` (from [`quilt_target`]).
pub fn write_quilt(
    path: &Path,
    spec: &QuiltSpec,
    images: &[Image],
    opts: &WriteOptions,
) -> Result<Vec<PathBuf>> {
    let quilt = output::compose_quilt(images, spec.layout)?;
    output::write_image(path, &quilt, opts)?;
    Ok(vec![path.to_path_buf()])
}

/// `--depth`: every view's channels (a depth pass at every pixel).
pub fn measure_depth(world: &World, camera: &Camera, rig: &Rig) -> Vec<DepthChannels> {
    (0..rig.views.len())
        .map(|v| DepthChannels::measure(world, camera, rig, v))
        .collect()
}

/// `--depth` needs float outputs that hold one view each or all views.
pub fn check_depth_output(out: &Path, separate_or_multiview: bool) -> Result<()> {
    let exr = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !exr || !separate_or_multiview {
        bail!(
            "--depth writes Z and disparity channels into .exr files of --layout separate or \
             multiview: use an .exr output and one of those layouts"
        );
    }
    Ok(())
}

/// Writes the views with their depth channels: one multi-view EXR at `out`,
/// or one EXR per view at the first `images.len()` of `paths` (all or none).
pub fn write_with_depth(
    multiview: Option<&Path>,
    paths: &[PathBuf],
    images: &[Image],
    depth: &[DepthChannels],
    interaxial: f32,
    convergence: Option<f64>,
) -> Result<Vec<PathBuf>> {
    if let Some(out) = multiview {
        let names: Vec<String> = match images.len() {
            2 => vec!["left".into(), "right".into()],
            n => (0..n).map(|i| format!("view{i}")).collect(),
        };
        let views: Vec<(&str, &Image)> = names.iter().map(String::as_str).zip(images).collect();
        output::write_multiview_exr_with_depth(
            out,
            &views,
            depth,
            interaxial,
            convergence.map(|c| c as f32),
        )?;
        return Ok(vec![out.to_path_buf()]);
    }
    if paths.len() < images.len() {
        bail!("{} views but {} output files", images.len(), paths.len());
    }
    let staged = paths
        .iter()
        .zip(images)
        .zip(depth)
        .map(|((p, img), d)| output::stage_exr_with_depth(p, img, d))
        .collect::<twinray::Result<Vec<_>>>()?;
    Ok(output::commit_all(staged)?)
}

/// Memory beyond the renderer's estimate, in bytes: a composed quilt of
/// `quilt_tiles` tiles (float, and its 8-bit copy) and the depth channels of
/// `views` views (two floats a pixel).
pub fn extra_memory(width: u32, height: u32, views: usize, quilt_tiles: usize, depth: bool) -> u64 {
    let pixels = u64::from(width).saturating_mul(u64::from(height));
    let quilt_bytes = pixels
        .saturating_mul(quilt_tiles as u64)
        .saturating_mul(12 + 3);
    let depth_bytes = if depth {
        pixels.saturating_mul(views as u64).saturating_mul(8)
    } else {
        0
    };
    quilt_bytes.saturating_add(depth_bytes)
}
