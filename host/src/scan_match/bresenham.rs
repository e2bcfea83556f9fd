//! Bresenham's line algorithm on integer pixel coordinates.
//!
//! The pixels depend only on the start pixel and the integer offset to the end pixel, so
//! shifting both end points by a whole number of pixels shifts the drawn pixels by exactly the
//! same amount. The fast matcher relies on this to draw a rotated scan once and then slide it.

/// The pixels of the 8-connected line from `from_px` to `to_px`, both ends included, in order.
///
/// Uses the all-octant integer form of Bresenham's algorithm (one error term, no floating
/// point). A line from a pixel to itself yields that single pixel.
#[derive(Clone, Debug)]
pub struct BresenhamLine {
    pixel: [i64; 2],
    end: [i64; 2],
    delta_x: i64,
    /// Minus the absolute y extent, as in the textbook form of the algorithm.
    delta_y: i64,
    step: [i64; 2],
    error: i64,
    done: bool,
}

impl BresenhamLine {
    /// Starts a line from `from_px` to `to_px` (column, row).
    pub fn new(from_px: [i32; 2], to_px: [i32; 2]) -> Self {
        let from = from_px.map(i64::from);
        let end = to_px.map(i64::from);
        let delta_x = (end[0] - from[0]).abs();
        let delta_y = -(end[1] - from[1]).abs();
        BresenhamLine {
            pixel: from,
            end,
            delta_x,
            delta_y,
            step: [(end[0] - from[0]).signum(), (end[1] - from[1]).signum()],
            error: delta_x + delta_y,
            done: false,
        }
    }
}

impl Iterator for BresenhamLine {
    type Item = [i32; 2];

    fn next(&mut self) -> Option<[i32; 2]> {
        if self.done {
            return None;
        }
        // The pixel lies between the two end points, which are both `i32`.
        let current = self.pixel.map(|c| c as i32);
        if self.pixel == self.end {
            self.done = true;
            return Some(current);
        }
        let twice_error = 2 * self.error;
        if twice_error >= self.delta_y {
            self.error += self.delta_y;
            self.pixel[0] += self.step[0];
        }
        if twice_error <= self.delta_x {
            self.error += self.delta_x;
            self.pixel[1] += self.step[1];
        }
        Some(current)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn line(from: [i32; 2], to: [i32; 2]) -> Vec<[i32; 2]> {
        BresenhamLine::new(from, to).collect()
    }

    #[test]
    fn test_single_pixel() {
        assert_eq!(line([3, -4], [3, -4]), vec![[3, -4]]);
    }

    #[test]
    fn test_shallow_line() {
        assert_eq!(
            line([0, 0], [5, 2]),
            vec![[0, 0], [1, 0], [2, 1], [3, 1], [4, 2], [5, 2]]
        );
    }

    #[test]
    fn test_steep_and_negative_lines() {
        assert_eq!(
            line([0, 0], [0, -3]),
            vec![[0, 0], [0, -1], [0, -2], [0, -3]]
        );
        assert_eq!(
            line([2, 2], [-1, -1]),
            vec![[2, 2], [1, 1], [0, 0], [-1, -1]]
        );
    }

    #[test]
    fn test_pixel_count_and_connectivity() {
        for &(from, to) in &[([0, 0], [17, -5]), ([-3, 8], [4, -20]), ([9, 9], [-30, 2])] {
            let pixels = line(from, to);
            let extent = (to[0] - from[0]).abs().max((to[1] - from[1]).abs());
            assert_eq!(pixels.len(), extent as usize + 1);
            assert_eq!(pixels.first(), Some(&from));
            assert_eq!(pixels.last(), Some(&to));
            for pair in pixels.windows(2) {
                assert!(
                    (pair[0][0] - pair[1][0]).abs() <= 1 && (pair[0][1] - pair[1][1]).abs() <= 1
                );
            }
        }
    }

    #[test]
    fn test_shift_invariance() {
        let base = line([1, 2], [40, -13]);
        let shifted = line([1 + 7, 2 - 5], [40 + 7, -13 - 5]);
        let expected: Vec<_> = base.iter().map(|p| [p[0] + 7, p[1] - 5]).collect();
        assert_eq!(shifted, expected);
    }
}
