//! Tests of the emulated LMS2xx: the example requests and their replies, timing, baud
//! switches, streaming and scan skipping, power cycles and a firmware bring-up against it.
//! The helpers that send requests are shared with the replay tests
//! ([`super::replay_source`]).

use super::*;
use crate::emulators::garble;
use firmware::sick::bringup::Action;
use firmware::sick::{BringUp, BringUpConfig, Event, Input, RangeDecoder, Receiver, crc16};
use protocol::LaserState;

pub(super) fn hex(text: &str) -> Vec<u8> {
    text.split_whitespace()
        .map(|b| u8::from_str_radix(b, 16).unwrap())
        .collect()
}

/// A request telegram with its CRC appended.
fn with_crc(mut bytes: Vec<u8>) -> Vec<u8> {
    let crc = crc16(&bytes);
    bytes.extend_from_slice(&crc.to_le_bytes());
    bytes
}

/// A sensor that has been on for a while: no `90h`, ready at time 0.
pub(super) fn running(options: Lms2xxOptions) -> Lms2xx {
    Lms2xx::new(Lms2xxOptions {
        send_power_on: false,
        seed: 1,
        ..options
    })
}

/// Sends `request` at `baud` at `at_us`, returns every run sent until `until_us`.
pub(super) fn exchange(
    lms: &mut Lms2xx,
    request: &[u8],
    baud: u32,
    at_us: u64,
    until_us: u64,
) -> Vec<TxRun> {
    lms.receive(request, baud, at_us);
    lms.poll_output_runs(until_us)
}

pub(super) fn bytes_of(runs: &[TxRun]) -> Vec<u8> {
    runs.iter().flat_map(|r| r.bytes.clone()).collect()
}

#[test]
fn answers_the_example_requests() {
    let mut lms = running(Lms2xxOptions::default());
    let cases = [
        // Stop streaming → ACK, A0 00 (§4, §11).
        ("02 00 02 00 20 25 35 08", "06 02 80 03 00 A0 00 10 16 0A"),
        // Installation mode with the default password.
        (
            "02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 53 BE C5",
            "06 02 80 03 00 A0 00 10 16 0A",
        ),
        ("02 00 02 00 20 25 35 08", "06 02 80 03 00 A0 00 10 16 0A"),
        // Variant 180°/0.5°.
        (
            "02 00 05 00 3B B4 00 32 00 3B 1F",
            "06 02 80 07 00 BB 01 B4 00 32 00 10 03 9D",
        ),
        // Bad CRC → NAK only.
        ("02 00 01 00 31 15 13", "15"),
        // Wrong address → silence.
        ("02 05 01 00 31 15 12", ""),
    ];
    let mut now_us = 0;
    for (request, reply) in cases {
        let runs = exchange(&mut lms, &hex(request), 9_600, now_us, now_us + 500_000);
        assert_eq!(bytes_of(&runs), hex(reply), "{request}");
        now_us += 500_000;
    }
    // Sub-command 26h (mean values) is not emulated: ACK, 92h.
    let request = with_crc(hex("02 00 03 00 20 26 05"));
    let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
    assert_eq!(bytes_of(&runs), hex("06 02 80 02 00 92 10 7F 33"));
    now_us += 500_000;
    // Wrong password → A0 01.
    let request = with_crc(hex("02 00 0A 00 20 00 53 49 43 4B 5F 4C 4D 00"));
    let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
    let expected = emit_reply(&Reply::ModeSwitch {
        result: 1,
        status: STATUS_OK,
    });
    assert_eq!(bytes_of(&runs), [&[ACK][..], &expected].concat());
    now_us += 500_000;
    // 0.25° at 180° is refused; the active variant (180°/0.5°) is echoed.
    let request = with_crc(hex("02 00 05 00 3B B4 00 19 00"));
    let runs = exchange(&mut lms, &request, 9_600, now_us, now_us + 500_000);
    let reply = with_crc(hex("02 80 07 00 BB 00 B4 00 32 00 10"));
    assert_eq!(bytes_of(&runs), [&[ACK][..], &reply].concat());
    now_us += 500_000;
    // Type.
    let runs = exchange(
        &mut lms,
        &hex("02 00 01 00 3A 1E 12"),
        9_600,
        now_us,
        now_us + 500_000,
    );
    let bytes = bytes_of(&runs);
    assert_eq!(bytes[0], ACK);
    let telegram = Telegram::new_checked(&bytes[1..]).unwrap();
    assert_eq!(telegram.check_crc(), Ok(()));
    assert_eq!(
        Reply::parse(&telegram).unwrap(),
        Reply::Type {
            text: heapless::Vec::from_slice(b"LMS200;S18063;V02.19 ").unwrap(),
            status: STATUS_OK
        }
    );
    now_us += 500_000;
    // Status: exactly what the firmware's emitter makes of the sensor's state.
    let runs = exchange(
        &mut lms,
        &hex("02 00 01 00 31 15 12"),
        9_600,
        now_us,
        now_us + 500_000,
    );
    let expected = StatusReply {
        version: *b"V02.19 ",
        operating_mode: OPERATING_MODE_ON_REQUEST,
        device_status: 0,
        measuring_mode: MeasuringMode(0),
        angle_deg: 180,
        resolution_cdeg: 50,
        baud_code: 0x8067,
        permanent_baud: false,
        address: 0,
        unit_byte: 0,
        status: STATUS_OK,
    };
    let expected = [&[ACK][..], &emit_reply(&Reply::Status(expected))].concat();
    assert_eq!(bytes_of(&runs), expected);
    assert_eq!(bytes_of(&runs).len(), 1 + 160);
    now_us += 500_000;
    // One scan: a 361-value B0 in cm.
    let runs = exchange(
        &mut lms,
        &hex("02 00 02 00 30 01 31 18"),
        9_600,
        now_us,
        now_us + 1_500_000,
    );
    let bytes = bytes_of(&runs);
    assert_eq!(bytes[0], ACK);
    assert_eq!(&bytes[1..8], &hex("02 80 D6 02 B0 69 01")[..]);
    let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
    assert_eq!((scan.values.len(), scan.unit), (361, RangeUnit::Cm));
    // 5 m straight ahead.
    assert!(
        (i32::from(scan.values[180]) - 500).abs() <= 6,
        "{}",
        scan.values[180]
    );
    now_us += 1_500_000;
    // Reset → ACK, 91h; then 90h.
    let runs = exchange(
        &mut lms,
        &hex("02 00 01 00 10 34 12"),
        9_600,
        now_us,
        now_us + 2_000_000,
    );
    let bytes = bytes_of(&runs);
    assert_eq!(&bytes[..9], &hex("06 02 80 02 00 91 10 79 30")[..]);
    let telegram = Telegram::new_checked(&bytes[9..]).unwrap();
    assert_eq!(telegram.command(), 0x90);
    assert_eq!(telegram.data(), b"LMS200;S18063;V02.19 \x10");
    assert_eq!(lms.variant(), Variant::DEFAULT);
    let c = lms.counters();
    assert_eq!(
        (c.requests, c.acks, c.naks, c.wrong_address),
        (11, 11, 1, 1)
    );
    assert_eq!((c.rejected, c.power_on_messages, c.scans_sent), (1, 1, 1));
    assert_eq!(c.replies, 11);
}

#[test]
fn reply_timing() {
    let mut lms = running(Lms2xxOptions::default());
    lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 1_000);
    // The ACK leaves within a few ms, the A0 after the mode switch delay.
    assert_eq!(lms.next_output_us(), Some(1_000 + 2_000));
    assert!(lms.poll_output(3_000).is_empty());
    assert_eq!(lms.next_output_us(), Some(1_000 + 2_000 + 1_042));
    assert!(lms.poll_output(4_041).is_empty());
    assert_eq!(lms.poll_output(4_042), [ACK]);
    assert!(lms.poll_output(100_000).is_empty());
    assert!(!lms.is_streaming());
    let a0 = lms.poll_output(120_000);
    assert_eq!(a0, hex("02 80 03 00 A0 00 10 16 0A"));
    assert!(lms.is_streaming());
}

#[test]
fn configuration_write_needs_installation_mode() {
    let mut lms = running(Lms2xxOptions::default());
    let mut block = lms.config();
    block.set_unit(RangeUnit::Mm);
    block.set_measuring_mode(MeasuringMode(0x04));
    let write = Request::WriteConfig(block).to_bytes();
    let runs = exchange(&mut lms, write.as_bytes(), 9_600, 0, 2_000_000);
    let bytes = bytes_of(&runs);
    let reply = Reply::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
    assert!(matches!(
        reply,
        Reply::ConfigWritten {
            accepted: false,
            ..
        }
    ));
    assert_eq!(lms.config().unit(), Some(RangeUnit::Cm));
    let install = Request::SetMode(OperatingMode::Installation {
        password: DEFAULT_PASSWORD,
    });
    exchange(
        &mut lms,
        install.to_bytes().as_bytes(),
        9_600,
        2_000_000,
        2_500_000,
    );
    assert!(lms.is_installation_mode());
    lms.receive(write.as_bytes(), 9_600, 2_500_000);
    // The EEPROM write takes about a second.
    assert_eq!(lms.poll_output(3_000_000), [ACK]);
    let bytes = lms.poll_output(4_000_000);
    let reply = Reply::parse(&Telegram::new_checked(&bytes[..]).unwrap()).unwrap();
    assert_eq!(
        reply,
        Reply::ConfigWritten {
            accepted: true,
            block,
            status: STATUS_OK
        }
    );
    assert_eq!(lms.counters().eeprom_writes, 1);
    // Scans now come in mm, measuring mode 4 (16 m, 3FFFh for no echo).
    let runs = exchange(
        &mut lms,
        &hex("02 00 02 00 30 01 31 18"),
        9_600,
        4_000_000,
        5_000_000,
    );
    let bytes = bytes_of(&runs);
    let scan = ScanRepr::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap();
    assert_eq!((scan.unit, scan.values.len()), (RangeUnit::Mm, 181));
    assert!((i32::from(scan.values[90]) - 5_000).abs() < 60);
    // The status reports the new mode and unit.
    let runs = exchange(
        &mut lms,
        &hex("02 00 01 00 31 15 12"),
        9_600,
        5_000_000,
        6_000_000,
    );
    let bytes = bytes_of(&runs);
    let Reply::Status(status) = Reply::parse(&Telegram::new_checked(&bytes[1..]).unwrap()).unwrap()
    else {
        panic!()
    };
    assert_eq!(status.operating_mode, OPERATING_MODE_INSTALLATION);
    assert_eq!(
        (status.measuring_mode, status.unit()),
        (MeasuringMode(4), Some(RangeUnit::Mm))
    );
}

#[test]
fn baud_switch_takes_effect_after_the_reply() {
    let mut lms = running(Lms2xxOptions::default());
    let status = hex("02 00 01 00 31 15 12");
    lms.receive(&hex("02 00 02 00 20 48 58 08"), 9_600, 0);
    // Before the A0 has left, the sensor still listens at 9 600 Bd only.
    lms.receive(&status, 500_000, 50_000);
    assert_eq!(lms.baud(), 9_600);
    let runs = lms.poll_output_runs(500_000);
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].baud, 9_600);
    assert_eq!(runs[0].bytes, hex("06 02 80 03 00 A0 00 10 16 0A"));
    assert_eq!(lms.baud(), 500_000);
    // At the old rate the host is not understood any more.
    let garbage = lms.counters().garbage_bytes;
    let runs = exchange(&mut lms, &status, 9_600, 600_000, 1_000_000);
    assert!(runs.is_empty());
    assert_eq!(lms.counters().garbage_bytes, garbage + 7);
    // At the new rate it is; the status reports 500 kBd.
    let runs = exchange(&mut lms, &status, 500_000, 1_000_000, 1_100_000);
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].baud, 500_000);
    let telegram = Telegram::new_checked(&runs[0].bytes[1..]).unwrap();
    let Reply::Status(status) = Reply::parse(&telegram).unwrap() else {
        panic!()
    };
    assert_eq!(status.baud(), Some(LmsBaud::B500000));
    assert_eq!(lms.counters().requests, 2);
}

#[test]
fn request_at_the_wrong_baud_is_ignored() {
    let mut lms = running(Lms2xxOptions::default());
    let runs = exchange(&mut lms, &hex("02 00 01 00 31 15 12"), 38_400, 0, 1_000_000);
    assert!(runs.is_empty());
    let c = lms.counters();
    assert_eq!((c.requests, c.garbage_bytes, c.acks, c.naks), (0, 7, 0, 0));
    // A request split by a pause over 6 ms is dropped too.
    lms.receive(&hex("02 00 01"), 9_600, 1_000_000);
    lms.receive(&hex("00 31 15 12"), 9_600, 1_007_000);
    assert!(lms.poll_output(2_000_000).is_empty());
    // Without the pause it is answered.
    lms.receive(&hex("02 00 01"), 9_600, 2_000_000);
    lms.receive(&hex("00 31 15 12"), 9_600, 2_001_000);
    assert_eq!(lms.poll_output(3_000_000)[0], ACK);
}

/// Streams at `baud` with `variant` for `duration_us` after the stream has started;
/// returns the arrival times of the decoded scans and the sensor.
fn stream(baud: u32, variant: Variant, duration_us: u64) -> (Vec<u64>, Vec<ScanRepr>, Lms2xx) {
    let mut lms = running(Lms2xxOptions {
        baud,
        variant,
        unit: RangeUnit::Mm,
        ..Lms2xxOptions::default()
    });
    lms.receive(&hex("02 00 02 00 20 24 34 08"), baud, 0);
    let mut receiver = Receiver::new();
    let (mut stamps, mut scans) = (Vec::new(), Vec::new());
    let mut now_us = 0;
    while now_us < 500_000 + duration_us {
        now_us += 1_000;
        for byte in lms.poll_output(now_us) {
            if let Some(Event::Telegram { telegram, .. }) = receiver.push(byte, now_us) {
                if telegram.command() == 0xB0 && now_us >= 500_000 {
                    stamps.push(now_us);
                    scans.push(ScanRepr::parse(&telegram).unwrap());
                }
            }
        }
    }
    (stamps, scans, lms)
}

#[test]
fn streams_every_scan_at_500k() {
    let (stamps, scans, lms) = stream(500_000, Variant::new(180, 50), 2_000_000);
    // 37.5 complete scans per second.
    assert!((74..=76).contains(&stamps.len()), "{}", stamps.len());
    assert_eq!(lms.counters().scans_skipped, 0);
    for pair in stamps.windows(2) {
        assert!((26_000..=28_000).contains(&(pair[1] - pair[0])), "{pair:?}");
    }
    assert!(
        scans
            .iter()
            .all(|s| s.values.len() == 361 && s.unit == RangeUnit::Mm)
    );
    // 75 Hz at 1°, 18.75 Hz at 100°/0.25°.
    let (stamps, _, _) = stream(500_000, Variant::new(180, 100), 2_000_000);
    assert!((149..=151).contains(&stamps.len()), "{}", stamps.len());
    let (stamps, scans, _) = stream(500_000, Variant::new(100, 25), 2_000_000);
    assert!((37..=38).contains(&stamps.len()), "{}", stamps.len());
    assert_eq!(scans[0].values.len(), 401);
}

#[test]
fn skips_scans_at_38400() {
    let (stamps, _, lms) = stream(38_400, Variant::new(180, 50), 2_000_000);
    // 732 bytes take 191 ms: one scan in eight goes out (the line carries ≤ 5.2/s).
    assert!((9..=10).contains(&stamps.len()), "{}", stamps.len());
    for pair in stamps.windows(2) {
        assert!((pair[1] - pair[0]).abs_diff(213_333) < 1_500, "{pair:?}");
    }
    // Seven skipped scans between two sent ones, up to seven before the first and after
    // the last.
    let c = lms.counters();
    let between = 7 * (c.scans_sent - 1);
    assert!((between..=between + 14).contains(&c.scans_skipped), "{c:?}");
}

/// A moving sensor at 38 400 Bd whose stream is asked for at `request_us`, polled every
/// `poll_us`: the scans' measurement times, every byte it sent, and its stream starts.
fn slow_stream(request_us: u64, poll_us: u64) -> (Vec<u64>, Vec<u8>, Vec<StreamStart>) {
    let mut lms = running(Lms2xxOptions {
        baud: 38_400,
        variant: Variant::new(180, 50),
        ..Lms2xxOptions::default()
    });
    lms.set_motion(|t_us| SensorPose::new(t_us as f64 * 1e-6, 0.0, 0.0));
    lms.stop_scans_at(1_500_000);
    let mut now_us = 0;
    let mut bytes = Vec::new();
    let mut measured = Vec::new();
    while now_us < 2_000_000 {
        if (now_us..now_us + poll_us).contains(&request_us) {
            lms.receive(&hex("02 00 02 00 20 24 34 08"), 38_400, request_us);
        }
        now_us += poll_us;
        bytes.extend(lms.poll_output(now_us));
        measured.extend(lms.take_scans_started());
    }
    (measured, bytes, lms.stream_starts().to_vec())
}

#[test]
fn slow_streams_keep_the_mirror_grid_whenever_they_are_asked_for() {
    // The sensor streams 105 ms after the request (ACK, mode switch, A0h); it sends every
    // eighth scan, those ending at multiples of 213.3 ms since it came up. Asked for
    // anywhere before the grid point at 213.3 ms less that, the stream begins there and
    // sends the same scans, measured at the same poses, however often it is polled.
    let (measured, bytes, starts) = slow_stream(0, 1_000);
    assert_eq!(
        measured,
        [
            213_333, 426_666, 640_000, 853_333, 1_066_666, 1_280_000, 1_493_333
        ]
    );
    assert_eq!(starts.len(), 1);
    assert_eq!(starts[0].first_scan_us, 213_333);
    assert!(
        (104_000..106_000).contains(&starts[0].streaming_us),
        "{starts:?}"
    );
    for (request_us, poll_us) in [(0, 7_000), (50_000, 1_000), (100_000, 3_000)] {
        let (m, b, _) = slow_stream(request_us, poll_us);
        assert_eq!(
            m, measured,
            "asked at {request_us} µs, polled every {poll_us} µs"
        );
        assert!(
            b == bytes,
            "asked at {request_us} µs, polled every {poll_us} µs"
        );
    }
    // Asked for too late for the first grid point: it starts at the next one.
    let (m, _, starts) = slow_stream(120_000, 1_000);
    assert_eq!(m, measured[1..]);
    assert_eq!(starts[0].first_scan_us, 426_666);
    // The scans were measured where the sensor was: different poses, different ranges.
    let scan_of = |k: usize| {
        let start = 10 + k * 732;
        ScanRepr::parse(&Telegram::new_checked(&bytes[start..start + 732]).unwrap()).unwrap()
    };
    assert_ne!(scan_of(0).values, scan_of(5).values);
}

#[test]
fn power_cycle_sends_power_on_at_9600() {
    let mut lms = running(Lms2xxOptions {
        baud: 500_000,
        variant: Variant::new(180, 50),
        ..Lms2xxOptions::default()
    });
    lms.receive(&hex("02 00 02 00 20 24 34 08"), 500_000, 0);
    let _ = lms.poll_output(1_000_000);
    assert!(lms.is_streaming());
    lms.power_cycle(1_000_000);
    assert_eq!(lms.baud(), 9_600);
    assert!(!lms.is_streaming());
    // Silent while starting, then 90h at 9 600 Bd.
    let runs = lms.poll_output_runs(1_000_000 + 690_000);
    assert!(runs.is_empty());
    lms.receive(&hex("02 00 01 00 31 15 12"), 9_600, 1_500_000);
    let runs = lms.poll_output_runs(3_000_000);
    assert_eq!(runs.len(), 1);
    assert_eq!(runs[0].baud, 9_600);
    let telegram = Telegram::new_checked(&runs[0].bytes[..]).unwrap();
    assert_eq!(telegram.check_crc(), Ok(()));
    assert!(matches!(
        Reply::parse(&telegram),
        Ok(Reply::PowerOn {
            status: STATUS_OK,
            ..
        })
    ));
    assert_eq!(telegram.total_len(), runs[0].bytes.len());
    // Then it answers at 9 600 Bd, not streaming, in its power-on variant.
    let runs = exchange(
        &mut lms,
        &hex("02 00 01 00 31 15 12"),
        9_600,
        3_000_000,
        4_000_000,
    );
    let telegram = Telegram::new_checked(&runs[0].bytes[1..]).unwrap();
    let Reply::Status(status) = Reply::parse(&telegram).unwrap() else {
        panic!()
    };
    assert_eq!(status.baud(), Some(LmsBaud::B9600));
    assert!(!status.is_streaming());
    assert_eq!((status.angle_deg, status.resolution_cdeg), (180, 50));
}

#[test]
fn a_request_interrupts_a_scan() {
    let mut lms = running(Lms2xxOptions::default());
    lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 0);
    // At 9 600 Bd a 181-value scan takes 387 ms; ask for the status in the middle.
    let before = lms.poll_output(400_000);
    lms.receive(&hex("02 00 01 00 31 15 12"), 9_600, 400_000);
    let after = lms.poll_output(404_000);
    assert_eq!(after, [ACK]);
    assert_eq!(lms.counters().scans_interrupted, 1);
    assert!(before.len() < 10 + 372);
}

#[test]
fn same_seed_same_bytes() {
    let run = |seed| {
        let mut lms = Lms2xx::new(Lms2xxOptions {
            seed,
            ..Lms2xxOptions::default()
        });
        lms.receive(&hex("02 00 02 00 20 24 34 08"), 9_600, 800_000);
        lms.poll_output(3_000_000)
    };
    assert_eq!(run(3), run(3));
    assert_ne!(run(3), run(4));
}

/// The board side of the bring-up test: the firmware's bring-up and receiver with a UART
/// and a timer on a simulated clock.
struct Board {
    bringup: BringUp,
    receiver: Receiver,
    uart_baud: u32,
    deadline_us: Option<u64>,
    /// (arrival time, scan) of every B0 while streaming.
    scans: Vec<(u64, ScanRepr)>,
}

impl Board {
    fn apply(&mut self, actions: firmware::sick::Actions, lms: &mut Lms2xx, now_us: u64) {
        for action in actions {
            match action {
                Action::Send(request) => lms.receive(request.as_bytes(), self.uart_baud, now_us),
                Action::SetBaud(baud) => {
                    self.uart_baud = baud;
                    self.receiver.clear();
                }
                Action::StartTimer { duration_ms } => {
                    self.deadline_us = Some(now_us + u64::from(duration_ms) * 1_000);
                }
                _ => {}
            }
        }
    }

    fn on_byte(&mut self, byte: Option<u8>, lms: &mut Lms2xx, now_us: u64) {
        let event = match byte {
            Some(byte) => self.receiver.push(byte, now_us),
            None => self.receiver.poll(now_us),
        };
        let Some(event) = event else {
            return;
        };
        if let Event::Telegram { telegram, .. } = &event {
            if telegram.command() == 0xB0 && self.bringup.state() == LaserState::Streaming {
                self.scans
                    .push((now_us, ScanRepr::parse(telegram).unwrap()));
            }
        }
        let actions = self.bringup.handle(event.into());
        self.apply(actions, lms, now_us);
    }
}

#[test]
fn firmware_bring_up_from_power_on_to_streaming() {
    let mut lms = Lms2xx::new(Lms2xxOptions {
        seed: 42,
        ..Lms2xxOptions::default()
    });
    let mut board = Board {
        bringup: BringUp::new(BringUpConfig::default()),
        receiver: Receiver::new(),
        uart_baud: 9_600,
        deadline_us: None,
        scans: Vec::new(),
    };
    let actions = board.bringup.handle(Input::Start);
    board.apply(actions, &mut lms, 0);
    let mut streaming_since_us = None;
    let mut now_us = 0;
    while now_us < 8_000_000 {
        now_us += 100;
        for run in lms.poll_output_runs(now_us) {
            for byte in garble(&run.bytes, run.baud, board.uart_baud) {
                board.on_byte(Some(byte), &mut lms, now_us);
            }
        }
        board.on_byte(None, &mut lms, now_us);
        if board.deadline_us.is_some_and(|d| now_us >= d) {
            board.deadline_us = None;
            let actions = board.bringup.handle(Input::Timeout);
            board.apply(actions, &mut lms, now_us);
        }
        if streaming_since_us.is_none() && board.bringup.state() == LaserState::Streaming {
            streaming_since_us = Some(now_us);
        }
    }
    let since_us = streaming_since_us.expect("never streamed");
    assert!(since_us < 6_000_000, "{since_us}");
    assert_eq!(board.bringup.state(), LaserState::Streaming);
    assert_eq!((lms.baud(), board.uart_baud), (500_000, 500_000));
    assert_eq!(lms.variant(), Variant::new(180, 50));
    assert_eq!(lms.config().unit(), Some(RangeUnit::Mm));
    assert_eq!(lms.counters().eeprom_writes, 1);
    assert!(lms.counters().power_on_messages >= 1);
    // 37.5 scans per second since streaming started.
    let seconds = (now_us - since_us) as f64 / 1e6;
    let rate = board.scans.len() as f64 / seconds;
    assert!((rate - 37.5).abs() < 1.5, "{rate} scans/s");
    // Each scan: 361 values in mm matching the room within the noise.
    let setup = board.bringup.setup().unwrap();
    let decoder = RangeDecoder::new(setup.measuring_mode, setup.unit).unwrap();
    let model = lms.range_model();
    let variant = lms.variant();
    for (_, scan) in &board.scans {
        assert_eq!(scan.values.len(), 361);
        for (i, &word) in scan.values.iter().enumerate() {
            let expected = model.true_range_m(variant.beam_angle_cdeg(i as u16));
            let measured = decoder.range_mm(word);
            match (expected, measured) {
                (Some(range_m), Some(range_mm)) => {
                    let error_mm = (f64::from(range_mm) - range_m * 1_000.0).abs();
                    assert!(error_mm <= 60.0, "beam {i}: {range_mm} mm vs {range_m} m");
                }
                (expected, measured) => panic!("beam {i}: {expected:?} vs {measured:?}"),
            }
        }
    }
}
