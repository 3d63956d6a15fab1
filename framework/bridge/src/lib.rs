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

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_record::feed::{ArmFeed, FeedError, FeedMessage};

/// What a bridge forwarded.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BridgeSummary {
    /// Messages read from the arm per topic (each sent to every client subscribed to it).
    pub messages: BTreeMap<String, u64>,
    /// The arm stopped (its final sample).
    pub arm_stopped: bool,
}

/// Hands the arm's samples to `send` until `stop` is set, the arm's final sample, or `timeout`
/// without a sample; `between` runs after every poll (a bridge's other duties, such as
/// answering commands).
fn pump(
    feed: &mut ArmFeed,
    stop: &AtomicBool,
    timeout: Duration,
    bridge: &str,
    mut send: impl FnMut(&FeedMessage<'_>),
    mut between: impl FnMut(),
) -> Result<BridgeSummary, FeedError> {
    let mut summary = BridgeSummary::default();
    let mut last_sample = Instant::now();
    loop {
        let n = feed.poll(|m| {
            send(&m);
            *summary.messages.entry(m.topic.to_string()).or_default() += 1;
            summary.arm_stopped |= m.final_sample;
            Ok::<_, FeedError>(())
        })?;
        between();
        if stop.load(Ordering::Acquire) || summary.arm_stopped {
            return Ok(summary);
        }
        if n > 0 {
            last_sample = Instant::now();
        } else if last_sample.elapsed() > timeout {
            tracing::warn!(timeout_s = timeout.as_secs_f64(), "the arm fell silent; the {bridge} bridge stops");
            return Ok(summary);
        } else {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}
