//! Frame codecs shared by the real buses and the simulated ones, so that the same decoders run
//! in simulation and on the robot. Pure functions over bytes: no I/O, no allocation, no panic on
//! any input (fuzzed with proptest).

pub mod as5048;
pub mod canopen;
pub mod netft;
