//! What the board does with each host command. Every command is acknowledged, with the board
//! time at reception so that a time-sync ping doubles as a clock sample.

use protocol::{AckMsg, AckResult, Kind, Message, Received};

use crate::tasks::LaserRequest;

/// The consequences of one received frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct CommandOutcome {
    /// The acknowledgement to send, if the frame was a command.
    pub ack: Option<AckMsg>,
    /// A request for the laser task.
    pub laser: Option<LaserRequest>,
    /// Whether a status message was asked for.
    pub status_requested: bool,
}

/// Decides what to do with a frame received from the host at board time `now_us`.
///
/// Laser requests are accepted here only if the command is valid; `laser_queue_full` says
/// whether the laser task can take one now (if not, the answer is [`AckResult::Busy`]).
/// Frames of board-to-host kinds are ignored.
pub fn handle_command(received: &Received, now_us: u64, laser_queue_full: bool) -> CommandOutcome {
    let mut outcome = CommandOutcome {
        ack: None,
        laser: None,
        status_requested: false,
    };
    let mut host_time_us = 0;
    let result = match &received.message {
        Message::ConfigureLaser(cmd) if !cmd.is_supported() => AckResult::Rejected,
        Message::ConfigureLaser(cmd) => laser(
            &mut outcome,
            LaserRequest::Configure(*cmd),
            laser_queue_full,
        ),
        Message::SetStreaming(cmd) => laser(
            &mut outcome,
            LaserRequest::SetStreaming(cmd.enabled),
            laser_queue_full,
        ),
        Message::RequestStatus(_) => {
            outcome.status_requested = true;
            AckResult::Accepted
        }
        Message::TimeSyncPing(ping) => {
            host_time_us = ping.host_time_us;
            AckResult::Accepted
        }
        _ => return outcome,
    };
    outcome.ack = Some(AckMsg {
        command_seq: received.header.seq,
        command_kind: u8::from(received.header.kind),
        result,
        board_time_us: now_us,
        host_time_us,
    });
    outcome
}

fn laser(outcome: &mut CommandOutcome, request: LaserRequest, queue_full: bool) -> AckResult {
    if queue_full {
        AckResult::Busy
    } else {
        outcome.laser = Some(request);
        AckResult::Accepted
    }
}

/// Whether a kind is a command the board obeys.
pub fn is_command(kind: Kind) -> bool {
    kind.direction() == Some(protocol::Direction::HostToBoard)
}

#[cfg(test)]
mod tests {
    use super::*;
    use protocol::{
        AngularResolution, ConfigureLaserCmd, Header, PROTOCOL_VERSION, RangeUnit, ScanAngle,
        SetStreamingCmd, TimeSyncPingCmd,
    };

    fn received(message: Message, seq: u16) -> Received {
        Received {
            header: Header {
                version: PROTOCOL_VERSION,
                kind: message.kind(),
                seq,
            },
            lost_before: 0,
            message,
        }
    }

    #[test]
    fn ping_is_acknowledged_with_both_clocks() {
        let out = handle_command(
            &received(
                Message::TimeSyncPing(TimeSyncPingCmd { host_time_us: 77 }),
                9,
            ),
            1234,
            false,
        );
        let ack = out.ack.unwrap();
        assert_eq!(
            (ack.command_seq, ack.command_kind, ack.result),
            (9, 0x44, AckResult::Accepted)
        );
        assert_eq!((ack.board_time_us, ack.host_time_us), (1234, 77));
    }

    #[test]
    fn unsupported_variant_is_rejected_and_not_forwarded() {
        let cmd = ConfigureLaserCmd {
            angle: ScanAngle::Deg180,
            resolution: AngularResolution::Quarter,
            unit: RangeUnit::Mm,
        };
        let out = handle_command(&received(Message::ConfigureLaser(cmd), 1), 0, false);
        assert_eq!(out.ack.unwrap().result, AckResult::Rejected);
        assert_eq!(out.laser, None);
    }

    #[test]
    fn busy_laser_queue_answers_busy() {
        let m = Message::SetStreaming(SetStreamingCmd { enabled: false });
        assert_eq!(
            handle_command(&received(m.clone(), 1), 0, true)
                .ack
                .unwrap()
                .result,
            AckResult::Busy
        );
        let out = handle_command(&received(m, 2), 0, false);
        assert_eq!(out.laser, Some(LaserRequest::SetStreaming(false)));
    }

    #[test]
    fn board_messages_from_the_host_are_ignored() {
        let m = Message::Heartbeat(protocol::HeartbeatMsg { uptime_us: 0 });
        let out = handle_command(&received(m, 0), 0, false);
        assert_eq!(
            out,
            CommandOutcome {
                ack: None,
                laser: None,
                status_requested: false
            }
        );
    }
}
