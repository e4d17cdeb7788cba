//! Depth and disparity as OpenEXR channels, for compositing and checking.
//!
//! Beside a view's `R`, `G`, `B`, two 32-bit float channels:
//! * `Z`: the camera depth of the surface seen at the pixel centre, along the
//!   view direction, in scene units; `+inf` where nothing is hit (the depth
//!   pass of `depth.rs` at every pixel);
//! * `disparity`: where that point lies in the neighbouring view, minus the
//!   pixel's column, for the view to the right (`x_{v+1} − x_v`; for the
//!   rightmost view, towards its left neighbour, `x_v − x_{v−1}`), in pixels:
//!   negative in front of the screen, positive behind it. Where nothing is hit
//!   it is the disparity of infinity (the convergence shift).
//!
//! In a multi-view file the channels of a view other than the first carry its
//! name as prefix (`right.Z`), as the colour channels do; a single-view file
//! has plain `R G B Z disparity`.

use std::path::Path;

use exr::prelude::{
    AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes, SmallVec, Text,
    WritableImage,
};

use crate::output::atomic::{stage, Staged};
use crate::output::check_image;
use crate::output::encode::exr_failure;
use crate::rig::depth_pass::depth_pass;
use crate::rig::pair_disparity;
use crate::rig::Camera;
use crate::rig::Rig;
use crate::world::World;
use crate::{Error, Image, Result};

/// One view's `Z` and `disparity`, row-major like its image.
#[derive(Clone, Debug, PartialEq)]
pub struct DepthChannels {
    pub z: Vec<f32>,
    pub disparity: Vec<f32>,
}

impl DepthChannels {
    /// The channels of view `view` of `rig`: a depth pass at every pixel.
    pub fn measure(world: &World, camera: &Camera, rig: &Rig, view: usize) -> DepthChannels {
        let n = rig.views.len();
        let v = rig.views[view.min(n.saturating_sub(1))];
        let pass = depth_pass(world, camera, v, 1);
        // The neighbour pair: this view and the next, or the last two.
        let pair = if n < 2 {
            None
        } else if view + 1 < n {
            Some((rig.views[view], rig.views[view + 1]))
        } else {
            Some((rig.views[n - 2], rig.views[n - 1]))
        };
        let disparity = pass
            .depth
            .iter()
            .map(|&z| match pair {
                Some((a, b)) => pair_disparity(camera, a, b, f64::from(z)) as f32,
                None => 0.0,
            })
            .collect();
        DepthChannels {
            z: pass.depth,
            disparity,
        }
    }

    /// The channels by name.
    pub fn named(&self) -> [(&'static str, &[f32]); 2] {
        [("Z", &self.z), ("disparity", &self.disparity)]
    }

    /// Both channels have the size of `img`.
    pub(crate) fn check(&self, img: &Image, what: &str) -> Result<()> {
        let pixels = img.pixels.len();
        if self.z.len() != pixels || self.disparity.len() != pixels {
            return Err(Error::Invalid(format!(
                "{what}: depth channels of {} and {} values for {pixels} pixels",
                self.z.len(),
                self.disparity.len()
            )));
        }
        Ok(())
    }
}

/// Encodes `img` with its `Z` and `disparity` channels as a single-view EXR
/// for `path`, to be put in place by [`commit_all`](crate::output::commit_all).
pub fn stage_exr_with_depth(path: &Path, img: &Image, depth: &DepthChannels) -> Result<Staged> {
    check_image(img, "image")?;
    depth.check(img, "image")?;
    let text = |s: &str| {
        Text::new_or_none(s)
            .ok_or_else(|| Error::Invalid(format!("'{s}' cannot be stored in an EXR header")))
    };
    let mut channels = SmallVec::<[AnyChannel<FlatSamples>; 4]>::new();
    for (name, pick) in [("R", 0), ("G", 1), ("B", 2)] {
        let samples = img.pixels.iter().map(|c| c[pick]).collect();
        channels.push(AnyChannel::new(text(name)?, FlatSamples::F32(samples)));
    }
    for (name, samples) in depth.named() {
        channels.push(AnyChannel::new(
            text(name)?,
            FlatSamples::F32(samples.to_vec()),
        ));
    }
    let layer = Layer::new(
        (img.width as usize, img.height as usize),
        LayerAttributes::default(),
        Encoding::FAST_LOSSLESS,
        AnyChannels::sort(channels),
    );
    let image = exr::prelude::Image::from_layer(layer);
    stage(path, |w| image.write().to_buffered(w).map_err(exr_failure))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Color;

    fn channel(path: &Path, name: &str) -> Vec<f32> {
        let img = crate::output::multiview_exr::tests::read_back(path);
        crate::output::multiview_exr::tests::channel(&img, name)
    }

    #[test]
    fn depth_and_disparity_sit_beside_the_colours() {
        let dir = tempfile::tempdir().unwrap();
        let img = Image::filled(3, 2, Color::new(0.1, 0.2, 0.3));
        let depth = DepthChannels {
            z: vec![1.0, 2.0, 3.0, 4.0, 5.0, f32::INFINITY],
            disparity: vec![-1.0, 0.0, 1.0, 2.0, 3.0, 4.0],
        };
        let single = dir.path().join("one.exr");
        stage_exr_with_depth(&single, &img, &depth)
            .unwrap()
            .commit()
            .unwrap();
        assert_eq!(channel(&single, "Z"), depth.z);
        assert_eq!(channel(&single, "disparity"), depth.disparity);
        assert_eq!(crate::output::read_image(&single).unwrap(), img);

        let multi = dir.path().join("pair.exr");
        let other = DepthChannels {
            z: vec![9.0; 6],
            disparity: vec![-9.0; 6],
        };
        crate::output::write_multiview_exr_with_depth(
            &multi,
            &[("left", &img), ("right", &img)],
            &[depth.clone(), other.clone()],
            0.1,
            None,
        )
        .unwrap();
        assert_eq!(channel(&multi, "Z"), depth.z);
        assert_eq!(channel(&multi, "right.Z"), other.z);
        assert_eq!(channel(&multi, "right.disparity"), other.disparity);

        let short = DepthChannels {
            z: vec![1.0],
            disparity: vec![1.0],
        };
        assert!(stage_exr_with_depth(&dir.path().join("bad.exr"), &img, &short).is_err());
        assert!(!dir.path().join("bad.exr").exists());
    }
}
