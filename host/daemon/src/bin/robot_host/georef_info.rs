//! `robot-host georef-info FILE`: prints a geo-referenced image's size, CRS and corners as JSON.
//!
//! The JSON is [`GeoImageInfo`]: `crs`, `width`, `height`, `corners_wgs84` (`[lon, lat]` of
//! `upper_left`, `upper_right`, `lower_right`, `lower_left`, `center`), `corners_model` (the
//! same corners in the CRS's own coordinates) and `geo_transform`. It is pretty-printed, or on
//! one line with `--compact`.
//!
//! An image mapped to a model space without a CRS (e.g. a GeoTIFF with only a
//! ModelTransformation) is still described: `crs` and `corners_wgs84` are `null`, its model
//! corners are given, a `note` in the JSON says why, and a warning goes to stderr; the exit
//! code is 0. A missing, unreadable or un-geo-referenced file prints the error on stderr and
//! exits with code 1.

use std::path::PathBuf;
use std::process::ExitCode;

use host::geoimage::{GeoImage, GeoImageInfo};

/// Arguments of `georef-info`.
#[derive(Debug, clap::Args)]
pub struct GeorefInfoArgs {
    /// GeoTIFF (.tif/.tiff), or PNG/JPEG with a world file (.pgw/.jgw/.wld) and .prj/.aux.xml.
    pub file: PathBuf,
    /// Print the JSON on one line instead of pretty-printed.
    #[arg(long)]
    pub compact: bool,
}

/// Runs `georef-info`; returns the process exit code.
pub fn run(args: &GeorefInfoArgs) -> ExitCode {
    let image = match GeoImage::open(&args.file) {
        Ok(image) => image,
        Err(e) => {
            eprintln!("robot-host georef-info: {e}");
            return ExitCode::FAILURE;
        }
    };
    let info = image.info();
    if let Some(note) = &info.note {
        eprintln!(
            "robot-host georef-info: warning: {}: {note}",
            args.file.display()
        );
    }
    match render(&info, args.compact) {
        Ok(json) => {
            println!("{json}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("robot-host georef-info: cannot format the result: {e}");
            ExitCode::FAILURE
        }
    }
}

fn render(info: &GeoImageInfo, compact: bool) -> serde_json::Result<String> {
    if compact {
        serde_json::to_string(info)
    } else {
        serde_json::to_string_pretty(info)
    }
}
