//! The landmark map and the trajectory drawn as a PNG, for `GET /api/map.png` when there is
//! no occupancy grid.
//!
//! The drawing is the map seen from above, x to the right and y up, scaled so that its longer
//! side spans `max_side_px` pixels: a white background, the trajectory as a blue line and each
//! landmark as a red square. Points that are not finite are left out.

use host::scan_match::BresenhamLine;

/// Colour of the background.
pub const BACKGROUND_RGB: [u8; 3] = [255, 255, 255];
/// Colour of the trajectory.
pub const TRAJECTORY_RGB: [u8; 3] = [30, 90, 200];
/// Colour of a landmark.
pub const LANDMARK_RGB: [u8; 3] = [200, 30, 30];

/// Blank pixels around the drawing.
const MARGIN_PX: u32 = 8;
/// Half the side of a landmark's square, pixels.
const LANDMARK_HALF_SIDE_PX: i64 = 2;
/// The smallest extent drawn, metres, so that a single point still gets a finite scale.
const MIN_EXTENT_M: f64 = 1.0;

/// Why the map could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum MapRenderError {
    /// Neither a trajectory nor a landmark with finite coordinates.
    #[error("no map built yet: no trajectory and no landmarks")]
    Empty,
    /// The PNG encoder failed.
    #[error("cannot encode the map as PNG: {0}")]
    Encoding(#[from] png::EncodingError),
}

/// Draws `trajectory_m` and `landmarks_m` (map frame, metres) as an RGB PNG whose longer side is
/// `max_side_px` pixels (at least `2 × 8 + 1`).
///
/// # Errors
/// [`MapRenderError::Empty`] when there is no finite point to draw, or an encoder error.
pub fn render_map_png(
    trajectory_m: &[[f64; 2]],
    landmarks_m: &[[f64; 2]],
    max_side_px: u32,
) -> Result<Vec<u8>, MapRenderError> {
    let finite = |p: &&[f64; 2]| p[0].is_finite() && p[1].is_finite();
    let trajectory: Vec<[f64; 2]> = trajectory_m.iter().filter(finite).copied().collect();
    let landmarks: Vec<[f64; 2]> = landmarks_m.iter().filter(finite).copied().collect();
    let placement = Placement::fit(trajectory.iter().chain(&landmarks), max_side_px)
        .ok_or(MapRenderError::Empty)?;

    let mut canvas = Canvas::new(placement.width_px, placement.height_px);
    for pair in trajectory.windows(2) {
        let from = placement.pixel(pair[0]);
        let to = placement.pixel(pair[1]);
        BresenhamLine::new(from, to).for_each(|p| canvas.set(p, TRAJECTORY_RGB));
    }
    if let [single] = trajectory.as_slice() {
        canvas.set(placement.pixel(*single), TRAJECTORY_RGB);
    }
    for landmark in &landmarks {
        let [column, row] = placement.pixel(*landmark).map(i64::from);
        let side = -LANDMARK_HALF_SIDE_PX..=LANDMARK_HALF_SIDE_PX;
        for d_row in side.clone() {
            for d_column in side.clone() {
                canvas.set_wide([column + d_column, row + d_row], LANDMARK_RGB);
            }
        }
    }
    canvas.encode_png()
}

/// How map coordinates become pixels.
#[derive(Debug, Clone, Copy)]
struct Placement {
    min_x_m: f64,
    max_y_m: f64,
    px_per_m: f64,
    width_px: u32,
    height_px: u32,
}

impl Placement {
    /// The placement that fits `points` into `max_side_px`, or `None` without points.
    fn fit<'a>(points: impl Iterator<Item = &'a [f64; 2]>, max_side_px: u32) -> Option<Self> {
        let mut bounds: Option<[f64; 4]> = None;
        for p in points {
            let b = bounds.get_or_insert([p[0], p[1], p[0], p[1]]);
            *b = [
                b[0].min(p[0]),
                b[1].min(p[1]),
                b[2].max(p[0]),
                b[3].max(p[1]),
            ];
        }
        let [min_x_m, min_y_m, max_x_m, max_y_m] = bounds?;
        let extent_x_m = (max_x_m - min_x_m).max(MIN_EXTENT_M);
        let extent_y_m = (max_y_m - min_y_m).max(MIN_EXTENT_M);
        let drawable_px = f64::from(max_side_px.max(2 * MARGIN_PX + 1) - 2 * MARGIN_PX);
        let px_per_m = drawable_px / extent_x_m.max(extent_y_m);
        // Both products are at most `drawable_px`, a `u32`.
        let side = |extent_m: f64| (extent_m * px_per_m).ceil() as u32 + 2 * MARGIN_PX;
        Some(Placement {
            min_x_m,
            max_y_m,
            px_per_m,
            width_px: side(extent_x_m),
            height_px: side(extent_y_m),
        })
    }

    /// The pixel (column, row) of `point_m`.
    fn pixel(&self, point_m: [f64; 2]) -> [i32; 2] {
        let margin = f64::from(MARGIN_PX);
        let column = margin + (point_m[0] - self.min_x_m) * self.px_per_m;
        let row = margin + (self.max_y_m - point_m[1]) * self.px_per_m;
        // Inside the image by construction: the points were used to fit it.
        [column.round() as i32, row.round() as i32]
    }
}

/// An RGB image being drawn.
struct Canvas {
    width_px: u32,
    height_px: u32,
    rgb: Vec<u8>,
}

impl Canvas {
    /// A canvas of the background colour.
    fn new(width_px: u32, height_px: u32) -> Self {
        let pixels = width_px as usize * height_px as usize;
        Canvas {
            width_px,
            height_px,
            rgb: BACKGROUND_RGB.repeat(pixels),
        }
    }

    /// Colours `pixel` (column, row); pixels outside the canvas are left out.
    fn set(&mut self, pixel: [i32; 2], rgb: [u8; 3]) {
        self.set_wide(pixel.map(i64::from), rgb);
    }

    /// As [`Canvas::set`], for pixel coordinates that may lie far outside.
    fn set_wide(&mut self, [column, row]: [i64; 2], rgb: [u8; 3]) {
        let (Ok(column), Ok(row)) = (u32::try_from(column), u32::try_from(row)) else {
            return;
        };
        if column >= self.width_px || row >= self.height_px {
            return;
        }
        let start = 3 * (row as usize * self.width_px as usize + column as usize);
        self.rgb[start..start + 3].copy_from_slice(&rgb);
    }

    /// The canvas as an 8-bit RGB PNG.
    fn encode_png(&self) -> Result<Vec<u8>, MapRenderError> {
        let mut bytes = Vec::new();
        let mut encoder = png::Encoder::new(&mut bytes, self.width_px, self.height_px);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header()?;
        writer.write_image_data(&self.rgb)?;
        writer.finish()?;
        Ok(bytes)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Decodes an RGB PNG into (width, height, pixels).
    fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!(info.color_type, png::ColorType::Rgb);
        (info.width, info.height, pixels)
    }

    fn pixel_at(width: u32, pixels: &[u8], [column, row]: [u32; 2]) -> [u8; 3] {
        let start = 3 * (row * width + column) as usize;
        [pixels[start], pixels[start + 1], pixels[start + 2]]
    }

    #[test]
    fn test_landmarks_and_trajectory_land_where_the_map_puts_them() {
        // A 10 m × 5 m map drawn 116 px wide: 10 px per metre inside an 8 px margin.
        let trajectory = [[0.0, 0.0], [10.0, 0.0]];
        let landmarks = [[5.0, 5.0]];
        let bytes = render_map_png(&trajectory, &landmarks, 116).unwrap();
        let (width, height, pixels) = decode(&bytes);
        assert_eq!((width, height), (116, 66));
        // The trajectory runs along y = 0, the bottom row of the drawing.
        assert_eq!(pixel_at(width, &pixels, [8, 58]), TRAJECTORY_RGB);
        assert_eq!(pixel_at(width, &pixels, [60, 58]), TRAJECTORY_RGB);
        assert_eq!(pixel_at(width, &pixels, [108, 58]), TRAJECTORY_RGB);
        // y up: the landmark at y = 5 m is on the top row, in the middle.
        assert_eq!(pixel_at(width, &pixels, [58, 8]), LANDMARK_RGB);
        assert_eq!(pixel_at(width, &pixels, [60, 10]), LANDMARK_RGB);
        assert_eq!(pixel_at(width, &pixels, [58, 30]), BACKGROUND_RGB);
        assert_eq!(pixel_at(width, &pixels, [0, 0]), BACKGROUND_RGB);
    }

    #[test]
    fn test_single_point_is_drawn() {
        let bytes = render_map_png(&[[3.0, -2.0]], &[], 64).unwrap();
        let (width, height, pixels) = decode(&bytes);
        assert_eq!((width, height), (64, 64));
        assert_eq!(pixel_at(width, &pixels, [8, 8]), TRAJECTORY_RGB);
    }

    #[test]
    fn test_nothing_to_draw_is_an_error() {
        let error = render_map_png(&[], &[[f64::NAN, 0.0]], 64).unwrap_err();
        assert!(matches!(error, MapRenderError::Empty), "{error}");
    }
}
