//! `robot-host georef-info FILE`: JSON on stdout for a geo-referenced image, a clear error on
//! stderr and exit code 1 otherwise.

use std::path::Path;
use std::process::{Command, Output};

fn georef_info(args: &[&str]) -> Output {
    match Command::new(env!("CARGO_BIN_EXE_robot-host"))
        .arg("georef-info")
        .args(args)
        .output()
    {
        Ok(output) => output,
        Err(e) => panic!("cannot run robot-host: {e}"),
    }
}

fn stdout_json(output: &Output) -> serde_json::Value {
    match serde_json::from_slice(&output.stdout) {
        Ok(v) => v,
        Err(e) => panic!(
            "stdout is not JSON ({e}): {}",
            String::from_utf8_lossy(&output.stdout)
        ),
    }
}

#[test]
fn prints_crs_and_corners_of_a_geotiff() {
    let Some(path) = datasets::require("geotiff/byte.tif", "prints_crs_and_corners_of_a_geotiff")
    else {
        return;
    };
    let path = path.to_string_lossy().into_owned();
    let output = georef_info(&[&path]);
    assert!(
        output.status.success(),
        "{}",
        String::from_utf8_lossy(&output.stderr)
    );
    let json = stdout_json(&output);
    assert_eq!(json["crs"]["name"], "EPSG:26711");
    assert_eq!(
        (json["width"].as_u64(), json["height"].as_u64()),
        (Some(20), Some(20))
    );
    let ul = &json["corners_wgs84"]["upper_left"];
    // GDAL's wgs84Extent UL is (-117.6420428, 33.9023684); the NAD27 Helmert lands within 2 m.
    assert!(
        (ul[0].as_f64().unwrap_or(0.0) - -117.6420428).abs() < 2.5e-5,
        "{ul}"
    );
    assert!(
        (ul[1].as_f64().unwrap_or(0.0) - 33.9023684).abs() < 2.5e-5,
        "{ul}"
    );
    // Pretty by default, one line with --compact.
    assert!(String::from_utf8_lossy(&output.stdout).lines().count() > 10);
    let compact = georef_info(&["--compact", &path]);
    assert_eq!(String::from_utf8_lossy(&compact.stdout).lines().count(), 1);
    assert_eq!(stdout_json(&compact), json);
}

#[test]
fn image_without_crs_prints_null_crs_and_model_corners() {
    let Some(path) = datasets::require("geotiff/rotated.tif", "image_without_crs_prints_null")
    else {
        return;
    };
    let output = georef_info(&[&path.to_string_lossy()]);
    assert!(output.status.success());
    let json = stdout_json(&output);
    assert!(json["crs"].is_null() && json["corners_wgs84"].is_null());
    assert_eq!(
        json["corners_model"]["upper_left"],
        serde_json::json!([100.0, 200.0])
    );
    assert!(String::from_utf8_lossy(&output.stderr).contains("no coordinate reference system"));
}

#[test]
fn missing_file_is_an_error_with_exit_code_1() {
    let output = georef_info(&["/nonexistent/map.tif"]);
    assert_eq!(output.status.code(), Some(1));
    assert!(output.stdout.is_empty());
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("/nonexistent/map.tif"), "{stderr}");
}

#[test]
fn image_without_georeferencing_is_an_error_with_exit_code_1() {
    let dir = std::env::temp_dir().join(format!("georef-info-cli-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("plain.png");
    write_grey_png(&png);
    let output = georef_info(&[&png.to_string_lossy()]);
    std::fs::remove_dir_all(&dir).unwrap();
    assert_eq!(output.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(stderr.contains("not geo-referenced"), "{stderr}");
}

#[test]
fn unknown_file_type_is_an_error_with_exit_code_1() {
    let output = georef_info(&["notes.txt"]);
    assert_eq!(output.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&output.stderr).contains("unsupported image type"));
}

/// A 2×2 grey PNG with no world file beside it.
fn write_grey_png(path: &Path) {
    let file = std::fs::File::create(path).unwrap();
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), 2, 2);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().unwrap();
    writer.write_image_data(&[0, 64, 128, 255]).unwrap();
}
