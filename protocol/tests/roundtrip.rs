//! Property tests: every message survives encode → decode, whatever its field values, in any
//! chunking; arbitrary bytes never panic the decoder; damage to one frame never costs another.

use proptest::collection::vec;
use proptest::option;
use proptest::prelude::*;
use protocol::*;

fn range_unit() -> impl Strategy<Value = RangeUnit> {
    prop_oneof![Just(RangeUnit::Cm), Just(RangeUnit::Mm)]
}

fn scan() -> impl Strategy<Value = ScanMsg> {
    (
        any::<u64>(),
        any::<u32>(),
        any::<(u16, u16)>(),
        range_unit(),
        any::<u16>(),
        vec(any::<u16>(), 0..=MAX_SCAN_VALUES),
        any::<u8>(),
        option::of(any::<(u8, u8)>()),
    )
        .prop_map(
            |(
                stamp_us,
                scan_counter,
                (start, step),
                unit,
                count_word,
                values,
                status,
                sensor_indices,
            )| ScanMsg {
                stamp_us,
                scan_counter,
                start_angle_cdeg: start,
                step_angle_cdeg: step,
                unit,
                count_word,
                values: heapless::Vec::from_slice(&values).unwrap(),
                status,
                sensor_indices,
            },
        )
}

fn quality() -> impl Strategy<Value = FixQuality> {
    (0u8..=8).prop_map(|d| FixQuality::from_gga_digit(d).unwrap())
}

fn gst() -> impl Strategy<Value = GstSigmas> {
    vec(option::of(any::<u32>()), 7).prop_map(|v| GstSigmas {
        rms_mm: v[0],
        semi_major_mm: v[1],
        semi_minor_mm: v[2],
        orientation_cdeg: v[3],
        lat_sigma_mm: v[4],
        lon_sigma_mm: v[5],
        alt_sigma_mm: v[6],
    })
}

fn gps_fix() -> impl Strategy<Value = GpsFixMsg> {
    (
        (
            any::<u64>(),
            prop_oneof![
                Just(FixSource::Gga),
                Just(FixSource::Rmc),
                Just(FixSource::Gll)
            ],
            any::<[u8; 2]>(),
        ),
        option::of(
            (any::<u16>(), any::<u8>(), any::<u8>()).prop_map(|(year, month, day)| Date {
                year,
                month,
                day,
            }),
        ),
        option::of((any::<(u8, u8, u8)>(), any::<u32>()).prop_map(
            |((hour, minute, second), micros)| TimeOfDay {
                hour,
                minute,
                second,
                micros,
            },
        )),
        quality(),
        option::of(
            (
                -90_000_000_000i64..=90_000_000_000,
                -180_000_000_000i64..=180_000_000_000,
            )
                .prop_map(|(lat_ndeg, lon_ndeg)| Position { lat_ndeg, lon_ndeg }),
        ),
        (
            option::of(any::<i32>()),
            option::of(any::<i32>()),
            option::of(any::<u8>()),
            option::of(any::<u16>()),
        ),
        (
            option::of(any::<u32>()),
            option::of(any::<u32>()),
            option::of(gst()),
        ),
    )
        .prop_map(
            |(
                (stamp_us, source, talker),
                date,
                time,
                quality,
                position,
                (alt, geoid, sats, hdop),
                (speed, course, gst),
            )| GpsFixMsg {
                stamp_us,
                source,
                talker,
                date,
                time,
                quality,
                position,
                alt_msl_mm: alt,
                geoid_sep_mm: geoid,
                num_sats: sats,
                hdop_centi: hdop,
                speed_mm_s: speed,
                course_cdeg: course,
                gst,
            },
        )
}

fn counters() -> impl Strategy<Value = LinkCounters> {
    any::<[u32; 7]>().prop_map(|c| LinkCounters {
        bytes: c[0],
        telegrams: c[1],
        crc_errors: c[2],
        resyncs: c[3],
        uart_overruns: c[4],
        dropped_frames: c[5],
        missed: c[6],
    })
}

fn status() -> impl Strategy<Value = StatusMsg> {
    let laser_state = prop_oneof![
        Just(LaserState::DetectingBaud),
        Just(LaserState::Configuring),
        Just(LaserState::SwitchingBaud),
        Just(LaserState::Streaming),
        Just(LaserState::Idle),
        Just(LaserState::Failed),
    ];
    let gps_state = prop_oneof![
        Just(GpsState::Silent),
        Just(GpsState::NoFix),
        Just(GpsState::Fix)
    ];
    (
        any::<u64>(),
        counters(),
        counters(),
        counters(),
        laser_state,
        any::<u32>(),
        gps_state,
        any::<u32>(),
    )
        .prop_map(
            |(uptime_us, laser, gps, host, laser_state, laser_baud, gps_state, pps_edges)| {
                StatusMsg {
                    uptime_us,
                    laser,
                    gps,
                    host,
                    laser_state,
                    laser_baud,
                    gps_state,
                    pps_edges,
                }
            },
        )
}

fn message() -> impl Strategy<Value = Message> {
    let level = prop_oneof![
        Just(LogLevel::Debug),
        Just(LogLevel::Info),
        Just(LogLevel::Warn),
        Just(LogLevel::Error)
    ];
    let result = prop_oneof![
        Just(AckResult::Accepted),
        Just(AckResult::Rejected),
        Just(AckResult::Busy)
    ];
    let angle = prop_oneof![Just(ScanAngle::Deg100), Just(ScanAngle::Deg180)];
    let res = prop_oneof![
        Just(AngularResolution::Quarter),
        Just(AngularResolution::Half),
        Just(AngularResolution::One)
    ];
    prop_oneof![
        scan().prop_map(Message::Scan),
        gps_fix().prop_map(Message::GpsFix),
        (any::<u64>(), "[ -~]{0,126}").prop_map(|(stamp_us, s)| Message::Nmea(NmeaMsg {
            stamp_us,
            sentence: heapless::String::try_from(s.as_str()).unwrap()
        })),
        status().prop_map(Message::Status),
        any::<u64>().prop_map(|uptime_us| Message::Heartbeat(HeartbeatMsg { uptime_us })),
        (any::<u64>(), level, "\\PC{0,16}").prop_map(|(stamp_us, level, s)| Message::Log(LogMsg {
            stamp_us,
            level,
            text: heapless::String::try_from(s.as_str()).unwrap()
        })),
        (any::<(u16, u8, u64, u64)>(), result).prop_map(
            |((command_seq, command_kind, board_time_us, host_time_us), result)| {
                Message::Ack(AckMsg {
                    command_seq,
                    command_kind,
                    result,
                    board_time_us,
                    host_time_us,
                })
            }
        ),
        (angle, res, range_unit()).prop_map(|(angle, resolution, unit)| Message::ConfigureLaser(
            ConfigureLaserCmd {
                angle,
                resolution,
                unit
            }
        )),
        any::<bool>().prop_map(|enabled| Message::SetStreaming(SetStreamingCmd { enabled })),
        Just(Message::RequestStatus(RequestStatusCmd)),
        any::<u64>()
            .prop_map(|host_time_us| Message::TimeSyncPing(TimeSyncPingCmd { host_time_us })),
        any::<(u64, u32)>().prop_map(|(edge_us, count)| Message::Pps(PpsMsg { edge_us, count })),
    ]
}

fn encode_all(messages: &[Message]) -> Vec<u8> {
    let mut enc = Encoder::new();
    let mut out = [0u8; MAX_WIRE_LEN];
    let mut wire = Vec::new();
    for m in messages {
        wire.extend_from_slice(enc.encode(m, &mut out).unwrap());
    }
    wire
}

proptest! {
    #[test]
    fn round_trip_in_any_chunking(messages in vec(message(), 1..8), chunk in 1usize..300) {
        let wire = encode_all(&messages);
        let mut dec = Decoder::new();
        let mut got = Vec::new();
        for piece in wire.chunks(chunk) {
            dec.feed(piece, |r| got.push(r.message));
        }
        prop_assert_eq!(got, messages);
        prop_assert_eq!(dec.stats().lost, 0);
        prop_assert_eq!(dec.stats().bytes, wire.len() as u64);
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in vec(any::<u8>(), 0..4096)) {
        let mut dec = Decoder::new();
        dec.feed(&bytes, |_| {});
        prop_assert_eq!(dec.stats().bytes, bytes.len() as u64);
    }

    #[test]
    fn damage_costs_only_the_damaged_frame(
        messages in vec(message(), 2..8),
        victim in any::<prop::sample::Index>(),
        offset in any::<prop::sample::Index>(),
        flip in 1u8..=255,
    ) {
        let mut enc = Encoder::new();
        let mut out = [0u8; MAX_WIRE_LEN];
        let frames: Vec<Vec<u8>> = messages.iter().map(|m| enc.encode(m, &mut out).unwrap().to_vec()).collect();
        let v = victim.index(frames.len());
        let mut wire = Vec::new();
        for (i, f) in frames.iter().enumerate() {
            let mut f = f.clone();
            if i == v {
                // Damage one byte before the delimiter (a zero would split the frame in two,
                // which the next test covers).
                let at = offset.index(f.len() - 1);
                f[at] ^= flip;
                if f[at] == 0 { f[at] = 0x5a; }
            }
            wire.extend(f);
        }
        let mut dec = Decoder::new();
        let mut got = Vec::new();
        dec.feed(&wire, |r| got.push(r.message));
        // Every other frame arrives intact and in order; the damaged one is rejected, or
        // delivered unchanged if the damage was to a COBS code that still decodes to the same
        // bytes (impossible with a CRC-32 unless the flip was a no-op).
        let others: Vec<_> = messages.iter().enumerate().filter(|(i, _)| *i != v).map(|(_, m)| m.clone()).collect();
        prop_assert!(got == others || got == messages, "got {} of {}", got.len(), messages.len());
    }
}
