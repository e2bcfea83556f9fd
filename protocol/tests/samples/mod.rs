//! One representative message of every kind, shared by the golden and round-trip tests.

#![allow(dead_code)] // Each test file uses a different subset.

use protocol::*;

pub fn scan() -> ScanMsg {
    ScanMsg {
        stamp_us: 1_234_567,
        scan_counter: 42,
        start_angle_cdeg: 0,
        step_angle_cdeg: 100,
        unit: RangeUnit::Mm,
        count_word: 0x4003,
        values: heapless::Vec::from_slice(&[1000, 2000, 0x1FFF]).unwrap(),
        status: 0x10,
        sensor_indices: None,
    }
}

pub fn gps_fix() -> GpsFixMsg {
    GpsFixMsg {
        stamp_us: 5_000_000,
        source: FixSource::Gga,
        talker: *b"GP",
        date: Some(Date {
            year: 2024,
            month: 3,
            day: 9,
        }),
        time: Some(TimeOfDay {
            hour: 12,
            minute: 35,
            second: 19,
            micros: 500_000,
        }),
        quality: FixQuality::Gps,
        position: Some(Position {
            lat_ndeg: 48_117_300_000,
            lon_ndeg: 11_516_666_667,
        }),
        alt_msl_mm: Some(545_400),
        geoid_sep_mm: Some(46_900),
        num_sats: Some(8),
        hdop_centi: Some(90),
        speed_mm_s: None,
        course_cdeg: None,
        gst: Some(GstSigmas {
            lat_sigma_mm: Some(1_200),
            lon_sigma_mm: Some(900),
            ..GstSigmas::default()
        }),
    }
}

pub fn no_fix() -> GpsFixMsg {
    GpsFixMsg {
        stamp_us: 6_000_000,
        source: FixSource::Rmc,
        talker: *b"GN",
        date: None,
        time: None,
        quality: FixQuality::Invalid,
        position: None,
        alt_msl_mm: None,
        geoid_sep_mm: None,
        num_sats: None,
        hdop_centi: None,
        speed_mm_s: None,
        course_cdeg: None,
        gst: None,
    }
}

pub fn nmea() -> NmeaMsg {
    NmeaMsg {
        stamp_us: 7,
        sentence: heapless::String::try_from("$GPGGA,,,,,,0,,,,,,,,*66").unwrap(),
    }
}

pub fn status() -> StatusMsg {
    StatusMsg {
        uptime_us: 10_000_000,
        laser: LinkCounters {
            bytes: 73_200,
            telegrams: 100,
            crc_errors: 1,
            resyncs: 2,
            uart_overruns: 0,
            dropped_frames: 3,
            missed: 4,
        },
        gps: LinkCounters {
            bytes: 700,
            telegrams: 10,
            ..LinkCounters::default()
        },
        host: LinkCounters::default(),
        laser_state: LaserState::Streaming,
        laser_baud: 500_000,
        gps_state: GpsState::Fix,
        pps_edges: 9,
    }
}

pub fn heartbeat() -> HeartbeatMsg {
    HeartbeatMsg { uptime_us: 5 }
}

pub fn log() -> LogMsg {
    LogMsg {
        stamp_us: 1,
        level: LogLevel::Warn,
        text: heapless::String::try_from("laser restarted").unwrap(),
    }
}

pub fn ack() -> AckMsg {
    AckMsg {
        command_seq: 3,
        command_kind: 0x44,
        result: AckResult::Accepted,
        board_time_us: 1000,
        host_time_us: 999,
    }
}

pub fn configure() -> ConfigureLaserCmd {
    ConfigureLaserCmd {
        angle: ScanAngle::Deg180,
        resolution: AngularResolution::Half,
        unit: RangeUnit::Mm,
    }
}

/// Every kind once.
pub fn all() -> Vec<Message> {
    vec![
        Message::Scan(scan()),
        Message::GpsFix(gps_fix()),
        Message::GpsFix(no_fix()),
        Message::Nmea(nmea()),
        Message::Status(status()),
        Message::Heartbeat(heartbeat()),
        Message::Log(log()),
        Message::Ack(ack()),
        Message::ConfigureLaser(configure()),
        Message::SetStreaming(SetStreamingCmd { enabled: true }),
        Message::RequestStatus(RequestStatusCmd),
        Message::TimeSyncPing(TimeSyncPingCmd { host_time_us: 999 }),
        Message::Pps(PpsMsg {
            edge_us: 2_000_000,
            count: 2,
        }),
    ]
}
