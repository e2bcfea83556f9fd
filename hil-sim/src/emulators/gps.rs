//! An emulated NMEA 0183 GNSS receiver: a pure state machine that prints one burst of
//! sentences per epoch, paced at its baud rate (`shared/protocols/nmea0183.md`).
//!
//! Each epoch (`rate_hz` per second from [`GpsEmulatorOptions::first_epoch_us`]) the receiver
//! takes the true position — from [`GpsEmulator::set_truth`] or a trajectory function
//! ([`GpsEmulator::set_trajectory`]) — adds Gaussian noise, converts east/north metres to
//! latitude/longitude around [`GpsEmulatorOptions::datum`] with a local tangent-plane
//! approximation ([`GeoDatum`]), and writes, in u-blox order, RMC, VTG, GGA, GSA and GST
//! (the last three optional), all built with the firmware's `emit`. UTC time is
//! [`GpsEmulatorOptions::start_unix_us`] plus the epoch time; RMC carries the date.
//!
//! Without a fix ([`GpsEmulator::set_fix`]) the sentences of §9 are sent: time and date but
//! no position, GGA quality 0 with `00` satellites and HDOP 99.99, RMC status `V` mode `N`,
//! GSA fix type 1 with DOPs 99.99, VTG mode `N`, GST with empty statistics.
//!
//! Pacing: a burst starts [`GpsEmulatorOptions::output_delay_us`] after its epoch and takes
//! 10 bit times per byte. A burst is about 330 bytes with every sentence, so at 9 600 Bd
//! (960 bytes/s) only up to 2 Hz fits; the default rate is therefore 115 200 Bd, which carries
//! 10 Hz with room to spare (as the Quectel L76K logs in the dataset, captured at 115 200).
//! When the line is still busy with earlier bursts for a whole epoch period, the burst is
//! dropped ([`GpsCounters::epochs_dropped`]), as a receiver with a full output buffer does.
//! Noise is drawn every epoch, fix or not, so the bytes depend only on the seed and inputs.

use firmware::nmea::{GgaRepr, GsaFixType, GsaRepr, GstRepr, Mode, RmcRepr, Selection, VtgRepr};
use protocol::{FixQuality, GstSigmas, Position};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rand_distr::{Distribution, StandardNormal};

use super::tx_line::{TxLine, TxRun};
use super::utc::utc_from_unix_us;
use crate::world::GeoDatum;

/// DOP printed without a fix (u-blox).
const NO_FIX_DOP_CENTI: u16 = 9_999;
/// Satellite IDs reported in GSA, in order.
const SATELLITE_IDS: [u16; 12] = [2, 5, 7, 9, 13, 15, 18, 20, 24, 29, 30, 31];

/// The true state of the antenna at an epoch.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct GpsTruth {
    /// East of the datum, metres.
    pub east_m: f64,
    /// North of the datum, metres.
    pub north_m: f64,
    /// Above the datum, metres.
    pub up_m: f64,
    /// Speed over ground, m/s.
    pub speed_mps: f64,
    /// Course over ground, degrees clockwise from true north.
    pub course_deg: f64,
}

/// The receiver's settings.
#[derive(Debug, Clone, PartialEq)]
pub struct GpsEmulatorOptions {
    /// Epochs per second, 1–10 (clamped).
    pub rate_hz: u32,
    /// Baud rate of the output.
    pub baud: u32,
    /// Origin of the east/north/up frame.
    pub datum: GeoDatum,
    /// Talker of every sentence, `*b"GP"` or `*b"GN"`.
    pub talker: [u8; 2],
    /// Seed of the noise.
    pub seed: u64,
    /// Horizontal noise per axis (east, north), 1 σ, metres.
    pub horizontal_sigma_m: f64,
    /// Vertical noise, 1 σ, metres.
    pub vertical_sigma_m: f64,
    /// Whether to send GSA.
    pub include_gsa: bool,
    /// Whether to send VTG.
    pub include_vtg: bool,
    /// Whether to send GST.
    pub include_gst: bool,
    /// UTC at emulator time 0, µs since 1970-01-01T00:00Z.
    pub start_unix_us: u64,
    /// Emulator time of the first epoch, µs.
    pub first_epoch_us: u64,
    /// From an epoch to the first byte of its burst, µs.
    pub output_delay_us: u64,
    /// Satellites used in the fix (at most 12).
    pub num_sats: u8,
    /// Horizontal dilution of precision, hundredths.
    pub hdop_centi: u16,
    /// Position dilution of precision, hundredths.
    pub pdop_centi: u16,
    /// Vertical dilution of precision, hundredths.
    pub vdop_centi: u16,
    /// Geoid separation printed in GGA, metres.
    pub geoid_sep_m: f64,
}

impl Default for GpsEmulatorOptions {
    /// 10 Hz at 115 200 Bd, `GN`, 0.5 m horizontal noise, every sentence, starting
    /// 2024-06-01T12:00:00Z.
    fn default() -> Self {
        GpsEmulatorOptions {
            rate_hz: 10,
            baud: 115_200,
            datum: GeoDatum::default(),
            talker: *b"GN",
            seed: 0,
            horizontal_sigma_m: 0.5,
            vertical_sigma_m: 0.8,
            include_gsa: true,
            include_vtg: true,
            include_gst: true,
            start_unix_us: 1_717_243_200_000_000,
            first_epoch_us: 0,
            output_delay_us: 20_000,
            num_sats: 9,
            hdop_centi: 90,
            pdop_centi: 160,
            vdop_centi: 130,
            geoid_sep_m: 47.0,
        }
    }
}

/// What the receiver did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GpsCounters {
    /// Epochs computed.
    pub epochs: u32,
    /// Epochs whose burst was dropped because the line was busy.
    pub epochs_dropped: u32,
    /// Epochs sent with a fix.
    pub fixes: u32,
    /// Sentences sent.
    pub sentences: u32,
    /// Sentences that could not be written (a value NMEA cannot express) and were left out.
    pub emit_errors: u32,
    /// Bytes that have left the line.
    pub bytes_sent: u64,
}

/// A function giving the truth at an emulator time in µs.
pub type Trajectory = Box<dyn FnMut(u64) -> GpsTruth + Send>;

/// The emulated receiver. See the [module documentation](self).
pub struct GpsEmulator {
    options: GpsEmulatorOptions,
    truth: GpsTruth,
    trajectory: Option<Trajectory>,
    has_fix: bool,
    rng: ChaCha8Rng,
    next_epoch: u64,
    line: TxLine,
    out: Vec<TxRun>,
    last_now_us: u64,
    counters: GpsCounters,
    /// No epoch at or after this time is computed.
    epochs_end_us: Option<u64>,
}

impl core::fmt::Debug for GpsEmulator {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("GpsEmulator")
            .field("options", &self.options)
            .field("truth", &self.truth)
            .field("has_fix", &self.has_fix)
            .field("next_epoch", &self.next_epoch)
            .field("counters", &self.counters)
            .finish_non_exhaustive()
    }
}

impl GpsEmulator {
    /// A receiver with a fix at the datum, standing still.
    pub fn new(mut options: GpsEmulatorOptions) -> GpsEmulator {
        options.rate_hz = options.rate_hz.clamp(1, 10);
        options.baud = options.baud.max(300);
        options.num_sats = options.num_sats.min(SATELLITE_IDS.len() as u8);
        GpsEmulator {
            rng: ChaCha8Rng::seed_from_u64(options.seed),
            options,
            truth: GpsTruth::default(),
            trajectory: None,
            has_fix: true,
            next_epoch: 0,
            line: TxLine::new(),
            out: Vec::new(),
            last_now_us: 0,
            counters: GpsCounters::default(),
            epochs_end_us: None,
        }
    }

    /// From `end_us` on, no epoch is computed; the bursts of earlier ones leave whole.
    pub fn stop_epochs_at(&mut self, end_us: u64) {
        self.epochs_end_us = Some(end_us);
    }

    /// When the burst of the next epoch starts, if there is one.
    fn next_burst_us(&self) -> Option<u64> {
        let epoch_us = self.epoch_us(self.next_epoch);
        self.epochs_end_us
            .is_none_or(|end| epoch_us < end)
            .then_some(epoch_us + self.options.output_delay_us)
    }

    /// Sets the true position and motion used from the next epoch on (and drops a
    /// trajectory function).
    pub fn set_truth(&mut self, east_m: f64, north_m: f64, speed_mps: f64, course_deg: f64) {
        self.trajectory = None;
        self.truth = GpsTruth {
            east_m,
            north_m,
            up_m: self.truth.up_m,
            speed_mps,
            course_deg,
        };
    }

    /// Sets the whole true state (height included) used from the next epoch on (and drops a
    /// trajectory function).
    pub fn set_truth_state(&mut self, truth: GpsTruth) {
        self.trajectory = None;
        self.truth = truth;
    }

    /// Takes the truth of every epoch from `trajectory`, called with the epoch's time.
    pub fn set_trajectory(&mut self, trajectory: impl FnMut(u64) -> GpsTruth + Send + 'static) {
        self.trajectory = Some(Box::new(trajectory));
    }

    /// Whether the receiver has a fix from the next epoch on.
    pub fn set_fix(&mut self, has_fix: bool) {
        self.has_fix = has_fix;
    }

    /// The options.
    pub fn options(&self) -> &GpsEmulatorOptions {
        &self.options
    }

    /// The baud rate of the output.
    pub fn baud(&self) -> u32 {
        self.options.baud
    }

    /// The counters.
    pub fn counters(&self) -> GpsCounters {
        self.counters
    }

    /// The truth of the last epoch (or as last set).
    pub fn truth(&self) -> GpsTruth {
        self.truth
    }

    /// Emulator time of epoch `index`, µs.
    pub fn epoch_us(&self, index: u64) -> u64 {
        self.options.first_epoch_us + index * 1_000_000 / u64::from(self.options.rate_hz)
    }

    /// The bytes that have left the receiver by `now_us`, in order.
    pub fn poll_output(&mut self, now_us: u64) -> Vec<u8> {
        self.poll_output_runs(now_us)
            .into_iter()
            .flat_map(|run| run.bytes)
            .collect()
    }

    /// As [`Self::poll_output`], grouped by baud rate (always the one rate).
    pub fn poll_output_runs(&mut self, now_us: u64) -> Vec<TxRun> {
        let now_us = now_us.max(self.last_now_us);
        self.last_now_us = now_us;
        while let Some(burst_us) = self.next_burst_us()
            && burst_us <= now_us
        {
            let epoch_us = self.epoch_us(self.next_epoch);
            self.next_epoch += 1;
            let period_us = 1_000_000 / u64::from(self.options.rate_hz);
            let burst = self.epoch_burst(epoch_us);
            if self.line.free_at_us() > burst_us + period_us {
                self.counters.epochs_dropped += 1;
            } else {
                self.line.push(burst_us, self.options.baud, burst, false);
            }
        }
        let mut out = std::mem::take(&mut self.out);
        self.line.transmit_until(now_us, &mut out);
        self.counters.bytes_sent += out.iter().map(|r| r.bytes.len() as u64).sum::<u64>();
        out
    }

    /// When the next byte leaves or the next burst starts (`None` once
    /// [`Self::stop_epochs_at`] has ended the output and every byte has left).
    pub fn next_output_us(&self) -> Option<u64> {
        [self.line.next_byte_end_us(), self.next_burst_us()]
            .into_iter()
            .flatten()
            .min()
    }

    /// Computes the epoch at `epoch_us` and writes its sentences.
    fn epoch_burst(&mut self, epoch_us: u64) -> Vec<u8> {
        if let Some(trajectory) = &mut self.trajectory {
            self.truth = trajectory(epoch_us);
        }
        self.counters.epochs += 1;
        let noise = [(); 3].map(|()| -> f64 { StandardNormal.sample(&mut self.rng) });
        let o = &self.options;
        let (date, time) = utc_from_unix_us(o.start_unix_us + epoch_us);
        let (time, date) = (Some(time), Some(date));
        let talker = o.talker;
        let mut text = String::new();
        let mut sentences = 0;
        let mut errors = 0;
        let mut put = |emit: &dyn Fn(&mut String) -> core::fmt::Result| {
            let mut sentence = String::new();
            match emit(&mut sentence) {
                Ok(()) => {
                    text.push_str(&sentence);
                    sentences += 1;
                }
                Err(_) => errors += 1,
            }
        };
        if self.has_fix {
            let t = self.truth;
            let (lat_deg, lon_deg, alt_m) = o.datum.to_geodetic(
                t.east_m + noise[0] * o.horizontal_sigma_m,
                t.north_m + noise[1] * o.horizontal_sigma_m,
                t.up_m + noise[2] * o.vertical_sigma_m,
            );
            let position = Some(Position {
                lat_ndeg: (lat_deg * 1e9).round() as i64,
                lon_ndeg: (lon_deg * 1e9).round() as i64,
            });
            let speed_mm_s = Some((t.speed_mps.max(0.0) * 1_000.0).round() as u32);
            let course_cdeg =
                Some((t.course_deg.rem_euclid(360.0) * 100.0).round() as u32 % 36_000);
            let mode = Some(Mode::Autonomous);
            let rmc = RmcRepr {
                time,
                valid: Some(true),
                position,
                speed_mm_s,
                course_cdeg,
                date,
                mag_var_cdeg: None,
                mode,
                nav_status: None,
            };
            put(&|s| rmc.emit(talker, s));
            if o.include_vtg {
                let vtg = VtgRepr {
                    course_cdeg,
                    course_mag_cdeg: None,
                    speed_mm_s,
                    mode,
                };
                put(&|s| vtg.emit(talker, s));
            }
            let gga = GgaRepr {
                time,
                position,
                quality: Some(FixQuality::Gps),
                num_sats: Some(o.num_sats),
                hdop_centi: Some(o.hdop_centi),
                alt_msl_mm: Some((alt_m * 1_000.0).round() as i32),
                geoid_sep_mm: Some((o.geoid_sep_m * 1_000.0).round() as i32),
                dgps_age_ms: None,
                dgps_station: None,
            };
            put(&|s| gga.emit(talker, s));
            if o.include_gsa {
                let gsa = GsaRepr {
                    selection: Some(Selection::Automatic),
                    fix_type: Some(GsaFixType::Fix3d),
                    sat_ids: heapless::Vec::from_slice(&SATELLITE_IDS[..usize::from(o.num_sats)])
                        .unwrap_or_default(),
                    pdop_centi: Some(o.pdop_centi),
                    hdop_centi: Some(o.hdop_centi),
                    vdop_centi: Some(o.vdop_centi),
                    system_id: None,
                };
                put(&|s| gsa.emit(talker, s));
            }
            if o.include_gst {
                let h_mm = Some((o.horizontal_sigma_m * 1_000.0).round() as u32);
                let v_mm = Some((o.vertical_sigma_m * 1_000.0).round() as u32);
                let gst = GstRepr {
                    time,
                    sigmas: GstSigmas {
                        rms_mm: h_mm,
                        semi_major_mm: h_mm,
                        semi_minor_mm: h_mm,
                        orientation_cdeg: Some(0),
                        lat_sigma_mm: h_mm,
                        lon_sigma_mm: h_mm,
                        alt_sigma_mm: v_mm,
                    },
                };
                put(&|s| gst.emit(talker, s));
            }
        } else {
            let not_valid = Some(Mode::NotValid);
            let rmc = RmcRepr {
                time,
                valid: Some(false),
                position: None,
                speed_mm_s: None,
                course_cdeg: None,
                date,
                mag_var_cdeg: None,
                mode: not_valid,
                nav_status: None,
            };
            put(&|s| rmc.emit(talker, s));
            if o.include_vtg {
                let vtg = VtgRepr {
                    course_cdeg: None,
                    course_mag_cdeg: None,
                    speed_mm_s: None,
                    mode: not_valid,
                };
                put(&|s| vtg.emit(talker, s));
            }
            let gga = GgaRepr {
                time,
                position: None,
                quality: Some(FixQuality::Invalid),
                num_sats: Some(0),
                hdop_centi: Some(NO_FIX_DOP_CENTI),
                alt_msl_mm: None,
                geoid_sep_mm: None,
                dgps_age_ms: None,
                dgps_station: None,
            };
            put(&|s| gga.emit(talker, s));
            if o.include_gsa {
                let gsa = GsaRepr {
                    selection: Some(Selection::Automatic),
                    fix_type: Some(GsaFixType::NoFix),
                    sat_ids: heapless::Vec::new(),
                    pdop_centi: Some(NO_FIX_DOP_CENTI),
                    hdop_centi: Some(NO_FIX_DOP_CENTI),
                    vdop_centi: Some(NO_FIX_DOP_CENTI),
                    system_id: None,
                };
                put(&|s| gsa.emit(talker, s));
            }
            if o.include_gst {
                let gst = GstRepr {
                    time,
                    sigmas: GstSigmas::default(),
                };
                put(&|s| gst.emit(talker, s));
            }
        }
        if self.has_fix {
            self.counters.fixes += 1;
        }
        self.counters.sentences += sentences;
        self.counters.emit_errors += errors;
        text.into_bytes()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use firmware::nmea::GpsReceiver;
    use protocol::{FixSource, GpsFixMsg};

    /// Runs `gps` from `from_us` to `to_us` in 1 ms steps, decoding with the firmware's
    /// receiver; calls `each_ms` before every step.
    fn run(
        gps: &mut GpsEmulator,
        receiver: &mut GpsReceiver,
        from_us: u64,
        to_us: u64,
        mut each_ms: impl FnMut(&mut GpsEmulator, u64),
    ) -> Vec<GpsFixMsg> {
        let mut fixes = Vec::new();
        let mut now_us = from_us;
        while now_us < to_us {
            now_us += 1_000;
            each_ms(gps, now_us);
            let bytes = gps.poll_output(now_us);
            receiver.push(&bytes, now_us, |sentence| fixes.extend(sentence.fix));
        }
        fixes
    }

    fn local_m(gps: &GpsEmulator, fix: &GpsFixMsg) -> (f64, f64) {
        let position = fix.position.unwrap();
        gps.options()
            .datum
            .to_local_m(position.lat_deg(), position.lon_deg())
    }

    #[test]
    fn fixes_parse_back_to_the_truth() {
        let mut gps = GpsEmulator::new(GpsEmulatorOptions {
            seed: 5,
            ..GpsEmulatorOptions::default()
        });
        gps.set_truth(30.0, -12.0, 1.5, 45.0);
        let mut receiver = GpsReceiver::new();
        let fixes = run(&mut gps, &mut receiver, 0, 10_000_000, |_, _| {});
        let stats = receiver.stats();
        assert_eq!(
            (stats.bad_checksum, stats.malformed, stats.truncated),
            (0, 0, 0)
        );
        assert_eq!(gps.counters().epochs_dropped, 0);
        let gga: Vec<_> = fixes
            .iter()
            .filter(|f| f.source == FixSource::Gga)
            .collect();
        assert!((99..=100).contains(&gga.len()), "{}", gga.len());
        let sigma_m = gps.options().horizontal_sigma_m;
        let (mut sum_east, mut sum_north) = (0.0, 0.0);
        for fix in &gga {
            let (east, north) = local_m(&gps, fix);
            assert!((east - 30.0).abs() < 5.0 * sigma_m, "{east}");
            assert!((north + 12.0).abs() < 5.0 * sigma_m, "{north}");
            sum_east += east;
            sum_north += north;
            assert_eq!(fix.quality, FixQuality::Gps);
            assert_eq!(fix.num_sats, Some(9));
            let alt_m = f64::from(fix.alt_msl_mm.unwrap()) / 1e3;
            assert!((alt_m - 520.0).abs() < 5.0 * 0.8);
            assert_eq!(fix.speed_mm_s, Some(1_500));
            assert_eq!(fix.course_cdeg, Some(4_500));
        }
        let n = gga.len() as f64;
        assert!((sum_east / n - 30.0).abs() < 0.25 && (sum_north / n + 12.0).abs() < 0.25);
        // GST sigmas reach the reports; RMC carries the date and the epoch's time.
        assert_eq!(gga.last().unwrap().gst.unwrap().lat_sigma_mm, Some(500));
        let first_rmc = fixes.iter().find(|f| f.source == FixSource::Rmc).unwrap();
        let date = first_rmc.date.unwrap();
        assert_eq!((date.year, date.month, date.day), (2024, 6, 1));
        let time = first_rmc.time.unwrap();
        assert_eq!(
            (time.hour, time.minute, time.second, time.micros),
            (12, 0, 0, 0)
        );
    }

    #[test]
    fn zero_noise_is_exact() {
        let mut gps = GpsEmulator::new(GpsEmulatorOptions {
            horizontal_sigma_m: 0.0,
            vertical_sigma_m: 0.0,
            talker: *b"GP",
            ..GpsEmulatorOptions::default()
        });
        gps.set_trajectory(|t_us| GpsTruth {
            east_m: t_us as f64 * 1e-6,
            north_m: 100.0,
            up_m: 2.0,
            speed_mps: 1.0,
            course_deg: 90.0,
        });
        let mut receiver = GpsReceiver::new();
        let fixes = run(&mut gps, &mut receiver, 0, 2_000_000, |_, _| {});
        let gga: Vec<_> = fixes
            .iter()
            .filter(|f| f.source == FixSource::Gga)
            .collect();
        assert!(gga.len() >= 19);
        for fix in gga {
            let t_s =
                f64::from(fix.time.unwrap().micros) / 1e6 + f64::from(fix.time.unwrap().second);
            let (east, north) = local_m(&gps, fix);
            assert!(
                (east - t_s).abs() < 1e-3 && (north - 100.0).abs() < 1e-3,
                "{east} {north}"
            );
            assert_eq!(fix.alt_msl_mm, Some(522_000));
            assert_eq!(fix.talker, *b"GP");
        }
    }

    #[test]
    fn no_fix_period_yields_no_position() {
        let mut gps = GpsEmulator::new(GpsEmulatorOptions::default());
        let mut receiver = GpsReceiver::new();
        let fixes = run(&mut gps, &mut receiver, 0, 3_000_000, |gps, now_us| {
            gps.set_fix(!(1_000_000..2_000_000).contains(&now_us));
        });
        let in_outage = |f: &&GpsFixMsg| {
            let t = f.time.unwrap();
            t.second == 1
        };
        let outage: Vec<_> = fixes.iter().filter(in_outage).collect();
        assert!(outage.len() >= 20);
        for fix in &outage {
            assert_eq!(fix.position, None);
            assert_eq!(fix.quality, FixQuality::Invalid);
            assert_eq!((fix.alt_msl_mm, fix.speed_mm_s), (None, None));
        }
        // Time and date still come during the outage; the fix comes back after it.
        assert!(outage.iter().any(|f| f.date.is_some()));
        assert!(
            fixes
                .iter()
                .filter(|f| f.time.unwrap().second == 2)
                .all(|f| f.position.is_some())
        );
        assert!(receiver.stats().bad_checksum == 0 && receiver.stats().malformed == 0);
        assert_eq!(gps.counters().fixes, 20);
    }

    #[test]
    fn ten_hertz_needs_more_than_9600_baud() {
        let mut gps = GpsEmulator::new(GpsEmulatorOptions {
            baud: 9_600,
            ..GpsEmulatorOptions::default()
        });
        let mut receiver = GpsReceiver::new();
        run(&mut gps, &mut receiver, 0, 5_000_000, |_, _| {});
        let c = gps.counters();
        assert!(c.epochs_dropped > 20, "{c:?}");
        // The line never carries more than 960 bytes/s.
        assert!(c.bytes_sent <= 5 * 960, "{c:?}");
        // At the default 115 200 Bd all ten epochs a second go out.
        let mut gps = GpsEmulator::new(GpsEmulatorOptions::default());
        run(&mut gps, &mut receiver, 0, 5_000_000, |_, _| {});
        assert_eq!(gps.counters().epochs_dropped, 0);
        assert_eq!(gps.counters().sentences, 50 * 5);
        assert!(gps.counters().bytes_sent / 50 < 400, "{:?}", gps.counters());
    }

    #[test]
    fn bytes_are_paced_and_deterministic() {
        let bytes = |seed| {
            let mut gps = GpsEmulator::new(GpsEmulatorOptions {
                seed,
                ..GpsEmulatorOptions::default()
            });
            let first = gps.next_output_us();
            (first, gps.poll_output(1_000_000))
        };
        let (first, a) = bytes(1);
        assert_eq!(first, Some(20_000));
        assert_eq!(a, bytes(1).1);
        assert_ne!(a, bytes(2).1);
        let mut gps = GpsEmulator::new(GpsEmulatorOptions::default());
        assert!(gps.poll_output(20_000).is_empty());
        // 115 200 Bd: one byte per 86.8 µs.
        assert_eq!(gps.poll_output(20_087), b"$");
        assert_eq!(gps.next_output_us(), Some(20_000 + 174));
    }

    #[test]
    fn stopped_output_ends_with_whole_bursts() {
        let mut gps = GpsEmulator::new(GpsEmulatorOptions::default());
        gps.stop_epochs_at(230_000);
        // Polled just after the stop: the epoch at 200 ms is still on the line.
        let mut bytes = gps.poll_output(230_001);
        assert!(gps.next_output_us().is_some());
        bytes.extend(gps.poll_output(10_000_000));
        assert_eq!(gps.next_output_us(), None);
        // Three epochs (0, 100, 200 ms), each ending with GST.
        assert_eq!(gps.counters().epochs, 3);
        let text = String::from_utf8(bytes).unwrap();
        assert_eq!(text.matches("GST,").count(), 3);
        assert!(text.ends_with("\r\n"));
    }
}
