//! ROS 2 nodes see the arm: its samples as ROS 2 topics over DDS (RTPS, what every ROS 2 RMW
//! speaks), published by a ROS 2 node of a pure-Rust client (`ros2-client` on RustDDS: no ROS
//! installation to build or run). The topics and types are the ROS 2 recording profile's
//! ([`jointctl_ros2::topics`]), with ROS 2's default QoS (reliable, volatile, keep last 10).
//!
//! It only publishes. DDS has no authentication unless DDS Security is set up, so any host that
//! reaches the domain could send whatever a bridge accepted: commands stay with the
//! authenticated Zenoh bridge.

use std::sync::atomic::AtomicBool;
use std::time::{Duration, Instant};

use jointctl_ipc::IpcScope;
use jointctl_record::feed::{ArmFeed, FeedError, Sample};
use jointctl_ros2::from_arm::{self, WallClock};
use jointctl_ros2::msg;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{Context, ContextOptions, MessageTypeName, Name, Node, NodeName, NodeOptions, Publisher, QosProfile};

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
const DIAGNOSTICS_PERIOD: Duration = Duration::from_secs(1);

/// A publisher for each of the profile's topics.
struct Publishers {
    joint_states: Publisher<msg::JointState>,
    joint_details: Publisher<msg::JointDetails>,
    diagnostics: Publisher<msg::DiagnosticArray>,
    raw: Publisher<msg::RawFrame>,
    commands: Publisher<msg::CommandRecord>,
}

fn publisher<M: msg::Message>(node: &mut Node, topic: &str, domain_id: u16) -> Result<Publisher<M>, Ros2BridgeError> {
    let dds = |reason: String| Ros2BridgeError::Dds { what: format!("publisher of {topic}"), domain_id, reason };
    let (package, rest) = M::NAME.split_once("/msg/").ok_or_else(|| dds(format!("type name {} is not package/msg/Type", M::NAME)))?;
    // `/jointctl/raw`: the namespace `/jointctl`, the name `raw`.
    let (namespace, base) = topic.rsplit_once('/').map_or(("/", topic), |(ns, b)| (if ns.is_empty() { "/" } else { ns }, b));
    let name = Name::new(namespace, base).map_err(|e| dds(format!("{e:?}")))?;
    // ROS 2's default QoS. A reliable writer with a bounded history replaces its oldest sample
    // rather than waiting for a slow reader: the bridge never blocks on the network.
    let qos = QosProfile::publisher_default().reliability_reliable(WhenFull::Fail).durability(Durability::Volatile).history(History::KeepLast { depth: 10 });
    let t = node.create_topic(&name, MessageTypeName::new(package, rest), &qos).map_err(|e| dds(e.to_string()))?;
    node.create_publisher::<M>(&t, None).map_err(|e| dds(e.to_string()))
}

/// Publishes the arm until `stop` is set or the arm stops or falls silent; `ready` learns the
/// node's name and the domain once the publishers exist.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// use jointctl_bridge::ros2::{Ros2Options, serve};
/// let opts = Ros2Options { arm: "sherpa".into(), scope: Default::default(), domain_id: Some(0), config: None, timeout_s: 5.0 };
/// let summary = serve(&opts, &std::sync::atomic::AtomicBool::new(false), |node, domain| eprintln!("node /{node} in DDS domain {domain}"))?;
/// println!("{:?}", summary.messages);
/// # Ok(()) }
/// ```
pub fn serve(opts: &Ros2Options, stop: &AtomicBool, ready: impl FnOnce(&str, u16)) -> Result<BridgeSummary, Ros2BridgeError> {
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let mut feed = ArmFeed::open(&opts.arm, &opts.scope, timeout, &format!("jointctl-bridge-ros2-{}", std::process::id()))?;
    let descriptor = *feed.descriptor();
    let config_file = opts.config.clone().or_else(|| descriptor.config_path());
    let domain_id = match (opts.domain_id, &config_file) {
        (Some(d), _) => d,
        (None, Some(file)) => jointctl_config::load(file).map_err(|e| Ros2BridgeError::Config { file: file.clone(), reason: e.to_string() })?.config.network.ros2.domain_id,
        (None, None) => 0,
    };
    let dds = |what: &'static str| move |e: String| Ros2BridgeError::Dds { what: what.to_string(), domain_id, reason: e };
    let context = Context::with_options(ContextOptions::new().domain_id(domain_id)).map_err(|e| dds("DDS participant")(e.to_string()))?;
    let name = node_name(&opts.arm);
    let node_name = NodeName::new("/", &name).map_err(|e| dds("node")(format!("{e:?}")))?;
    let mut node = context.new_node(node_name, NodeOptions::new().enable_rosout(false)).map_err(|e| dds("node")(e.to_string()))?;
    let publishers = Publishers {
        joint_states: publisher(&mut node, jointctl_ros2::JOINT_STATES, domain_id)?,
        joint_details: publisher(&mut node, jointctl_ros2::JOINT_DETAILS, domain_id)?,
        diagnostics: publisher(&mut node, jointctl_ros2::DIAGNOSTICS, domain_id)?,
        raw: publisher(&mut node, jointctl_ros2::RAW, domain_id)?,
        commands: publisher(&mut node, jointctl_ros2::COMMANDS, domain_id)?,
    };
    ready(&name, domain_id);
    let (arm, mut last_diagnostics, mut failed_writes) = (opts.arm.as_str(), None::<Instant>, 0u64);
    // The arm's monotonic stamps on the wall clock, as ROS 2 stamps are: both clocks read now.
    let clock = WallClock::from_pair(
        std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64),
        jointctl_record::feed::monotonic_ns(),
    );
    let result = crate::pump(
        &mut feed,
        stop,
        timeout,
        "ROS 2",
        |m| {
            let written = match m.sample {
                Sample::State(s) => [
                    publishers.joint_states.publish(from_arm::joint_state(s, &clock, arm)).is_ok(),
                    publishers.joint_details.publish(from_arm::joint_details(s, &clock, arm)).is_ok(),
                ]
                .iter()
                .all(|ok| *ok),
                Sample::Diagnostics(d) if last_diagnostics.is_none_or(|t| t.elapsed() >= DIAGNOSTICS_PERIOD) => {
                    last_diagnostics = Some(Instant::now());
                    publishers.diagnostics.publish(from_arm::diagnostic_array(d, &clock, arm)).is_ok()
                }
                Sample::Diagnostics(_) => true,
                Sample::Raw(f) => publishers.raw.publish(from_arm::raw_frame(f, &descriptor, &clock, arm)).is_ok(),
                Sample::Command(c) => publishers.commands.publish(from_arm::command_record(c, &clock, arm)).is_ok(),
            };
            if !written {
                failed_writes += 1;
                // The first, then every thousandth: a network that is gone does not flood the log.
                if failed_writes % 1000 == 1 {
                    tracing::warn!(failed_writes, "a ROS 2 write failed (the DDS writer's queue is full or its transport failed)");
                }
            }
        },
        || {},
    );
    Ok(result?)
}
