//! Goals set on the image: pixel → WGS84 (through the image's geo-referencing) → the local
//! metric frame at the datum (`enu`) → the map frame, through the map's alignment to GPS.

use std::sync::Arc;

use crate::state::{GoalError, GoalInMap, GoalRequest, GoalResolver, SharedState};
use host::geoimage::GeoImage;
use host::geometry::Pose2;
use host::georef::LocalFrame;

/// Resolves goals against the live map and the geo-referenced image.
pub struct MapGoalResolver {
    state: SharedState,
    image: Option<Arc<GeoImage>>,
    margin_m: f64,
}

impl MapGoalResolver {
    /// A resolver reading the map from `state`, pixels from `image`; goals farther than
    /// `margin_m` from the map are refused.
    pub fn new(state: SharedState, image: Option<Arc<GeoImage>>, margin_m: f64) -> Self {
        MapGoalResolver {
            state,
            image,
            margin_m,
        }
    }

    /// `[lon_deg, lat_deg]` of the request, checked.
    fn geodetic(&self, request: &GoalRequest) -> Result<[f64; 2], GoalError> {
        match *request {
            GoalRequest::Pixel { pixel_x, pixel_y } => {
                if !(pixel_x.is_finite() && pixel_y.is_finite()) {
                    return Err(GoalError::Invalid(
                        "pixel_x and pixel_y must be numbers".into(),
                    ));
                }
                let image = self.image.as_ref().ok_or_else(|| {
                    GoalError::NotGeoreferenced("there is no geo-referenced image".into())
                })?;
                let (width, height) = (image.width(), image.height());
                if pixel_x < 0.0
                    || pixel_y < 0.0
                    || pixel_x > f64::from(width)
                    || pixel_y > f64::from(height)
                {
                    return Err(GoalError::OutsideImage {
                        x: pixel_x,
                        y: pixel_y,
                        width,
                        height,
                    });
                }
                image
                    .pixel_to_wgs84(pixel_x, pixel_y)
                    .map_err(|e| GoalError::Invalid(e.to_string()))
            }
            GoalRequest::Geodetic { lat_deg, lon_deg } => {
                if !(lat_deg.is_finite() && lat_deg.abs() <= 90.0) {
                    return Err(GoalError::Invalid(format!(
                        "lat_deg must be within ±90°, got {lat_deg}"
                    )));
                }
                if !(lon_deg.is_finite() && lon_deg.abs() <= 180.0) {
                    return Err(GoalError::Invalid(format!(
                        "lon_deg must be within ±180°, got {lon_deg}"
                    )));
                }
                Ok([lon_deg, lat_deg])
            }
        }
    }
}

impl GoalResolver for MapGoalResolver {
    fn resolve(&self, request: &GoalRequest) -> Result<GoalInMap, GoalError> {
        let [lon_deg, lat_deg] = self.geodetic(request)?;
        let (datum, enu_from_map, map_points) = {
            let state = self
                .state
                .read()
                .map_err(|_| GoalError::NotGeoreferenced("the map is not available".into()))?;
            let datum = state.datum_lat_lon_deg.ok_or_else(|| {
                GoalError::NotGeoreferenced(
                    "the map is not aligned to GPS yet (drive a few tens of metres with a fix)"
                        .into(),
                )
            })?;
            let points: Vec<[f64; 2]> = state
                .trajectory_m
                .iter()
                .copied()
                .chain(state.landmarks.iter().map(|l| [l.x_m, l.y_m]))
                .collect();
            (datum, state.enu_from_map.unwrap_or(Pose2::IDENTITY), points)
        };
        let frame = LocalFrame::new(datum[0], datum[1], 0.0)
            .map_err(|e| GoalError::Invalid(e.to_string()))?;
        let [east_m, north_m, _] = frame
            .to_enu_m(lat_deg, lon_deg, 0.0)
            .map_err(|e| GoalError::Invalid(e.to_string()))?;
        let [x_m, y_m] = enu_from_map.inverse().transform_point([east_m, north_m]);
        let nearest_m = map_points
            .iter()
            .map(|p| (p[0] - x_m).hypot(p[1] - y_m))
            .fold(f64::INFINITY, f64::min);
        if nearest_m > self.margin_m {
            let reason = if nearest_m.is_finite() {
                format!(
                    "it is {nearest_m:.0} m from the nearest mapped point, more than {:.0} m",
                    self.margin_m
                )
            } else {
                "nothing is mapped yet".to_string()
            };
            return Err(GoalError::OutsideMap {
                lat_deg,
                lon_deg,
                reason,
            });
        }
        let pixel = self.image.as_ref().and_then(|image| {
            image.wgs84_to_pixel(lon_deg, lat_deg).ok().filter(|p| {
                (0.0..=f64::from(image.width())).contains(&p[0])
                    && (0.0..=f64::from(image.height())).contains(&p[1])
            })
        });
        let goal = GoalInMap {
            x_m,
            y_m,
            lat_deg,
            lon_deg,
            pixel,
        };
        if let Ok(mut state) = self.state.write() {
            state.goal = Some(goal);
        }
        Ok(goal)
    }
}
