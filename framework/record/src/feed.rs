//! A running arm's published samples as JSON messages: what the recorder writes into a file and
//! what the bridges send to Foxglove and over Zenoh, one reader for all of them.

use std::time::{Duration, Instant};

use iceoryx2::port::subscriber::Subscriber;
use iceoryx2::prelude::*;
use jointctl_ipc::raw::{CommandRecord, RawDescriptor, RawFrame, RawFrameHeader};
use jointctl_ipc::wire::ByteRecord;
use jointctl_ipc::{ArmState, ArmStateHeader, Diagnostics, DiagnosticsHeader, IpcScope, IpcSetupError, JointSample, ServiceNames};

use crate::messages;

/// Why an arm's samples cannot be read.
#[derive(Debug, thiserror::Error)]
pub enum FeedError {
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
    /// Receiving from shared memory failed.
    #[error("cannot receive from `{service}`: {reason}")]
    Receive {
        /// Service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
}

/// Counts the gaps in a channel's numbering (cycles, command sequence numbers): the samples a
/// reader never got, because it fell behind the arm or because the runtime dropped the record
/// (its `publish_drops`). Numbers at or below the newest are passed over: a restarted arm,
/// numbering again from 0 in the same reader, is not counted until it passes the old newest.
///
/// ```
/// let mut g = jointctl_record::feed::NumberGaps::default();
/// for n in [5, 6, 9, 8, 10] {
///     g.see(n);
/// }
/// assert_eq!((g.lost(), g.newest()), (2, Some(10)), "7 and 8 missing when 9 came; 8 late is not found again");
/// ```
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct NumberGaps {
    next: Option<u64>,
    lost: u64,
}

impl NumberGaps {
    /// Takes the next number read.
    pub fn see(&mut self, number: u64) {
        if let Some(next) = self.next
            && number > next
        {
            self.lost += number - next;
        }
        self.next = Some(self.next.map_or(number.saturating_add(1), |n| n.max(number.saturating_add(1))));
    }

    /// The newest number seen.
    pub fn newest(&self) -> Option<u64> {
        self.next.map(|n| n - 1)
    }

    /// Numbers skipped so far.
    pub fn lost(&self) -> u64 {
        self.lost
    }
}

/// One published sample as JSON (the recording's form, [`messages`]).
#[derive(Clone, Copy, Debug)]
pub struct FeedMessage<'a> {
    /// The channel: one of [`messages::CHANNELS`]' topics.
    pub topic: &'static str,
    /// Its cycle (or, for `commands`, its sequence number): a gap is a lost sample.
    pub number: u64,
    /// CLOCK_MONOTONIC stamp of the cycle (or of the command's acceptance) [ns].
    pub stamp_ns: u64,
    /// The JSON text (empty when the feed was told not to write it, [`ArmFeed::set_json`]).
    pub json: &'a str,
    /// The runtime's final joint state (the arm stopped).
    pub final_sample: bool,
    /// The sample itself, for a writer of another form (the ROS 2 profile).
    pub sample: Sample<'a>,
}

/// The typed sample a [`FeedMessage`] was made from.
#[derive(Clone, Copy, Debug)]
pub enum Sample<'a> {
    /// A raw frame (`raw`); its devices are named by [`ArmFeed::descriptor`].
    Raw(&'a RawFrame),
    /// A joint state (`joint_state`).
    State(&'a ArmState),
    /// Diagnostics (`diagnostics`).
    Diagnostics(&'a Diagnostics),
    /// An accepted command (`commands`).
    Command(&'a CommandRecord),
}

/// Subscribers to every published service of one arm.
pub struct ArmFeed {
    names: ServiceNames,
    raw: Subscriber<ipc::Service, [u8], RawFrameHeader>,
    // The last raw frame received, reused (the samples are sized by the arm).
    raw_buf: RawFrame,
    state: Subscriber<ipc::Service, [JointSample], ArmStateHeader>,
    // The last joint state received, reused (the samples are slices sized by the arm).
    state_buf: ArmState,
    diagnostics: Subscriber<ipc::Service, [u8], DiagnosticsHeader>,
    // The last diagnostics received, reused.
    diagnostics_buf: Diagnostics,
    commands: Subscriber<ipc::Service, CommandRecord, ()>,
    descriptor: RawDescriptor,
    // One text buffer, reused: at 1 kHz, three messages a cycle.
    text: String,
    // Whether to write the JSON text at all (a reader of the typed samples alone does not).
    json: bool,
    // Last: the ports above must be dropped before their node.
    _node: Node<ipc::Service>,
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

fn subscriber<T: std::fmt::Debug + iceoryx2::prelude::IceoryxSend + ?Sized + 'static, H: std::fmt::Debug + ZeroCopySend + 'static>(
    arm: &str,
    service: &str,
    timeout: Duration,
    open: impl FnMut() -> Result<iceoryx2::service::port_factory::publish_subscribe::PortFactory<ipc::Service, T, H>, IpcSetupError>,
) -> Result<Subscriber<ipc::Service, T, H>, FeedError> {
    open_waiting(timeout, open)
        .map_err(|source| FeedError::Ipc { arm: arm.to_string(), source })?
        .subscriber_builder()
        .create()
        .map_err(|e| FeedError::Subscribe { service: service.to_string(), reason: format!("{e:?}") })
}

impl ArmFeed {
    /// Subscribes to the arm's services as `node_name`, waiting up to `timeout` for a runtime to
    /// create them and publish its raw-reading descriptor.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// use jointctl_record::feed::ArmFeed;
    /// let mut feed = ArmFeed::open("sherpa", &Default::default(), std::time::Duration::from_secs(5), "my-viewer")?;
    /// feed.poll(|m| {
    ///     println!("{} {}", m.topic, m.json);
    ///     Ok::<_, jointctl_record::feed::FeedError>(())
    /// })?;
    /// # Ok(()) }
    /// ```
    pub fn open(arm: &str, scope: &IpcScope, timeout: Duration, node_name: &str) -> Result<ArmFeed, FeedError> {
        let ipc = |source| FeedError::Ipc { arm: arm.to_string(), source };
        let node = jointctl_ipc::create_node_in(scope, node_name).map_err(ipc)?;
        let names = ServiceNames::for_arm(arm);
        let raw = subscriber(arm, &names.raw, timeout, || jointctl_ipc::raw_service(&node, &names.raw))?;
        let state = subscriber(arm, &names.joint_state, timeout, || jointctl_ipc::joint_state_service(&node, &names.joint_state))?;
        let diagnostics = subscriber(arm, &names.diagnostics, timeout, || jointctl_ipc::diagnostics_service(&node, &names.diagnostics))?;
        let commands = subscriber(arm, &names.commands, timeout, || jointctl_ipc::commands_service(&node, &names.commands))?;
        let descriptor_sub = subscriber(arm, &names.raw_descriptor, timeout, || jointctl_ipc::raw_descriptor_service(&node, &names.raw_descriptor))?;
        // The descriptor names the raw frames' devices: it comes from the service's history.
        let started = Instant::now();
        let descriptor: RawDescriptor = loop {
            if let Some(s) = descriptor_sub.receive().map_err(|e| FeedError::Receive { service: names.raw_descriptor.clone(), reason: format!("{e:?}") })? {
                break RawDescriptor::try_from(&s).map_err(|e| FeedError::Receive { service: names.raw_descriptor.clone(), reason: e.to_string() })?;
            }
            if started.elapsed() > timeout {
                return Err(FeedError::Silent { arm: arm.to_string(), what: "raw-reading descriptor", timeout_s: timeout.as_secs_f64() });
            }
            std::thread::sleep(Duration::from_millis(5));
        };
        drop(descriptor_sub);
        Ok(ArmFeed { names, raw, raw_buf: RawFrame::EMPTY, state, state_buf: ArmState::EMPTY, diagnostics, diagnostics_buf: Diagnostics::EMPTY, commands, descriptor, text: String::with_capacity(16 * 1024), json: true, _node: node })
    }

    /// Whether [`FeedMessage::json`] is written (on by default). A reader that uses only
    /// [`FeedMessage::sample`] (the ROS 2 recorder and bridge) turns it off, and saves encoding
    /// three JSON messages a cycle; `json` is then empty.
    ///
    /// ```no_run
    /// # fn main() -> Result<(), Box<dyn std::error::Error>> {
    /// let mut feed = jointctl_record::feed::ArmFeed::open("sherpa", &Default::default(), std::time::Duration::from_secs(5), "typed-reader")?;
    /// feed.set_json(false);
    /// feed.poll(|m| {
    ///     assert!(m.json.is_empty());
    ///     Ok::<_, jointctl_record::feed::FeedError>(())
    /// })?;
    /// # Ok(()) }
    /// ```
    pub fn set_json(&mut self, on: bool) {
        self.json = on;
        if !on {
            self.text.clear();
        }
    }

    /// The arm's raw-reading descriptor (devices, rate, activation readings, YAML path).
    pub fn descriptor(&self) -> &RawDescriptor {
        &self.descriptor
    }

    /// Hands every buffered sample to `each` (raw, joint state, diagnostics, then commands) and
    /// returns how many there were; stops at the first error `each` returns.
    pub fn poll<E: From<FeedError>>(&mut self, mut each: impl FnMut(FeedMessage<'_>) -> Result<(), E>) -> Result<usize, E> {
        let receive_error = |service: &str| {
            let service = service.to_string();
            move |e: iceoryx2::port::ReceiveError| FeedError::Receive { service: service.clone(), reason: format!("{e:?}") }
        };
        let mut n = 0;
        let (text, json) = (&mut self.text, self.json);
        // A sample whose payload is not what its header says is an error, never a frame.
        let size_error = |service: &str| {
            let service = service.to_string();
            move |e: jointctl_ipc::wire::PayloadSizeError| FeedError::Receive { service: service.clone(), reason: e.to_string() }
        };
        while let Some(sample) = self.raw.receive().map_err(receive_error(&self.names.raw))? {
            self.raw_buf.copy_from_parts(sample.user_header(), sample.payload()).map_err(size_error(&self.names.raw))?;
            let s = &self.raw_buf;
            if json {
                messages::write_raw(text, s, &self.descriptor);
            }
            each(FeedMessage { topic: "raw", number: s.cycle, stamp_ns: s.stamp_ns, json: text, final_sample: false, sample: Sample::Raw(s) })?;
            n += 1;
        }
        while let Some(sample) = self.state.receive().map_err(receive_error(&self.names.joint_state))? {
            self.state_buf.copy_from_parts(sample.user_header(), sample.payload());
            let s = &self.state_buf;
            if json {
                messages::write_joint_state(text, s);
            }
            each(FeedMessage { topic: "joint_state", number: s.cycle, stamp_ns: s.stamp_ns, json: text, final_sample: s.final_sample != 0, sample: Sample::State(s) })?;
            n += 1;
        }
        while let Some(sample) = self.diagnostics.receive().map_err(receive_error(&self.names.diagnostics))? {
            self.diagnostics_buf.copy_from_parts(sample.user_header(), sample.payload()).map_err(size_error(&self.names.diagnostics))?;
            let s = &self.diagnostics_buf;
            if json {
                messages::write_diagnostics(text, s);
            }
            each(FeedMessage { topic: "diagnostics", number: s.cycle, stamp_ns: s.stamp_ns, json: text, final_sample: false, sample: Sample::Diagnostics(s) })?;
            n += 1;
        }
        while let Some(s) = self.commands.receive().map_err(receive_error(&self.names.commands))? {
            if json {
                *text = messages::command(&s).to_string();
            }
            each(FeedMessage { topic: "commands", number: s.sequence, stamp_ns: s.stamp_ns, json: text, final_sample: false, sample: Sample::Command(&s) })?;
            n += 1;
        }
        Ok(n)
    }
}

/// A CLOCK_MONOTONIC stamp [ns] of this machine (the runtime's cycle stamps) on the wall clock
/// [UNIX ns]: the wall clock now minus how long ago the stamp was. `None` for a stamp in the
/// future or before the epoch.
///
/// ```
/// let now = jointctl_record::feed::wall_clock_ns(jointctl_record::feed::monotonic_ns()).unwrap();
/// let unix = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).unwrap().as_nanos() as u64;
/// assert!(unix.abs_diff(now) < 1_000_000_000);
/// ```
pub fn wall_clock_ns(stamp_ns: u64) -> Option<u64> {
    let mono_now = monotonic_ns();
    let wall_now = u64::try_from(std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).ok()?.as_nanos()).ok()?;
    wall_now.checked_sub(mono_now.checked_sub(stamp_ns)?)
}

/// CLOCK_MONOTONIC [ns], the clock of the cycle stamps (the runtime's `timing::monotonic_ns`;
/// not shared from there, so that a reader does not link the runtime).
#[allow(unsafe_code)]
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime writes into a valid timespec.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    ts.tv_sec as u64 * 1_000_000_000 + ts.tv_nsec as u64
}
