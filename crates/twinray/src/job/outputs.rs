//! The files of a job: which they are (checked before anything is rendered)
//! and how the rendered views are composed and written to them, all or none.

use std::borrow::Cow;
use std::path::{Path, PathBuf};

use super::spec::{AnaglyphSpec, InterlaceSpec, JobSpec, LayoutSpec, OutputSpec, TonemapSpec};
use super::Message;
use crate::output::{
    self, AnaglyphMethod, DepthChannels, DisplayTransform, InterlaceMode, Layout, QuiltSpec,
    StereoOptions, Tonemap, WriteOptions,
};
use crate::render::ViewStorage;
use crate::rig::Camera;
use crate::rig::Rig;
use crate::{Error, Image, Result, Rgb8Image, Scene, World};

/// Every file a job reads, which no output may replace: the scene file
/// and the files its load read (buffers, textures, material libraries),
/// the environment image, the camera path, and the files read to make the
/// spec (a job file).
pub fn job_inputs(spec: &JobSpec, scene: &Scene) -> Vec<PathBuf> {
    std::iter::once(&spec.scene)
        .chain(&scene.inputs)
        .chain(&spec.studio.env)
        .chain(&spec.animation.path)
        .chain(&spec.read_files)
        .cloned()
        .collect()
}

/// Checks that `out`'s name suits the layout (an MPO's `.mpo`, a multi-view
/// EXR's `.exr`, an image format otherwise).
pub(super) fn check_layout_format(layout: LayoutSpec, out: &Path) -> Result<()> {
    let ext = out
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let refuse = |m: &str| Err(Error::Invalid(m.to_string()));
    match layout {
        LayoutSpec::Mpo if ext != "mpo" => Err(Error::Invalid(format!(
            "--layout mpo writes a .mpo file; got '{}'",
            out.display()
        ))),
        LayoutSpec::Multiview if ext != "exr" => refuse(
            "--layout multiview writes one multi-view OpenEXR file: the output must end in .exr",
        ),
        LayoutSpec::Mpo | LayoutSpec::Multiview => Ok(()),
        _ if ext == "mpo" => refuse("a .mpo output needs --layout mpo"),
        _ => output::ImageFormat::from_path(out).map(|_| ()),
    }
}

/// Whether `out` is a float image (EXR, PFM): written as rendered, linear,
/// without exposure or tone curve.
fn is_float_output(out: &Path) -> bool {
    let ext = out
        .extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default();
    matches!(ext.as_str(), "exr" | "pfm")
}

/// Checks the colour settings: `--srgb` (the old spelling of the default)
/// against `--linear`, the exposure; warns where they cannot apply.
pub(super) fn check_display(o: &OutputSpec) -> Result<Vec<Message>> {
    if o.srgb && o.linear {
        return Err(Error::Invalid(
            "--srgb and --linear contradict each other (sRGB is the default of 8-bit outputs)"
                .into(),
        ));
    }
    if !o.exposure.is_finite() || o.exposure.abs() > 64.0 {
        return Err(Error::Invalid(format!(
            "--exposure must be a number of stops between -64 and 64, got {}",
            o.exposure
        )));
    }
    let mut messages = Vec::new();
    if o.srgb {
        messages.push(Message::note(
            "--srgb is the default of 8-bit outputs now and changes nothing (--linear turns it off)",
        ));
    }
    if is_float_output(&o.path) && (o.exposure != 0.0 || o.tonemap != TonemapSpec::Clamp) {
        messages.push(Message::warning(
            "--exposure and --tonemap apply to 8-bit outputs; float files keep the rendered values",
        ));
    }
    Ok(messages)
}

/// The display transform of 8-bit outputs.
pub(super) fn display_transform(o: &OutputSpec) -> DisplayTransform {
    DisplayTransform {
        exposure: o.exposure,
        tonemap: match o.tonemap {
            TonemapSpec::Clamp => Tonemap::Clamp,
            TonemapSpec::Aces => Tonemap::Aces,
            TonemapSpec::Agx => Tonemap::Agx,
        },
    }
}

/// The views as an 8-bit output shows them: exposure and tone curve
/// applied (before any composition: an anaglyph mixes tone-mapped eyes).
/// The sRGB curve comes at encoding ([`WriteOptions::srgb`]). Without a
/// transform (the default), the views themselves: a copy of 48 views of
/// 420×560 was 135 MB of fresh memory, which the kernel clears first (a
/// tenth of a second on the project's VM).
pub(super) fn displayed<'a>(o: &OutputSpec, images: &'a [Image]) -> Cow<'a, [Image]> {
    let transform = display_transform(o);
    if transform.is_identity() {
        Cow::Borrowed(images)
    } else {
        Cow::Owned(images.iter().map(|i| transform.apply(i)).collect())
    }
}

/// How 8-bit outputs are encoded: sRGB unless `--linear`.
pub(super) fn write_options(o: &OutputSpec) -> WriteOptions {
    WriteOptions { srgb: !o.linear }
}

/// `--depth` needs float outputs that hold one view each or all views.
pub(super) fn check_depth_output(out: &Path, separate_or_multiview: bool) -> Result<()> {
    let exr = out
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("exr"));
    if !exr || !separate_or_multiview {
        return Err(Error::Invalid(
            "--depth writes Z and disparity channels into .exr files of --layout separate or \
             multiview: use an .exr output and one of those layouts"
                .into(),
        ));
    }
    Ok(())
}

/// The stereo layout of the output settings (a quilt is never written as a pair).
pub(super) fn stereo_layout(o: &OutputSpec) -> Layout {
    match o.layout {
        LayoutSpec::Separate | LayoutSpec::Quilt => Layout::Separate,
        LayoutSpec::Sbs => Layout::SideBySide,
        LayoutSpec::Cross => Layout::Cross,
        LayoutSpec::Tb => Layout::TopBottom,
        LayoutSpec::Mpo => Layout::Mpo,
        LayoutSpec::Multiview => Layout::MultiviewExr,
        LayoutSpec::Anaglyph => {
            Layout::Anaglyph(match o.anaglyph.unwrap_or(AnaglyphSpec::Dubois) {
                AnaglyphSpec::Dubois => AnaglyphMethod::Dubois,
                AnaglyphSpec::Color => AnaglyphMethod::Color,
                AnaglyphSpec::Gray => AnaglyphMethod::Gray,
                AnaglyphSpec::GreenMagenta => AnaglyphMethod::GreenMagenta,
                AnaglyphSpec::YellowBlue => AnaglyphMethod::YellowBlue,
            })
        }
        LayoutSpec::Interlace => {
            Layout::Interlace(match o.interlace.unwrap_or(InterlaceSpec::Rows) {
                InterlaceSpec::Rows => InterlaceMode::Rows,
                InterlaceSpec::Columns => InterlaceMode::Columns,
                InterlaceSpec::Checker => InterlaceMode::Checker,
            })
        }
    }
}

/// `NAME_i.ext` beside `out`: view `i` of a set of separate files.
pub fn numbered(out: &Path, i: usize) -> PathBuf {
    let stem = out.file_stem().and_then(|s| s.to_str()).unwrap_or("view");
    let name = match out.extension().and_then(|e| e.to_str()) {
        Some(ext) => format!("{stem}_{i}.{ext}"),
        None => format!("{stem}_{i}"),
    };
    out.with_file_name(name)
}

/// What the writer needs beyond the images: the output settings, the quilt
/// grid, and the rig's interaxial and convergence (for MPO and EXR metadata).
pub(super) struct Targets<'a> {
    pub output: &'a OutputSpec,
    pub quilt: Option<&'a QuiltSpec>,
    pub views: usize,
    pub interaxial: f32,
    pub effective_convergence: Option<f64>,
}

impl Targets<'_> {
    fn write_options(&self) -> WriteOptions {
        write_options(self.output)
    }

    fn stereo_options(&self) -> StereoOptions {
        StereoOptions {
            image: self.write_options(),
            squeeze: self.output.squeeze,
            interaxial_m: f64::from(self.interaxial),
            convergence_m: self.effective_convergence,
        }
    }

    /// The files this render will write, checked before rendering: formats,
    /// size limits, directories, targets that may be replaced, and no output
    /// that is one of `inputs` ([`job_inputs`]) or another output.
    pub fn plan(&self, (width, height): (u32, u32), inputs: &[PathBuf]) -> Result<Vec<PathBuf>> {
        let out = &self.output.path;
        let (w, h) = (u64::from(width), u64::from(height));
        let mut files = if self.views == 1 {
            output::check_image_target(out, w, h)?;
            vec![out.clone()]
        } else if let (LayoutSpec::Quilt, Some(spec)) = (self.output.layout, self.quilt) {
            vec![quilt_target(out, spec, width, height)?]
        } else if self.output.layout == LayoutSpec::Multiview {
            output::check_stereo_targets(
                out,
                Layout::MultiviewExr,
                width,
                height,
                &self.stereo_options(),
            )?
        } else if self.views > 2 {
            let files: Vec<PathBuf> = (0..self.views).map(|i| numbered(out, i)).collect();
            for f in &files {
                output::check_image_target(f, w, h)?;
            }
            files
        } else {
            output::check_stereo_targets(
                out,
                stereo_layout(self.output),
                width,
                height,
                &self.stereo_options(),
            )?
        };
        if let Some(stats) = &self.output.stats {
            output::check_file_target(stats)?;
            files.push(stats.clone());
        }
        let inputs: Vec<&Path> = inputs.iter().map(PathBuf::as_path).collect();
        output::check_distinct(&files, &inputs)?;
        Ok(files)
    }

    /// The images the layout delivers, composed in memory as [`Targets::write`]
    /// would write them (before 8-bit quantisation): one frame for a
    /// side-by-side, cross, top-bottom, anaglyph, interlaced or quilt layout;
    /// the views as they are for separate files, MPO and multi-view EXR.
    pub fn compose(&self, images: &[Image]) -> Result<Vec<Image>> {
        if images.len() < 2 {
            return Ok(images.to_vec());
        }
        if let (LayoutSpec::Quilt, Some(spec)) = (self.output.layout, self.quilt) {
            return Ok(vec![output::compose_quilt(images, spec.layout)?]);
        }
        if images.len() > 2 {
            return Ok(images.to_vec());
        }
        let (left, right) = (&images[0], &images[1]);
        let squeeze = self.output.squeeze;
        let frame = match stereo_layout(self.output) {
            Layout::Separate | Layout::Mpo | Layout::MultiviewExr => return Ok(images.to_vec()),
            Layout::SideBySide => output::side_by_side(left, right, squeeze)?,
            Layout::Cross => output::cross(left, right, squeeze)?,
            Layout::TopBottom => output::top_bottom(left, right, squeeze)?,
            Layout::Anaglyph(method) => output::anaglyph(left, right, method)?,
            Layout::Interlace(mode) => output::interlace(left, right, mode)?,
        };
        Ok(vec![frame])
    }

    /// Writes the images (a set of files: all or none); returns the files
    /// written (`files` from [`Targets::plan`], for the quilt and depth cases).
    pub fn write(
        &self,
        images: &[Image],
        depth: Option<&[DepthChannels]>,
        files: &[PathBuf],
    ) -> Result<Vec<PathBuf>> {
        let out = &self.output.path;
        let multiview = self.output.layout == LayoutSpec::Multiview && images.len() > 1;
        if let Some(depth) = depth {
            return write_with_depth(
                multiview.then_some(out.as_path()),
                files,
                images,
                depth,
                self.interaxial,
                self.effective_convergence,
            );
        }
        // 8-bit outputs: exposure and tone curve before the views are
        // composed (an anaglyph mixes tone-mapped eyes), sRGB when encoded.
        let shown: Cow<[Image]>;
        let images = if multiview || is_float_output(out) {
            images
        } else {
            shown = displayed(self.output, images);
            &shown
        };
        if let (LayoutSpec::Quilt, Some(spec)) = (self.output.layout, self.quilt) {
            output::write_quilt(&files[0], images, spec.layout, &self.write_options())?;
            return Ok(vec![files[0].clone()]);
        }
        let wo = self.write_options();
        if images.len() == 1 {
            output::write_image(out, &images[0], &wo)?;
            return Ok(vec![out.clone()]);
        }
        if multiview {
            let names = view_names(images.len());
            let views: Vec<(&str, &Image)> = names.iter().map(String::as_str).zip(images).collect();
            output::write_multiview_exr(
                out,
                &views,
                self.interaxial,
                self.effective_convergence.map(|c| c as f32),
            )?;
            return Ok(vec![out.clone()]);
        }
        if images.len() > 2 {
            // Separate files, one per view: scene_0.png, scene_1.png, ...
            // encoded first (on the caller's thread pool: 48 PNGs took a
            // fifth of a quilt's wall time on one thread), then put in place
            // together.
            use rayon::prelude::*;
            let staged = images
                .par_iter()
                .enumerate()
                .map(|(i, img)| output::stage_image(&numbered(out, i), img, &wo))
                .collect::<Result<Vec<_>>>()?;
            return output::commit_all(staged);
        }
        output::write_stereo(
            out,
            stereo_layout(self.output),
            &images[0],
            &images[1],
            &self.stereo_options(),
        )
    }

    /// How the views may be kept for these files: as the 8-bit pixels the
    /// files hold where every file is an 8-bit image of views as rendered
    /// (no exposure or tone curve, no depth channels) whose pixels it only
    /// moves: one view a file, a quilt, a pair side by side, crossed,
    /// top-bottom or interlaced; else in floats (squeezed pairs, anaglyphs,
    /// MPO, float files).
    /// The job also keeps floats under a floating window, which masks the
    /// views after the render.
    pub fn storage(&self) -> ViewStorage {
        let o = self.output;
        let eight_bit = output::ImageFormat::from_path(&o.path).is_ok_and(|f| f.is_8_bit());
        let one_view_each = match (o.layout, self.quilt) {
            (LayoutSpec::Quilt, Some(_)) => true,
            (LayoutSpec::Multiview, _) => self.views == 1,
            _ => {
                let layout = stereo_layout(o);
                self.views != 2
                    || layout == Layout::Separate
                    || output::moves_pixels_only(layout, o.squeeze)
            }
        };
        if eight_bit && !o.depth && display_transform(o).is_identity() && one_view_each {
            ViewStorage::Rgb8(self.write_options())
        } else {
            ViewStorage::Float
        }
    }

    /// [`Targets::write`] for views kept as 8-bit pixels (as
    /// [`Targets::storage`] allows): the same files, byte for byte.
    pub fn write_rgb8(&self, views: &[Rgb8Image], files: &[PathBuf]) -> Result<Vec<PathBuf>> {
        if self.storage() == ViewStorage::Float {
            return Err(Error::Invalid(
                "these files are not written from views kept as 8-bit pixels".into(),
            ));
        }
        let out = &self.output.path;
        if let (LayoutSpec::Quilt, Some(spec)) = (self.output.layout, self.quilt) {
            output::write_quilt_rgb8(&files[0], views, spec.layout)?;
            return Ok(vec![files[0].clone()]);
        }
        let layout = stereo_layout(self.output);
        if views.len() == 2 && layout != Layout::Separate {
            let frame = output::pair_frame_rgb8(&views[0], &views[1], layout)?;
            output::stage_rgb8_image(out, &frame)?.commit()?;
            return Ok(vec![out.clone()]);
        }
        let paths: Vec<PathBuf> = match views.len() {
            1 => vec![out.clone()],
            2 => {
                let (l, r) = output::separate_paths(out);
                vec![l, r]
            }
            n => (0..n).map(|i| numbered(out, i)).collect(),
        };
        // Encoded first, on the caller's thread pool, then put in place
        // together, as the float views are.
        use rayon::prelude::*;
        let staged = views
            .par_iter()
            .zip(&paths)
            .map(|(v, p)| output::stage_rgb8_image(p, v))
            .collect::<Result<Vec<_>>>()?;
        output::commit_all(staged)
    }
}

/// The views composed into one picture as the layout shows them (a video
/// frame): one view as it is, a pair side by side, top-bottom, crossed,
/// interlaced or as an anaglyph, or a quilt; with how the eyes are packed.
pub(super) fn compose_frame(
    output: &OutputSpec,
    quilt: Option<&QuiltSpec>,
    images: &[Image],
) -> Result<(Image, crate::video::FramePacking)> {
    use crate::video::FramePacking;
    if let (LayoutSpec::Quilt, Some(spec)) = (output.layout, quilt) {
        return Ok((
            output::compose_quilt(images, spec.layout)?,
            FramePacking::None,
        ));
    }
    match images {
        [one] => Ok((one.clone(), FramePacking::None)),
        [left, right] => {
            let (l, r, squeeze) = (left, right, output.squeeze);
            Ok(match stereo_layout(output) {
                Layout::SideBySide => (output::side_by_side(l, r, squeeze)?, FramePacking::SideBySide),
                Layout::TopBottom => (output::top_bottom(l, r, squeeze)?, FramePacking::TopBottom),
                Layout::Cross => (output::cross(l, r, squeeze)?, FramePacking::None),
                Layout::Anaglyph(m) => (output::anaglyph(l, r, m)?, FramePacking::None),
                Layout::Interlace(m) => (output::interlace(l, r, m)?, FramePacking::None),
                Layout::Separate | Layout::Mpo | Layout::MultiviewExr => {
                    return Err(Error::Invalid(format!(
                        "a video shows one picture a frame: --layout {} is not one (use sbs, tb, anaglyph, cross, interlace or quilt)",
                        output.layout.name()
                    )))
                }
            })
        }
        _ => Err(Error::Invalid(format!(
            "a video of {} views needs --layout quilt",
            images.len()
        ))),
    }
}

/// The views' names in a multi-view EXR: `left`, `right` for a pair.
fn view_names(n: usize) -> Vec<String> {
    match n {
        2 => vec!["left".into(), "right".into()],
        n => (0..n).map(|i| format!("view{i}")).collect(),
    }
}

/// The quilt file for `out` (`NAME_qsCxRaA.ext`), checked: format, size
/// limits, directory, a target that may be replaced.
fn quilt_target(out: &Path, spec: &QuiltSpec, width: u32, height: u32) -> Result<PathBuf> {
    let path = output::quilt_path(out, spec.layout, width, height);
    let (w, h) = spec.layout.size(width, height);
    if w > u64::from(u32::MAX) || h > u64::from(u32::MAX) {
        return Err(Error::Invalid(format!("a {w}x{h} quilt is too large")));
    }
    output::check_image_target(&path, w, h)?;
    Ok(path)
}

/// Every view's depth channels (a depth pass at every pixel).
pub(super) fn measure_depth(world: &World, camera: &Camera, rig: &Rig) -> Vec<DepthChannels> {
    (0..rig.views.len())
        .map(|v| DepthChannels::measure(world, camera, rig, v))
        .collect()
}

/// Writes the views with their depth channels: one multi-view EXR at `out`,
/// or one EXR per view at the first `images.len()` of `paths` (all or none).
fn write_with_depth(
    multiview: Option<&Path>,
    paths: &[PathBuf],
    images: &[Image],
    depth: &[DepthChannels],
    interaxial: f32,
    convergence: Option<f64>,
) -> Result<Vec<PathBuf>> {
    if let Some(out) = multiview {
        let names = view_names(images.len());
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
        return Err(Error::Invalid(format!(
            "{} views but {} output files",
            images.len(),
            paths.len()
        )));
    }
    let staged = paths
        .iter()
        .zip(images)
        .zip(depth)
        .map(|((p, img), d)| output::stage_exr_with_depth(p, img, d))
        .collect::<Result<Vec<_>>>()?;
    output::commit_all(staged)
}

/// The bytes a pixel of a quilt written to `out` takes while it is
/// composed: an image file's 8-bit pixels straight from the views
/// (`output::write_quilt`), a float file's floats, and for a video frame
/// both (it is composed in floats, then made 8-bit).
pub(super) fn quilt_pixel_bytes(out: &Path) -> u64 {
    match output::ImageFormat::from_path(out) {
        Ok(f) if f.is_8_bit() => 3,
        Ok(_) => 12,
        Err(_) => 12 + 3,
    }
}

/// Memory beyond the renderer's estimate, in bytes: a composed quilt of
/// `quilt_tiles` tiles of `quilt_pixel_bytes` a pixel and the depth channels
/// of `views` views (two floats a pixel).
pub(super) fn extra_memory(
    width: u32,
    height: u32,
    views: usize,
    quilt_tiles: usize,
    quilt_pixel_bytes: u64,
    depth: bool,
) -> u64 {
    let pixels = u64::from(width).saturating_mul(u64::from(height));
    let quilt_bytes = pixels
        .saturating_mul(quilt_tiles as u64)
        .saturating_mul(quilt_pixel_bytes);
    let depth_bytes = if depth {
        pixels.saturating_mul(views as u64).saturating_mul(8)
    } else {
        0
    };
    quilt_bytes.saturating_add(depth_bytes)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    /// The default display (no exposure, the clamp) lends the views as they
    /// are; exposure or a tone curve makes new ones.
    #[test]
    fn the_default_display_lends_the_views_and_a_tone_curve_makes_new_ones() {
        let views = vec![Image::filled(3, 2, Color::new(0.25, 2.0, 0.5)); 2];
        let mut spec = OutputSpec::default();
        let shown = displayed(&spec, &views);
        assert!(matches!(shown, Cow::Borrowed(_)));
        assert!(std::ptr::eq(shown.as_ptr(), views.as_ptr()));
        spec.exposure = 1.0;
        let shown = displayed(&spec, &views);
        assert!(matches!(shown, Cow::Owned(_)));
        assert_eq!(shown[1].get(0, 0), Color::new(0.5, 1.0, 1.0));
    }

    /// A quilt's composition takes what its writer holds: 8-bit pixels for
    /// an image file, floats for a float file, both for a video's frame.
    #[test]
    fn a_quilts_memory_is_counted_as_its_writer_holds_it() {
        let bytes = |name: &str| quilt_pixel_bytes(Path::new(name));
        assert_eq!(
            [
                bytes("q.png"),
                bytes("q.JPG"),
                bytes("q.exr"),
                bytes("q.pfm"),
                bytes("q.mp4")
            ],
            [3, 3, 12, 12, 15]
        );
        assert_eq!(extra_memory(10, 10, 48, 48, 3, false), 10 * 10 * 48 * 3);
        assert_eq!(extra_memory(10, 10, 2, 0, 15, true), 10 * 10 * 2 * 8);
    }
}
