//! Recording a running arm: its `raw`, `joint_state`, `diagnostics` and `commands` services into
//! one MCAP file, gapless or saying what was lost.

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_ipc::IpcScope;
use serde_json::Value;

use crate::feed::{ArmFeed, FeedError, NumberGaps, monotonic_ns};
use crate::messages;

/// What to record.
#[derive(Clone, Debug)]
pub struct RecordOptions {
    /// The arm (its YAML `arm:` name).
    pub arm: String,
    /// Its shared memory.
    pub scope: IpcScope,
    /// The MCAP file to write.
    pub out: PathBuf,
    /// Stop after this long [s] of the arm's own time (cycle stamps); `None`: until stopped.
    pub duration_s: Option<f64>,
    /// How long to wait for the arm's services to appear, and for a sample [s].
    pub timeout_s: f64,
    /// The file's form.
    pub profile: Profile,
}

/// The form of a recording.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Profile {
    /// jointctl's channels (`raw`, `joint_state`, `diagnostics`, `commands`) as JSON with JSON
    /// schemas: what Foxglove opens and the `mcap` CLI prints.
    #[default]
    Json,
    /// The ROS 2 profile: CDR messages with `ros2msg` schemas on ROS 2 topics
    /// ([`jointctl_ros2::topics`]), as `ros2 bag record -s mcap` writes them (read by rosbags and
    /// mcap-ros2-support in the tests). Stamps are the wall clock. `/diagnostics` carries the
    /// loop's status each cycle and the others when they change, all once a second
    /// ([`jointctl_ros2::direct::DirectEncoder::diagnostic_changes`]).
    Ros2,
}

impl Profile {
    /// The file's channels: (topic, the arm's channel it comes from).
    fn channels(self) -> Vec<(&'static str, &'static str)> {
        match self {
            Profile::Json => messages::CHANNELS.iter().map(|(t, _)| (*t, *t)).collect(),
            Profile::Ros2 => jointctl_ros2::topics().iter().map(|t| (t.topic, t.source)).collect(),
        }
    }
}

/// What a recording holds.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordSummary {
    /// The file written.
    pub file: PathBuf,
    /// From the first to the last joint-state stamp [s].
    pub duration_s: f64,
    /// Messages per channel of the file (the ROS 2 profile's topics, or the JSON form's channels).
    pub messages: BTreeMap<String, u64>,
    /// Samples lost per channel of the arm (`raw`, `joint_state`, `diagnostics`, `commands`:
    /// gaps in cycle or sequence numbers), whichever form the file has.
    pub lost_by_channel: BTreeMap<String, u64>,
    /// Size of the file [bytes].
    pub bytes: u64,
    /// Stopped by the runtime's final sample (the arm stopped).
    pub arm_stopped: bool,
}

impl RecordSummary {
    /// A recording of `file` that holds no sample (yet).
    fn empty(file: PathBuf, profile: Profile) -> Self {
        let messages = profile.channels().iter().map(|(t, _)| (t.to_string(), 0)).collect();
        let lost_by_channel = messages::CHANNELS.iter().map(|(t, _)| (t.to_string(), 0)).collect();
        let bytes = std::fs::metadata(&file).map_or(0, |m| m.len());
        RecordSummary { file, duration_s: 0.0, messages, lost_by_channel, bytes, arm_stopped: false }
    }

    /// Samples lost on every channel together.
    pub fn lost(&self) -> u64 {
        self.lost_by_channel.values().sum()
    }

    /// The documented `--json` summary: `{"file", "duration_s", "messages": {...}, "lost": n}`.
    ///
    /// ```
    /// let s = jointctl_record::recorder::RecordSummary {
    ///     file: "r.mcap".into(), duration_s: 1.0, messages: [("raw".to_string(), 40)].into(),
    ///     lost_by_channel: [("raw".to_string(), 0)].into(), bytes: 10, arm_stopped: false,
    /// };
    /// assert_eq!(s.json()["messages"]["raw"], 40);
    /// ```
    pub fn json(&self) -> Value {
        serde_json::json!({
            "file": self.file.display().to_string(),
            "duration_s": self.duration_s,
            "messages": self.messages,
            "lost": self.lost(),
            "lost_by_channel": self.lost_by_channel,
            "bytes": self.bytes,
        })
    }
}

/// Why a recording failed.
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The arm's samples could not be read.
    #[error(transparent)]
    Feed(#[from] FeedError),
    /// The file could not be written.
    #[error("cannot write {}", .file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: std::io::Error,
    },
    /// The recording stopped on a failure after it had begun: what the file holds up to it.
    #[error("the recording stopped after {:.2} s: {source}", .summary.duration_s)]
    Stopped {
        /// What was recorded up to the failure.
        summary: Box<RecordSummary>,
        /// The failure.
        source: Box<RecordError>,
    },
    /// A sample could not be written as its ROS 2 message.
    #[error("cannot write {}: {source}", .file.display())]
    Encode {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: jointctl_ros2::EncodeError,
    },
    /// The MCAP writer failed.
    #[error("cannot write {} as MCAP", .file.display())]
    Mcap {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: mcap::McapError,
    },
}

/// Where the recorder writes: the file, and what it counts on the way.
struct Sink<W: std::io::Write + std::io::Seek> {
    writer: mcap::Writer<W>,
    /// The file's channels: topic, the arm's channel it comes from, id.
    channels: Vec<(&'static str, &'static str, u16)>,
    out: PathBuf,
    profile: Profile,
    /// The ROS 2 profile's stamps: the arm's monotonic clock on the wall clock.
    clock: jointctl_ros2::from_arm::WallClock,
    arm: String,
    descriptor: jointctl_ipc::raw::RawDescriptor,
    /// The ROS 2 profile's writer and its message buffer, kept between messages.
    direct: jointctl_ros2::direct::DirectEncoder,
    cdr: Vec<u8>,
    /// Messages written, by the file's topic.
    counts: BTreeMap<&'static str, u64>,
    /// Numbering gaps, by the arm's channel.
    gaps: BTreeMap<&'static str, NumberGaps>,
    first_stamp: Option<u64>,
    last_stamp: u64,
    arm_stopped: bool,
}

impl<W: std::io::Write + std::io::Seek> Sink<W> {
    fn write(&mut self, m: &crate::feed::FeedMessage<'_>) -> Result<(), RecordError> {
        if m.topic == "joint_state" {
            self.first_stamp.get_or_insert(m.stamp_ns);
            self.last_stamp = self.last_stamp.max(m.stamp_ns);
            self.arm_stopped |= m.final_sample;
        }
        self.gaps.entry(m.topic).or_default().see(m.number);
        let stamp = match self.profile {
            Profile::Json => m.stamp_ns,
            Profile::Ros2 => self.clock.unix_ns(m.stamp_ns),
        };
        for i in 0..self.channels.len() {
            let (topic, source, channel_id) = self.channels[i];
            if source != m.topic {
                continue;
            }
            let count = self.counts.entry(topic).or_default();
            let header = mcap::records::MessageHeader { channel_id, sequence: *count as u32, log_time: stamp, publish_time: stamp };
            *count += 1;
            let data = match self.profile {
                Profile::Json => m.json.as_bytes(),
                Profile::Ros2 => {
                    self.ros2(topic, &m.sample)?;
                    &self.cdr
                }
            };
            self.writer.write_to_known_channel(&header, data).map_err(|source| RecordError::Mcap { file: self.out.clone(), source })?;
        }
        Ok(())
    }

    /// The CDR of `sample` as the message of ROS 2 topic `topic`, into `self.cdr`: the cycle's
    /// samples written directly (no message built: at 700 DOFs that was 40 000 strings a cycle),
    /// `/diagnostics` with the statuses that changed (every one once a second, as ROS 2 nodes
    /// publish them), a command through its message.
    fn ros2(&mut self, topic: &str, sample: &crate::feed::Sample<'_>) -> Result<(), RecordError> {
        use crate::feed::Sample;
        use jointctl_ros2::from_arm;
        let (clock, arm, out) = (&self.clock, self.arm.as_str(), &mut self.cdr);
        match sample {
            Sample::State(s) if topic == jointctl_ros2::JOINT_STATES => self.direct.joint_state(s, clock, arm, out),
            Sample::State(s) => self.direct.joint_details(s, clock, arm, out),
            Sample::Raw(f) => self.direct.raw_frame(f, &self.descriptor, clock, arm, out),
            Sample::Diagnostics(d) => self.direct.diagnostic_changes(d, clock, arm, out),
            Sample::Command(c) => {
                // Copied into the kept buffer, not put in its place: the next cycle's messages
                // would grow a new one again.
                let cdr = jointctl_ros2::encode(&from_arm::command_record(c, clock, arm)).map_err(|source| RecordError::Encode { file: self.out.clone(), source })?;
                out.clear();
                out.extend_from_slice(&cdr);
            }
        }
        Ok(())
    }

    /// The newest cycle (or command sequence) written on `topic`.
    fn newest(&self, topic: &str) -> Option<u64> {
        self.gaps.get(topic).and_then(NumberGaps::newest)
    }

    /// What the file holds so far (its size is read once it is closed).
    fn summary(&self) -> RecordSummary {
        RecordSummary {
            file: self.out.clone(),
            duration_s: self.first_stamp.map_or(0.0, |f| self.last_stamp.saturating_sub(f) as f64 * 1e-9),
            messages: self.counts.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
            lost_by_channel: self.gaps.iter().map(|(source, g)| (source.to_string(), g.lost())).collect(),
            bytes: 0,
            arm_stopped: self.arm_stopped,
        }
    }
}

/// The files to attach: the arm's YAML and the files its joints include (as the config crate
/// resolves them); a description that no longer loads is attached alone.
fn config_files(config: &Path) -> Vec<(String, Vec<u8>)> {
    let Ok(text) = jointctl_files::read(config, jointctl_files::FileKind::Config) else { return Vec::new() };
    let name = |p: &Path| p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned());
    let mut out = vec![(name(config), text)];
    let included = jointctl_config::load(config).map(|l| l.included).unwrap_or_default();
    for path in included {
        if let Ok(bytes) = jointctl_files::read(&path, jointctl_files::FileKind::Include) {
            out.push((name(&path), bytes));
        }
    }
    out
}

/// The QoS a ROS 2 player offers each topic, in rosbag2's YAML form of Iron and later (policy
/// names, not the older enum numbers: a file without rosbag2's metadata record is read as the
/// newest version): ROS 2's defaults, reliable, volatile, keep last 10.
const OFFERED_QOS: &str = "- history: keep_last\n  depth: 10\n  reliability: reliable\n  durability: volatile\n  deadline:\n    sec: 9223372036\n    nsec: 854775807\n  lifespan:\n    sec: 9223372036\n    nsec: 854775807\n  liveliness: automatic\n  liveliness_lease_duration:\n    sec: 9223372036\n    nsec: 854775807\n  avoid_ros_namespace_conventions: false\n";

fn unix_ns() -> u64 {
    std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map_or(0, |d| d.as_nanos() as u64)
}

/// Records until `stop` is set, `opts.duration_s` has passed in the arm's time, or the arm
/// stops (its final sample); then finishes a valid, indexed file.
///
/// ```no_run
/// # fn main() -> Result<(), Box<dyn std::error::Error>> {
/// let opts = jointctl_record::recorder::RecordOptions {
///     arm: "sherpa".into(), scope: Default::default(), out: "r.mcap".into(), duration_s: Some(10.0), timeout_s: 5.0,
///     profile: jointctl_record::recorder::Profile::Json,
/// };
/// let summary = jointctl_record::recorder::record(&opts, &std::sync::atomic::AtomicBool::new(false))?;
/// assert_eq!(summary.lost(), 0);
/// # Ok(()) }
/// ```
pub fn record(opts: &RecordOptions, stop: &AtomicBool) -> Result<RecordSummary, RecordError> {
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let mut feed = ArmFeed::open(&opts.arm, &opts.scope, timeout, &format!("jointctl-record-{}", std::process::id()))?;
    let descriptor = feed.descriptor().clone();
    let rate_hz = descriptor.rate_hz;
    // The ROS 2 profile's messages are made from the typed samples: no JSON.
    feed.set_json(opts.profile == Profile::Json);

    let file = std::fs::File::create(&opts.out).map_err(|source| RecordError::File { file: opts.out.clone(), source })?;
    let mcap_error = |source| RecordError::Mcap { file: opts.out.clone(), source };
    // A file that cannot be written from its start (a full disk) is a recording stopped before
    // its first sample: the summary says so too.
    let before_start = |source: mcap::McapError| RecordError::Stopped {
        summary: Box::new(RecordSummary::empty(opts.out.clone(), opts.profile)),
        source: Box::new(mcap_error(source)),
    };
    let mut writer = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        // zstd's fastest level: the JSON of successive cycles differs little, so level 1 still
        // compresses it about tenfold, at half the CPU of the default.
        .compression_level(1)
        // A crash loses the chunk being written: chunks of 256 KiB of JSON (about a second of
        // the SHERPA arm at 40 Hz, 30 ms at 1 kHz; the default 768 KiB held three seconds) bound
        // that, at a few dozen bytes of index each.
        .chunk_size(Some(256 * 1024))
        .profile(match opts.profile {
            Profile::Json => "",
            Profile::Ros2 => "ros2",
        })
        .library(format!("jointctl-record {}", env!("CARGO_PKG_VERSION")))
        .create(BufWriter::new(file))
        .map_err(before_start)?;
    let mut channels = Vec::new();
    match opts.profile {
        Profile::Json => {
            for (topic, schema_name) in messages::CHANNELS {
                let schema = messages::schema(topic).map(|s| s.to_string()).unwrap_or_default();
                let schema_id = writer.add_schema(schema_name, "jsonschema", schema.as_bytes()).map_err(before_start)?;
                channels.push((topic, topic, writer.add_channel(schema_id, topic, "json", &BTreeMap::new()).map_err(before_start)?));
            }
        }
        Profile::Ros2 => {
            for t in jointctl_ros2::topics() {
                let schema_id = writer.add_schema(t.type_name, "ros2msg", t.schema.as_bytes()).map_err(before_start)?;
                // The QoS `ros2 bag play` publishes with: reliable, volatile, a history of the
                // recorder's depth (rosbag2's offered_qos_profiles metadata, as it records them).
                let metadata = BTreeMap::from([("offered_qos_profiles".to_string(), OFFERED_QOS.to_string())]);
                channels.push((t.topic, t.source, writer.add_channel(schema_id, t.topic, "cdr", &metadata).map_err(before_start)?));
            }
        }
    }
    let start_unix_ns = unix_ns();
    let start_monotonic_ns = monotonic_ns();
    let mut metadata = BTreeMap::from([
        ("arm".to_string(), opts.arm.clone()),
        ("start_unix_ns".to_string(), start_unix_ns.to_string()),
        ("start_monotonic_ns".to_string(), start_monotonic_ns.to_string()),
        ("rate_hz".to_string(), descriptor.rate_hz.to_string()),
        ("log_time".to_string(), match opts.profile {
            Profile::Json => "CLOCK_MONOTONIC of each cycle's sensor read [ns]; start_unix_ns and start_monotonic_ns were taken together",
            Profile::Ros2 => "each cycle's sensor read on the wall clock (UNIX time [ns]): its CLOCK_MONOTONIC stamp (stamp_ns in the jointctl messages) plus start_unix_ns - start_monotonic_ns, taken together",
        }.to_string()),
    ]);
    if let Some(path) = descriptor.config_path() {
        metadata.insert("config".to_string(), path.display().to_string());
    }
    writer.write_metadata(&mcap::records::Metadata { name: "jointctl".into(), metadata }).map_err(before_start)?;
    // The readings the joints were activated with: a replay activates its observers with them.
    let activation = messages::raw(&descriptor.activation, &descriptor).to_string();
    writer.write_metadata(&mcap::records::Metadata { name: "activation".into(), metadata: BTreeMap::from([("raw".to_string(), activation)]) }).map_err(before_start)?;
    if let Some(path) = descriptor.config_path() {
        for (name, data) in config_files(&path) {
            // On the file's clock, as its messages.
            let log_time = if opts.profile == Profile::Ros2 { start_unix_ns } else { start_monotonic_ns };
            let attachment = mcap::Attachment { log_time, create_time: start_unix_ns, name, media_type: "application/yaml".into(), data: data.into() };
            writer.attach(&attachment).map_err(before_start)?;
        }
    }

    let mut sink = Sink {
        writer,
        counts: channels.iter().map(|(t, ..)| (*t, 0)).collect(),
        gaps: channels.iter().map(|(_, source, _)| (*source, NumberGaps::default())).collect(),
        channels,
        out: opts.out.clone(),
        profile: opts.profile,
        clock: jointctl_ros2::from_arm::WallClock::from_pair(start_unix_ns, start_monotonic_ns),
        arm: opts.arm.clone(),
        descriptor,
        direct: Default::default(),
        cdr: Vec::new(),
        first_stamp: None,
        last_stamp: 0,
        arm_stopped: false,
    };
    // A failure while recording (a full disk, a reader gone) still closes what was written and
    // says how far it got.
    let outcome = take_samples(&mut feed, &mut sink, opts, stop, timeout, rate_hz);
    let mut summary = sink.summary();
    let got_state = sink.newest("joint_state").is_some();
    let finished = sink.writer.finish().map_err(mcap_error);
    drop(sink);
    summary.bytes = std::fs::metadata(&opts.out).map_or(0, |m| m.len());
    if let Err(source) = outcome.and(finished) {
        return Err(RecordError::Stopped { summary: Box::new(summary), source: Box::new(source) });
    }
    if !got_state {
        return Err(FeedError::Silent { arm: opts.arm.clone(), what: "joint state", timeout_s: opts.timeout_s }.into());
    }
    Ok(summary)
}

/// Takes the arm's samples into `sink` until the duration, a stop, the arm's final sample or
/// silence, then the last cycle's samples that follow its joint state.
fn take_samples<W: std::io::Write + std::io::Seek>(feed: &mut ArmFeed, sink: &mut Sink<W>, opts: &RecordOptions, stop: &AtomicBool, timeout: Duration, rate_hz: f64) -> Result<(), RecordError> {
    let mut last_sample = Instant::now();
    loop {
        let got = feed.poll(|m| sink.write(&m))?;
        let elapsed_s = sink.first_stamp.map_or(0.0, |f| sink.last_stamp.saturating_sub(f) as f64 * 1e-9);
        if stop.load(Ordering::Acquire) || sink.arm_stopped || opts.duration_s.is_some_and(|d| elapsed_s >= d) {
            break;
        }
        if got > 0 {
            last_sample = Instant::now();
        } else if last_sample.elapsed() > timeout {
            break;
        } else {
            // Each service buffers 64 samples (64 ms at 1 kHz): waking every 2 ms keeps up with
            // room to spare, at a quarter of the wake-ups of a tighter poll.
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    // The recording ends with its last joint state. The runtime publishes a cycle's state, then
    // its diagnostics and raw readings: those of the last cycle may not have arrived when the
    // state did (a file ended with a joint state whose raw readings were not in it, and the
    // elbow's drive read as lost in its last cycle). Wait for them, a few cycles at most, and
    // take nothing newer.
    if let Some(end_cycle) = sink.newest("joint_state") {
        let period_s = if rate_hz > 0.0 { 1.0 / rate_hz } else { 0.1 };
        let deadline = Instant::now() + Duration::from_secs_f64((5.0 * period_s).clamp(0.05, 1.0));
        let last_stamp = sink.last_stamp;
        while ["raw", "diagnostics"].iter().any(|t| sink.newest(t).is_none_or(|n| n < end_cycle)) && Instant::now() < deadline {
            feed.poll(|m| {
                let in_recording = match m.topic {
                    "commands" => m.stamp_ns <= last_stamp,
                    _ => m.number <= end_cycle && m.topic != "joint_state",
                };
                if in_recording { sink.write(&m) } else { Ok(()) }
            })?;
            std::thread::sleep(Duration::from_millis(1));
        }
    }
    Ok(())
}

