//! The daemon's web view in a real browser.
//!
//! Starts `robot_host::web::WebServer` in-process on 127.0.0.1 with a live state holding a
//! trajectory, landmarks, a small occupancy grid, a pose with its covariance, counters and a
//! generated 400 × 300 geo-referenced image, then drives Debian's headless Chromium over the
//! DevTools protocol: the page must show the counters from the state and follow them when they
//! change, draw the map over the image where `pixel_from_map` puts it, set the goal where the
//! image is clicked (checked against the state and the goal resolver), and show the resolver's
//! refusal for a click outside the map and outside the image. With a camera, the panel must
//! show its newest frame with each feature's search ellipse and the corners found moving. The
//! screenshots are left in `target/tmp/`.
//!
//! Without `/usr/bin/chromium` the test prints that it skipped; with `CI` set it fails instead.

use std::error::Error;
use std::ffi::OsStr;
use std::net::{Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::sleep;
use std::time::{Duration, Instant};

use headless_chrome::browser::tab::point::Point;
use headless_chrome::protocol::cdp::Page::CaptureScreenshotFormatOption;
use headless_chrome::{Browser, LaunchOptions, Tab};
use robot_host::state::{
    CameraFeatureView, CameraStatus, CameraView, GridView, ImageView, LandmarkView,
};
use robot_host::web::{AccessPolicy, WebContext, WebLimits, WebServer};
use robot_host::{
    GoalError, GoalInMap, GoalRequest, GoalResolver, LinkCounters, LiveState, PoseView, SharedState,
};

type TestResult = Result<(), Box<dyn Error + Send + Sync>>;

/// Where Debian's `chromium` package puts the browser.
const CHROMIUM: &str = "/usr/bin/chromium";

/// Flags for a browser on a machine with no network: without the background-networking ones
/// Chromium hangs on refused connections.
const CHROMIUM_FLAGS: [&str; 8] = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
];

/// The browser window, CSS pixels.
const WINDOW_PX: (u32, u32) = (1280, 900);

/// How long to wait for the page to show something.
const PAGE_TIMEOUT: Duration = Duration::from_secs(15);

/// Size of the generated image, pixels.
const IMAGE_WIDTH_PX: u32 = 400;
const IMAGE_HEIGHT_PX: u32 = 300;

/// Map → image: 4 pixels per metre, the map origin at the image centre, y up
/// (`col = a + b·x + c·y`, `row = d + e·x + f·y`).
const PIXEL_FROM_MAP: [f64; 6] = [200.0, 4.0, 0.0, 150.0, 0.0, -4.0];
/// The resolver refuses goals east of this, metres: image columns beyond 320.
const MAP_EAST_LIMIT_M: f64 = 30.0;
/// WGS84 position of the map origin, degrees.
const ORIGIN_LAT_LON_DEG: [f64; 2] = [48.0, 11.0];
/// Metres per degree of latitude and of longitude near the origin (flat, enough for a test).
const M_PER_DEG: [f64; 2] = [111_320.0, 74_488.0];

/// Landmark colour on the page (app.js `COLOURS.landmark`, #ff9800).
const LANDMARK_RGB: [u8; 3] = [255, 152, 0];
/// Goal marker colour on the page (app.js `COLOURS.goal`, #d500f9).
const GOAL_RGB: [u8; 3] = [213, 0, 249];

/// Image pixels → map through the inverse of [`PIXEL_FROM_MAP`]; records every request.
#[derive(Default)]
struct RecordingResolver {
    requests: Mutex<Vec<GoalRequest>>,
}

impl RecordingResolver {
    fn requests(&self) -> Vec<GoalRequest> {
        self.requests
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .clone()
    }
}

impl GoalResolver for RecordingResolver {
    fn resolve(&self, request: &GoalRequest) -> Result<GoalInMap, GoalError> {
        self.requests
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .push(*request);
        let GoalRequest::Pixel { pixel_x, pixel_y } = *request else {
            return Err(GoalError::Invalid(
                "this test sets goals by pixel".to_owned(),
            ));
        };
        let (width, height) = (f64::from(IMAGE_WIDTH_PX), f64::from(IMAGE_HEIGHT_PX));
        if !(0.0..=width).contains(&pixel_x) || !(0.0..=height).contains(&pixel_y) {
            return Err(GoalError::OutsideImage {
                x: pixel_x,
                y: pixel_y,
                width: IMAGE_WIDTH_PX,
                height: IMAGE_HEIGHT_PX,
            });
        }
        let [x_m, y_m] = map_from_pixel([pixel_x, pixel_y]);
        let lat_deg = ORIGIN_LAT_LON_DEG[0] + y_m / M_PER_DEG[0];
        let lon_deg = ORIGIN_LAT_LON_DEG[1] + x_m / M_PER_DEG[1];
        if x_m > MAP_EAST_LIMIT_M {
            return Err(GoalError::OutsideMap {
                lat_deg,
                lon_deg,
                reason: format!("{x_m:.1} m east of the origin; the map ends at 30 m"),
            });
        }
        Ok(GoalInMap {
            x_m,
            y_m,
            lat_deg,
            lon_deg,
            pixel: Some([pixel_x, pixel_y]),
        })
    }
}

fn pixel_from_map([x_m, y_m]: [f64; 2]) -> [f64; 2] {
    let [a, b, c, d, e, f] = PIXEL_FROM_MAP;
    [a + b * x_m + c * y_m, d + e * x_m + f * y_m]
}

fn map_from_pixel([column, row]: [f64; 2]) -> [f64; 2] {
    let [a, b, _, d, _, f] = PIXEL_FROM_MAP;
    [(column - a) / b, (row - d) / f]
}

/// An aerial-looking RGB image: meadow, a field, a road along the bottom.
fn generated_image_png() -> Vec<u8> {
    let mut rgb = Vec::with_capacity((IMAGE_WIDTH_PX * IMAGE_HEIGHT_PX * 3) as usize);
    for row in 0..IMAGE_HEIGHT_PX {
        for column in 0..IMAGE_WIDTH_PX {
            let shade = ((column / 8 + row / 8) % 2) as u8 * 10;
            let pixel = if (255..285).contains(&row) {
                [150, 150, 145]
            } else if (230..390).contains(&column) && (20..120).contains(&row) {
                [190 + shade, 170 + shade, 110]
            } else {
                [70 + shade, 130 + shade, 60]
            };
            rgb.extend_from_slice(&pixel);
        }
    }
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, IMAGE_WIDTH_PX, IMAGE_HEIGHT_PX);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().expect("PNG header");
    writer.write_image_data(&rgb).expect("PNG data");
    writer.finish().expect("PNG end");
    png_bytes
}

/// The occupancy grid: a 10 m × 6 m building with 0.5 m walls, lower-left at (-40, 10) m.
const GRID_ORIGIN_M: [f64; 2] = [-40.0, 10.0];
const GRID_RESOLUTION_M: f64 = 0.1;
const GRID_CELLS: [u32; 2] = [100, 60];
const WALL_CELLS: u32 = 5;

fn building_grid() -> GridView {
    let [width, height] = GRID_CELLS;
    let mut grey = Vec::with_capacity((width * height) as usize);
    for row in 0..height {
        for column in 0..width {
            let wall = column < WALL_CELLS
                || column >= width - WALL_CELLS
                || row < WALL_CELLS
                || row >= height - WALL_CELLS;
            // A door in the south wall.
            let door = row >= height - WALL_CELLS && (45..55).contains(&column);
            grey.push(match (wall, door) {
                (true, false) => 0,
                _ => 254,
            });
        }
    }
    let mut png_bytes = Vec::new();
    let mut encoder = png::Encoder::new(&mut png_bytes, width, height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().expect("PNG header");
    writer.write_image_data(&grey).expect("PNG data");
    writer.finish().expect("PNG end");
    GridView {
        png: png_bytes,
        resolution_m: GRID_RESOLUTION_M,
        origin_m: GRID_ORIGIN_M,
        size_cells: GRID_CELLS,
    }
}

/// Landmarks on a ring around the trajectory.
fn landmarks_m() -> Vec<[f64; 2]> {
    (0..12)
        .map(|k| {
            let angle = f64::from(k) * 30f64.to_radians();
            [-5.0 + 28.0 * angle.cos(), -2.0 + 18.0 * angle.sin()]
        })
        .collect()
}

/// A figure-of-eight drive leaving the building's door.
fn trajectory_m() -> Vec<[f64; 2]> {
    let mut points = vec![[-35.0, 12.0], [-35.0, 6.0], [-20.0, 0.0]];
    points.extend((0..=90).map(|i| {
        let t = f64::from(i) / 90.0 * 1.8 * std::f64::consts::PI;
        [-5.0 - 15.0 * (t).cos(), -2.0 + 11.0 * (2.0 * t).sin()]
    }));
    points
}

fn filled_state() -> LiveState {
    let trajectory = trajectory_m();
    let [last, before] = [
        trajectory[trajectory.len() - 1],
        trajectory[trajectory.len() - 2],
    ];
    let pose = PoseView {
        x_m: last[0],
        y_m: last[1],
        theta_rad: (last[1] - before[1]).atan2(last[0] - before[0]),
        lat_deg: Some(ORIGIN_LAT_LON_DEG[0] + last[1] / M_PER_DEG[0]),
        lon_deg: Some(ORIGIN_LAT_LON_DEG[1] + last[0] / M_PER_DEG[1]),
        position_cov_m2: [1.5, 0.6, 0.8],
        time_s: 321.0,
    };
    LiveState {
        pose,
        trajectory_m: trajectory,
        landmarks: landmarks_m()
            .into_iter()
            .map(|[x_m, y_m]| LandmarkView {
                x_m,
                y_m,
                lat_lon_deg: None,
            })
            .collect(),
        grid: Some(building_grid()),
        counters: LinkCounters {
            frames: 12_400,
            frames_lost: 2,
            crc_errors: 3,
            telegrams: 12_345,
            telegram_crc_errors: 7,
            gps_fixes: 980,
            gps_fix_quality: 4,
            gps_satellites: 11,
            reconnects: 1,
            board_restarts: 2,
            clock_synchronised: true,
        },
        image: Some(ImageView {
            width: IMAGE_WIDTH_PX,
            height: IMAGE_HEIGHT_PX,
            crs: "EPSG:32632".to_owned(),
        }),
        pixel_from_map: Some(PIXEL_FROM_MAP),
        ..LiveState::default()
    }
}

/// Evaluates `expression` in the page and returns its value as JSON.
fn evaluate(
    tab: &Tab,
    expression: &str,
) -> Result<serde_json::Value, Box<dyn Error + Send + Sync>> {
    let result = tab.evaluate(expression, false)?;
    match result.value {
        Some(value) => Ok(value),
        None => Err(format!("`{expression}` gave no value: {:?}", result.description).into()),
    }
}

fn text(tab: &Tab, id: &str) -> Result<String, Box<dyn Error + Send + Sync>> {
    let value = evaluate(tab, &format!("document.getElementById('{id}').textContent"))?;
    Ok(value.as_str().unwrap_or_default().to_owned())
}

fn number(tab: &Tab, expression: &str) -> Result<f64, Box<dyn Error + Send + Sync>> {
    let value = evaluate(tab, expression)?;
    value
        .as_f64()
        .ok_or_else(|| format!("`{expression}` is not a number: {value}").into())
}

/// JavaScript: whether the element `id` is shown (not `display: none`).
fn shown(id: &str) -> String {
    format!("(getComputedStyle(document.getElementById('{id}')).display !== 'none')")
}

/// Waits until the JavaScript `condition` holds in the page.
fn wait_until(tab: &Tab, what: &str, condition: &str) -> TestResult {
    let deadline = Instant::now() + PAGE_TIMEOUT;
    loop {
        if evaluate(tab, condition)?.as_bool() == Some(true) {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err(format!("the page did not show {what} within {PAGE_TIMEOUT:?}").into());
        }
        sleep(Duration::from_millis(50));
    }
}

/// Where the page draws the image: the canvas's position in the window and the image fitted
/// into it (scaled to fit, centred), as app.js's `fitImage` documents.
struct ImageOnPage {
    canvas_left: f64,
    canvas_top: f64,
    scale: f64,
    offset: [f64; 2],
}

impl ImageOnPage {
    fn measure(tab: &Tab) -> Result<Self, Box<dyn Error + Send + Sync>> {
        let rect = "document.getElementById('view').getBoundingClientRect()";
        let width = number(tab, &format!("{rect}.width"))?;
        let height = number(tab, &format!("{rect}.height"))?;
        let (image_width, image_height) = (f64::from(IMAGE_WIDTH_PX), f64::from(IMAGE_HEIGHT_PX));
        let scale = (width / image_width).min(height / image_height);
        Ok(ImageOnPage {
            canvas_left: number(tab, &format!("{rect}.left"))?,
            canvas_top: number(tab, &format!("{rect}.top"))?,
            scale,
            offset: [
                (width - scale * image_width) / 2.0,
                (height - scale * image_height) / 2.0,
            ],
        })
    }

    /// Canvas coordinates (CSS pixels) of an image pixel.
    fn canvas_from_pixel(&self, [column, row]: [f64; 2]) -> [f64; 2] {
        [
            self.offset[0] + self.scale * column,
            self.offset[1] + self.scale * row,
        ]
    }

    /// The window point over `pixel`, rounded to whole CSS pixels, and the image pixel under
    /// that point.
    fn click_point(&self, pixel: [f64; 2]) -> (Point, [f64; 2]) {
        let [x, y] = self.canvas_from_pixel(pixel);
        let window = [
            (self.canvas_left + x).round(),
            (self.canvas_top + y).round(),
        ];
        let under = [
            (window[0] - self.canvas_left - self.offset[0]) / self.scale,
            (window[1] - self.canvas_top - self.offset[1]) / self.scale,
        ];
        (
            Point {
                x: window[0],
                y: window[1],
            },
            under,
        )
    }
}

/// The canvas's colour at canvas point `[x, y]` (CSS pixels).
fn canvas_rgb(tab: &Tab, [x, y]: [f64; 2]) -> Result<[u8; 3], Box<dyn Error + Send + Sync>> {
    let expression = format!(
        "(() => {{ const c = document.getElementById('view'); \
         const k = c.width / c.getBoundingClientRect().width; \
         const d = c.getContext('2d').getImageData(Math.floor({x} * k), Math.floor({y} * k), 1, 1).data; \
         return `${{d[0]}},${{d[1]}},${{d[2]}}`; }})()"
    );
    rgb_of(&evaluate(tab, &expression)?)
}

/// The colour the page's `` `${r},${g},${b}` `` answer names.
fn rgb_of(value: &serde_json::Value) -> Result<[u8; 3], Box<dyn Error + Send + Sync>> {
    let channels: Vec<u8> = value
        .as_str()
        .unwrap_or_default()
        .split(',')
        .map(str::parse)
        .collect::<Result<_, _>>()?;
    channels
        .try_into()
        .map_err(|c| format!("not a colour: {c:?}").into())
}

fn colour_is_near(actual: [u8; 3], expected: [u8; 3]) -> bool {
    actual
        .iter()
        .zip(expected)
        .all(|(a, e)| a.abs_diff(e) <= 40)
}

/// Waits until the canvas shows about `expected` at canvas point `at` (CSS pixels).
fn wait_for_colour(tab: &Tab, what: &str, at: [f64; 2], expected: [u8; 3]) -> TestResult {
    let deadline = Instant::now() + PAGE_TIMEOUT;
    loop {
        let actual = canvas_rgb(tab, at)?;
        if colour_is_near(actual, expected) {
            return Ok(());
        }
        if Instant::now() > deadline {
            return Err(format!(
                "{what}: the canvas shows {actual:?} at {at:?}, expected about {expected:?}"
            )
            .into());
        }
        sleep(Duration::from_millis(50));
    }
}

fn stored_goal(state: &SharedState) -> Option<GoalInMap> {
    state.read().unwrap_or_else(PoisonError::into_inner).goal
}

/// A web server on 127.0.0.1 and a headless Chromium showing its page.
struct Session {
    server: WebServer,
    state: SharedState,
    resolver: Arc<RecordingResolver>,
    browser: Browser,
    tab: Arc<Tab>,
    /// The browser's fresh profile, removed at the end.
    _profile: tempfile::TempDir,
}

impl Session {
    /// Serves `state` (and `image_png`) and opens the page, or returns `None` when Chromium is
    /// missing and `CI` is not set.
    ///
    /// # Panics
    /// When Chromium is missing and `CI` is set.
    fn open(
        test: &str,
        state: LiveState,
        image_png: Option<Vec<u8>>,
    ) -> Result<Option<Session>, Box<dyn Error + Send + Sync>> {
        if !Path::new(CHROMIUM).exists() {
            let why = format!("{test}: {CHROMIUM} not found");
            if datasets::in_ci() {
                panic!("{why}; failing because CI is set (install the chromium package)");
            }
            eprintln!("SKIPPED {why}");
            return Ok(None);
        }
        let shared = LiveState::shared();
        *shared.write().unwrap_or_else(PoisonError::into_inner) = state;
        let resolver = Arc::new(RecordingResolver::default());
        let server = WebServer::start(
            SocketAddr::from((Ipv4Addr::LOCALHOST, 0)),
            WebContext {
                state: shared.clone(),
                goal: resolver.clone(),
                image_png: image_png.map(Arc::new),
                access: AccessPolicy::open(),
                limits: WebLimits::default(),
            },
        )?;
        let profile = tempfile::tempdir()?;
        let options = LaunchOptions::default_builder()
            .path(Some(PathBuf::from(CHROMIUM)))
            .headless(true)
            .sandbox(false)
            .window_size(Some(WINDOW_PX))
            .user_data_dir(Some(profile.path().to_path_buf()))
            .args(CHROMIUM_FLAGS.iter().map(OsStr::new).collect())
            .idle_browser_timeout(Duration::from_secs(60))
            .build()?;
        let browser = Browser::new(options)?;
        let tab = browser.new_tab()?;
        tab.navigate_to(&format!("http://{}/", server.local_addr()))?
            .wait_until_navigated()?;
        Ok(Some(Session {
            server,
            state: shared,
            resolver,
            browser,
            tab,
            _profile: profile,
        }))
    }

    /// Saves a screenshot of the page as `target/tmp/NAME.png`.
    fn screenshot(&self, name: &str) -> TestResult {
        let png_bytes =
            self.tab
                .capture_screenshot(CaptureScreenshotFormatOption::Png, None, None, true)?;
        let path = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("{name}.png"));
        std::fs::write(&path, png_bytes)?;
        eprintln!("{name}: screenshot in {}", path.display());
        Ok(())
    }

    fn close(self) {
        drop(self.tab);
        drop(self.browser);
        self.server.stop();
    }
}

/// The view on a geo-referenced image: counters, the map over the image, goals set by click.
#[test]
fn web_view() -> TestResult {
    let Some(session) = Session::open("web_view", filled_state(), Some(generated_image_png()))?
    else {
        return Ok(());
    };
    let (tab, state) = (&session.tab, &session.state);

    // The counters come from the state, and follow it.
    wait_until(
        tab,
        "the telegram count",
        "document.getElementById('telegrams').textContent === '12345'",
    )?;
    assert_eq!(text(tab, "telegram-crc-errors")?, "7");
    assert_eq!(text(tab, "crc-errors")?, "3");
    assert_eq!(text(tab, "board-restarts")?, "2");
    assert_eq!(text(tab, "gps-fix")?, "RTK fixed");
    assert_eq!(text(tab, "gps-satellites")?, "11");
    assert_eq!(text(tab, "clock")?, "synchronised");
    assert_eq!(text(tab, "link-status")?, "live");
    state
        .write()
        .unwrap_or_else(PoisonError::into_inner)
        .counters
        .telegrams = 12_399;
    wait_until(
        tab,
        "the new telegram count",
        "document.getElementById('telegrams').textContent === '12399'",
    )?;

    // The map lies over the image where pixel_from_map puts it.
    wait_until(
        tab,
        "the image",
        &format!(
            "document.getElementById('view-note').textContent === '' && {}",
            shown("goal-hint")
        ),
    )?;
    let image = ImageOnPage::measure(tab)?;
    let landmark = landmarks_m()[3];
    wait_for_colour(
        tab,
        "a landmark",
        image.canvas_from_pixel(pixel_from_map(landmark)),
        LANDMARK_RGB,
    )?;
    let west_wall_m = [
        GRID_ORIGIN_M[0] + 0.25,
        GRID_ORIGIN_M[1] + 0.5 * f64::from(GRID_CELLS[1]) * GRID_RESOLUTION_M,
    ];
    wait_for_colour(
        tab,
        "the building's west wall",
        image.canvas_from_pixel(pixel_from_map(west_wall_m)),
        [0, 0, 0],
    )?;

    // A click on the image sets the goal there.
    let wanted_pixel = [260.0, 120.0];
    let (point, clicked_pixel) = image.click_point(wanted_pixel);
    tab.click_point(point)?;
    wait_until(tab, "the goal", &shown("goal"))?;
    let requests = session.resolver.requests();
    let [GoalRequest::Pixel { pixel_x, pixel_y }] = requests.as_slice() else {
        return Err(format!("expected one pixel goal request, got {requests:?}").into());
    };
    let tolerance_px = 0.5 / image.scale;
    assert!(
        (pixel_x - clicked_pixel[0]).abs() <= tolerance_px
            && (pixel_y - clicked_pixel[1]).abs() <= tolerance_px,
        "the page sent pixel ({pixel_x}, {pixel_y}), the click was over {clicked_pixel:?}"
    );
    let goal = stored_goal(state).ok_or("the goal was not stored in the state")?;
    assert_eq!([goal.x_m, goal.y_m], map_from_pixel([*pixel_x, *pixel_y]));
    let wanted_m = map_from_pixel(wanted_pixel);
    assert!(
        (goal.x_m - wanted_m[0]).abs() < 0.5 && (goal.y_m - wanted_m[1]).abs() < 0.5,
        "goal ({}, {}) m, clicked near {wanted_m:?} m",
        goal.x_m,
        goal.y_m
    );
    assert_eq!(text(tab, "goal-x")?, format!("{:.2}", goal.x_m));
    assert_eq!(text(tab, "goal-y")?, format!("{:.2}", goal.y_m));
    assert_eq!(text(tab, "goal-lat")?, format!("{:.7}", goal.lat_deg));
    assert_eq!(text(tab, "goal-lon")?, format!("{:.7}", goal.lon_deg));
    let goal_on_canvas = image.canvas_from_pixel([*pixel_x, *pixel_y]);
    wait_for_colour(
        tab,
        "the goal marker",
        [goal_on_canvas[0] + 12.0, goal_on_canvas[1]],
        GOAL_RGB,
    )?;

    // A click east of the map is refused with the resolver's reason; the goal stays.
    let (point, _) = image.click_point([360.0, 200.0]);
    tab.click_point(point)?;
    wait_until(tab, "the refusal", &shown("goal-error"))?;
    let refusal = text(tab, "goal-error")?;
    assert!(
        refusal.starts_with("Goal refused: ")
            && refusal.contains("is outside the map: ")
            && refusal.contains("m east of the origin; the map ends at 30 m"),
        "{refusal}"
    );
    assert_eq!(stored_goal(state), Some(goal));
    assert_eq!(text(tab, "goal-x")?, format!("{:.2}", goal.x_m));
    session.screenshot("web_view")?;

    // So is a click beside the image, in the band the fitted image leaves free.
    let beside = if image.offset[1] >= 5.0 {
        [100.0, -5.0]
    } else if image.offset[0] >= 5.0 {
        [-5.0, 100.0]
    } else {
        return Err("the image fills the canvas: no place beside it to click".into());
    };
    tab.click_point(Point {
        x: image.canvas_left + image.offset[0] + beside[0],
        y: image.canvas_top + image.offset[1] + beside[1],
    })?;
    wait_until(
        tab,
        "the refusal of a click beside the image",
        "document.getElementById('goal-error').textContent.includes('outside the 400×300 image')",
    )?;
    assert_eq!(stored_goal(state), Some(goal));

    session.close();
    Ok(())
}

/// Where the page draws the map in its own frame without an image: everything kept in view
/// (trajectory, landmarks, grid corners, pose) fitted with a 24 px margin, centred, y up, as
/// app.js's `fitMap` documents. Returns the canvas point of `point_m`.
fn canvas_from_map_fitted(
    state: &LiveState,
    width: f64,
    height: f64,
    point_m: [f64; 2],
) -> [f64; 2] {
    const MARGIN_PX: f64 = 24.0;
    let mut points: Vec<[f64; 2]> = state.trajectory_m.clone();
    points.extend(state.landmarks.iter().map(|l| [l.x_m, l.y_m]));
    if let Some(grid) = &state.grid {
        let [w, h] = grid.size_cells.map(f64::from);
        points.push(grid.origin_m);
        points.push([
            grid.origin_m[0] + w * grid.resolution_m,
            grid.origin_m[1] + h * grid.resolution_m,
        ]);
    }
    points.push([state.pose.x_m, state.pose.y_m]);
    let min = |axis: usize| points.iter().map(|p| p[axis]).fold(f64::INFINITY, f64::min);
    let max = |axis: usize| {
        points
            .iter()
            .map(|p| p[axis])
            .fold(f64::NEG_INFINITY, f64::max)
    };
    let span = [(max(0) - min(0)).max(1.0), (max(1) - min(1)).max(1.0)];
    let scale = ((width - 2.0 * MARGIN_PX) / span[0]).min((height - 2.0 * MARGIN_PX) / span[1]);
    [
        (width - scale * span[0]) / 2.0 + scale * (point_m[0] - min(0)),
        (height - scale * span[1]) / 2.0 + scale * (min(1) + span[1] - point_m[1]),
    ]
}

/// The view without an image: the map drawn in its own frame, and no goal set by click.
#[test]
fn web_view_without_image() -> TestResult {
    let mut filled = filled_state();
    filled.image = None;
    filled.pixel_from_map = None;
    let Some(session) = Session::open("web_view_without_image", filled.clone(), None)? else {
        return Ok(());
    };
    let tab = &session.tab;
    wait_until(
        tab,
        "the note on the map's frame",
        "document.getElementById('view-note').textContent.startsWith('No geo-referenced image')",
    )?;
    assert_eq!(text(tab, "telegrams")?, "12345");
    for hidden in ["goal-hint", "goal"] {
        assert_eq!(
            evaluate(tab, &shown(hidden))?,
            serde_json::Value::Bool(false),
            "{hidden} is shown"
        );
    }

    let rect = "document.getElementById('view').getBoundingClientRect()";
    let (width, height) = (
        number(tab, &format!("{rect}.width"))?,
        number(tab, &format!("{rect}.height"))?,
    );
    let landmark = landmarks_m()[3];
    wait_for_colour(
        tab,
        "a landmark",
        canvas_from_map_fitted(&filled, width, height, landmark),
        LANDMARK_RGB,
    )?;
    let west_wall_m = [
        GRID_ORIGIN_M[0] + 0.25,
        GRID_ORIGIN_M[1] + 0.5 * f64::from(GRID_CELLS[1]) * GRID_RESOLUTION_M,
    ];
    wait_for_colour(
        tab,
        "the building's west wall",
        canvas_from_map_fitted(&filled, width, height, west_wall_m),
        [0, 0, 0],
    )?;

    tab.click_point(Point {
        x: number(tab, &format!("{rect}.left"))? + width / 2.0,
        y: number(tab, &format!("{rect}.top"))? + height / 2.0,
    })?;
    wait_until(
        tab,
        "the explanation that goals need the image",
        "document.getElementById('goal-error').textContent.startsWith('Goals are set by clicking')",
    )?;
    assert!(session.resolver.requests().is_empty());
    assert_eq!(stored_goal(&session.state), None);
    session.screenshot("web_view_without_image")?;
    session.close();
    Ok(())
}

/// The camera panel's canvas colour at pixel `[x, y]` of the frame it draws.
fn camera_rgb(tab: &Tab, [x, y]: [u32; 2]) -> Result<[u8; 3], Box<dyn Error + Send + Sync>> {
    let expression = format!(
        "(() => {{ const d = document.getElementById('camera').getContext('2d')\
         .getImageData({x}, {y}, 1, 1).data; return `${{d[0]}},${{d[1]}},${{d[2]}}`; }})()"
    );
    rgb_of(&evaluate(tab, &expression)?)
}

/// A 320 × 240 grey frame: a dark left half and a light right half.
fn camera_frame_jpeg() -> Vec<u8> {
    let frame = image::GrayImage::from_fn(320, 240, |x, _| {
        image::Luma([if x < 160 { 40 } else { 200 }])
    });
    robot_host::camera_capture::encode_jpeg(&frame, 90).expect("a JPEG")
}

/// The camera panel: the newest frame, each feature's 3σ search ellipse, the corners found
/// moving, and the method's counts.
#[test]
fn web_view_camera() -> TestResult {
    let mut state = filled_state();
    state.camera = Some(CameraView {
        jpegs: [(7, Arc::new(camera_frame_jpeg()))].into(),
        status: CameraStatus {
            source: "/dev/video0".to_owned(),
            frame: 7,
            time_s: 12.5,
            size_px: [320, 240],
            frames_captured: 9,
            frames_skipped: 2,
            frames_refused: 0,
            tracking: true,
            // 4 px standard deviation on each axis: the 3σ ellipse is a 12-px circle.
            features: vec![CameraFeatureView {
                pixel: [100.0, 120.0],
                covariance_px2: [16.0, 0.0, 16.0],
            }],
            measured: 1,
            added: Vec::new(),
            moving: vec![[[250.0, 60.0], [230.0, 60.0]]],
            local_maps: 2,
            places_recognised: 1,
            rejected_as_moving: 3,
            scale_from_gps: Some(1.25),
        },
    });
    let Some(session) = Session::open("web_view_camera", state, Some(generated_image_png()))?
    else {
        return Ok(());
    };
    let tab = &session.tab;
    wait_until(tab, "the camera panel", &shown("camera-panel"))?;
    wait_until(
        tab,
        "the camera frame",
        "document.getElementById('camera').width === 320",
    )?;
    assert_eq!(
        number(tab, "document.getElementById('camera').height")?,
        240.0
    );
    // The frame itself, away from the drawings.
    let dark = camera_rgb(tab, [40, 200])?;
    let light = camera_rgb(tab, [300, 200])?;
    assert!(dark.iter().all(|&c| c.abs_diff(40) <= 10), "{dark:?}");
    assert!(light.iter().all(|&c| c.abs_diff(200) <= 10), "{light:?}");
    // The feature's search ellipse, 12 px about its pixel; not inside it.
    let feature_yellow = [0xff, 0xd2, 0x1f];
    let on_ellipse = camera_rgb(tab, [112, 120])?;
    assert!(colour_is_near(on_ellipse, feature_yellow), "{on_ellipse:?}");
    let inside = camera_rgb(tab, [106, 120])?;
    assert!(inside.iter().all(|&c| c.abs_diff(40) <= 10), "{inside:?}");
    // The moving corner in blue, and its way from where it was.
    let moving_blue = [0x2f, 0x7d, 0xff];
    for at in [[250, 60], [240, 60]] {
        let colour = camera_rgb(tab, at)?;
        assert!(colour_is_near(colour, moving_blue), "{at:?}: {colour:?}");
    }
    let note = text(tab, "camera-note")?;
    for part in [
        "/dev/video0: frame 7",
        "1 features looked for, 1 measured",
        "2 local maps",
        "1 places recognised",
        "3 rejected as moving",
        "1.250 m per map unit from GPS",
        "2 frames skipped",
    ] {
        assert!(note.contains(part), "{part:?} in {note:?}");
    }
    session.screenshot("web_view_camera")?;
    session.close();
    Ok(())
}
