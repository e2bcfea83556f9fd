//! A geo-referenced image as a user's GIS tools leave it: an image file (TIFF with its tags and
//! GeoKeys, PNG or JPEG) and the sidecars beside it (world file, `.aux.xml` with a WKT
//! projection, `.prj`), written to a scratch folder and opened as the daemon opens
//! `--image`. Nothing may panic; a refusal must say what it refused; an image that opens must
//! answer for its corners and its pixels.
//!
//! An input that starts like a TIFF file is taken whole as one (so real GeoTIFFs seed the
//! corpus); any other is read as an [`ImageFiles`].

#![no_main]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use arbitrary::{Arbitrary, Unstructured};
use host::geoimage::GeoImage;
use libfuzzer_sys::fuzz_target;

/// Images larger than this many pixels are opened but not decoded.
const MAX_DECODED_PIXELS: u64 = 1 << 22;

#[derive(Arbitrary, Debug)]
struct ImageFiles {
    /// 0: `.tif`, 1: `.png`, 2: `.jpg`, others: `.tiff`.
    format: u8,
    image: Vec<u8>,
    world_file: Option<String>,
    aux_xml: Option<String>,
    prj: Option<String>,
}

/// The scratch folder of this process, made once.
fn scratch() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("host-fuzz-geo-image-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch folder");
        dir
    })
}

/// Empties the scratch folder, so that no input finds another's files beside it.
fn clear(dir: &Path) {
    for entry in std::fs::read_dir(dir).into_iter().flatten().flatten() {
        let _ = std::fs::remove_file(entry.path());
    }
}

fn check(path: &Path) {
    match GeoImage::open(path) {
        Ok(image) => {
            let _ = image.info();
            let _ = image.pixel_to_wgs84(0.5, 0.5);
            let _ = image.wgs84_to_pixel(11.0, 48.0);
            let pixels = u64::from(image.width()) * u64::from(image.height());
            if pixels <= MAX_DECODED_PIXELS {
                if let Ok(rgba) = image.to_rgba8() {
                    assert_eq!(rgba.len() as u64, 4 * pixels);
                }
            }
        }
        Err(error) => assert!(!error.to_string().is_empty()),
    }
}

fuzz_target!(|data: &[u8]| {
    let dir = scratch();
    if data.starts_with(b"II*\0") || data.starts_with(b"MM\0*") {
        let path = dir.join("whole.tif");
        std::fs::write(&path, data).expect("scratch file");
        check(&path);
        clear(dir);
        return;
    }
    let Ok(files) = ImageFiles::arbitrary(&mut Unstructured::new(data)) else {
        return;
    };
    let (extension, world_extension) = match files.format {
        0 => ("tif", "tfw"),
        1 => ("png", "pgw"),
        2 => ("jpg", "jgw"),
        _ => ("tiff", "wld"),
    };
    let path = dir.join(format!("image.{extension}"));
    let sidecars = [
        (format!("image.{world_extension}"), files.world_file),
        (format!("image.{extension}.aux.xml"), files.aux_xml),
        ("image.prj".to_owned(), files.prj),
    ];
    std::fs::write(&path, &files.image).expect("scratch file");
    for (name, text) in sidecars {
        if let Some(text) = text {
            std::fs::write(dir.join(name), text).expect("scratch file");
        }
    }
    check(&path);
    clear(dir);
});
