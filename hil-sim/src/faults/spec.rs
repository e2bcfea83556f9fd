//! The faults to inject, as given on the command line with `--faults`.
//!
//! The value is a comma-separated list of items (an empty string means no faults):
//!
//! | item                   | meaning                                                         |
//! |------------------------|-----------------------------------------------------------------|
//! | `ber=RATE`             | probability that a bit on a sensor line is flipped              |
//! | `drop=RATE`            | probability that a byte on a sensor line is lost                |
//! | `truncate=RATE`        | probability that a laser telegram is cut short                  |
//! | `laser-restart=T_S`    | the laser is power cycled at `T_S` seconds                      |
//! | `gps-outage=T_S:DUR_S` | the GPS has no fix from `T_S` for `DUR_S` seconds               |
//! | `link-replug=T_S`      | the host link is unplugged and plugged back in at `T_S` seconds |
//!
//! Rates lie in `0..=1` and each rate key may appear once; times and durations are
//! non-negative seconds of simulated time, and the timed items may appear any number of times.
//! Numbers are anything [`f64`]'s `FromStr` accepts (`1e-5`, `0.25`, `30`) except NaN and
//! infinities.
//!
//! [`FaultSpec`]'s `Display` writes the canonical form: non-zero rates in the order of the
//! table, then the events of each kind sorted by time. Parsing the canonical form gives back
//! an equal spec.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

/// Keys of the three rate items, in canonical order.
const RATE_KEYS: [&str; 3] = ["ber", "drop", "truncate"];

/// Every key the parser knows, for error messages.
const KNOWN_KEYS: &str = "ber, drop, truncate, laser-restart, gps-outage, link-replug";

/// A period without a GPS fix.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct GpsOutage {
    /// When the fix is lost, in seconds of simulated time.
    pub start_s: f64,
    /// How long the fix stays lost, in seconds.
    pub duration_s: f64,
}

impl GpsOutage {
    /// When the fix comes back, in seconds of simulated time.
    pub fn end_s(&self) -> f64 {
        self.start_s + self.duration_s
    }

    /// Whether `t_s` falls inside the outage (start included, end excluded).
    pub fn contains(&self, t_s: f64) -> bool {
        (self.start_s..self.end_s()).contains(&t_s)
    }
}

/// The faults to inject in one run. See the [module documentation](self) for the syntax.
///
/// The default injects nothing.
#[derive(Debug, Clone, Default, PartialEq, Serialize)]
pub struct FaultSpec {
    /// Probability that a bit sent by a sensor is flipped (`ber=`), in `0..=1`.
    pub ber: f64,
    /// Probability that a byte sent by a sensor is lost (`drop=`), in `0..=1`.
    pub drop: f64,
    /// Probability that a laser telegram is cut short (`truncate=`), in `0..=1`.
    pub truncate: f64,
    /// When the laser is power cycled (`laser-restart=`), in seconds, sorted.
    pub laser_restarts_s: Vec<f64>,
    /// Periods without a GPS fix (`gps-outage=`), sorted by start.
    pub gps_outages: Vec<GpsOutage>,
    /// When the host link is unplugged and plugged back in (`link-replug=`), in seconds, sorted.
    pub link_replugs_s: Vec<f64>,
}

impl FaultSpec {
    /// Whether the spec injects nothing at all.
    pub fn is_empty(&self) -> bool {
        !self.has_byte_faults()
            && self.laser_restarts_s.is_empty()
            && self.gps_outages.is_empty()
            && self.link_replugs_s.is_empty()
    }

    /// Whether any of the byte-level rates (`ber`, `drop`, `truncate`) is non-zero.
    pub fn has_byte_faults(&self) -> bool {
        self.ber > 0.0 || self.drop > 0.0 || self.truncate > 0.0
    }

    /// Whether the GPS has no fix at `t_s` seconds because of one of the [`Self::gps_outages`].
    pub fn gps_outage_at(&self, t_s: f64) -> bool {
        self.gps_outages.iter().any(|outage| outage.contains(t_s))
    }

    /// The rate slot for a rate key, or `None` if `key` is not one.
    fn rate_mut(&mut self, key: &str) -> Option<&mut f64> {
        match key {
            "ber" => Some(&mut self.ber),
            "drop" => Some(&mut self.drop),
            "truncate" => Some(&mut self.truncate),
            _ => None,
        }
    }
}

impl FromStr for FaultSpec {
    type Err = FaultSpecError;

    /// Parses a `--faults` value. See the [module documentation](self) for the syntax.
    ///
    /// # Errors
    ///
    /// Returns a [`FaultSpecError`] naming the first item that is empty, has no `=`, has an
    /// unknown key, a value that is not a finite number, a rate outside `0..=1`, a negative
    /// time or duration, a `gps-outage` without `:DUR_S`, or repeats a rate key.
    fn from_str(s: &str) -> Result<FaultSpec, FaultSpecError> {
        let mut spec = FaultSpec::default();
        if s.trim().is_empty() {
            return Ok(spec);
        }
        let mut rates_seen = [false; RATE_KEYS.len()];
        for raw_item in s.split(',') {
            let item = raw_item.trim();
            let err = |kind, part: &str| FaultSpecError::new(kind, item, part);
            if item.is_empty() {
                return Err(err(FaultSpecErrorKind::EmptyItem, ""));
            }
            let Some((key, value)) = item.split_once('=') else {
                return Err(err(FaultSpecErrorKind::MissingEquals, item));
            };
            let (key, value) = (key.trim(), value.trim());
            if let Some(index) = RATE_KEYS.iter().position(|k| *k == key) {
                if rates_seen[index] {
                    return Err(err(FaultSpecErrorKind::DuplicateRate, key));
                }
                rates_seen[index] = true;
                let rate = parse_number(value)
                    .ok_or_else(|| err(FaultSpecErrorKind::NotANumber, value))?;
                if !(0.0..=1.0).contains(&rate) {
                    return Err(err(FaultSpecErrorKind::RateOutOfRange, value));
                }
                if let Some(slot) = spec.rate_mut(key) {
                    *slot = rate;
                }
                continue;
            }
            let time = |text: &str| -> Result<f64, FaultSpecError> {
                let t =
                    parse_number(text).ok_or_else(|| err(FaultSpecErrorKind::NotANumber, text))?;
                if t < 0.0 {
                    return Err(err(FaultSpecErrorKind::NegativeTime, text));
                }
                // Turns -0 into +0 so that the canonical form never shows "-0".
                Ok(t + 0.0)
            };
            match key {
                "laser-restart" => spec.laser_restarts_s.push(time(value)?),
                "link-replug" => spec.link_replugs_s.push(time(value)?),
                "gps-outage" => {
                    let Some((start, duration)) = value.split_once(':') else {
                        return Err(err(FaultSpecErrorKind::MissingDuration, value));
                    };
                    spec.gps_outages.push(GpsOutage {
                        start_s: time(start.trim())?,
                        duration_s: time(duration.trim())?,
                    });
                }
                _ => return Err(err(FaultSpecErrorKind::UnknownKey, key)),
            }
        }
        spec.laser_restarts_s.sort_by(f64::total_cmp);
        spec.link_replugs_s.sort_by(f64::total_cmp);
        spec.gps_outages.sort_by(|a, b| {
            a.start_s
                .total_cmp(&b.start_s)
                .then(a.duration_s.total_cmp(&b.duration_s))
        });
        Ok(spec)
    }
}

/// A finite number, or `None`.
fn parse_number(text: &str) -> Option<f64> {
    text.parse::<f64>().ok().filter(|x| x.is_finite())
}

impl fmt::Display for FaultSpec {
    /// Writes the canonical form, which [`FaultSpec::from_str`] parses back to an equal spec.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        // `f64`'s `Display` writes the shortest text that parses back to the same value.
        let rates = RATE_KEYS
            .iter()
            .zip([self.ber, self.drop, self.truncate])
            .filter(|(_, rate)| *rate > 0.0)
            .map(|(key, rate)| format!("{key}={rate}"));
        let restarts = self
            .laser_restarts_s
            .iter()
            .map(|t| format!("laser-restart={t}"));
        let outages = self
            .gps_outages
            .iter()
            .map(|o| format!("gps-outage={}:{}", o.start_s, o.duration_s));
        let replugs = self
            .link_replugs_s
            .iter()
            .map(|t| format!("link-replug={t}"));
        let items: Vec<String> = rates
            .chain(restarts)
            .chain(outages)
            .chain(replugs)
            .collect();
        f.write_str(&items.join(","))
    }
}

/// What is wrong with an item of a `--faults` value.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FaultSpecErrorKind {
    /// Two commas in a row, or a comma at either end.
    EmptyItem,
    /// The item is not `KEY=VALUE`.
    MissingEquals,
    /// The key is none of the known ones.
    UnknownKey,
    /// The value (or a part of it) is not a finite number.
    NotANumber,
    /// A rate lies outside `0..=1`.
    RateOutOfRange,
    /// A time or duration is negative.
    NegativeTime,
    /// A `gps-outage` value lacks the `:DUR_S` part.
    MissingDuration,
    /// A rate key appears a second time.
    DuplicateRate,
}

/// A `--faults` value that could not be parsed: which item, which part of it and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultSpecError {
    kind: FaultSpecErrorKind,
    item: String,
    part: String,
}

impl FaultSpecError {
    fn new(kind: FaultSpecErrorKind, item: &str, part: &str) -> FaultSpecError {
        FaultSpecError {
            kind,
            item: item.to_owned(),
            part: part.to_owned(),
        }
    }

    /// What is wrong.
    pub fn kind(&self) -> FaultSpecErrorKind {
        self.kind
    }

    /// The offending item, trimmed, e.g. `ber=2`.
    pub fn item(&self) -> &str {
        &self.item
    }
}

impl fmt::Display for FaultSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let FaultSpecError { kind, item, part } = self;
        match kind {
            FaultSpecErrorKind::EmptyItem => {
                f.write_str("empty item in fault list (two commas in a row?)")
            }
            FaultSpecErrorKind::MissingEquals => {
                write!(f, "fault \"{item}\": missing \"=\", expected KEY=VALUE")
            }
            FaultSpecErrorKind::UnknownKey => write!(
                f,
                "fault \"{item}\": unknown key \"{part}\", expected one of {KNOWN_KEYS}"
            ),
            FaultSpecErrorKind::NotANumber => {
                write!(f, "fault \"{item}\": \"{part}\" is not a finite number")
            }
            FaultSpecErrorKind::RateOutOfRange => {
                write!(f, "fault \"{item}\": rate {part} is outside 0..=1")
            }
            FaultSpecErrorKind::NegativeTime => {
                write!(f, "fault \"{item}\": time {part} s is negative")
            }
            FaultSpecErrorKind::MissingDuration => write!(
                f,
                "fault \"{item}\": expected gps-outage=START_S:DURATION_S, got \"{part}\""
            ),
            FaultSpecErrorKind::DuplicateRate => {
                write!(
                    f,
                    "fault \"{item}\": rate \"{part}\" is given more than once"
                )
            }
        }
    }
}

impl std::error::Error for FaultSpecError {}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Result<FaultSpec, FaultSpecError> {
        s.parse()
    }

    #[test]
    fn empty_is_no_faults() {
        for s in ["", "  "] {
            let spec = parse(s).unwrap();
            assert_eq!(spec, FaultSpec::default());
            assert!(spec.is_empty());
            assert_eq!(spec.to_string(), "");
        }
    }

    #[test]
    fn parses_every_key() {
        let spec = parse(
            "ber=1e-5, drop=0.001,truncate=0.25,laser-restart=30,gps-outage=60:15.5,\
             link-replug=90,laser-restart=10,gps-outage=5:1",
        )
        .unwrap();
        assert_eq!(spec.ber, 1e-5);
        assert_eq!(spec.drop, 0.001);
        assert_eq!(spec.truncate, 0.25);
        assert_eq!(spec.laser_restarts_s, [10.0, 30.0]);
        assert_eq!(
            spec.gps_outages,
            [
                GpsOutage {
                    start_s: 5.0,
                    duration_s: 1.0
                },
                GpsOutage {
                    start_s: 60.0,
                    duration_s: 15.5
                }
            ]
        );
        assert_eq!(spec.link_replugs_s, [90.0]);
        assert!(spec.has_byte_faults());
        assert!(!spec.is_empty());
        assert!(spec.gps_outage_at(60.0));
        assert!(spec.gps_outage_at(75.4));
        assert!(!spec.gps_outage_at(75.5));
        assert!(!spec.gps_outage_at(59.9));
    }

    #[test]
    fn rate_bounds_are_inclusive() {
        let spec = parse("ber=0,drop=1,truncate=0.0").unwrap();
        assert_eq!((spec.ber, spec.drop, spec.truncate), (0.0, 1.0, 0.0));
        assert_eq!(spec.to_string(), "drop=1");
    }

    #[test]
    fn display_is_canonical_and_round_trips() {
        let spec = parse(
            "link-replug=7,gps-outage=3:0.5,truncate=0.1,laser-restart=2.25,ber=0.001,\
             laser-restart=-0,drop=0",
        )
        .unwrap();
        let canonical = spec.to_string();
        assert_eq!(
            canonical,
            "ber=0.001,truncate=0.1,laser-restart=0,laser-restart=2.25,\
             gps-outage=3:0.5,link-replug=7"
        );
        assert_eq!(parse(&canonical).unwrap(), spec);
        // Awkward values survive the trip too.
        let spec = FaultSpec {
            ber: 1e-9,
            drop: 0.1 + 0.2,
            truncate: 1.0 / 3.0,
            laser_restarts_s: vec![1e-7, 12345.678],
            gps_outages: vec![GpsOutage {
                start_s: 0.1,
                duration_s: 1e10,
            }],
            link_replugs_s: vec![0.0],
        };
        assert_eq!(parse(&spec.to_string()).unwrap(), spec);
    }

    #[test]
    fn serializes_to_json() {
        let spec = parse("ber=0.5,gps-outage=1:2").unwrap();
        let json = serde_json::to_value(&spec).unwrap();
        assert_eq!(
            json,
            serde_json::json!({
                "ber": 0.5,
                "drop": 0.0,
                "truncate": 0.0,
                "laser_restarts_s": [],
                "gps_outages": [{"start_s": 1.0, "duration_s": 2.0}],
                "link_replugs_s": [],
            })
        );
    }

    #[track_caller]
    fn assert_error(s: &str, kind: FaultSpecErrorKind, item: &str, message: &str) {
        let err = parse(s).unwrap_err();
        assert_eq!(err.kind(), kind, "{s:?}");
        assert_eq!(err.item(), item, "{s:?}");
        assert_eq!(err.to_string(), message, "{s:?}");
    }

    #[test]
    fn bad_input_names_the_item_and_the_reason() {
        use FaultSpecErrorKind::*;
        assert_error(
            "ber=0.1,foo=1",
            UnknownKey,
            "foo=1",
            "fault \"foo=1\": unknown key \"foo\", expected one of ber, drop, truncate, \
             laser-restart, gps-outage, link-replug",
        );
        assert_error(
            "ber",
            MissingEquals,
            "ber",
            "fault \"ber\": missing \"=\", expected KEY=VALUE",
        );
        assert_error(
            "drop=lots",
            NotANumber,
            "drop=lots",
            "fault \"drop=lots\": \"lots\" is not a finite number",
        );
        assert_error(
            "ber=",
            NotANumber,
            "ber=",
            "fault \"ber=\": \"\" is not a finite number",
        );
        assert_error(
            "laser-restart=inf",
            NotANumber,
            "laser-restart=inf",
            "fault \"laser-restart=inf\": \"inf\" is not a finite number",
        );
        assert_error(
            "ber=NaN",
            NotANumber,
            "ber=NaN",
            "fault \"ber=NaN\": \"NaN\" is not a finite number",
        );
        assert_error(
            "gps-outage=5:x",
            NotANumber,
            "gps-outage=5:x",
            "fault \"gps-outage=5:x\": \"x\" is not a finite number",
        );
        assert_error(
            "truncate=1.5",
            RateOutOfRange,
            "truncate=1.5",
            "fault \"truncate=1.5\": rate 1.5 is outside 0..=1",
        );
        assert_error(
            "ber=-1e-3",
            RateOutOfRange,
            "ber=-1e-3",
            "fault \"ber=-1e-3\": rate -1e-3 is outside 0..=1",
        );
        assert_error(
            "link-replug=-2",
            NegativeTime,
            "link-replug=-2",
            "fault \"link-replug=-2\": time -2 s is negative",
        );
        assert_error(
            "gps-outage=10:-1",
            NegativeTime,
            "gps-outage=10:-1",
            "fault \"gps-outage=10:-1\": time -1 s is negative",
        );
        assert_error(
            "gps-outage=10",
            MissingDuration,
            "gps-outage=10",
            "fault \"gps-outage=10\": expected gps-outage=START_S:DURATION_S, got \"10\"",
        );
        assert_error(
            "ber=0,drop=0.1,ber=0.2",
            DuplicateRate,
            "ber=0.2",
            "fault \"ber=0.2\": rate \"ber\" is given more than once",
        );
        assert_error(
            "ber=0.1,,drop=0.1",
            EmptyItem,
            "",
            "empty item in fault list (two commas in a row?)",
        );
        assert_error(
            "ber=0.1,",
            EmptyItem,
            "",
            "empty item in fault list (two commas in a row?)",
        );
    }

    #[test]
    fn events_may_repeat() {
        let spec = parse("link-replug=4,link-replug=4,gps-outage=1:1,gps-outage=1:1").unwrap();
        assert_eq!(spec.link_replugs_s, [4.0, 4.0]);
        assert_eq!(spec.gps_outages.len(), 2);
        assert_eq!(parse(&spec.to_string()).unwrap(), spec);
    }
}
