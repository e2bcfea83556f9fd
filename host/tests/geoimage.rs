//! `host::geoimage` against the real GeoTIFF / world-file samples in `geotiff/` of the shared
//! datasets (see that folder's SOURCES.md for where every file and every expected number
//! comes from).
//!
//! Expected values are, by preference, numbers other projects print in their own tests or docs
//! (GDAL's `gdalinfo` docs, rasterio's tests and CLI docs, georust's tests, the WorldFile
//! projects' tests). Where none exists for WGS84 corners, the values were printed by GDAL 3.6
//! (`gdalinfo -json FILE`, its `wgs84Extent`, 7 decimals) on this machine while the test was
//! written; SOURCES.md's own closed-form computations agree with them to 1e-7°.
//!
//! Tolerances: 1e-6° (≈ 0.1 m) where the CRS's datum is WGS84 or treated as identical to it
//! (NAD83 and ETRS89 are taken as WGS84: they differ by 1–2 m, which GDAL ignores as well
//! without a time-dependent transformation). NAD27 (`byte.tif`) goes through the EPSG:1173
//! Helmert while GDAL picked EPSG:1175; the difference is measured and bounded at 2 m.
//!
//! Each test prints its worst corner error in metres (`cargo test -- --nocapture`).

use std::path::{Path, PathBuf};

use host::geoimage::{Corners, GeoImage, GeoImageError, GeoImageInfo};

/// The sample `name`, or `None` (test skipped, or failed under CI) when the datasets are absent.
fn sample(name: &str, test: &str) -> Option<PathBuf> {
    datasets::require(&format!("geotiff/{name}"), test)
}

fn open(path: &Path) -> GeoImage {
    match GeoImage::open(path) {
        Ok(image) => image,
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

/// Ground distance in metres between two nearby `[lon, lat]` points (equirectangular).
fn distance_m(a: [f64; 2], b: [f64; 2]) -> f64 {
    let lat = a[1].to_radians();
    let dx = (a[0] - b[0]).to_radians() * lat.cos() * 6_378_137.0;
    let dy = (a[1] - b[1]).to_radians() * 6_378_137.0;
    dx.hypot(dy)
}

/// Asserts every named corner is within `tol_deg` of the expected `[lon, lat]` on both axes;
/// returns the worst distance in metres.
fn assert_corners(got: &Corners, want: &[(&str, [f64; 2])], tol_deg: f64) -> f64 {
    let mut worst_m: f64 = 0.0;
    for (name, w) in want {
        let g = match *name {
            "upper_left" => got.upper_left,
            "upper_right" => got.upper_right,
            "lower_right" => got.lower_right,
            "lower_left" => got.lower_left,
            "center" => got.center,
            other => panic!("unknown corner {other}"),
        };
        let (dlon, dlat) = ((g[0] - w[0]).abs(), (g[1] - w[1]).abs());
        assert!(
            dlon <= tol_deg && dlat <= tol_deg,
            "{name}: got {g:?}, want {w:?} (diff {dlon:e}°, {dlat:e}°; tolerance {tol_deg:e}°)"
        );
        worst_m = worst_m.max(distance_m(g, *w));
    }
    worst_m
}

fn wgs84_corners(info: &GeoImageInfo) -> &Corners {
    info.corners_wgs84.as_ref().expect("WGS84 corners")
}

/// `GDALChecksumImage` of one band given in row-major order: `sum += v % P[i]` with the primes
/// 7…43 cycled over the whole band, masked to 16 bits after each addition.
fn gdal_checksum(band: impl Iterator<Item = u8>) -> u32 {
    const PRIMES: [u32; 11] = [7, 11, 13, 17, 19, 23, 29, 31, 37, 41, 43];
    let mut sum = 0u32;
    for (i, v) in band.enumerate() {
        sum = (sum + u32::from(v) % PRIMES[i % PRIMES.len()]) & 0xffff;
    }
    sum
}

/// Channel `c` (0 = R … 3 = A) of an RGBA8 buffer.
fn channel(rgba: &[u8], c: usize) -> impl Iterator<Item = u8> + '_ {
    rgba.chunks_exact(4).map(move |p| p[c])
}

fn pixel(rgba: &[u8], width: u32, col: u32, row: u32) -> [u8; 4] {
    let i = (row as usize * width as usize + col as usize) * 4;
    [rgba[i], rgba[i + 1], rgba[i + 2], rgba[i + 3]]
}

fn decode(image: &GeoImage) -> Vec<u8> {
    match image.to_rgba8() {
        Ok(rgba) => rgba,
        Err(e) => panic!("{}: {e}", image.path().display()),
    }
}

#[test]
fn byte_tif_nad27_utm_11n() {
    let Some(path) = sample("byte.tif", "byte_tif_nad27_utm_11n") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    let crs = image.crs().expect("a CRS");
    assert_eq!(
        (crs.name.as_str(), crs.description.as_str()),
        ("EPSG:26711", "NAD27 / UTM zone 11N")
    );
    assert_eq!((info.width, info.height), (20, 20));
    // gdalinfo.rst (quoted): geoTransform and cornerCoordinates.
    assert_eq!(
        info.geo_transform,
        [440720.0, 60.0, 0.0, 3751320.0, 0.0, -60.0]
    );
    assert_eq!(info.corners_model.lower_right, [441920.0, 3750120.0]);
    assert_eq!(info.corners_model.center, [441320.0, 3750720.0]);
    // gdalinfo.rst (quoted) wgs84Extent, after GDAL's NAD27 → WGS84 shift (EPSG:1175 here).
    let gdal = [
        ("upper_left", [-117.6420428, 33.9023684]),
        ("lower_left", [-117.6419617, 33.8915461]),
        ("lower_right", [-117.6289846, 33.8916131]),
        ("upper_right", [-117.629064, 33.9024353]),
    ];
    let worst_m = assert_corners(wgs84_corners(&info), &gdal, 2.5e-5);
    eprintln!("byte.tif: worst corner vs GDAL wgs84Extent {worst_m:.2} m (EPSG:1173 vs 1175)");
    assert!(worst_m < 2.0, "{worst_m} m");
    // Without a datum shift the corners would be the NAD27 ones, about 80 m east: the shift
    // must have moved them by far more than the tolerance above.
    let nad27_upper_left = [-117.6411686, 33.9023527];
    assert!(distance_m(wgs84_corners(&info).upper_left, nad27_upper_left) > 70.0);

    let rgba = decode(&image);
    assert_eq!(
        gdal_checksum(channel(&rgba, 0)),
        4672,
        "GDAL's band checksum (quoted)"
    );
    assert_eq!(pixel(&rgba, 20, 0, 0), [107, 107, 107, 255]);
    assert_eq!(pixel(&rgba, 20, 10, 10)[0], 115);
    assert_eq!(pixel(&rgba, 20, 19, 19)[0], 107);
    let first_row: Vec<u8> = channel(&rgba, 0).take(20).collect();
    let want = [
        107, 123, 132, 115, 132, 132, 140, 132, 132, 132, 107, 132, 107, 132, 132, 107, 123, 115,
        156, 148,
    ];
    assert_eq!(first_row, want);
}

#[test]
fn naip_aerial_nad83_utm_17n() {
    let name = "m_3607824_se_17_1_20160620_sub.tif";
    let Some(path) = sample(name, "naip_aerial_nad83_utm_17n") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    let crs = image.crs().expect("a CRS");
    // georust/gdal (quoted): "NAD83 / UTM zone 17N", geo_transform().apply(0,0) = (768269, 4057292).
    assert_eq!(crs.description, "NAD83 / UTM zone 17N");
    assert_eq!(image.pixel_to_model(0.0, 0.0), [768269.0, 4057292.0]);
    assert_eq!(info.corners_model.lower_right, [768569.0, 4056992.0]);
    // GDAL 3.6 wgs84Extent (NAD83 taken as WGS84, as GDAL does).
    let gdal = [
        ("upper_left", [-78.0000601, 36.623435]),
        ("lower_left", [-78.0001648, 36.6207343]),
        ("lower_right", [-77.9968143, 36.6206498]),
        ("upper_right", [-77.9967095, 36.6233506]),
    ];
    let worst_m = assert_corners(wgs84_corners(&info), &gdal, 1e-6);
    eprintln!("{name}: worst corner vs GDAL {worst_m:.3} m");

    let rgba = decode(&image);
    // R, G, B are shown; the NIR band (ExtraSamples = unspecified) is ignored, alpha is opaque.
    assert_eq!(pixel(&rgba, 300, 0, 0), [74, 91, 83, 255]);
    assert_eq!(pixel(&rgba, 300, 150, 150), [114, 128, 103, 255]);
    assert_eq!(pixel(&rgba, 300, 299, 299), [59, 78, 72, 255]);
    let sums: Vec<u32> = (0..3).map(|c| gdal_checksum(channel(&rgba, c))).collect();
    assert_eq!(sums, [32555, 5766, 25111]);
}

/// rasterio's numbers for RGB.byte.tif, which shares rgb_lzw.tif's and rgb-byte-tenth.tif's
/// geo-referencing.
fn assert_landsat_extent(image: &GeoImage) -> f64 {
    let info = image.info();
    // rio info (quoted): bounds and lnglat of the centre.
    assert_eq!(info.corners_model.upper_left, [101985.0, 2826915.0]);
    assert_eq!(info.corners_model.lower_right, [339315.0, 2611485.0]);
    let corners = wgs84_corners(&info);
    let mut worst_m = assert_corners(
        corners,
        &[("center", [-77.75790625255473, 24.561583285327067])],
        1e-9,
    );
    // test_warp.py::test_transform_bounds (quoted): west = UL lon, south = LL lat,
    // east = LR lon, north = UR lat for this image.
    let (west, south, east, north) = (
        -78.95864996545055,
        23.564991210854686,
        -76.57492370013823,
        25.550873767433984,
    );
    for (got, want) in [
        (corners.upper_left[0], west),
        (corners.lower_left[1], south),
        (corners.lower_right[0], east),
        (corners.upper_right[1], north),
    ] {
        assert!((got - want).abs() < 1e-9, "bound {got} vs {want}");
    }
    // GDAL 3.6 wgs84Extent for the other coordinates of those corners.
    worst_m = worst_m.max(assert_corners(
        corners,
        &[
            ("upper_left", [-78.95865, 25.5060874]),
            ("lower_left", [-78.8981334, 23.5649912]),
            ("lower_right", [-76.5749237, 23.605947]),
            ("upper_right", [-76.5994383, 25.5508738]),
        ],
        1e-6,
    ));
    worst_m
}

#[test]
fn rgb_lzw_tiled_wgs84_utm_18n() {
    let Some(path) = sample("rgb_lzw.tif", "rgb_lzw_tiled_wgs84_utm_18n") else {
        return;
    };
    let image = open(&path);
    assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:32618"));
    assert_eq!((image.width(), image.height()), (791, 718));
    // test_coords.py (quoted): xy(1, 0, offset="ul") is row 1, column 0.
    assert_eq!(image.pixel_to_model(0.0, 1.0), [101985.0, 2826614.95821727]);
    let worst_m = assert_landsat_extent(&image);
    eprintln!("rgb_lzw.tif: worst corner error {worst_m:.3} m");

    let rgba = decode(&image);
    let sums: Vec<u32> = (0..3).map(|c| gdal_checksum(channel(&rgba, c))).collect();
    assert_eq!(sums, [25420, 29131, 37860], "rasterio's checksums (quoted)");
    assert_eq!(pixel(&rgba, 791, 0, 0), [0, 0, 0, 255]);
    assert_eq!(pixel(&rgba, 791, 395, 359), [18, 25, 14, 255]);
}

#[test]
fn rgb_byte_tenth_user_defined_utm() {
    let Some(path) = sample("rgb-byte-tenth.tif", "rgb_byte_tenth_user_defined_utm") else {
        return;
    };
    let image = open(&path);
    let crs = image.crs().expect("a CRS");
    // PCS 32767 + Projection 16018 on the WGS 84 ellipsoid: no EPSG code, same numbers.
    assert_eq!(crs.epsg, None);
    assert_eq!(crs.description, "UTM Zone 18, Northern Hemisphere");
    let worst_m = assert_landsat_extent(&image);
    eprintln!("rgb-byte-tenth.tif: worst corner error {worst_m:.3} m");

    let rgba = decode(&image);
    let sums: Vec<u32> = (0..3).map(|c| gdal_checksum(channel(&rgba, c))).collect();
    assert_eq!(sums, [43839, 45180, 47242]);
    assert_eq!(pixel(&rgba, 79, 39, 35), [18, 25, 14, 255]);
}

#[test]
fn world_rgb_geographic_planar() {
    let Some(path) = sample("world.rgb.tif", "world_rgb_geographic_planar") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:4326"));
    let worst_m = assert_corners(
        wgs84_corners(&info),
        &[
            ("upper_left", [-180.0, 90.0]),
            ("upper_right", [180.0, 90.0]),
            ("lower_right", [180.0, -90.0]),
            ("lower_left", [-180.0, -90.0]),
            ("center", [0.0, 0.0]),
        ],
        1e-9,
    );
    eprintln!("world.rgb.tif: worst corner error {worst_m:.3} m");
    // The centre of pixel (256, 128) is at (0.3515625°E, 0.3515625°S).
    let [lon, lat] = image.pixel_to_wgs84(256.5, 128.5).unwrap();
    assert!((lon - 0.3515625).abs() < 1e-12 && (lat + 0.3515625).abs() < 1e-12);

    // PlanarConfiguration = 2: three planes interleaved into RGBA.
    let rgba = decode(&image);
    let sums: Vec<u32> = (0..3).map(|c| gdal_checksum(channel(&rgba, c))).collect();
    assert_eq!(sums, [52132, 49397, 43014]);
    assert_eq!(pixel(&rgba, 512, 0, 0), [76, 157, 200, 255]);
    assert_eq!(pixel(&rgba, 512, 256, 128), [52, 139, 208, 255]);
    assert_eq!(pixel(&rgba, 512, 511, 255), [167, 148, 54, 255]);
}

#[test]
fn web_mercator_3857() {
    let Some(path) = sample("rgb1_fake_nir_epsg3857.tif", "web_mercator_3857") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:3857"));
    let corners = wgs84_corners(&info);
    // Its west edge is RGB.byte.tif's west bound (rasterio test_transform_bounds, quoted).
    assert!((corners.upper_left[0] - -78.95864996545055).abs() < 1e-7);
    let worst_m = assert_corners(
        corners,
        &[
            ("upper_left", [-78.95865, 25.5334746]),
            ("lower_left", [-78.95865, 24.4247756]),
            ("lower_right", [-77.7421779, 24.4247756]),
            ("upper_right", [-77.7421779, 25.5334746]),
        ],
        1e-6,
    );
    eprintln!("rgb1_fake_nir_epsg3857.tif: worst corner vs GDAL {worst_m:.3} m");

    let rgba = decode(&image);
    assert_eq!(gdal_checksum(channel(&rgba, 0)), 15695);
    assert_eq!(pixel(&rgba, 676, 338, 340), [94, 94, 94, 255]);
    assert_eq!(pixel(&rgba, 676, 0, 0), [0, 0, 0, 255]);
}

/// georust/geotiff tests/transform.rs (quoted): capitals as (lon, lat) in EPSG:4326, and the
/// pixel each lands on (SOURCES.md's list). "Eisenstadt" in georust is Graz's position.
const CAPITALS: [(&str, [f64; 2], [u32; 2]); 7] = [
    ("Bregenz", [9.74926, 47.50315], [0, 101]),
    ("Innsbruck", [11.39960, 47.26239], [124, 126]),
    ("Klagenfurt", [14.31528, 46.62366], [349, 189]),
    ("Linz", [14.30571, 48.27532], [338, 5]),
    ("Salzburg", [13.05345, 47.80763], [247, 62]),
    ("St. Pölten", [15.62291, 48.20440], [436, 7]),
    ("Vienna", [16.37499, 48.22158], [492, 0]),
];

#[test]
fn austrian_capitals_laea_pixel_is_area() {
    let name = "austrian_capitals_model_transformation_pixel_is_area.tif";
    let Some(path) = sample(name, "austrian_capitals_laea_pixel_is_area") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:3035"));
    // georust (quoted): model extent (4302000, 2621000)–(4809000, 2811000).
    assert_eq!(info.corners_model.lower_left, [4302000.0, 2621000.0]);
    assert_eq!(info.corners_model.upper_right, [4809000.0, 2811000.0]);
    let worst_m = assert_corners(
        wgs84_corners(&info),
        &[
            ("upper_left", [9.7434515, 48.4121732]),
            ("lower_left", [9.7518014, 46.7021134]),
            ("lower_right", [16.361167, 46.5140784]),
            ("upper_right", [16.5737508, 48.2168505]),
        ],
        1e-6,
    );
    eprintln!("{name}: worst corner vs GDAL {worst_m:.3} m (ETRS89 taken as WGS84)");

    // WhiteIsZero is shown photometrically corrected: the capitals (raw 255) are black, the
    // background (raw 0) white; georust's expectations after the tiff crate's inversion.
    let rgba = decode(&image);
    let w = image.width();
    for (city, lon_lat, want) in CAPITALS {
        let [col, row] = image.wgs84_to_pixel(lon_lat[0], lon_lat[1]).unwrap();
        let got = [col.floor() as u32, row.floor() as u32];
        assert_eq!(got, want, "{city}: pixel ({col}, {row})");
        assert_eq!(
            pixel(&rgba, w, got[0], got[1]),
            [0, 0, 0, 255],
            "{city} is black"
        );
    }
    assert_eq!(
        pixel(&rgba, w, 253, 95),
        [255, 255, 255, 255],
        "extent centre is white"
    );
    // Raw samples: GDAL's checksum 165 is of the stored values, i.e. 255 - shown.
    assert_eq!(gdal_checksum(channel(&rgba, 0).map(|v| 255 - v)), 165);
    // The model extent's lower-left corner is the outer edge: just outside the last row.
    let [col, row] = image.geo_transform().invert(4302000.0, 2621000.0).unwrap();
    assert_eq!([col, row], [0.0, 190.0]);
}

#[test]
fn austrian_capitals_laea_pixel_is_point() {
    let area = "austrian_capitals_model_transformation_pixel_is_area.tif";
    let point = "austrian_capitals_model_transformation_pixel_is_point.tif";
    let test = "austrian_capitals_laea_pixel_is_point";
    let (Some(area_path), Some(point_path)) = (sample(area, test), sample(point, test)) else {
        return;
    };
    let (area, point) = (open(&area_path), open(&point_path));
    let info = point.info();
    // georust (quoted): PixelIsPoint shifts the extent by (−500, +500).
    assert_eq!(info.corners_model.lower_left, [4301500.0, 2621500.0]);
    assert_eq!(info.corners_model.upper_right, [4808500.0, 2811500.0]);
    // ... and every lookup point: model (x − 500, y + 500) is the same pixel in the point file.
    for (city, lon_lat, _) in CAPITALS {
        let area_px = area.wgs84_to_pixel(lon_lat[0], lon_lat[1]).unwrap();
        let [x, y] = area.pixel_to_model(area_px[0], area_px[1]);
        let point_px = point.geo_transform().invert(x - 500.0, y + 500.0).unwrap();
        assert!(
            (point_px[0] - area_px[0]).abs() < 1e-9 && (point_px[1] - area_px[1]).abs() < 1e-9,
            "{city}: {point_px:?} vs {area_px:?}"
        );
    }
    let worst_m = assert_corners(
        wgs84_corners(&info),
        &[
            ("upper_left", [9.7366767, 48.4166557]),
            ("lower_left", [9.7452483, 46.7066003]),
            ("lower_right", [16.3552131, 46.5189473]),
            ("upper_right", [16.5676298, 48.2217287]),
        ],
        1e-6,
    );
    eprintln!(
        "{}: worst corner vs GDAL {worst_m:.3} m",
        point_path.display()
    );
}

#[test]
fn rotated_without_crs() {
    let Some(path) = sample("rotated.tif", "rotated_without_crs") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    assert!(image.crs().is_none());
    assert!(info.crs.is_none() && info.corners_wgs84.is_none());
    assert!(
        info.note
            .as_deref()
            .is_some_and(|n| n.contains("no coordinate reference system"))
    );
    assert!(matches!(
        image.pixel_to_wgs84(0.0, 0.0),
        Err(GeoImageError::NoCrs)
    ));
    assert!(matches!(
        image.wgs84_to_pixel(0.0, 0.0),
        Err(GeoImageError::NoCrs)
    ));
    // rasterio test_rotated_bounds (quoted): res (20, 10), bounds of the rotated corners.
    let [_, a, b, _, d, e] = info.geo_transform;
    assert!((a.hypot(d) - 20.0).abs() < 1e-12 && (b.hypot(e) - 10.0).abs() < 1e-12);
    let c = &info.corners_model;
    let xs = [
        c.upper_left[0],
        c.upper_right[0],
        c.lower_right[0],
        c.lower_left[0],
    ];
    let ys = [
        c.upper_left[1],
        c.upper_right[1],
        c.lower_right[1],
        c.lower_left[1],
    ];
    let bounds = [
        xs.iter().copied().fold(f64::INFINITY, f64::min),
        ys.iter().copied().fold(f64::INFINITY, f64::min),
        xs.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        ys.iter().copied().fold(f64::NEG_INFINITY, f64::max),
    ];
    let want = [100.0, 70.0961894323342, 348.20508075688775, 300.0];
    for (g, w) in bounds.iter().zip(want) {
        assert!((g - w).abs() < 1e-9, "bounds {bounds:?} vs {want:?}");
    }

    let rgba = decode(&image);
    assert_eq!(gdal_checksum(channel(&rgba, 0)), 1531);
    assert_eq!(pixel(&rgba, 10, 0, 0)[0], 0);
    assert_eq!(pixel(&rgba, 10, 5, 7)[0], 75);
    assert_eq!(pixel(&rgba, 10, 9, 14)[0], 149);
}

#[test]
fn gadas_png_world_file_and_aux_xml() {
    let Some(path) = sample("gadas-export.png", "gadas_png_world_file_and_aux_xml") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    // The ESRI Web Mercator Auxiliary Sphere WKT of the .aux.xml is EPSG:3857.
    assert_eq!(image.crs().map(|c| c.name.as_str()), Some("EPSG:3857"));
    assert_eq!((info.width, info.height), (968, 475));
    // WorldFile/wld-bbox (quoted): [xmin, ymin, xmax, ymax] with the half-pixel rule.
    let c = &info.corners_model;
    let bbox = [
        c.lower_left[0],
        c.lower_left[1],
        c.upper_right[0],
        c.upper_right[1],
    ];
    let want = [
        7698736.857788673,
        163239.83797837654,
        10066450.245949663,
        1325082.6679127468,
    ];
    for (g, w) in bbox.iter().zip(want) {
        assert!((g - w).abs() < 1e-6, "bbox {bbox:?} vs {want:?}");
    }
    // georaster's ymax (1322636.683…) is a full pixel too low: we must not reproduce it.
    assert!((c.upper_left[1] - 1322636.6830076217).abs() > 2000.0);
    // GDAL's warp to EPSG:4326 (quoted, indirect): west and north edges.
    let worst_m = assert_corners(
        wgs84_corners(&info),
        &[("upper_left", [69.15892987765864, 11.81870408668788])],
        1e-9,
    );
    // GDAL 3.6 wgs84Extent for the other corners.
    let worst_m = worst_m.max(assert_corners(
        wgs84_corners(&info),
        &[
            ("lower_left", [69.1589299, 1.4662483]),
            ("lower_right", [90.4284611, 1.4662483]),
            ("upper_right", [90.4284611, 11.8187041]),
        ],
        1e-6,
    ));
    eprintln!("gadas-export.png: worst corner error {worst_m:.3} m");

    let rgba = decode(&image);
    assert_eq!(pixel(&rgba, 968, 0, 0), [61, 102, 160, 255]);
    assert_eq!(pixel(&rgba, 968, 484, 237), [87, 133, 170, 255]);
    // georaster (quoted): band sums.
    let sums: Vec<u64> = (0..4)
        .map(|b| channel(&rgba, b).map(u64::from).sum())
        .collect();
    assert_eq!(sums, [33119890, 52234997, 71075206, 117249000]);
}

#[test]
fn bessel_towgs84_tiepoint_at_image_centre() {
    let name = "GeogToWGS84GeoKey5.tif";
    let Some(path) = sample(name, "bessel_towgs84_tiepoint_at_image_centre") else {
        return;
    };
    let image = open(&path);
    let info = image.info();
    let crs = image.crs().expect("a CRS");
    // georaster (quoted) reports projection 32767: user-defined, no EPSG code.
    assert_eq!(crs.epsg, None);
    assert!(
        crs.proj_string.contains("+ellps=bessel"),
        "{}",
        crs.proj_string
    );
    assert!(
        crs.datum_shift
            .contains("598.1,73.7,418.2,0.202,0.045,-2.455,6.7")
    );
    // Tie point at raster (50.5, 50.5) = centre of pixel (50, 50), in the Bessel datum.
    assert_eq!(
        image.pixel_to_model(50.5, 50.5),
        [9.0010573796, 52.0013760079]
    );
    // GDAL geotransform (gdalinfo, and SOURCES.md's computation).
    let gt = info.geo_transform;
    assert!((gt[0] - 8.999654601821101).abs() < 1e-12 && (gt[3] - 52.0027787856789).abs() < 1e-12);
    // GDAL 3.6 wgs84Extent, after the 7-parameter Helmert.
    let worst_m = assert_corners(
        wgs84_corners(&info),
        &[
            ("upper_left", [8.9985974, 52.0014026]),
            ("lower_left", [8.9985975, 51.9985974]),
            ("lower_right", [9.0014026, 51.9985974]),
            ("upper_right", [9.0014026, 52.0014026]),
        ],
        1e-6,
    );
    eprintln!("{name}: worst corner vs GDAL {worst_m:.3} m");
    // The sample is built so that its red pixel's centre is at 9°E 52°N in WGS 84.
    let [lon, lat] = image.pixel_to_wgs84(50.5, 50.5).unwrap();
    assert!(distance_m([lon, lat], [9.0, 52.0]) < 0.01, "({lon}, {lat})");

    // Palette: index 1 (dark red) at (50, 50), index 2 (near white) elsewhere.
    let rgba = decode(&image);
    assert_eq!(pixel(&rgba, 101, 50, 50), [191, 0, 0, 255]);
    assert_eq!(pixel(&rgba, 101, 0, 0), [254, 254, 254, 255]);
}

#[test]
fn wgs84_to_pixel_inverts_pixel_to_wgs84_on_every_sample() {
    let names = [
        "byte.tif",
        "m_3607824_se_17_1_20160620_sub.tif",
        "rgb_lzw.tif",
        "rgb-byte-tenth.tif",
        "world.rgb.tif",
        "rgb1_fake_nir_epsg3857.tif",
        "austrian_capitals_model_transformation_pixel_is_area.tif",
        "austrian_capitals_model_transformation_pixel_is_point.tif",
        "gadas-export.png",
        "GeogToWGS84GeoKey5.tif",
    ];
    for name in names {
        let Some(path) = sample(
            name,
            "wgs84_to_pixel_inverts_pixel_to_wgs84_on_every_sample",
        ) else {
            return;
        };
        let image = open(&path);
        let (col, row) = (
            f64::from(image.width()) * 0.3,
            f64::from(image.height()) * 0.7,
        );
        let [lon, lat] = image.pixel_to_wgs84(col, row).unwrap();
        let [c, r] = image.wgs84_to_pixel(lon, lat).unwrap();
        // Compared on the ground: a datum shift's geocentric → geodetic step iterates and is
        // good to about a millimetre, which is 1e-5 pixel on byte.tif and 1e-4 on the 3 m
        // pixels of GeogToWGS84GeoKey5.tif.
        let pixel_m = distance_m([lon, lat], image.pixel_to_wgs84(col + 1.0, row).unwrap());
        let error_m = (c - col).hypot(r - row) * pixel_m;
        assert!(
            error_m < 2e-3,
            "{name}: ({c}, {r}) vs ({col}, {row}), {error_m} m"
        );
    }
}
