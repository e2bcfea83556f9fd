//! Host software for the robot computer.
