//! A generated aerial image of a world, geo-referenced in WGS84 latitude and longitude: grass,
//! the robot's paths, tree crowns, and buildings and walls, seen from above.
//!
//! The image's pixels are square in degrees of latitude and longitude scaled at the datum, so
//! that a pixel is the same number of metres east and north there: the world frame (east and
//! north of [`GeoDatum`]) maps to pixels by an affine transform.

use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use tiny_skia::{Color, FillRule, LineCap, Paint, PathBuilder, Pixmap, Stroke, Transform};

use super::{GeoDatum, Scenario, Shape};

/// Room around the world's shapes, metres.
const MARGIN_M: f64 = 25.0;
/// Radius of a crown as a multiple of the trunk's radius, and the least crown radius.
const CROWN_PER_TRUNK: f64 = 8.0;
const MIN_CROWN_M: f64 = 1.5;

/// An RGB image with its geo-referencing.
#[derive(Debug, Clone, PartialEq)]
pub struct AerialImage {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// RGB8, row-major from the top-left.
    pub rgb: Vec<u8>,
    /// Longitude and latitude of the outer top-left corner of the top-left pixel, degrees.
    pub upper_left_lon_lat_deg: [f64; 2],
    /// Size of a pixel in longitude and latitude, degrees.
    pub pixel_size_deg: [f64; 2],
    /// Size of a pixel at the datum, metres.
    pub pixel_size_m: f64,
}

/// Draws `scenario` from above at `pixel_size_m` metres per pixel.
pub fn render_aerial(scenario: &Scenario, pixel_size_m: f64) -> AerialImage {
    let (min_m, max_m) = scenario.world().bounds_m();
    let west_m = min_m[0] - MARGIN_M;
    let north_m = max_m[1] + MARGIN_M;
    let width = (((max_m[0] - min_m[0] + 2.0 * MARGIN_M) / pixel_size_m).ceil() as u32).max(1);
    let height = (((max_m[1] - min_m[1] + 2.0 * MARGIN_M) / pixel_size_m).ceil() as u32).max(1);
    let datum = scenario.datum();
    let (ul_lat, ul_lon, _) = datum.to_geodetic(west_m, north_m, 0.0);
    let (lat_1, lon_1, _) = datum.to_geodetic(west_m + pixel_size_m, north_m - pixel_size_m, 0.0);
    let pixel_size_deg = [lon_1 - ul_lon, ul_lat - lat_1];

    let Some(mut pixmap) = Pixmap::new(width, height) else {
        return AerialImage {
            width: 0,
            height: 0,
            rgb: Vec::new(),
            upper_left_lon_lat_deg: [ul_lon, ul_lat],
            pixel_size_deg,
            pixel_size_m,
        };
    };
    paint_grass(&mut pixmap, scenario.seed());
    // World (east, north) metres → pixels.
    let scale = (1.0 / pixel_size_m) as f32;
    let to_pixels = Transform::from_row(
        scale,
        0.0,
        0.0,
        -scale,
        (-west_m / pixel_size_m) as f32,
        (north_m / pixel_size_m) as f32,
    );
    draw_paths(&mut pixmap, scenario, to_pixels);
    draw_shapes(&mut pixmap, scenario, to_pixels);

    let rgb = pixmap
        .pixels()
        .iter()
        .flat_map(|p| {
            let c = p.demultiply();
            [c.red(), c.green(), c.blue()]
        })
        .collect();
    AerialImage {
        width,
        height,
        rgb,
        upper_left_lon_lat_deg: [ul_lon, ul_lat],
        pixel_size_deg,
        pixel_size_m,
    }
}

/// Grass with a little seeded texture.
fn paint_grass(pixmap: &mut Pixmap, seed: u64) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x00A3_21A1);
    for pixel in pixmap.pixels_mut() {
        let shade: i16 = rng.random_range(-12..=12);
        let channel = |base: i16| (base + shade).clamp(0, 255) as u8;
        *pixel = tiny_skia::ColorU8::from_rgba(channel(96), channel(142), channel(70), 255)
            .premultiply();
    }
}

/// The robot's route as a gravel path.
fn draw_paths(pixmap: &mut Pixmap, scenario: &Scenario, to_pixels: Transform) {
    let trajectory = scenario.trajectory();
    let mut path = PathBuilder::new();
    let steps = (trajectory.duration_s() / 0.5).ceil() as usize;
    for i in 0..=steps {
        let p = trajectory.pose_at(i as f64 * 0.5);
        if i == 0 {
            path.move_to(p.x_m as f32, p.y_m as f32);
        } else {
            path.line_to(p.x_m as f32, p.y_m as f32);
        }
    }
    if let Some(path) = path.finish() {
        let mut paint = Paint {
            anti_alias: true,
            ..Paint::default()
        };
        paint.set_color_rgba8(196, 178, 140, 255);
        let stroke = Stroke {
            width: 3.0,
            line_cap: LineCap::Round,
            ..Stroke::default()
        };
        pixmap.stroke_path(&path, &paint, &stroke, to_pixels, None);
    }
}

/// Crowns over the trunks, and walls.
fn draw_shapes(pixmap: &mut Pixmap, scenario: &Scenario, to_pixels: Transform) {
    let mut paint = Paint {
        anti_alias: true,
        ..Paint::default()
    };
    let wall = Stroke {
        width: 0.8,
        line_cap: LineCap::Square,
        ..Stroke::default()
    };
    for shape in scenario.world().shapes() {
        match *shape {
            Shape::Segment { a_m, b_m } => {
                let mut path = PathBuilder::new();
                path.move_to(a_m[0] as f32, a_m[1] as f32);
                path.line_to(b_m[0] as f32, b_m[1] as f32);
                if let Some(path) = path.finish() {
                    paint.set_color_rgba8(120, 120, 124, 255);
                    pixmap.stroke_path(&path, &paint, &wall, to_pixels, None);
                }
            }
            Shape::Circle { center_m, radius_m } => {
                let crown_m = (radius_m * CROWN_PER_TRUNK).max(MIN_CROWN_M);
                for (r, colour) in [(crown_m, (38, 84, 36)), (crown_m * 0.6, (52, 104, 46))] {
                    if let Some(circle) =
                        PathBuilder::from_circle(center_m[0] as f32, center_m[1] as f32, r as f32)
                    {
                        paint.set_color(Color::from_rgba8(colour.0, colour.1, colour.2, 255));
                        pixmap.fill_path(&circle, &paint, FillRule::Winding, to_pixels, None);
                    }
                }
            }
        }
    }
}

/// Where the world point (`east_m`, `north_m`) falls in `image`, pixels from its top-left
/// outer corner.
pub fn pixel_of(image: &AerialImage, datum: &GeoDatum, east_m: f64, north_m: f64) -> [f64; 2] {
    let (lat, lon, _) = datum.to_geodetic(east_m, north_m, 0.0);
    [
        (lon - image.upper_left_lon_lat_deg[0]) / image.pixel_size_deg[0],
        (image.upper_left_lon_lat_deg[1] - lat) / image.pixel_size_deg[1],
    ]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::WorldKind;

    #[test]
    fn trees_are_dark_crowns_where_the_world_has_them() {
        let scenario = Scenario::generate(WorldKind::Outdoor, 3);
        let image = render_aerial(&scenario, 0.5);
        assert!(image.width > 100 && image.height > 100);
        assert_eq!(image.rgb.len(), (image.width * image.height * 3) as usize);
        let tree = scenario.landmarks()[0];
        let [col, row] = pixel_of(
            &image,
            &scenario.datum(),
            tree.center_m[0],
            tree.center_m[1],
        );
        let i = (row as usize * image.width as usize + col as usize) * 3;
        // The crown's centre is crown green (the tree's own, or a neighbour's over it, with
        // anti-aliased edges), far darker than the grass (green 130 or more).
        let pixel = &image.rgb[i..i + 3];
        assert!(
            pixel[1] <= 104 && pixel[0] <= 52 && pixel[1] > pixel[0],
            "{pixel:?}"
        );
        // A pixel size of half a metre is half a metre east and north at the datum.
        let [c1, r1] = pixel_of(&image, &scenario.datum(), 10.0, -10.0);
        let [c0, r0] = pixel_of(&image, &scenario.datum(), 0.0, 0.0);
        assert!((c1 - c0 - 20.0).abs() < 1e-6 && (r1 - r0 - 20.0).abs() < 1e-6);
    }
}
