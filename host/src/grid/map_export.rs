//! A probability grid as an image and metadata in the format of the ROS `map_server`.
//!
//! The image has one 8-bit grey pixel per cell, in three shades (`mode: trinary`): occupied
//! cells are black (0), free cells white (254) and unknown cells grey (205). Image row 0 is the
//! top of the map, the grid's highest row, so the image looks like the map seen from above with
//! x to the right and y up. The YAML file names the image and places its lower-left corner
//! (`origin`, in the grid frame, yaw zero) with the cell size (`resolution`). Its thresholds are
//! the `map_server` defaults, with which these three shades read back as occupied, free and
//! unknown (`map_server` takes `(255 − pixel) / 255` as the occupancy of a pixel).
//!
//! The image can be written as binary PGM (`P5`), as the `map_server` reads by default, or as
//! PNG, which browsers show.

use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::probability_grid::ProbabilityGrid;

/// Pixel value of an occupied cell.
pub const OCCUPIED_PIXEL: u8 = 0;
/// Pixel value of a free cell.
pub const FREE_PIXEL: u8 = 254;
/// Pixel value of an unknown cell.
pub const UNKNOWN_PIXEL: u8 = 205;

/// Which known cells count as occupied and which as free.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MapExportOptions {
    /// A known cell with a probability above this is occupied; 0.5.
    pub occupied_above_probability: f32,
    /// A known cell with a probability below this is free; 0.5. Known cells between the two
    /// thresholds are shown as unknown.
    pub free_below_probability: f32,
}

impl Default for MapExportOptions {
    /// Occupied above one half, free below: every observed cell shows what the evidence favours.
    fn default() -> Self {
        MapExportOptions {
            occupied_above_probability: 0.5,
            free_below_probability: 0.5,
        }
    }
}

/// A grid rendered as a trinary grey image, with its placement, ready to write.
#[derive(Clone, Debug, PartialEq)]
pub struct MapExport {
    width_px: usize,
    height_px: usize,
    /// Row-major, row 0 at the top (the grid's highest y).
    pixels: Vec<u8>,
    resolution_m: f64,
    lower_corner_in_grid: [f64; 2],
}

impl MapExport {
    /// Renders `grid`, one pixel per cell, classifying cells by `options`.
    pub fn from_grid(grid: &ProbabilityGrid, options: &MapExportOptions) -> Self {
        let limits = grid.limits();
        let (width_px, height_px) = (limits.width_cells(), limits.height_cells());
        let mut pixels = Vec::with_capacity(width_px * height_px);
        for image_row in 0..height_px {
            let row = height_px - 1 - image_row;
            pixels.extend((0..width_px).map(|column| {
                // Both indices are below the grid's size, whose cells all have `i32` indices.
                let cell = [column as i32, row as i32];
                match grid.probability(cell) {
                    Some(p) if p > options.occupied_above_probability => OCCUPIED_PIXEL,
                    Some(p) if p < options.free_below_probability => FREE_PIXEL,
                    _ => UNKNOWN_PIXEL,
                }
            }));
        }
        MapExport {
            width_px,
            height_px,
            pixels,
            resolution_m: limits.resolution_m(),
            lower_corner_in_grid: limits.lower_corner_in_grid(),
        }
    }

    /// Image width, in pixels (grid columns).
    pub fn width_px(&self) -> usize {
        self.width_px
    }

    /// Image height, in pixels (grid rows).
    pub fn height_px(&self) -> usize {
        self.height_px
    }

    /// The pixels, row-major, row 0 at the top of the map.
    pub fn pixels(&self) -> &[u8] {
        &self.pixels
    }

    /// Side of one pixel, in metres.
    pub fn resolution_m(&self) -> f64 {
        self.resolution_m
    }

    /// The lower-left corner of the image in the grid frame, in metres (the YAML `origin`).
    pub fn lower_corner_in_grid(&self) -> [f64; 2] {
        self.lower_corner_in_grid
    }

    /// Writes the image as binary PGM (`P5`, maximum value 255) to `writer`.
    ///
    /// # Errors
    ///
    /// Any error of `writer`.
    pub fn write_pgm(&self, mut writer: impl Write) -> io::Result<()> {
        write!(writer, "P5\n{} {}\n255\n", self.width_px, self.height_px)?;
        writer.write_all(&self.pixels)?;
        writer.flush()
    }

    /// Writes the image as 8-bit greyscale PNG to `writer`.
    ///
    /// # Errors
    ///
    /// Any error of `writer`, or [`io::ErrorKind::InvalidInput`] for an empty image or one too
    /// large for PNG.
    pub fn write_png(&self, writer: impl Write) -> io::Result<()> {
        let size_error = || {
            io::Error::new(
                io::ErrorKind::InvalidInput,
                format!(
                    "a {} × {} map cannot be written as PNG",
                    self.width_px, self.height_px
                ),
            )
        };
        if self.pixels.is_empty() {
            return Err(size_error());
        }
        let width = u32::try_from(self.width_px).map_err(|_| size_error())?;
        let height = u32::try_from(self.height_px).map_err(|_| size_error())?;
        let mut encoder = png::Encoder::new(writer, width, height);
        encoder.set_color(png::ColorType::Grayscale);
        encoder.set_depth(png::BitDepth::Eight);
        let mut png_writer = encoder.write_header()?;
        png_writer.write_image_data(&self.pixels)?;
        png_writer.finish()?;
        Ok(())
    }

    /// Writes the `map_server` YAML metadata to `writer`, naming `image_file_name` (relative to
    /// the YAML file) as the image.
    ///
    /// # Errors
    ///
    /// Any error of `writer`.
    pub fn write_yaml(&self, image_file_name: &str, mut writer: impl Write) -> io::Result<()> {
        let [x_m, y_m] = self.lower_corner_in_grid;
        let yaml = format!(
            "image: {}\nresolution: {:?}\norigin: [{:?}, {:?}, 0.0]\nnegate: 0\n\
             occupied_thresh: 0.65\nfree_thresh: 0.196\nmode: trinary\n",
            yaml_string(image_file_name),
            self.resolution_m,
            x_m,
            y_m,
        );
        writer.write_all(yaml.as_bytes())?;
        writer.flush()
    }

    /// Writes the image as PGM to the file `pgm_path`.
    ///
    /// # Errors
    ///
    /// Any error creating or writing the file; the message names `pgm_path`.
    pub fn save_pgm(&self, pgm_path: &Path) -> io::Result<()> {
        write_file(pgm_path, |file| self.write_pgm(file))
    }

    /// Writes the image as PNG to the file `png_path`.
    ///
    /// # Errors
    ///
    /// As [`MapExport::write_png`], or any error creating or writing the file; the message names
    /// `png_path`.
    pub fn save_png(&self, png_path: &Path) -> io::Result<()> {
        write_file(png_path, |file| self.write_png(file))
    }

    /// Writes a `map_server` map: the YAML file `yaml_path` and, beside it, the PGM image with
    /// the same name ending in `.pgm` (`maps/office.yaml` and `maps/office.pgm`).
    ///
    /// # Errors
    ///
    /// [`io::ErrorKind::InvalidInput`] if `yaml_path` has no file name or one that is not UTF-8,
    /// or any error creating or writing either file; the message names the file.
    pub fn save_ros_map(&self, yaml_path: &Path) -> io::Result<()> {
        let pgm_path = yaml_path.with_extension("pgm");
        let image_file_name = yaml_path
            .file_name()
            .and_then(|_| pgm_path.file_name())
            .and_then(|name| name.to_str())
            .ok_or_else(|| {
                io::Error::new(
                    io::ErrorKind::InvalidInput,
                    format!(
                        "{}: a map needs a UTF-8 file name for its image",
                        yaml_path.display()
                    ),
                )
            })?;
        self.save_pgm(&pgm_path)?;
        write_file(yaml_path, |file| self.write_yaml(image_file_name, file))
    }
}

/// Creates `path` and runs `write` on a buffered writer to it, naming `path` in any error.
fn write_file(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<File>) -> io::Result<()>,
) -> io::Result<()> {
    let with_path =
        |error: io::Error| io::Error::new(error.kind(), format!("{}: {error}", path.display()));
    let mut file = BufWriter::new(File::create(path).map_err(with_path)?);
    write(&mut file).map_err(with_path)?;
    file.flush().map_err(with_path)
}

/// `text` as a YAML scalar: as it is when that is unambiguous, double-quoted otherwise.
fn yaml_string(text: &str) -> String {
    let plain = !text.is_empty()
        && text
            .chars()
            .all(|c| c.is_ascii_alphanumeric() || matches!(c, '.' | '_' | '-' | '/'))
        && !text.starts_with('-');
    if plain {
        return text.to_owned();
    }
    let mut quoted = String::with_capacity(text.len() + 2);
    quoted.push('"');
    for c in text.chars() {
        match c {
            '"' => quoted.push_str("\\\""),
            '\\' => quoted.push_str("\\\\"),
            c if c.is_control() => {
                // Writing to a String cannot fail.
                let _ = write!(quoted, "\\u{:04x}", u32::from(c));
            }
            c => quoted.push(c),
        }
    }
    quoted.push('"');
    quoted
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::grid::map_limits::MapLimits;
    use crate::grid::probability_grid::{ProbabilityGridOptions, log_odds_from_probability};

    /// A 3 × 2 grid of 5 cm cells at (-0.1, 0.25):
    ///
    /// ```text
    /// row 1:  free      unknown   occupied
    /// row 0:  occupied  free      unknown
    /// ```
    fn tiny_grid() -> ProbabilityGrid {
        let mut grid = ProbabilityGrid::with_limits(
            MapLimits::new(0.05, [-0.1, 0.25], 3, 2),
            ProbabilityGridOptions::default(),
        );
        for (cell, p) in [
            ([0, 0], 0.9f32),
            ([1, 0], 0.2),
            ([0, 1], 0.45),
            ([2, 1], 0.55),
        ] {
            grid.update_log_odds(cell, log_odds_from_probability(p));
        }
        grid
    }

    /// The golden image of [`tiny_grid`], top row first.
    const TINY_PIXELS: [u8; 6] = [254, 205, 0, 0, 254, 205];

    #[test]
    fn test_pixels() {
        let export = MapExport::from_grid(&tiny_grid(), &MapExportOptions::default());
        assert_eq!((export.width_px(), export.height_px()), (3, 2));
        assert_eq!(export.pixels(), &TINY_PIXELS);
        let strict = MapExportOptions {
            occupied_above_probability: 0.65,
            free_below_probability: 0.3,
        };
        let export = MapExport::from_grid(&tiny_grid(), &strict);
        assert_eq!(export.pixels(), &[205, 205, 205, 0, 254, 205]);
    }

    #[test]
    fn test_pgm_golden() {
        let mut bytes = Vec::new();
        MapExport::from_grid(&tiny_grid(), &MapExportOptions::default())
            .write_pgm(&mut bytes)
            .unwrap();
        let mut expected = b"P5\n3 2\n255\n".to_vec();
        expected.extend_from_slice(&TINY_PIXELS);
        assert_eq!(bytes, expected);
    }

    #[test]
    fn test_yaml_golden() {
        let mut bytes = Vec::new();
        MapExport::from_grid(&tiny_grid(), &MapExportOptions::default())
            .write_yaml("map.pgm", &mut bytes)
            .unwrap();
        assert_eq!(
            String::from_utf8(bytes).unwrap(),
            "image: map.pgm\n\
             resolution: 0.05\n\
             origin: [-0.1, 0.25, 0.0]\n\
             negate: 0\n\
             occupied_thresh: 0.65\n\
             free_thresh: 0.196\n\
             mode: trinary\n"
        );
    }

    #[test]
    fn test_yaml_quotes_unusual_names() {
        assert_eq!(yaml_string("maps/run-2.pgm"), "maps/run-2.pgm");
        assert_eq!(
            yaml_string("my map: \"a\".pgm"),
            "\"my map: \\\"a\\\".pgm\""
        );
        assert_eq!(yaml_string("-x.pgm"), "\"-x.pgm\"");
    }

    #[test]
    fn test_png_decodes_to_the_same_pixels() {
        let export = MapExport::from_grid(&tiny_grid(), &MapExportOptions::default());
        let mut bytes = Vec::new();
        export.write_png(&mut bytes).unwrap();
        let decoder = png::Decoder::new(io::Cursor::new(bytes));
        let mut reader = decoder.read_info().unwrap();
        let mut decoded = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut decoded).unwrap();
        assert_eq!((info.width, info.height), (3, 2));
        assert_eq!(info.color_type, png::ColorType::Grayscale);
        assert_eq!(info.bit_depth, png::BitDepth::Eight);
        assert_eq!(&decoded[..info.buffer_size()], &TINY_PIXELS);
    }

    #[test]
    fn test_empty_png_is_an_error() {
        let grid = ProbabilityGrid::new(0.05, ProbabilityGridOptions::default());
        let export = MapExport::from_grid(&grid, &MapExportOptions::default());
        let error = export.write_png(Vec::new()).unwrap_err();
        assert_eq!(error.kind(), io::ErrorKind::InvalidInput);
    }

    #[test]
    fn test_save_ros_map_and_errors_name_the_path() {
        let directory =
            std::env::temp_dir().join(format!("host-grid-export-{}", std::process::id()));
        std::fs::create_dir_all(&directory).unwrap();
        let export = MapExport::from_grid(&tiny_grid(), &MapExportOptions::default());
        let yaml_path = directory.join("office.yaml");
        export.save_ros_map(&yaml_path).unwrap();
        let yaml = std::fs::read_to_string(&yaml_path).unwrap();
        assert!(yaml.starts_with("image: office.pgm\n"), "{yaml}");
        let pgm = std::fs::read(directory.join("office.pgm")).unwrap();
        assert!(pgm.ends_with(&TINY_PIXELS));
        let png_path = directory.join("office.png");
        export.save_png(&png_path).unwrap();
        assert!(std::fs::metadata(&png_path).unwrap().len() > 0);

        let missing = directory.join("no-such-directory").join("map.yaml");
        let error = export.save_ros_map(&missing).unwrap_err();
        assert!(error.to_string().contains("no-such-directory"), "{error}");
        std::fs::remove_dir_all(&directory).unwrap();
    }
}
