//! Fault injection: what goes wrong between the emulated sensors and the firmware.
//!
//! * [`FaultSpec`] ([`spec`]): the faults asked for on the command line with `--faults`,
//!   e.g. `ber=1e-5,drop=1e-4,truncate=0.01,laser-restart=30,gps-outage=60:15,link-replug=90`.
//! * [`ByteFaults`] ([`bytes`]): a seeded, deterministic transformer that flips bits, drops
//!   bytes and cuts laser telegrams short in a byte stream, counting what it did in
//!   [`InjectedFaults`].
//!
//! Timed events (laser restarts, GPS outages, link replugs) are only described here; the
//! devices that own the emulators and ports act on them.

pub mod bytes;
pub mod spec;

pub use bytes::{ByteFaults, InjectedFaults};
pub use spec::{FaultSpec, FaultSpecError, FaultSpecErrorKind, GpsOutage};
