//! UTC calendar date and time of day from a count of microseconds since 1970-01-01T00:00Z
//! (no leap seconds, as GNSS receivers print UTC).

use protocol::{Date, TimeOfDay};

/// Microseconds in a day.
const DAY_US: u64 = 86_400_000_000;

/// The UTC date and time of day `unix_us` µs after the Unix epoch.
pub fn utc_from_unix_us(unix_us: u64) -> (Date, TimeOfDay) {
    let days = unix_us / DAY_US;
    let of_day_us = unix_us % DAY_US;
    let seconds = of_day_us / 1_000_000;
    let time = TimeOfDay {
        hour: (seconds / 3_600) as u8,
        minute: (seconds / 60 % 60) as u8,
        second: (seconds % 60) as u8,
        micros: (of_day_us % 1_000_000) as u32,
    };
    (date_from_days(days), time)
}

/// The proleptic Gregorian date `days` days after 1970-01-01: counts 400-year eras of
/// 146 097 days from 0000-03-01, so that the leap day falls at the end of a year.
fn date_from_days(days: u64) -> Date {
    let shifted = days + 719_468;
    let era = shifted / 146_097;
    let day_of_era = shifted % 146_097;
    let year_of_era =
        (day_of_era - day_of_era / 1_460 + day_of_era / 36_524 - day_of_era / 146_096) / 365;
    let day_of_year = day_of_era - (365 * year_of_era + year_of_era / 4 - year_of_era / 100);
    let month_from_march = (5 * day_of_year + 2) / 153;
    let day = day_of_year - (153 * month_from_march + 2) / 5 + 1;
    let month = if month_from_march < 10 {
        month_from_march + 3
    } else {
        month_from_march - 9
    };
    let year = year_of_era + era * 400 + u64::from(month <= 2);
    Date {
        year: year as u16,
        month: month as u8,
        day: day as u8,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_instants() {
        let (date, time) = utc_from_unix_us(0);
        assert_eq!((date.year, date.month, date.day), (1970, 1, 1));
        assert_eq!((time.hour, time.minute, time.second), (0, 0, 0));
        // 2024-06-01T12:00:00.25Z.
        let (date, time) = utc_from_unix_us(1_717_243_200_250_000);
        assert_eq!((date.year, date.month, date.day), (2024, 6, 1));
        assert_eq!(
            (time.hour, time.minute, time.second, time.micros),
            (12, 0, 0, 250_000)
        );
        // Leap day and the day after.
        let (date, _) = utc_from_unix_us(1_709_164_800 * 1_000_000);
        assert_eq!((date.year, date.month, date.day), (2024, 2, 29));
        let (date, time) = utc_from_unix_us(1_709_251_199 * 1_000_000);
        assert_eq!((date.year, date.month, date.day), (2024, 2, 29));
        assert_eq!((time.hour, time.minute, time.second), (23, 59, 59));
        let (date, _) = utc_from_unix_us(1_709_251_200 * 1_000_000);
        assert_eq!((date.month, date.day), (3, 1));
    }
}
