//! How a render hands back its views: in floats, or as the 8-bit pixels of
//! the files that will hold them.

use crate::image::{Image, Rgb8Image};
use crate::math::Color;
use crate::render::counts::TraceCounts;
use crate::render::sampler::RowColors;

pub struct RenderOutput {
    /// One image per view of the rig, in rig order; empty where the views
    /// were kept as 8-bit pixels (`rgb8`).
    pub images: Vec<Image>,
    /// The views as 8-bit pixels, in rig order, when [`ViewStorage::Rgb8`]
    /// was asked for and the sampling is not the SPD's corners (which
    /// gives `images`); else empty.
    pub rgb8: Vec<Rgb8Image>,
    pub counts: TraceCounts,
    pub seconds: f64,
    /// Samples (eye rays) per view: under adaptive sampling, where each
    /// view refines its own pixels, the mean over the views.
    pub samples_per_view: u64,
    /// Most eye samples one pixel's colour came from.
    pub max_samples_per_pixel: u32,
    /// Pixels the adaptive sampling refined, the mean over the views (0 for
    /// the other samplings).
    pub refined_pixels: u64,
}

/// How a render hands back its views.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ViewStorage {
    /// Linear float colours ([`RenderOutput::images`]).
    #[default]
    Float,
    /// The bytes an 8-bit file written with these options holds, from the
    /// colours clamped to [0, 1] (no exposure or tone curve), quantised row by
    /// row as the rows are traced ([`RenderOutput::rgb8`]). For a caller that
    /// only writes 8-bit files: a view takes a quarter of the fresh memory
    /// (which the kernel must clear first: 2.8 MB, about 2.4 ms on the
    /// project's VM, for a view of 420×560 in floats) and no pass of its own
    /// to quantise. Pixel centres, the adaptive sampling (its rows as they
    /// are refined; its corner lattice stays floats) and stratified samples
    /// (the film's sums, then bytes) are kept so; the SPD's corners give
    /// floats.
    Rgb8(crate::output::WriteOptions),
}

/// The images of a sampling, with what it cost.
pub(super) struct Sampled {
    pub images: Vec<Image>,
    pub rgb8: Vec<Rgb8Image>,
    pub counts: TraceCounts,
    pub samples_per_view: u64,
    pub max_per_pixel: u32,
    pub refined: u64,
}

/// Every view's pixels (or a row of them), in floats or as the files'
/// bytes, as [`ViewStorage`] asks.
pub(super) enum Views {
    Float(Vec<Vec<Color>>),
    Rgb8(Vec<Vec<u8>>),
}

impl Views {
    /// No pixels yet, room for `pixels` a view.
    pub fn empty(storage: ViewStorage, views: usize, pixels: usize) -> Views {
        match storage {
            ViewStorage::Float => {
                Views::Float((0..views).map(|_| Vec::with_capacity(pixels)).collect())
            }
            ViewStorage::Rgb8(_) => {
                Views::Rgb8((0..views).map(|_| Vec::with_capacity(3 * pixels)).collect())
            }
        }
    }

    /// A row of every view's colours, kept as `storage` asks (quantised with
    /// the writer's routine).
    pub fn of_row(colors: Vec<RowColors>, storage: ViewStorage) -> Views {
        match storage {
            ViewStorage::Float => Views::Float(colors),
            ViewStorage::Rgb8(opts) => Views::Rgb8(
                colors
                    .iter()
                    .map(|c| {
                        let mut bytes = vec![0u8; 3 * c.len()];
                        crate::output::rgb8_into(c, &mut bytes, &opts);
                        bytes
                    })
                    .collect(),
            ),
        }
    }

    /// `row` (of the same kind) after every view's pixels.
    pub fn append(&mut self, row: Views) {
        match (self, row) {
            (Views::Float(all), Views::Float(row)) => {
                all.iter_mut().zip(row).for_each(|(a, r)| a.extend(r))
            }
            (Views::Rgb8(all), Views::Rgb8(row)) => {
                all.iter_mut().zip(row).for_each(|(a, r)| a.extend(r))
            }
            _ => unreachable!("one render keeps its views one way"),
        }
    }

    /// The views as `w` x `h` images: float ones, or the files' bytes.
    pub fn into_images(self, w: usize, h: usize) -> (Vec<Image>, Vec<Rgb8Image>) {
        let (width, height) = (w as u32, h as u32);
        match self {
            Views::Float(views) => {
                let images = views.into_iter().map(|pixels| Image {
                    width,
                    height,
                    pixels,
                });
                (images.collect(), Vec::new())
            }
            Views::Rgb8(views) => {
                let images = views.into_iter().map(|bytes| Rgb8Image {
                    width,
                    height,
                    bytes,
                });
                (Vec::new(), images.collect())
            }
        }
    }
}
