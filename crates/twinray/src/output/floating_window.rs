//! The floating window applied: black masks at the frame's edges (see
//! `window.rs` for why and how wide).

use crate::math::Color;
use crate::rig::window::FloatingWindow;
use crate::Image;

/// Blackens `left` columns at the left edge of `img` and `right` columns at
/// its right edge (full height; more than the width blackens all of it).
pub fn mask_edges(img: &mut Image, left: u32, right: u32) {
    let w = img.width as usize;
    let (left, right) = ((left as usize).min(w), (right as usize).min(w));
    for row in img.pixels.chunks_mut(w.max(1)) {
        row[..left].fill(Color::ZERO);
        row[w - right..].fill(Color::ZERO);
    }
}

/// Masks every view of a rig (`images` left to right) for `window`: the
/// leftmost view's left edge by `window.left_px`, the rightmost view's right
/// edge by `window.right_px`, the views between in proportion.
pub fn apply_floating_window(images: &mut [Image], window: &FloatingWindow) {
    let n = images.len();
    for (v, img) in images.iter_mut().enumerate() {
        let (left, right) = window.masks(v, n);
        mask_edges(img, left, right);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn masks_blacken_the_outer_edges_only() {
        let mut views = vec![Image::filled(6, 2, Color::ONE); 2];
        apply_floating_window(
            &mut views,
            &FloatingWindow {
                left_px: 2,
                right_px: 1,
            },
        );
        let row = |img: &Image, y: u32| (0..6).map(|x| img.get(x, y).x).collect::<Vec<_>>();
        for y in 0..2 {
            assert_eq!(row(&views[0], y), [0.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
            assert_eq!(row(&views[1], y), [1.0, 1.0, 1.0, 1.0, 1.0, 0.0]);
        }
        let mut img = Image::filled(3, 1, Color::ONE);
        mask_edges(&mut img, 10, 10);
        assert_eq!(img, Image::new(3, 1));
    }
}
