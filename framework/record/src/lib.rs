//! # jointctl-record
//!
//! Recordings of a running arm, rosbag-like: [`recorder::record`] subscribes to the arm's
//! shared-memory services (`raw`, `joint_state`, `diagnostics`, `commands`) and writes them into
//! one MCAP file, each channel JSON with a JSON schema ([`messages`]), so that Foxglove opens the
//! file as it is. Log time is each cycle's CLOCK_MONOTONIC stamp; the wall-clock time at the start
//! is in the file's `jointctl` metadata; the arm's YAML (and the files it includes) are attached.
//! Lost samples are found from the cycle and sequence numbers and reported, never hidden.

#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod feed;
pub mod messages;
pub mod recorder;
pub mod reader;
