//! # jointctl-bridge
//!
//! A running arm beyond its machine's shared memory. Each bridge is a separate process that reads
//! the arm like any inspector ([`jointctl_record::feed::ArmFeed`]): a slow or dead network never
//! slows the control loop, whose publisher only ever drops samples for a slow reader.
//!
//! - [`foxglove`]: the official Foxglove SDK's WebSocket server (`foxglove.websocket.v1`), one
//!   JSON-schema channel per recorded topic, so a layout made on a recording works live.
//! - [`zenoh`]: the same messages over Zenoh for other machines, and commands from them, only
//!   when the arm's YAML allows them and only from peers that authenticate.
//!
//! Both send the recording's JSON ([`jointctl_record::messages`]): SI units in the field names,
//! `null` for a value that is not known.

#![deny(unsafe_code)]

pub mod foxglove;
pub mod zenoh;

/// The recorded topics every bridge sends, in the recording's names.
pub use jointctl_record::messages::CHANNELS;
