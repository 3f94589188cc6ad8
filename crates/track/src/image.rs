//! The plain grey image the tracker works on: a borrowed row-major view of `f32` values.

/// A borrowed grey image: `width × height` values, row-major (row 0 at the top), in any unit
/// (the camera's own values; the tracker's thresholds are relative to [`GreyView::full_scale`]).
///
/// Pixel convention (COLMAP): the centre of the upper-left pixel is `(0.5, 0.5)`; `u` grows to
/// the right, `v` downwards. The value of pixel column `i`, row `j` is the mean over the square
/// `[i, i + 1) × [j, j + 1)`.
#[derive(Debug, Clone, Copy)]
pub struct GreyView<'a> {
    width: usize,
    height: usize,
    full_scale: f32,
    pixels: &'a [f32],
}

impl<'a> GreyView<'a> {
    /// A view of `pixels` (`width · height` values, row-major) whose brightest possible value is
    /// `full_scale` (255 for 8-bit frames, 4095 for 12-bit, …). `None` when the length does not
    /// match or `full_scale` is not positive and finite.
    pub fn new(width: usize, height: usize, full_scale: f32, pixels: &'a [f32]) -> Option<Self> {
        (width.checked_mul(height) == Some(pixels.len())
            && full_scale.is_finite()
            && full_scale > 0.0)
            .then_some(Self {
                width,
                height,
                full_scale,
                pixels,
            })
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The brightest value a pixel can hold.
    pub fn full_scale(&self) -> f32 {
        self.full_scale
    }

    /// The value of column `i`, row `j` (both in range).
    #[inline]
    pub fn at(&self, i: usize, j: usize) -> f32 {
        self.pixels[j * self.width + i]
    }

    /// The values, row-major.
    pub fn pixels(&self) -> &'a [f32] {
        self.pixels
    }
}
