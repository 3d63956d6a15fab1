//! Recording a running arm: its `raw`, `joint_state`, `diagnostics` and `commands` services into
//! one MCAP file, gapless or saying what was lost.

use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use jointctl_ipc::raw::RawDescriptor;
use jointctl_ipc::{IpcScope, IpcSetupError, ServiceNames};
use serde_json::Value;

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
}

/// What a recording holds.
#[derive(Clone, Debug, PartialEq)]
pub struct RecordSummary {
    /// The file written.
    pub file: PathBuf,
    /// From the first to the last joint-state stamp [s].
    pub duration_s: f64,
    /// Messages per channel.
    pub messages: BTreeMap<String, u64>,
    /// Samples lost per channel (gaps in cycle or sequence numbers).
    pub lost_by_channel: BTreeMap<String, u64>,
    /// Size of the file [bytes].
    pub bytes: u64,
    /// Stopped by the runtime's final sample (the arm stopped).
    pub arm_stopped: bool,
}

impl RecordSummary {
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
    /// Shared memory could not be opened (no runtime runs the arm, or another domain).
    #[error("arm `{arm}`")]
    Ipc {
        /// The arm.
        arm: String,
        /// The reason.
        source: IpcSetupError,
    },
    /// A subscriber could not be created (every slot taken).
    #[error("cannot subscribe to `{service}`: {reason}")]
    Subscribe {
        /// Service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// Nothing arrived.
    #[error("no {what} from arm `{arm}` within {timeout_s} s: is `jointctl run` running with this arm and domain?")]
    Silent {
        /// The arm.
        arm: String,
        /// What was waited for.
        what: &'static str,
        /// How long.
        timeout_s: f64,
    },
    /// The file could not be written.
    #[error("cannot write {}", .file.display())]
    File {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: std::io::Error,
    },
    /// The MCAP writer failed.
    #[error("cannot write {} as MCAP", .file.display())]
    Mcap {
        /// The file.
        file: PathBuf,
        /// The reason.
        source: mcap::McapError,
    },
    /// Receiving from shared memory failed.
    #[error("cannot receive from `{service}`: {reason}")]
    Receive {
        /// Service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
}

/// Counts gaps in a channel's numbering.
#[derive(Default)]
struct Gaps {
    next: Option<u64>,
    lost: u64,
}

impl Gaps {
    fn see(&mut self, number: u64) {
        if let Some(next) = self.next
            && number > next
        {
            self.lost += number - next;
        }
        self.next = Some(self.next.map_or(number + 1, |n| n.max(number + 1)));
    }
}

fn open_waiting<T>(timeout: Duration, mut open: impl FnMut() -> Result<T, IpcSetupError>) -> Result<T, IpcSetupError> {
    let start = Instant::now();
    loop {
        match open() {
            Err(IpcSetupError::OpenPublishSubscribe { source: iceoryx2::service::builder::publish_subscribe::PublishSubscribeOpenError::DoesNotExist, .. })
                if start.elapsed() < timeout =>
            {
                std::thread::sleep(Duration::from_millis(20))
            }
            other => return other,
        }
    }
}

/// The files to attach: the arm's YAML and the files its joints include (as the config crate
/// resolves them); a description that no longer loads is attached alone.
fn config_files(config: &Path) -> Vec<(String, Vec<u8>)> {
    let Ok(text) = std::fs::read(config) else { return Vec::new() };
    let name = |p: &Path| p.file_name().map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into_owned());
    let mut out = vec![(name(config), text)];
    let included = jointctl_config::load(config).map(|l| l.included).unwrap_or_default();
    for path in included {
        if let Ok(bytes) = std::fs::read(&path) {
            out.push((name(&path), bytes));
        }
    }
    out
}

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
/// };
/// let summary = jointctl_record::recorder::record(&opts, &std::sync::atomic::AtomicBool::new(false))?;
/// assert_eq!(summary.lost(), 0);
/// # Ok(()) }
/// ```
pub fn record(opts: &RecordOptions, stop: &AtomicBool) -> Result<RecordSummary, RecordError> {
    let ipc = |source| RecordError::Ipc { arm: opts.arm.clone(), source };
    let timeout = Duration::from_secs_f64(opts.timeout_s.max(0.0));
    let node = jointctl_ipc::create_node_in(&opts.scope, &format!("jointctl-record-{}", std::process::id())).map_err(ipc)?;
    let names = ServiceNames::for_arm(&opts.arm);
    let subscribe_error = |service: &str| {
        let service = service.to_string();
        move |e: iceoryx2::port::subscriber::SubscriberCreateError| RecordError::Subscribe { service: service.clone(), reason: format!("{e:?}") }
    };
    let raw = open_waiting(timeout, || jointctl_ipc::raw_service(&node, &names.raw)).map_err(ipc)?.subscriber_builder().create().map_err(subscribe_error(&names.raw))?;
    let state = open_waiting(timeout, || jointctl_ipc::joint_state_service(&node, &names.joint_state))
        .map_err(ipc)?
        .subscriber_builder()
        .create()
        .map_err(subscribe_error(&names.joint_state))?;
    let diagnostics = open_waiting(timeout, || jointctl_ipc::diagnostics_service(&node, &names.diagnostics))
        .map_err(ipc)?
        .subscriber_builder()
        .create()
        .map_err(subscribe_error(&names.diagnostics))?;
    let commands = open_waiting(timeout, || jointctl_ipc::commands_service(&node, &names.commands))
        .map_err(ipc)?
        .subscriber_builder()
        .create()
        .map_err(subscribe_error(&names.commands))?;
    let descriptor_sub = open_waiting(timeout, || jointctl_ipc::raw_descriptor_service(&node, &names.raw_descriptor))
        .map_err(ipc)?
        .subscriber_builder()
        .create()
        .map_err(subscribe_error(&names.raw_descriptor))?;
    let receive_error = |service: &str| {
        let service = service.to_string();
        move |e: iceoryx2::port::ReceiveError| RecordError::Receive { service: service.clone(), reason: format!("{e:?}") }
    };
    // The descriptor names the raw frames' devices: it comes from the service's history.
    let started = Instant::now();
    let descriptor: RawDescriptor = loop {
        if let Some(s) = descriptor_sub.receive().map_err(receive_error(&names.raw_descriptor))? {
            break *s.payload();
        }
        if started.elapsed() > timeout {
            return Err(RecordError::Silent { arm: opts.arm.clone(), what: "raw-reading descriptor", timeout_s: opts.timeout_s });
        }
        std::thread::sleep(Duration::from_millis(5));
    };

    let file = std::fs::File::create(&opts.out).map_err(|source| RecordError::File { file: opts.out.clone(), source })?;
    let mcap_error = |source| RecordError::Mcap { file: opts.out.clone(), source };
    let mut writer = mcap::WriteOptions::new()
        .compression(Some(mcap::Compression::Zstd))
        // zstd's fastest level: the JSON of successive cycles differs little, so level 1 still
        // compresses it about tenfold, at half the CPU of the default.
        .compression_level(1)
        .profile("")
        .library(format!("jointctl-record {}", env!("CARGO_PKG_VERSION")))
        .create(BufWriter::new(file))
        .map_err(mcap_error)?;
    let mut channel = BTreeMap::new();
    for (topic, schema_name) in messages::CHANNELS {
        let schema = messages::schema(topic).map(|s| s.to_string()).unwrap_or_default();
        let schema_id = writer.add_schema(schema_name, "jsonschema", schema.as_bytes()).map_err(mcap_error)?;
        let id = writer.add_channel(schema_id, topic, "json", &BTreeMap::new()).map_err(mcap_error)?;
        channel.insert(topic, id);
    }
    let start_unix_ns = unix_ns();
    let start_monotonic_ns = monotonic_ns();
    let mut metadata = BTreeMap::from([
        ("arm".to_string(), opts.arm.clone()),
        ("start_unix_ns".to_string(), start_unix_ns.to_string()),
        ("start_monotonic_ns".to_string(), start_monotonic_ns.to_string()),
        ("rate_hz".to_string(), descriptor.rate_hz.to_string()),
        ("log_time".to_string(), "CLOCK_MONOTONIC of each cycle's sensor read [ns]; start_unix_ns and start_monotonic_ns were taken together".to_string()),
    ]);
    if let Some(path) = descriptor.config_path() {
        metadata.insert("config".to_string(), path.display().to_string());
    }
    writer.write_metadata(&mcap::records::Metadata { name: "jointctl".into(), metadata }).map_err(mcap_error)?;
    // The readings the joints were activated with: a replay activates its observers with them.
    let activation = messages::raw(&descriptor.activation, &descriptor).to_string();
    writer.write_metadata(&mcap::records::Metadata { name: "activation".into(), metadata: BTreeMap::from([("raw".to_string(), activation)]) }).map_err(mcap_error)?;
    if let Some(path) = descriptor.config_path() {
        for (name, data) in config_files(&path) {
            let attachment = mcap::Attachment { log_time: start_monotonic_ns, create_time: start_unix_ns, name, media_type: "application/yaml".into(), data: data.into() };
            writer.attach(&attachment).map_err(mcap_error)?;
        }
    }

    let mut counts: BTreeMap<&str, u64> = messages::CHANNELS.iter().map(|(t, _)| (*t, 0)).collect();
    let mut gaps: BTreeMap<&str, Gaps> = messages::CHANNELS.iter().map(|(t, _)| (*t, Gaps::default())).collect();
    let (mut first_stamp, mut last_stamp) = (None::<u64>, 0u64);
    let mut arm_stopped = false;
    let mut last_sample = Instant::now();
    // One text buffer, reused: at 1 kHz, three messages a cycle.
    let mut text = String::with_capacity(16 * 1024);
    let mut write = |writer: &mut mcap::Writer<BufWriter<std::fs::File>>, topic: &'static str, number: u64, stamp_ns: u64, body: &str| -> Result<(), RecordError> {
        let count = counts.entry(topic).or_default();
        let header = mcap::records::MessageHeader { channel_id: channel[topic], sequence: *count as u32, log_time: stamp_ns, publish_time: stamp_ns };
        *count += 1;
        gaps.entry(topic).or_default().see(number);
        writer.write_to_known_channel(&header, body.as_bytes()).map_err(|source| RecordError::Mcap { file: opts.out.clone(), source })
    };
    loop {
        let mut got = false;
        while let Some(s) = raw.receive().map_err(receive_error(&names.raw))? {
            got = true;
            messages::write_raw(&mut text, &s, &descriptor);
            write(&mut writer, "raw", s.cycle, s.stamp_ns, &text)?;
        }
        while let Some(s) = state.receive().map_err(receive_error(&names.joint_state))? {
            got = true;
            first_stamp.get_or_insert(s.stamp_ns);
            last_stamp = last_stamp.max(s.stamp_ns);
            arm_stopped |= s.final_sample != 0;
            messages::write_joint_state(&mut text, &s);
            write(&mut writer, "joint_state", s.cycle, s.stamp_ns, &text)?;
        }
        while let Some(s) = diagnostics.receive().map_err(receive_error(&names.diagnostics))? {
            got = true;
            messages::write_diagnostics(&mut text, &s);
            write(&mut writer, "diagnostics", s.cycle, s.stamp_ns, &text)?;
        }
        while let Some(s) = commands.receive().map_err(receive_error(&names.commands))? {
            got = true;
            write(&mut writer, "commands", s.sequence, s.stamp_ns, &messages::command(&s).to_string())?;
        }
        let elapsed_s = first_stamp.map_or(0.0, |f| last_stamp.saturating_sub(f) as f64 * 1e-9);
        if stop.load(Ordering::Acquire) || arm_stopped || opts.duration_s.is_some_and(|d| elapsed_s >= d) {
            break;
        }
        if got {
            last_sample = Instant::now();
        } else if last_sample.elapsed() > timeout {
            break;
        } else {
            // Each service buffers 64 samples (64 ms at 1 kHz): waking every 2 ms keeps up with
            // room to spare, at a quarter of the wake-ups of a tighter poll.
            std::thread::sleep(Duration::from_millis(2));
        }
    }
    writer.finish().map_err(mcap_error)?;
    drop(writer);
    if first_stamp.is_none() {
        return Err(RecordError::Silent { arm: opts.arm.clone(), what: "joint state", timeout_s: opts.timeout_s });
    }
    let bytes = std::fs::metadata(&opts.out).map_or(0, |m| m.len());
    Ok(RecordSummary {
        file: opts.out.clone(),
        duration_s: first_stamp.map_or(0.0, |f| last_stamp.saturating_sub(f) as f64 * 1e-9),
        messages: counts.iter().map(|(k, v)| (k.to_string(), *v)).collect(),
        lost_by_channel: gaps.iter().map(|(k, g)| (k.to_string(), g.lost)).collect(),
        bytes,
        arm_stopped,
    })
}

/// CLOCK_MONOTONIC [ns], the clock of the cycle stamps (the runtime's `timing::monotonic_ns`;
/// not shared from there, so that a recorder does not link the runtime).
#[allow(unsafe_code)]
fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into a valid timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}
