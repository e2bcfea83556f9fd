//! Value parsers of the subcommands' flags: numbers in a range (standard deviations,
//! distances in pixels, weights, fractions) and a geodetic datum.

/// Parses a number in `range` (finite); `rule` says what the range is in the error.
pub fn parse_in(
    text: &str,
    range: std::ops::RangeInclusive<f64>,
    rule: &str,
) -> Result<f64, String> {
    let value: f64 = text.trim().parse().map_err(|e| format!("{text:?}: {e}"))?;
    if value.is_finite() && range.contains(&value) {
        Ok(value)
    } else {
        Err(format!("{text:?}: {rule}"))
    }
}

/// Parses a standard deviation: a finite number, at least 0.
pub fn parse_sigma(text: &str) -> Result<f64, String> {
    parse_in(
        text,
        0.0..=f64::INFINITY,
        "a standard deviation must be a finite number of at least 0",
    )
}

/// Parses a distance in pixels: a finite number, at least 0.
pub fn parse_pixels(text: &str) -> Result<f64, String> {
    parse_in(
        text,
        0.0..=f64::INFINITY,
        "a distance in pixels must be a finite number of at least 0",
    )
}

/// Parses a weight: a finite number, at least 0.
pub fn parse_weight(text: &str) -> Result<f64, String> {
    parse_in(
        text,
        0.0..=f64::INFINITY,
        "a weight must be a finite number of at least 0",
    )
}

/// Parses a fraction: a number from 0 to 1.
pub fn parse_fraction(text: &str) -> Result<f64, String> {
    parse_in(text, 0.0..=1.0, "a fraction must lie between 0 and 1")
}

/// Parses `LAT,LON` in degrees into a local frame at sea level.
pub fn parse_datum(text: &str) -> Result<host::georef::LocalFrame, String> {
    let (lat, lon) = text
        .split_once(',')
        .ok_or_else(|| format!("{text:?}: expected LAT,LON in degrees"))?;
    let lat_deg: f64 = lat
        .trim()
        .parse()
        .map_err(|e| format!("latitude {lat:?}: {e}"))?;
    let lon_deg: f64 = lon
        .trim()
        .parse()
        .map_err(|e| format!("longitude {lon:?}: {e}"))?;
    host::georef::LocalFrame::new(lat_deg, lon_deg, 0.0).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_standard_deviation_is_finite_and_not_negative() {
        assert_eq!(parse_sigma("0.5"), Ok(0.5));
        assert_eq!(parse_sigma(" 0 "), Ok(0.0));
        for bad in ["-1", "NaN", "inf", "half"] {
            assert!(parse_sigma(bad).is_err(), "{bad}");
        }
    }
}
