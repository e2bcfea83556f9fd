//! A real receiver log through the whole chain: GPS pty → firmware GPS task (embassy std
//! executor) → host link frames → host decoder. The fixes that arrive must be exactly the
//! ones the parser produces on the same bytes, with nothing lost.

use std::io::Write;
use std::time::Duration;

use firmware::nmea::GpsReceiver;
use firmware::sick::BringUpConfig;
use firmware::tasks::gps::GpsOptions;
use hil_sim::board::{self, BoardConfig};
use hil_sim::pty::PtyLink;
use host::link::LinkReader;
use protocol::{GpsFixMsg, Message};
use system_tests::read_until;

fn without_stamp(mut fix: GpsFixMsg) -> GpsFixMsg {
    fix.stamp_us = 0;
    fix
}

#[test]
fn receiver_log_arrives_at_the_host_intact() {
    let Some(path) = datasets::require(
        "nmea-real/gpsd/ublox-lea-4h.log",
        "receiver_log_arrives_at_the_host_intact",
    ) else {
        return;
    };
    let log = std::fs::read(&path).unwrap();
    let lines: Vec<&[u8]> = log
        .split_inclusive(|&b| b == b'\n')
        .filter(|l| !l.starts_with(b"#"))
        .collect();

    let mut expected = Vec::new();
    let mut parser = GpsReceiver::new();
    for line in &lines {
        parser.push(line, 0, |s| expected.extend(s.fix.map(without_stamp)));
    }
    assert!(expected.len() > 10);

    let laser = PtyLink::open().unwrap();
    let mut gps = PtyLink::open().unwrap();
    let mut host = PtyLink::open().unwrap();
    let board = board::spawn(BoardConfig {
        laser_path: laser.board_path().into(),
        gps_path: gps.board_path().into(),
        host_path: host.board_path().into(),
        gps_baud: 9_600,
        laser: BringUpConfig::default(),
        gps: GpsOptions::default(),
    })
    .unwrap();

    // Paced a little, as a UART would deliver it, so the link is never congested.
    for line in &lines {
        gps.device.write_all(line).unwrap();
        std::thread::sleep(Duration::from_millis(3));
    }
    let mut reader = LinkReader::new();
    let want = expected.len();
    let received = read_until(
        &mut host.device,
        &mut reader,
        Duration::from_secs(20),
        |got| {
            got.iter()
                .filter(|r| matches!(r.message, Message::GpsFix(_)))
                .count()
                >= want
        },
    );
    let fixes: Vec<GpsFixMsg> = received
        .iter()
        .filter_map(|r| match &r.message {
            Message::GpsFix(f) => Some(without_stamp(*f)),
            _ => None,
        })
        .collect();
    assert_eq!(fixes, expected);
    assert_eq!(reader.stats().lost, 0);
    // The task may still be reading the sentences after the last fix.
    let sent_bytes = lines.iter().map(|l| l.len()).sum::<usize>();
    for _ in 0..100 {
        if board.shared.status(0).gps.bytes as usize == sent_bytes {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let status = board.shared.status(0);
    assert_eq!(status.gps.dropped_frames, 0);
    assert_eq!(status.gps.bytes as usize, sent_bytes);
    board.stop();
    drop(laser);
}
