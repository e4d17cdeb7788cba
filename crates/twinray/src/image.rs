//! A linear floating-point RGB image, the renderer's output for one view.

use crate::math::Color;

#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    /// Row-major, top row first.
    pub pixels: Vec<Color>,
}

impl Image {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Image {
        Image::filled(width, height, Color::ZERO)
    }

    /// An image of one colour.
    pub fn filled(width: u32, height: u32, color: Color) -> Image {
        Image {
            width,
            height,
            pixels: vec![color; width as usize * height as usize],
        }
    }

    #[inline]
    pub fn get(&self, x: u32, y: u32) -> Color {
        self.pixels[y as usize * self.width as usize + x as usize]
    }

    #[inline]
    pub fn set(&mut self, x: u32, y: u32, c: Color) {
        self.pixels[y as usize * self.width as usize + x as usize] = c;
    }
}

/// A view as an 8-bit file holds it: interleaved RGB bytes, three a pixel,
/// top row first, quantised with the file's options (see
/// [`ViewStorage::Rgb8`](crate::render::ViewStorage::Rgb8)).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Rgb8Image {
    pub width: u32,
    pub height: u32,
    pub bytes: Vec<u8>,
}
