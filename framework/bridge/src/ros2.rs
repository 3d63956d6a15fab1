//! ROS 2 nodes see the arm: its samples as ROS 2 topics over DDS (RTPS, what every ROS 2 RMW
//! speaks), published by a ROS 2 node of a pure-Rust client (`ros2-client` on RustDDS: no ROS
//! installation to build or run). The topics and types are the ROS 2 recording profile's
//! ([`jointctl_ros2::topics`]), with ROS 2's default QoS (reliable, volatile, keep last 10).
//!
//! Commands from ROS 2 (`trajectory_msgs/JointTrajectory` on `/jointctl/joint_trajectory`,
//! `jointctl_msgs/CommandRequest` on `/jointctl/command`) are refused, each answered on
//! `/jointctl/command_responses` with the reason, unless the arm's YAML allows their kind
//! (`network.ros2.commands.allow`). DDS has no authentication unless DDS Security is set up: any
//! host that reaches the domain can send what the YAML allows.

use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use jointctl_ipc::IpcScope;
use jointctl_record::feed::{ArmFeed, FeedError, Sample};
use jointctl_ros2::Encoded;
use jointctl_ros2::direct::DirectEncoder;
use jointctl_ros2::from_arm::{self, WallClock};
use jointctl_ros2::msg::{self, Time};
use ros2_client::qos::{Durability, History, WhenFull};
use jointctl_ipc::CommandClient;
use jointctl_record::messages;
use ros2_client::dds::rustdds::{DomainParticipant, GUID, TopicDescription};
use ros2_client::{Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile, Subscription};
use serde_json::{Value, json};

use crate::BridgeSummary;

/// What to serve.
#[derive(Clone, Debug)]
pub struct Ros2Options {
    /// The arm (its YAML `arm:` name).
    pub arm: String,
    /// Its shared memory.
    pub scope: IpcScope,
    /// The DDS domain (`ROS_DOMAIN_ID`, 0-232); `None`: the YAML's `network.ros2.domain_id`.
    pub domain_id: Option<u16>,
    /// The arm's YAML, for its `network` section; `None`: the file the runtime runs.
    pub config: Option<std::path::PathBuf>,
    /// How long to wait for the arm's services, and how long the arm may be silent [s].
    pub timeout_s: f64,
    /// How long to wait for the runtime's answer to a command [s].
    pub command_timeout_s: f64,
}

/// Why the bridge stopped with an error.
#[derive(Debug, thiserror::Error)]
pub enum Ros2BridgeError {
    /// The arm could not be read.
    #[error(transparent)]
    Feed(#[from] FeedError),
    /// The arm's YAML could not be read.
    #[error("{}: {reason}", .file.display())]
    Config {
        /// The file.
        file: std::path::PathBuf,
        /// Why.
        reason: String,
    },
    /// The runtime's command service could not be reached.
    #[error(transparent)]
    Runtime(jointctl_ipc::CommandError),
    /// The DDS participant, the node or a publisher could not be created.
    #[error("cannot create the ROS 2 {what} (DDS domain {domain_id}): {reason}")]
    Dds {
        /// What: `participant`, `node`, a topic.
        what: String,
        /// The domain.
        domain_id: u16,
        /// The client's reason.
        reason: String,
    },
}

/// The name of the arm's node: `jointctl_<arm>`, every character that a ROS 2 name does not take
/// made `_`.
///
/// ```
/// assert_eq!(jointctl_bridge::ros2::node_name("sherpa-2"), "jointctl_sherpa_2");
/// ```
pub fn node_name(arm: &str) -> String {
    let clean: String = arm.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    format!("jointctl_{clean}")
}

/// The diagnostics go out once a second, as ROS 2's `diagnostic_updater` sends them: the
/// aggregator and `rqt_runtime_monitor` expect that, and every cycle at 1 kHz would be a
/// thousand arrays a second of counters that change slowly.
const DIAGNOSTICS_PERIOD: Duration = Duration::from_nanos(jointctl_ros2::direct::EVERY_STATUS_PERIOD_NS);

/// A publisher for each of the arm's topics. The cycle's messages go out already in CDR
/// ([`Encoded`], written by [`DirectEncoder`] straight from the samples): built as messages, a
/// 700-DOF arm's cycle was some 9000 strings, and the bridge took 81-88 % of a core at 1 kHz
/// (61-62 % so; docs/benchmarks.md).
struct Publishers {
    joint_states: Publisher<Encoded<msg::JointState>>,
    joint_details: Publisher<Encoded<msg::JointDetails>>,
    diagnostics: Publisher<Encoded<msg::DiagnosticArray>>,
    raw: Publisher<Encoded<msg::RawFrame>>,
    commands: Publisher<msg::CommandRecord>,
    direct: DirectEncoder,
    cdr: Vec<u8>,
}

impl Publishers {
    /// Publishes the message of type `M` in `cdr`: whether the write went (a buffer that is not
    /// a little-endian CDR message, which `DirectEncoder` never writes, counts as a failed
    /// write).
    fn send<M: msg::Message>(publisher: &Publisher<Encoded<M>>, cdr: &[u8]) -> bool {
        Encoded::<M>::from_cdr(cdr).is_ok_and(|m| publisher.publish(m).is_ok())
    }
}

/// A topic of `M` on the node, with ROS 2's default QoS (reliable: a default ROS 2 subscription
/// matches only a reliable writer). The writers never wait: once a reader has left a writer's
/// limit of samples unacknowledged (RustDDS: 8192), a write fails at once and is counted.
fn topic<M: msg::Message>(node: &Node, topic: &str, domain_id: u16, what: &str) -> Result<ros2_client::dds::rustdds::Topic, Ros2BridgeError> {
    let dds = |reason: String| Ros2BridgeError::Dds { what: format!("{what} of {topic}"), domain_id, reason };
    let (package, rest) = M::NAME.split_once("/msg/").ok_or_else(|| dds(format!("type name {} is not package/msg/Type", M::NAME)))?;
    // `/jointctl/raw`: the namespace `/jointctl`, the name `raw`.
    let (namespace, base) = topic.rsplit_once('/').map_or(("/", topic), |(ns, b)| (if ns.is_empty() { "/" } else { ns }, b));
    let name = Name::new(namespace, base).map_err(|e| dds(format!("{e:?}")))?;
    let qos = QosProfile::publisher_default().reliability_reliable(WhenFull::Fail).durability(Durability::Volatile).history(History::KeepLast { depth: 10 });
    node.create_topic(&name, MessageTypeName::new(package, rest), &qos).map_err(|e| dds(e.to_string()))
}

fn publisher<M: msg::Message>(node: &mut Node, name: &str, domain_id: u16) -> Result<Publisher<M>, Ros2BridgeError> {
    named_publisher::<M, M>(node, name, domain_id).map(|(p, _)| p)
}

/// A publisher of `M` that takes it already in CDR.
fn encoded_publisher<M: msg::Message>(node: &mut Node, name: &str, domain_id: u16) -> Result<Publisher<Encoded<M>>, Ros2BridgeError> {
    named_publisher::<M, Encoded<M>>(node, name, domain_id).map(|(p, _)| p)
}

/// A publisher of `P` on a topic of type `M` ([`publisher`]), and the topic's DDS name
/// (`/jointctl/raw` is `rt/jointctl/raw` on the wire).
fn named_publisher<M: msg::Message, P: serde::Serialize>(node: &mut Node, name: &str, domain_id: u16) -> Result<(Publisher<P>, String), Ros2BridgeError> {
    let t = topic::<M>(node, name, domain_id, "publisher")?;
    let publisher = node.create_publisher::<P>(&t, None).map_err(|e| Ros2BridgeError::Dds { what: format!("publisher of {name}"), domain_id, reason: e.to_string() })?;
    Ok((publisher, t.name()))
}

fn subscription<M: msg::Message + 'static>(node: &mut Node, name: &str, domain_id: u16) -> Result<Subscription<M>, Ros2BridgeError> {
    let t = topic::<M>(node, name, domain_id, "subscription")?;
    node.create_subscription::<M>(&t, None).map_err(|e| Ros2BridgeError::Dds { what: format!("subscription of {name}"), domain_id, reason: e.to_string() })
}

/// Why a `trajectory_msgs/JointTrajectory` from ROS 2 is refused as a whole (the requester is
/// answered with this text on `/jointctl/command_responses`).
///
/// ```
/// use jointctl_bridge::ros2::{JointTrajectoryError, trajectory_commands};
/// use jointctl_ros2::msg::{JointTrajectory, JointTrajectoryPoint};
/// assert_eq!(trajectory_commands(&JointTrajectory::default()), Err(JointTrajectoryError::NoJoints));
/// let short = JointTrajectory {
///     joint_names: vec!["q1".into(), "q4".into()],
///     points: vec![JointTrajectoryPoint { positions: vec![0.1], ..Default::default() }],
///     ..Default::default()
/// };
/// let refused = trajectory_commands(&short).unwrap_err();
/// assert_eq!(refused, JointTrajectoryError::Positions { point: 0, got: 1, joints: 2 });
/// assert_eq!(refused.to_string(), "points[0] has 1 positions for 2 joints");
/// ```
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum JointTrajectoryError {
    /// `joint_names` is empty.
    #[error("the trajectory names no joint (joint_names is empty)")]
    NoJoints,
    /// A point's `positions` do not give one value per joint.
    #[error("points[{point}] has {got} positions for {joints} joints")]
    Positions {
        /// The point's index in `points`.
        point: usize,
        /// Its number of positions.
        got: usize,
        /// The number of `joint_names`.
        joints: usize,
    },
    /// A point's `velocities` are neither empty nor one per joint.
    #[error("points[{point}] has {got} velocities for {joints} joints")]
    Velocities {
        /// The point's index in `points`.
        point: usize,
        /// Its number of velocities.
        got: usize,
        /// The number of `joint_names`.
        joints: usize,
    },
}

/// A JointTrajectory as one jointctl trajectory command per DOF, each in the JSON form a network
/// command takes ([`messages::parse_request`] checks it). Points without velocities leave them
/// unset; a point whose positions (or velocities, when given) are not one per DOF makes the
/// whole message refused ([`JointTrajectoryError`]).
///
/// ```
/// use jointctl_ros2::msg::{Duration, JointTrajectory, JointTrajectoryPoint};
/// let t = JointTrajectory {
///     joint_names: vec!["q1".into(), "q4".into()],
///     points: vec![JointTrajectoryPoint { positions: vec![0.1, 0.2], time_from_start: Duration { sec: 1, nanosec: 0 }, ..Default::default() }],
///     ..Default::default()
/// };
/// let per_dof = jointctl_bridge::ros2::trajectory_commands(&t).unwrap();
/// assert_eq!(per_dof[1], serde_json::json!({"kind": "trajectory", "joint": "q4", "points": [[1.0, 0.2, null]]}));
/// ```
pub fn trajectory_commands(t: &msg::JointTrajectory) -> Result<Vec<Value>, JointTrajectoryError> {
    if t.joint_names.is_empty() {
        return Err(JointTrajectoryError::NoJoints);
    }
    for (i, p) in t.points.iter().enumerate() {
        if p.positions.len() != t.joint_names.len() {
            return Err(JointTrajectoryError::Positions { point: i, got: p.positions.len(), joints: t.joint_names.len() });
        }
        if !p.velocities.is_empty() && p.velocities.len() != t.joint_names.len() {
            return Err(JointTrajectoryError::Velocities { point: i, got: p.velocities.len(), joints: t.joint_names.len() });
        }
    }
    Ok(t.joint_names
        .iter()
        .enumerate()
        .map(|(j, name)| {
            let points: Vec<Value> = t.points.iter().map(|p| json!([p.time_from_start.seconds(), p.positions[j], p.velocities.get(j)])).collect();
            json!({"kind": "trajectory", "joint": name, "points": points})
        })
        .collect())
}

/// A `jointctl_msgs/CommandRequest` in the JSON form a network command takes.
fn request_json(r: &msg::CommandRequest) -> Value {
    let mut v = json!({"kind": r.kind, "joint": r.joint, "values": r.values, "points": r.points.iter().map(|p| json!([p.t_s, p.position_rad, p.velocity_rad_s])).collect::<Vec<_>>()});
    if !r.waveform.is_empty() {
        v["waveform"] = Value::from(r.waveform.as_str());
    }
    v
}

/// The longest an answer waits for its requester's reader of `/jointctl/command_responses` to
/// be discovered before it is sent anyway [s] (an assumption: discovery between two processes
/// of one host takes well under a second, and a requester does not wait longer than a few).
const ANSWER_HOLD_MAX: Duration = Duration::from_secs(5);

/// How long a reader is known before an answer is written to it [s]. RustDDS records a reader
/// in its discovery database first and matches it to the local writers just after, on another
/// thread; an answer written in between is lost (volatile). 100 ms covers that hand-over, an
/// assumption with a wide margin on a loaded machine.
const READER_SETTLE: Duration = Duration::from_millis(100);

/// How often the discovered readers of the answers are looked up (RustDDS copies every
/// discovered reader under a lock: 20 times a second, not after every poll of the arm).
const READER_LOOKUP_PERIOD: Duration = Duration::from_millis(50);

/// An answer not sent yet: its requester's reader has not been seen long enough.
struct PendingAnswer {
    /// The requester's writer (its participant's GUID prefix is the requester's).
    requester: GUID,
    /// When the command came.
    since: Instant,
    response: msg::CommandResponse,
}

/// Commands from ROS 2: what the YAML allows, the runtime's client when it allows any, the rate
/// limit, the answers, and the counts.
///
/// Discovery is not symmetric: the requester may have matched the bridge's writers and readers
/// (and so sent its command) before the bridge has discovered the requester's reader of the
/// answers. An answer written then is lost, as ROS 2's volatile topics lose it; so each answer
/// waits, without blocking the bridge, until its requester's reader is known (at most
/// [`ANSWER_HOLD_MAX`]).
struct Commands {
    allowed: Result<(Vec<String>, CommandClient, crate::RateLimit), String>,
    trajectories: Subscription<msg::JointTrajectory>,
    requests: Subscription<msg::CommandRequest>,
    responses: Publisher<msg::CommandResponse>,
    /// To look up the discovered readers of the answers.
    participant: DomainParticipant,
    /// The answers' DDS topic name (`rt/jointctl/command_responses`).
    responses_topic: String,
    pending: Vec<PendingAnswer>,
    /// The answers' readers discovered, and when each was first seen (kept current while no
    /// answer waits, so that a reader known for long is not new to the first answer).
    readers_seen: Vec<(GUID, Instant)>,
    /// When the readers were last looked up.
    last_lookup: Option<Instant>,
    /// Requesters (by participant) whose answer went out unseen: warned once each.
    warned: Vec<GUID>,
    accepted: u64,
    refused: u64,
}

impl Commands {
    /// Answers every command that has arrived.
    fn serve(&mut self, arm: &str, timeout_s: f64, clock: &WallClock) {
        let mut incoming: Vec<(GUID, Result<Value, String>)> = Vec::new();
        while let Ok(Some((t, info))) = self.trajectories.take() {
            let from = GUID::from(info.publisher_gid());
            match trajectory_commands(&t) {
                Ok(per_dof) => incoming.extend(per_dof.into_iter().map(|c| (from, Ok(c)))),
                Err(why) => incoming.push((from, Err(why.to_string()))),
            }
        }
        while let Ok(Some((r, info))) = self.requests.take() {
            incoming.push((GUID::from(info.publisher_gid()), Ok(request_json(&r))));
        }
        for (requester, command) in incoming {
            let (kind, joint) = match &command {
                Ok(v) => (v["kind"].as_str().unwrap_or("").to_string(), v["joint"].as_str().unwrap_or("").to_string()),
                Err(_) => ("trajectory".to_string(), String::new()),
            };
            let (accepted, message) = self.answer(arm, command, &kind, timeout_s);
            if accepted {
                self.accepted += 1;
                tracing::info!(arm, kind = %kind, joint = %joint, message = %message, "accepted a command from ROS 2");
            } else {
                self.refused += 1;
                tracing::info!(arm, kind = %kind, joint = %joint, reason = %message, "refused a command from ROS 2");
            }
            let stamp = Time::from_unix_ns(clock.unix_ns(jointctl_record::feed::monotonic_ns()));
            let response = msg::CommandResponse { header: msg::Header { stamp, frame_id: arm.to_string() }, kind, joint, accepted, message };
            self.pending.push(PendingAnswer { requester, since: Instant::now(), response });
        }
        self.answer_pending(arm);
    }

    /// Sends each pending answer whose requester's reader has been known for
    /// [`READER_SETTLE`], or that has waited [`ANSWER_HOLD_MAX`].
    fn answer_pending(&mut self, arm: &str) {
        let now = Instant::now();
        if self.last_lookup.is_none_or(|at| now.duration_since(at) >= READER_LOOKUP_PERIOD) {
            self.last_lookup = Some(now);
            let discovered: Vec<GUID> =
                self.participant.discovered_readers().into_iter().filter(|r| *r.subscription_topic_data.topic_name() == self.responses_topic).map(|r| r.reader_proxy.remote_reader_guid).collect();
            self.readers_seen.retain(|(g, _)| discovered.contains(g));
            for g in discovered {
                if !self.readers_seen.iter().any(|(seen, _)| *seen == g) {
                    self.readers_seen.push((g, now));
                }
            }
        }
        if self.pending.is_empty() {
            return;
        }
        let seen = &self.readers_seen;
        let ready = |p: &PendingAnswer| seen.iter().any(|(g, at)| g.prefix == p.requester.prefix && now.duration_since(*at) >= READER_SETTLE);
        let (send, wait): (Vec<PendingAnswer>, Vec<PendingAnswer>) = std::mem::take(&mut self.pending).into_iter().partition(|p| ready(p) || now.duration_since(p.since) >= ANSWER_HOLD_MAX);
        self.pending = wait;
        for p in send {
            if !ready(&p) && !self.warned.iter().any(|g| g.prefix == p.requester.prefix) {
                self.warned.push(p.requester);
                tracing::warn!(arm, kind = %p.response.kind, joint = %p.response.joint, "the requester's reader of {} was not discovered within {} s: its answers are sent and may be lost (said once per requester)", jointctl_ros2::COMMAND_RESPONSES, ANSWER_HOLD_MAX.as_secs());
            }
            let _ = self.responses.publish(p.response);
        }
    }

    /// Whether the command was accepted, and the runtime's answer or the reason it was refused.
    fn answer(&mut self, arm: &str, command: Result<Value, String>, kind: &str, timeout_s: f64) -> (bool, String) {
        let (allow, client, limit) = match &mut self.allowed {
            Ok(a) => (&a.0, &a.1, &mut a.2),
            Err(why) => return (false, why.clone()),
        };
        let v = match command {
            Ok(v) => v,
            Err(why) => return (false, why),
        };
        if !allow.iter().any(|k| k == kind) {
            return (false, format!("`{kind}` is not in network.ros2.commands.allow ({}) of the arm's YAML", allow.join(", ")));
        }
        if !limit.take(Instant::now()) {
            return (false, format!("more than {} commands a second from ROS 2 (network.ros2.commands.max_commands_per_s); this one was not forwarded", jointctl_config::short_number(limit.per_s)));
        }
        let request = match messages::parse_request(&v) {
            Ok(r) => r,
            Err(e) => return (false, e.to_string()),
        };
        match client.send(request, timeout_s) {
            Ok(response) => (response.accepted != 0, response.text().to_string()),
            Err(e) => {
                tracing::warn!(arm, error = %e, "a command from ROS 2 got no answer from the runtime");
                (false, format!("no answer from the runtime: {e}"))
            }
        }
    }
}

/// Publishes the arm until `stop` is set or the arm stops or falls silent; `ready` learns the
/// node's name and the domain once the publishers exist.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use jointctl_bridge::ros2::{Ros2Options, serve};
/// let opts = Ros2Options { arm: "sherpa".into(), scope: Default::default(), domain_id: Some(0), config: None, timeout_s: 5.0, command_timeout_s: 2.0 };
/// let summary = serve(&opts, &std::sync::atomic::AtomicBool::new(false), |node, domain| eprintln!("node /{node} in DDS domain {domain}"))?;
/// println!("{:?}", summary.messages);
/// # Ok(()) }
/// ```
pub fn serve(opts: &Ros2Options, stop: &AtomicBool, ready: impl FnOnce(&str, u16)) -> Result<BridgeSummary, Ros2BridgeError> {
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let mut feed = ArmFeed::open(&opts.arm, &opts.scope, timeout, &format!("jointctl-bridge-ros2-{}", std::process::id()))?;
    let descriptor = feed.descriptor().clone();
    // The ROS 2 messages are made from the typed samples: no JSON.
    feed.set_json(false);
    let config_file = opts.config.clone().or_else(|| descriptor.config_path());
    let section = match &config_file {
        Some(file) => Some(jointctl_config::load(file).map_err(|e| Ros2BridgeError::Config { file: file.clone(), reason: e.to_string() })?.config.network.ros2),
        None => None,
    };
    let domain_id = opts.domain_id.or(section.as_ref().map(|r| r.domain_id)).unwrap_or(0);
    let allowed = match (&config_file, section.and_then(|r| r.commands)) {
        (None, _) => Err("the runtime did not say which YAML it runs, so none allows commands from ROS 2".to_string()),
        (Some(file), None) => Err(format!("the arm's YAML ({}) does not allow commands from ROS 2 (it has no `network.ros2.commands`)", file.display())),
        (Some(_), Some(c)) => {
            let client = CommandClient::open(&opts.scope, &opts.arm, &format!("jointctl-bridge-ros2-cmd-{}", std::process::id())).map_err(Ros2BridgeError::Runtime)?;
            Ok((c.allow, client, crate::RateLimit::new(c.max_commands_per_s)))
        }
    };
    let dds = |what: &'static str| move |e: String| Ros2BridgeError::Dds { what: what.to_string(), domain_id, reason: e };
    let context = Context::with_options(ContextOptions::new().domain_id(domain_id)).map_err(|e| dds("DDS participant")(e.to_string()))?;
    let name = node_name(&opts.arm);
    let node_name = NodeName::new("/", &name).map_err(|e| dds("node")(format!("{e:?}")))?;
    let mut node = context.new_node(node_name, NodeOptions::new().enable_rosout(false)).map_err(|e| dds("node")(e.to_string()))?;
    let mut publishers = Publishers {
        joint_states: encoded_publisher(&mut node, jointctl_ros2::JOINT_STATES, domain_id)?,
        joint_details: encoded_publisher(&mut node, jointctl_ros2::JOINT_DETAILS, domain_id)?,
        diagnostics: encoded_publisher(&mut node, jointctl_ros2::DIAGNOSTICS, domain_id)?,
        raw: encoded_publisher(&mut node, jointctl_ros2::RAW, domain_id)?,
        commands: publisher(&mut node, jointctl_ros2::COMMANDS, domain_id)?,
        direct: DirectEncoder::default(),
        cdr: Vec::new(),
    };
    let (responses, responses_topic) = named_publisher::<msg::CommandResponse, msg::CommandResponse>(&mut node, jointctl_ros2::COMMAND_RESPONSES, domain_id)?;
    let mut commands = Commands {
        trajectories: subscription(&mut node, jointctl_ros2::JOINT_TRAJECTORY, domain_id)?,
        requests: subscription(&mut node, jointctl_ros2::COMMAND, domain_id)?,
        responses,
        participant: context.domain_participant(),
        responses_topic,
        pending: Vec::new(),
        readers_seen: Vec::new(),
        last_lookup: None,
        warned: Vec::new(),
        allowed,
        accepted: 0,
        refused: 0,
    };
    match &commands.allowed {
        Ok((allow, ..)) => tracing::info!(arm = %opts.arm, "commands from ROS 2 taken: {} (network.ros2.commands.allow)", allow.join(", ")),
        Err(why) => tracing::info!(arm = %opts.arm, "commands from ROS 2 refused: {why}"),
    }
    ready(&name, domain_id);
    let (arm, mut last_diagnostics, mut failed_writes) = (opts.arm.as_str(), None::<Instant>, 0u64);
    // The arm's monotonic stamps on the wall clock, as ROS 2 stamps are: both clocks read
    // together, again once a second (an NTP step then reaches the stamps within a second).
    let clocks_now = || {
        WallClock::from_pair(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64), jointctl_record::feed::monotonic_ns())
    };
    let clock = std::cell::Cell::new(clocks_now());
    let result = crate::pump(
        &mut feed,
        stop,
        timeout,
        "ROS 2",
        |m| {
            let stamps = clock.get();
            let p = &mut publishers;
            let written = match m.sample {
                Sample::State(s) => {
                    p.direct.joint_state(s, &stamps, arm, &mut p.cdr);
                    let states = Publishers::send(&p.joint_states, &p.cdr);
                    p.direct.joint_details(s, &stamps, arm, &mut p.cdr);
                    Publishers::send(&p.joint_details, &p.cdr) && states
                }
                Sample::Diagnostics(d) if last_diagnostics.is_none_or(|t| t.elapsed() >= DIAGNOSTICS_PERIOD) => {
                    last_diagnostics = Some(Instant::now());
                    clock.set(clocks_now());
                    p.direct.diagnostic_array(d, &stamps, arm, &mut p.cdr);
                    Publishers::send(&p.diagnostics, &p.cdr)
                }
                Sample::Diagnostics(_) => true,
                Sample::Raw(f) => {
                    p.direct.raw_frame(f, &descriptor, &stamps, arm, &mut p.cdr);
                    Publishers::send(&p.raw, &p.cdr)
                }
                Sample::Command(c) => p.commands.publish(from_arm::command_record(c, &stamps, arm)).is_ok(),
            };
            if !written {
                failed_writes += 1;
                // The first, then every thousandth: a reader that is gone does not flood the log
                // (RustDDS's own line for each is kept below ERROR by jointctl's log filter).
                if failed_writes % 1000 == 1 {
                    tracing::warn!(failed_writes, "a ROS 2 write failed (the DDS writer's queue is full or its transport failed)");
                }
            }
        },
        || commands.serve(arm, opts.command_timeout_s, &clock.get()),
    );
    // Answers still waiting for their reader go out now: the bridge is leaving.
    for p in std::mem::take(&mut commands.pending) {
        let _ = commands.responses.publish(p.response);
    }
    tracing::info!(arm, accepted = commands.accepted, refused = commands.refused, failed_writes, "commands from ROS 2, and writes that failed");
    Ok(result?)
}
