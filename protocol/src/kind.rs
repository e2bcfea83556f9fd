//! Message kinds: the second header byte, which says how to read the payload.

/// Which way a message travels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Direction {
    /// Sent by the board, read by the host.
    BoardToHost,
    /// Sent by the host, obeyed by the board.
    HostToBoard,
}

macro_rules! kinds {
    ($( $(#[$doc:meta])* $name:ident = $value:literal, $dir:ident; )*) => {
        /// The kind of a frame's payload. Values the receiver does not know become
        /// [`Kind::Unknown`] so that a newer peer never makes it fail.
        #[derive(Debug, Clone, Copy, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Kind {
            $( $(#[$doc])* $name, )*
            /// A kind this version does not know.
            Unknown(u8),
        }

        impl From<u8> for Kind {
            fn from(value: u8) -> Self {
                match value {
                    $( $value => Kind::$name, )*
                    other => Kind::Unknown(other),
                }
            }
        }

        impl From<Kind> for u8 {
            fn from(kind: Kind) -> u8 {
                match kind {
                    $( Kind::$name => $value, )*
                    Kind::Unknown(other) => other,
                }
            }
        }

        impl Kind {
            /// The direction this kind travels in, or `None` for an unknown kind.
            pub fn direction(self) -> Option<Direction> {
                match self {
                    $( Kind::$name => Some(Direction::$dir), )*
                    Kind::Unknown(_) => None,
                }
            }
        }
    };
}

kinds! {
    /// One laser scan ([`crate::ScanMsg`]).
    Scan = 0x01, BoardToHost;
    /// One GPS fix or no-fix report ([`crate::GpsFixMsg`]).
    GpsFix = 0x02, BoardToHost;
    /// A raw NMEA sentence passed through for recording ([`crate::NmeaMsg`]).
    Nmea = 0x03, BoardToHost;
    /// Device status and counters ([`crate::StatusMsg`]).
    Status = 0x04, BoardToHost;
    /// Board uptime for clock synchronisation ([`crate::HeartbeatMsg`]).
    Heartbeat = 0x05, BoardToHost;
    /// A log event ([`crate::LogMsg`]).
    Log = 0x06, BoardToHost;
    /// Acknowledgement of a host command ([`crate::AckMsg`]).
    Ack = 0x07, BoardToHost;
    /// A GPS pulse-per-second edge ([`crate::PpsMsg`]).
    Pps = 0x08, BoardToHost;
    /// Configure the laser's variant and units ([`crate::ConfigureLaserCmd`]).
    ConfigureLaser = 0x41, HostToBoard;
    /// Start or stop laser streaming ([`crate::SetStreamingCmd`]).
    SetStreaming = 0x42, HostToBoard;
    /// Ask for a status message now ([`crate::RequestStatusCmd`]).
    RequestStatus = 0x43, HostToBoard;
    /// Clock synchronisation ping ([`crate::TimeSyncPingCmd`]).
    TimeSyncPing = 0x44, HostToBoard;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_byte_round_trips() {
        for value in 0..=255u8 {
            assert_eq!(u8::from(Kind::from(value)), value);
        }
    }

    #[test]
    fn unknown_has_no_direction() {
        assert_eq!(Kind::from(0xEE), Kind::Unknown(0xEE));
        assert_eq!(Kind::Unknown(0xEE).direction(), None);
        assert_eq!(Kind::Scan.direction(), Some(Direction::BoardToHost));
        assert_eq!(Kind::SetStreaming.direction(), Some(Direction::HostToBoard));
    }
}
