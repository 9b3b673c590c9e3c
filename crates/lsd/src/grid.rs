//! A row-major 2D array: the images (grey, smoothed, gradient) and the pixel labels.

/// `width` x `height` values, the one at column `x`, row `y` at `data[x + y * width]`
/// (LSD's own layout).
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Grid<T> {
    pub(crate) data: Vec<T>,
    pub(crate) width: usize,
    pub(crate) height: usize,
}

impl<T: Copy> Grid<T> {
    /// A grid filled with `value`.
    pub(crate) fn filled(width: usize, height: usize, value: T) -> Self {
        Self {
            data: vec![value; width * height],
            width,
            height,
        }
    }

    #[inline]
    pub(crate) fn get(&self, x: usize, y: usize) -> T {
        self.data[x + y * self.width]
    }

    #[inline]
    pub(crate) fn set(&mut self, x: usize, y: usize, value: T) {
        self.data[x + y * self.width] = value;
    }

    /// Whether the signed coordinates fall inside the grid.
    #[inline]
    pub(crate) fn contains(&self, x: i64, y: i64) -> bool {
        x >= 0 && y >= 0 && (x as usize) < self.width && (y as usize) < self.height
    }
}
