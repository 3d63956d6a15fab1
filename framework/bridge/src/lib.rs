//! # jointctl-bridge
//!
//! A running arm beyond its machine's shared memory. Each bridge is a separate process that reads
//! the arm like any inspector ([`jointctl_record::feed::ArmFeed`]): a slow or dead network never
//! slows the control loop, whose publisher only ever drops samples for a slow reader.
//!
//! - [`foxglove`]: the official Foxglove SDK's WebSocket server (`foxglove.sdk.v1`, and the
//!   older `foxglove.websocket.v1` through a relay), one JSON-schema channel per recorded topic,
//!   so a layout made on a recording works live.
//! - [`zenoh`]: the same messages over Zenoh for other machines, and commands from them, only
//!   when the arm's YAML allows them and only from peers that authenticate.
//! - [`ros2`]: ROS 2 topics over DDS (`/joint_states`, `/diagnostics`, the jointctl topics),
//!   the ROS 2 recording profile's messages; commands only of the kinds the YAML allows.
//!
//! Foxglove and Zenoh send the recording's JSON ([`jointctl_record::messages`]): SI units in the field names,
//! `null` for a value that is not known.

#![warn(missing_docs)]
#![deny(unsafe_code)]

pub mod foxglove;
pub mod ros2;
pub mod zenoh;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_record::feed::{ArmFeed, FeedError, FeedMessage, NumberGaps};

/// What a bridge forwarded.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct BridgeSummary {
    /// Messages read from the arm per topic (each sent to every client subscribed to it).
    pub messages: BTreeMap<String, u64>,
    /// Samples the bridge never read, per topic: gaps in the cycle (or command sequence)
    /// numbers, where it fell behind the arm and the arm's queue moved on, or the runtime
    /// dropped the record itself (its diagnostics' `publish_drops`).
    pub lost: BTreeMap<String, u64>,
    /// The arm stopped (its final sample).
    pub arm_stopped: bool,
}

/// Where a bridge reads the arm's samples: the arm's feed, or a stand-in in tests.
trait Samples {
    /// Hands every sample waiting to `each`; returns how many there were.
    fn poll_each(&mut self, each: &mut dyn FnMut(FeedMessage<'_>)) -> Result<usize, FeedError>;
}

impl Samples for ArmFeed {
    fn poll_each(&mut self, each: &mut dyn FnMut(FeedMessage<'_>)) -> Result<usize, FeedError> {
        self.poll(|m| {
            each(m);
            Ok::<_, FeedError>(())
        })
    }
}

/// Hands the arm's samples to `send` until `stop` is set, the arm's final sample, or `timeout`
/// without a sample; `between` runs after every poll (a bridge's other duties, such as
/// answering commands).
///
/// The arm's silence is judged by polls alone, before `between` runs: the time a bridge spends
/// on its own duties is not the arm's. Judged after it, a burst of commands answered after a
/// poll that found nothing (3000 from the network, each waiting for the runtime's answer) read as
/// the arm falling silent, and the bridge stopped while the arm ran on (issue 40, finding 13).
fn pump(
    feed: &mut impl Samples,
    stop: &AtomicBool,
    timeout: Duration,
    bridge: &str,
    mut send: impl FnMut(&FeedMessage<'_>),
    mut between: impl FnMut(),
) -> Result<BridgeSummary, FeedError> {
    let mut summary = BridgeSummary::default();
    let mut gaps: BTreeMap<&'static str, NumberGaps> = BTreeMap::new();
    let mut last_sample = Instant::now();
    loop {
        let n = feed.poll_each(&mut |m| {
            send(&m);
            *summary.messages.entry(m.topic.to_string()).or_default() += 1;
            gaps.entry(m.topic).or_default().see(m.number);
            summary.arm_stopped |= m.final_sample;
        })?;
        let silent = if n > 0 {
            last_sample = Instant::now();
            false
        } else {
            last_sample.elapsed() > timeout
        };
        if !silent {
            between();
        }
        if stop.load(Ordering::Acquire) || summary.arm_stopped || silent {
            if silent {
                tracing::warn!(timeout_s = timeout.as_secs_f64(), "the arm fell silent; the {bridge} bridge stops");
            }
            summary.lost = gaps.iter().map(|(topic, g)| (topic.to_string(), g.lost())).collect();
            return Ok(summary);
        }
        if n == 0 {
            std::thread::sleep(Duration::from_millis(2));
        }
    }
}

/// Commands forwarded at most `per_s` a second: a token bucket of at most a second's worth (at
/// least one), refilled continuously.
pub(crate) struct RateLimit {
    pub(crate) per_s: f64,
    tokens: f64,
    at: Instant,
}

impl RateLimit {
    pub(crate) fn new(per_s: f64) -> Self {
        RateLimit { per_s, tokens: per_s.max(1.0), at: Instant::now() }
    }

    /// Takes a token at `now` if there is one.
    pub(crate) fn take(&mut self, now: Instant) -> bool {
        self.tokens = (self.tokens + self.per_s * now.saturating_duration_since(self.at).as_secs_f64()).min(self.per_s.max(1.0));
        self.at = now;
        if self.tokens >= 1.0 {
            self.tokens -= 1.0;
            true
        } else {
            false
        }
    }
}

#[cfg(test)]
mod rate_limit_tests {
    use crate::RateLimit;
    use std::time::{Duration, Instant};

    #[test]
    fn the_bucket_holds_a_seconds_worth_and_refills_at_the_rate() {
        let start = Instant::now();
        let mut limit = RateLimit { per_s: 5.0, tokens: 5.0, at: start };
        assert_eq!((0..8).filter(|_| limit.take(start)).count(), 5, "a second's worth at once");
        assert!(!limit.take(start + Duration::from_millis(100)), "half a token after 0.1 s");
        assert!(limit.take(start + Duration::from_millis(200)), "one after 0.2 s");
        // Idle for a minute: still a second's worth, not sixty.
        let later = start + Duration::from_secs(60);
        assert_eq!((0..8).filter(|_| limit.take(later)).count(), 5);
        // Below one a second: one token, refilled in 1 / rate.
        let mut slow = RateLimit { per_s: 0.1, tokens: 1.0, at: start };
        assert!(slow.take(start) && !slow.take(start + Duration::from_secs(9)) && slow.take(start + Duration::from_millis(10_500)));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The config checks `network.*.commands.allow` against its own list of command kinds (it
    /// does not link the shared-memory crate): the two lists must be the same.
    #[test]
    fn the_configs_command_kinds_are_the_runtimes() {
        let runtime: Vec<&str> = jointctl_ipc::CommandKind::ALL.iter().map(|(_, n)| *n).collect();
        assert_eq!(jointctl_config::COMMAND_KINDS.to_vec(), runtime);
    }

    /// A stand-in for the arm: one joint state a poll, except the polls listed as empty; the
    /// state of poll `n` is cycle `n * stride` (a stride over 1: the bridge fell behind).
    struct Arm {
        polls: usize,
        empty: Vec<usize>,
        stride: u64,
    }

    impl Samples for Arm {
        fn poll_each(&mut self, each: &mut dyn FnMut(FeedMessage<'_>)) -> Result<usize, FeedError> {
            self.polls += 1;
            if self.empty.contains(&self.polls) {
                return Ok(0);
            }
            each(FeedMessage { topic: "joint_state", number: self.polls as u64 * self.stride, stamp_ns: 0, json: "{}", final_sample: false, sample: jointctl_record::feed::Sample::State(&jointctl_ipc::ArmState::EMPTY) });
            Ok(1)
        }
    }

    #[test]
    fn time_spent_answering_commands_is_not_the_arms_silence() {
        // Issue 40, finding 13: the poll before a burst of commands found nothing, the burst took
        // longer than the timeout, and the bridge stopped as if the arm had fallen silent.
        let stop = AtomicBool::new(false);
        let mut arm = Arm { polls: 0, empty: vec![1], stride: 1 };
        let mut betweens = 0;
        let summary = pump(&mut arm, &stop, Duration::from_millis(50), "test", |_| {}, || {
            betweens += 1;
            if betweens == 1 {
                std::thread::sleep(Duration::from_millis(120));
            }
            if betweens == 5 {
                stop.store(true, Ordering::Release);
            }
        })
        .unwrap();
        assert_eq!(betweens, 5, "the bridge stopped after {betweens} rounds");
        assert_eq!(summary.messages.get("joint_state"), Some(&4));
        assert_eq!(summary.lost.get("joint_state"), Some(&0));
    }

    /// Finding (issue 34): a bridge said nothing of the samples it never read (the ROS 2 bridge
    /// of a 700-DOF arm on a loaded 2-core machine forwarded 5467 joint states in 10 s, and
    /// whether it had missed any could not be told). The summary now counts them, by the gaps
    /// in the cycle numbers.
    #[test]
    fn samples_the_bridge_never_read_are_counted_as_lost() {
        let stop = AtomicBool::new(false);
        let mut arm = Arm { polls: 0, empty: Vec::new(), stride: 3 };
        let mut polls = 0;
        let summary = pump(&mut arm, &stop, Duration::from_millis(50), "test", |_| {}, || {
            polls += 1;
            if polls == 10 {
                stop.store(true, Ordering::Release);
            }
        })
        .unwrap();
        // Cycles 3, 6, ..., 30 read: the 18 between them lost.
        assert_eq!((summary.messages.get("joint_state"), summary.lost.get("joint_state")), (Some(&10), Some(&18)));
    }

    #[test]
    fn an_arm_that_stays_silent_stops_the_bridge() {
        let stop = AtomicBool::new(false);
        let mut arm = Arm { polls: 0, empty: (1..10_000).collect(), stride: 1 };
        let started = Instant::now();
        let summary = pump(&mut arm, &stop, Duration::from_millis(50), "test", |_| {}, || {}).unwrap();
        assert!(started.elapsed() >= Duration::from_millis(50) && summary.messages.is_empty(), "{summary:?}");
    }
}
