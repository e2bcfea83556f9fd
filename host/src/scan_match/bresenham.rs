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

impl BresenhamLine {
    /// Whether `cell` is among the first `num_cells` cells of the line from `from_px` to
    /// `to_px` ([`BresenhamLine::new`]'s cells, in its order), without walking it.
    ///
    /// Each cell of the line lies one step further along its longer axis (its *major* axis)
    /// than the one before, and after `k` steps the error term has made
    /// `⌊(2·k·minor + major) / (2·major)⌋` steps along the other, `major` and `minor` being the
    /// line's extents along the two axes: the cell at the major coordinate of `cell` is known
    /// at once.
    pub fn contains_within(
        from_px: [i32; 2],
        to_px: [i32; 2],
        cell: [i32; 2],
        num_cells: usize,
    ) -> bool {
        let delta = [0, 1].map(|axis| i64::from(to_px[axis]) - i64::from(from_px[axis]));
        let offset = [0, 1].map(|axis| i64::from(cell[axis]) - i64::from(from_px[axis]));
        let (major, minor) = if delta[0].abs() >= delta[1].abs() {
            (0, 1)
        } else {
            (1, 0)
        };
        let major_extent = delta[major].abs();
        let minor_extent = delta[minor].abs();
        let steps = offset[major] * delta[major].signum();
        if offset[major] != 0 && steps <= 0 {
            return false;
        }
        if steps > major_extent || steps.unsigned_abs() >= num_cells as u64 {
            return false;
        }
        if major_extent == 0 {
            return offset == [0, 0];
        }
        let minor_steps = (2 * steps * minor_extent + major_extent) / (2 * major_extent);
        offset[minor] == minor_steps * delta[minor].signum()
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
    fn a_cell_is_found_on_a_line_exactly_where_the_walk_visits_it() {
        let from = [3, -2];
        for to_x in -14..=14 {
            for to_y in -14..=14 {
                let to = [from[0] + to_x, from[1] + to_y];
                let cells = line(from, to);
                for num_cells in [0, 1, cells.len() / 2, cells.len() - 1, cells.len()] {
                    for x in from[0] - 16..=from[0] + 16 {
                        for y in from[1] - 16..=from[1] + 16 {
                            let walked = cells[..num_cells].contains(&[x, y]);
                            assert_eq!(
                                BresenhamLine::contains_within(from, to, [x, y], num_cells),
                                walked,
                                "line {from:?} -> {to:?}, cell {:?}, first {num_cells}",
                                [x, y]
                            );
                        }
                    }
                }
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
