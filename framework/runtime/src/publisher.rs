//! The loop's shared-memory side: each cycle's record goes from the loop thread into a
//! wait-free ring, and a publisher thread, which owns the iceoryx2 node, sends it, answers
//! commands and logs where each record spent its time ([`HopSample`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use iceoryx2::port::update_connections::UpdateConnections;
use jointctl_ipc::raw::{CommandRecord, RawDescriptor, RawDescriptorHeader, RawDrive, RawFrame, RawFrameHeader, RawReading};
use jointctl_ipc::wire::ByteRecord;
use jointctl_ipc::{ArmState, ArmStateHeader, CommandResponse, Diagnostics, DiagnosticsHeader, JointDescriptor, JointDiagnostics, JointSample, JointsDescriptor, JointsDescriptorHeader, ServiceNames, decode_name, encode_name};

use crate::arm::Arm;
use crate::command_desk::CommandDesk;
use crate::commands::{ArmCommand, CommandValidator};
use crate::run_error::{RunError, port_error};
use crate::state_fill::fill_joints;
use crate::timing::{LoopStats, monotonic_ns};

/// One cycle's record, handed from the loop thread to the publisher thread. Its joint state is
/// sized by the arm: records go round between the two threads in boxes made at start (the
/// loop fills one from its working record, the publisher thread sends it and gives it back).
struct CycleRecord {
    state: ArmState,
    diagnostics: Diagnostics,
    raw: RawFrame,
    /// When the HAL read returned, when the cycle's work ended and when the record went into
    /// the ring [ns, CLOCK_MONOTONIC]; written only while a [`HopSample`] log is kept (0
    /// otherwise).
    readings_ns: u64,
    done_ns: u64,
    handed_ns: u64,
}

impl CycleRecord {
    /// This record overwritten by `other`, allocation-free (both are of the same arm).
    fn copy_from(&mut self, other: &CycleRecord) {
        self.state.copy_from(&other.state);
        self.diagnostics.copy_from(&other.diagnostics);
        self.raw.copy_from(&other.raw);
        (self.readings_ns, self.done_ns, self.handed_ns) = (other.readings_ns, other.done_ns, other.handed_ns);
    }
}

/// Where one cycle's state spent its time between the sensor read and iceoryx2, all
/// CLOCK_MONOTONIC [ns]: kept by the publisher thread when asked for
/// ([`ArmPublisher::with_hop_log`]) so that a benchmark can split the sensor → inspector latency
/// hop by hop (the inspector's receive time is the subscriber's to take).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct HopSample {
    /// The cycle.
    pub cycle: u64,
    /// The cycle began (its wake-up, just before the HAL read): the sample's `stamp_ns`.
    pub read_ns: u64,
    /// The HAL read returned: the readings in hand.
    pub readings_ns: u64,
    /// The cycle's control work ended: set-points written (the simulated HAL steps its physics
    /// in that write).
    pub done_ns: u64,
    /// The record was handed to the publisher thread (state and diagnostics filled).
    pub handed_ns: u64,
    /// The publisher thread took it from the ring.
    pub taken_ns: u64,
    /// The joint-state sample was sent (iceoryx2's `send` returned).
    pub sent_ns: u64,
}

/// Most cycles a [`HopSample`] log keeps (48 MB; 2.8 hours at 1 kHz).
pub const MAX_HOP_LOG: usize = 10_000_000;

/// Capacity of the loop → publisher ring [cycles]: 64 ms at 1 kHz before records are dropped.
const RING_CAPACITY: usize = 64;
/// Capacity of the IPC → loop command ring.
const COMMAND_CAPACITY: usize = 32;

pub use crate::state_fill::published_mode;

/// Logs each joint whose fault count grew since `seen` (the publisher thread's view of the
/// diagnostics), with its fault code and reason.
fn log_new_faults(d: &Diagnostics, seen: &mut [u64]) {
    for (j, seen) in d.joints.iter().zip(seen.iter_mut()) {
        if j.fault_count > *seen {
            *seen = j.fault_count;
            tracing::error!(joint = decode_name(&j.name), fault = j.fault_code, "joint faulted and is held: {}", decode_name(&j.fault_message));
        }
    }
}

/// The arm's plugin instances as `inspect joints` reads them.
fn joints_descriptor(arm: &Arm) -> JointsDescriptor {
    let mut d = JointsDescriptor { rate_hz: arm.rate_hz, joints: Vec::with_capacity(arm.slots.len()) };
    for slot in &arm.slots {
        let dofs = slot.dofs();
        d.joints.push(JointDescriptor {
            name: encode_name(&slot.name),
            plugin: encode_name(&slot.plugin),
            version: encode_name(&slot.plugin_version),
            library: slot.plugin_library.as_deref().map_or([0; jointctl_ipc::raw::PATH_LEN], |p| encode_name(&p.to_string_lossy())),
            first_dof: dofs.start as u32,
            dof_count: dofs.len() as u32,
            budget_ns: slot.budget_ns,
        });
    }
    d
}

/// Logs a kept sample (a descriptor) that could not be published: readers then wait for it in
/// vain.
fn warn_unkept<E: std::fmt::Display>(sent: Result<(), E>, service: &str) {
    if let Err(e) = sent {
        tracing::warn!(service, "could not publish the service's kept sample: {e}");
    }
}

/// Bytes of the payload of each per-cycle byte sample, for the publishers' slice lengths.
#[derive(Clone, Copy)]
struct PayloadSizes {
    dofs: usize,
    diagnostics: usize,
    raw: usize,
}

/// What the publisher thread owns: the arm's node and ports.
struct PublisherPorts {
    node: Node<ipc::Service>,
    state: Publisher<ipc::Service, [JointSample], ArmStateHeader>,
    diagnostics: Publisher<ipc::Service, [u8], DiagnosticsHeader>,
    raw: Publisher<ipc::Service, [u8], RawFrameHeader>,
    /// Kept so that its one sample stays in the service's history for late subscribers.
    descriptor: Publisher<ipc::Service, [u8], RawDescriptorHeader>,
    /// Kept likewise: the arm's plugin instances.
    joints: Publisher<ipc::Service, [JointDescriptor], JointsDescriptorHeader>,
    accepted: Publisher<ipc::Service, CommandRecord, ()>,
    server: iceoryx2::port::server::Server<ipc::Service, jointctl_ipc::CommandRequest, (), CommandResponse, ()>,
}

/// One of the arm's publish-subscribe services created with `create` (one of
/// `jointctl_ipc::create_*_service`) and this runtime's publisher on it.
fn publisher_of<T: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    arm_name: &str,
    service: &str,
    limits: jointctl_ipc::PortLimits,
    create: jointctl_ipc::ServiceCreator<T>,
) -> Result<Publisher<ipc::Service, T, ()>, RunError> {
    create(node, service, limits)?.publisher_builder().create().map_err(|e| port_error(arm_name, service, e))
}

/// [`publisher_of`] a sliced service, for samples of up to `len` elements.
fn sliced_publisher_of<T: std::fmt::Debug + ZeroCopySend + 'static, H: std::fmt::Debug + ZeroCopySend + 'static>(
    node: &Node<ipc::Service>,
    arm_name: &str,
    service: &str,
    limits: jointctl_ipc::PortLimits,
    create: jointctl_ipc::ServiceCreator<[T], H>,
    len: usize,
) -> Result<Publisher<ipc::Service, [T], H>, RunError> {
    create(node, service, limits)?.publisher_builder().initial_max_slice_len(len.max(1)).create().map_err(|e| port_error(arm_name, service, e))
}

impl PublisherPorts {
    /// Creates the arm's node and services; a taken publisher or server slot means another
    /// runtime runs this arm.
    fn open(
        scope: &jointctl_ipc::IpcScope,
        arm_name: &str,
        limits: jointctl_ipc::PortLimits,
        description: &RawDescriptor,
        instances: &JointsDescriptor,
        sizes: PayloadSizes,
    ) -> Result<Self, RunError> {
        let node = jointctl_ipc::create_node_in(scope, &format!("jointctl-run-{arm_name}"))?;
        let names = ServiceNames::for_arm(arm_name);
        // The command server and the raw services first, the joint state and diagnostics last:
        // a client that waits for the state (every inspector does) finds all of them there.
        let command_name = jointctl_ipc::command_service_name(arm_name);
        let server = jointctl_ipc::command_service(&node, &command_name, Some(limits))?
            .server_builder()
            .create()
            .map_err(|e| port_error(arm_name, &command_name, e))?;
        let raw = sliced_publisher_of(&node, arm_name, &names.raw, limits, jointctl_ipc::create_raw_service, sizes.raw)?;
        let descriptor = sliced_publisher_of(&node, arm_name, &names.raw_descriptor, limits, jointctl_ipc::create_raw_descriptor_service, description.payload_len())?;
        warn_unkept(jointctl_ipc::wire::send_record(&descriptor, description), &names.raw_descriptor);
        let joints = sliced_publisher_of(&node, arm_name, &names.joints, limits, jointctl_ipc::create_joints_service, instances.joints.len())?;
        warn_unkept(jointctl_ipc::send_sliced(&joints, instances.header(), instances.joints()), &names.joints);
        let accepted = publisher_of(&node, arm_name, &names.commands, limits, jointctl_ipc::create_commands_service)?;
        let state = sliced_publisher_of(&node, arm_name, &names.joint_state, limits, jointctl_ipc::create_joint_state_service, sizes.dofs)?;
        let diagnostics = sliced_publisher_of(&node, arm_name, &names.diagnostics, limits, jointctl_ipc::create_diagnostics_service, sizes.diagnostics)?;
        Ok(PublisherPorts { node, state, diagnostics, raw, descriptor, joints, accepted, server })
    }

    /// Publishes the loop's records and answers commands until `stop`; returns the samples
    /// iceoryx2 refused. Dropping the ports at the end releases the shared memory.
    fn serve(
        self,
        mut records: rtrb::Consumer<Box<CycleRecord>>,
        mut spent: rtrb::Producer<Box<CycleRecord>>,
        mut commands: rtrb::Producer<ArmCommand>,
        mut desk: CommandDesk,
        stop: &AtomicBool,
        hop_log_capacity: usize,
    ) -> (u64, Vec<HopSample>) {
        let mut failures = 0u64;
        // Allocated here, on the publisher thread, once; at most MAX_HOP_LOG entries.
        let hop_log_capacity = hop_log_capacity.min(MAX_HOP_LOG);
        let mut hops = Vec::with_capacity(hop_log_capacity);
        let mut accepted_count = 0u64;
        let mut faults_seen = Vec::new();
        loop {
            let stopping = stop.load(Ordering::Acquire);
            while let Ok(rec) = records.pop() {
                // The final sample, published outside any cycle, has no hops.
                let taken_ns = if hops.len() < hop_log_capacity && rec.state.final_sample == 0 { monotonic_ns() } else { 0 };
                let ok_state = jointctl_ipc::send_sliced(&self.state, rec.state.header(), rec.state.joints()).is_ok();
                if taken_ns != 0 {
                    let (cycle, read_ns) = (rec.state.cycle, rec.state.stamp_ns);
                    hops.push(HopSample { cycle, read_ns, readings_ns: rec.readings_ns, done_ns: rec.done_ns, handed_ns: rec.handed_ns, taken_ns, sent_ns: monotonic_ns() });
                }
                faults_seen.resize(rec.diagnostics.joints.len(), 0);
                log_new_faults(&rec.diagnostics, &mut faults_seen);
                let ok_diag = jointctl_ipc::wire::send_record(&self.diagnostics, &rec.diagnostics).is_ok();
                let ok_raw = jointctl_ipc::wire::send_record(&self.raw, &rec.raw).is_ok();
                failures += u64::from(!ok_state) + u64::from(!ok_diag) + u64::from(!ok_raw);
                // Back to the loop; the ring holds every box there is, so it has room.
                let _ = spent.push(rec);
            }
            // Commands are validated here, outside the control thread; only valid ones reach
            // the loop, and every request gets an answer. The accepted ones are published for
            // recorders, numbered so that a lost one shows.
            while let Ok(Some(request)) = self.server.receive() {
                let response = desk.answer(request.payload(), &mut commands);
                let (kind, joint) = (request.payload().kind.name(), decode_name(&request.payload().joint));
                if response.accepted == 1 {
                    tracing::info!(command = kind, joint, "accepted: {}", response.text());
                } else {
                    tracing::info!(command = kind, joint, "refused: {}", response.text());
                }
                if response.accepted == 1 {
                    accepted_count += 1;
                    let record = CommandRecord { sequence: accepted_count, stamp_ns: crate::timing::monotonic_ns(), request: *request.payload(), response };
                    let ok = self.accepted.loan_uninit().map(|s| s.write_payload(record).send().is_ok()).unwrap_or(false);
                    failures += u64::from(!ok);
                }
                let _ = request.send_copy(response);
            }
            // A subscriber that arrived since gets the descriptor from the history now.
            let _ = self.descriptor.update_connections();
            let _ = self.joints.update_connections();
            if stopping {
                break;
            }
            std::thread::park_timeout(std::time::Duration::from_millis(5));
        }
        let PublisherPorts { node, state, diagnostics, raw, descriptor, joints, accepted, server } = self;
        // Ports before the node: shared memory released in order.
        drop((server, state, diagnostics, raw, descriptor, joints, accepted, node));
        (failures, hops)
    }
}

/// The arm's last readings and set-points into a raw frame. Allocation-free.
fn fill_raw(raw: &mut RawFrame, arm: &Arm) {
    let readings = arm.last_readings();
    for (out, r) in raw.encoders.iter_mut().zip(&readings.encoders) {
        *out = RawReading::from_reading(r);
    }
    for ((out, r), sp) in raw.drives.iter_mut().zip(&readings.drives).zip(arm.last_setpoints()) {
        *out = RawDrive::new(r, sp);
    }
    for (out, r) in raw.torque_sensors.iter_mut().zip(&readings.torque_sensors) {
        *out = RawReading::from_reading(r);
    }
}

/// The loop's shared-memory side.
///
/// iceoryx2 0.10 allocates a small reference count in every `loan`, so the control thread never
/// calls it: each cycle's record goes into a wait-free single-producer ring (no lock, no
/// allocation, never waits) and a publisher thread, which owns the iceoryx2 node, sends it. A
/// full ring drops the record and counts it (`publish_drops`); the loop never slows down. The
/// records, sized by the arm, are made at start and go round: the loop fills an empty one
/// from `spent`, the publisher thread sends it and puts it back there.
pub struct ArmPublisher {
    producer: rtrb::Producer<Box<CycleRecord>>,
    spent: rtrb::Consumer<Box<CycleRecord>>,
    /// A box the full ring refused, used next.
    spare: Option<Box<CycleRecord>>,
    health: Vec<jointctl_hal::DeviceHealth>,
    commands: rtrb::Consumer<ArmCommand>,
    status: Arc<crate::status::LoopStatus>,
    record: Box<CycleRecord>,
    thread: Option<std::thread::JoinHandle<(u64, Vec<HopSample>)>>,
    /// The publisher thread's Linux thread id, for its scheduling settings.
    thread_tid: libc::pid_t,
    stop: Arc<AtomicBool>,
    drops: u64,
    /// Stamps each record's hand-off for the publisher thread's [`HopSample`] log.
    log_hops: bool,
    hops: Vec<HopSample>,
    failures: u64,
    /// The latest-state blackboard, written on the loop thread as soon as a cycle is observed.
    latest: jointctl_ipc::LatestStateWriter,
    latest_state: ArmState,
}

impl ArmPublisher {
    /// Creates the arm's services in its iceoryx2 domain (cleaning up after crashed runs) on a
    /// publisher thread, and returns once they exist.
    pub fn new(arm: &Arm, domain: Option<&str>) -> Result<Self, RunError> {
        Self::with_limits(arm, &jointctl_ipc::IpcScope::domain(domain), jointctl_ipc::PortLimits::default())
    }

    /// [`ArmPublisher::new`] in a whole scope (domain, root), admitting `limits` subscribers and
    /// command clients (the YAML's `ipc` section).
    pub fn with_limits(arm: &Arm, scope: &jointctl_ipc::IpcScope, limits: jointctl_ipc::PortLimits) -> Result<Self, RunError> {
        Self::with_hop_log(arm, scope, limits, 0)
    }

    /// [`ArmPublisher::with_limits`], and the publisher thread logs where the first
    /// `capacity` cycles' states spent their time ([`HopSample`], read after [`ArmPublisher::close`]
    /// with [`ArmPublisher::hops`]): one clock read more per cycle on the loop thread, two on
    /// the publisher's (the HAL read's return is always timed); the log's memory, at most
/// [`MAX_HOP_LOG`] entries, is taken once, on the publisher thread.
    pub fn with_hop_log(arm: &Arm, scope: &jointctl_ipc::IpcScope, limits: jointctl_ipc::PortLimits, capacity: usize) -> Result<Self, RunError> {
        let (producer, consumer) = rtrb::RingBuffer::<Box<CycleRecord>>::new(RING_CAPACITY);
        let (mut spent_producer, spent) = rtrb::RingBuffer::<Box<CycleRecord>>::new(RING_CAPACITY);
        let (command_producer, commands) = rtrb::RingBuffer::<ArmCommand>::new(COMMAND_CAPACITY);
        let status = Arc::new(crate::status::LoopStatus::new(arm.dof_names.len()));
        let desk = CommandDesk::new(CommandValidator::new(arm.dof_specs(), Arc::clone(&status)).with_loop_rate(1.0 / arm.dt_s), arm.dt_s);
        let stop = Arc::new(AtomicBool::new(false));
        // The latest-state blackboard before the publisher thread opens the other services, so
        // that a client that finds those finds it too. Written by the loop thread itself
        // (`post_observed`), not the publisher thread; until then it holds the named joints.
        let latest_state = ArmState::named(arm.dof_names.iter().map(String::as_str));
        let latest = jointctl_ipc::LatestStateWriter::create(scope, &arm.name, limits.max_subscribers, &latest_state)?;
        let (ready_tx, ready_rx) = std::sync::mpsc::channel::<Result<libc::pid_t, RunError>>();
        let arm_name = arm.name.clone();
        let scope = scope.clone();
        let (encoders, drives) = arm.raw_devices();
        let mut description = RawDescriptor::of(arm.rate_hz, &encoders, &drives, &arm.torque_sensor_names(), arm.config_path());
        fill_raw(&mut description.activation, arm);
        let instances = joints_descriptor(arm);
        // The loop's working record: its joints and devices named. Every cycle's raw frame holds
        // the described devices: the activation frame's shape.
        let mut diagnostics = Diagnostics::EMPTY;
        diagnostics.period_ns = (1e9 / arm.rate_hz) as u64;
        let named = |mut d: JointDiagnostics, name: &str| {
            d.name = encode_name(name);
            d
        };
        diagnostics.joints = arm.dof_names.iter().map(|name| named(JointDiagnostics::EMPTY, name)).collect();
        diagnostics.devices = arm
            .device_names()
            .map(|name| {
                let mut d = jointctl_ipc::DeviceDiagnostics::EMPTY;
                d.name = encode_name(name);
                d
            })
            .collect();
        let record = Box::new(CycleRecord { state: latest_state.clone(), diagnostics, raw: description.activation.clone(), readings_ns: 0, done_ns: 0, handed_ns: 0 });
        let sizes = PayloadSizes { dofs: arm.dof_names.len(), diagnostics: record.diagnostics.payload_len(), raw: record.raw.payload_len() };
        // The boxes the records go round in, made here, once.
        for _ in 0..RING_CAPACITY {
            let empty = Box::new(CycleRecord { state: record.state.clone(), diagnostics: record.diagnostics.clone(), raw: record.raw.clone(), readings_ns: 0, done_ns: 0, handed_ns: 0 });
            if spent_producer.push(empty).is_err() {
                break;
            }
        }
        let thread_stop = Arc::clone(&stop);
        let thread = std::thread::Builder::new()
            .name(format!("{arm_name}-publisher"))
            .spawn(move || {
                let ports = match PublisherPorts::open(&scope, &arm_name, limits, &description, &instances, sizes) {
                    Ok(ports) => {
                        let _ = ready_tx.send(Ok(crate::timing::thread_id()));
                        ports
                    }
                    Err(e) => {
                        let _ = ready_tx.send(Err(e));
                        return (0, Vec::new());
                    }
                };
                ports.serve(consumer, spent_producer, command_producer, desk, &thread_stop, capacity)
            })
            .map_err(|e| RunError::Thread(e.to_string()))?;
        let thread_tid = match ready_rx.recv() {
            Ok(Ok(tid)) => tid,
            Ok(Err(e)) => {
                let _ = thread.join();
                return Err(e);
            }
            Err(_) => return Err(RunError::Thread("the publisher thread ended during setup".into())),
        };
        let health = vec![jointctl_hal::DeviceHealth::default(); record.diagnostics.devices.len()];
        Ok(ArmPublisher { producer, spent, spare: None, health, commands, status, record, thread: Some(thread), thread_tid, stop, drops: 0, log_hops: capacity > 0, hops: Vec::new(), failures: 0, latest, latest_state })
    }

    /// Fills the state and raw parts of this cycle's record.
    pub fn publish_state(&mut self, arm: &Arm, cycle: u64, stamp_ns: u64, final_sample: bool) {
        let raw = &mut self.record.raw;
        raw.cycle = cycle;
        raw.stamp_ns = stamp_ns;
        fill_raw(raw, arm);
        let s = &mut self.record.state;
        s.cycle = cycle;
        s.stamp_ns = stamp_ns;
        s.final_sample = final_sample as u32;
        if final_sample || arm.stop_requested {
            self.status.set_stopping();
        }
        for slot in &arm.slots {
            for i in slot.dofs() {
                self.status.set_dof(i, arm.enabled[i], slot.fault);
            }
        }
        fill_joints(s, arm);
        if final_sample {
            // The blackboard's last word as well: readers see that the loop has ended.
            self.latest_state.final_sample = 1;
            self.post_observed(arm, cycle, stamp_ns);
        }
    }

    /// Writes the state just observed to the latest-state blackboard
    /// ([`jointctl_ipc::LatestStateWriter`]), on the loop thread: the readings and what the
    /// observers made of them; the mode, the torque reference, `enabled` and the gravity torque
    /// as the last cycle left them (this cycle's control, which sets them, comes after).
    /// Lock-free and allocation-free; an inspector reading it waits neither for the cycle's
    /// control nor for the publisher thread.
    pub fn post_observed(&mut self, arm: &Arm, cycle: u64, stamp_ns: u64) {
        let s = &mut self.latest_state;
        s.cycle = cycle;
        s.stamp_ns = stamp_ns;
        fill_joints(s, arm);
        self.latest.write(s);
    }

    /// Applies the commands the desk accepted since the last cycle, in order. Allocation-free.
    pub(crate) fn apply_commands(&mut self, arm: &mut Arm) {
        while let Ok(command) = self.commands.pop() {
            arm.apply(command);
            // Numbered as the desk numbered them when it accepted them (one queue, in order).
            self.record.raw.commands_applied += 1;
        }
    }

    /// When this cycle's control work ended [ns], for the hop log.
    pub(crate) fn set_done_ns(&mut self, done_ns: u64) {
        self.record.done_ns = done_ns;
    }

    /// The publisher thread's Linux thread id, for its scheduling settings.
    pub(crate) fn thread_id(&self) -> libc::pid_t {
        self.thread_tid
    }

    /// The status the command desk reads.
    pub fn status(&self) -> &Arc<crate::status::LoopStatus> {
        &self.status
    }

    /// Fills the diagnostics part and hands the record to the publisher thread.
    pub fn publish_diagnostics(&mut self, arm: &Arm, stats: &LoopStats, cycle: u64, stamp_ns: u64) {
        let d = &mut self.record.diagnostics;
        d.cycle = cycle;
        d.stamp_ns = stamp_ns;
        d.overruns = stats.overruns;
        d.missed_deadlines = stats.missed_deadlines;
        d.hal_errors = arm.hal_errors;
        d.publish_drops = self.drops;
        d.last_compute_ns = stats.last_compute_ns;
        d.max_compute_ns = stats.max_compute_ns;
        d.max_jitter_ns = stats.max_jitter_ns;
        d.jitter_histogram = stats.jitter_histogram;
        for slot in &arm.slots {
            for i in slot.dofs() {
                let j: &mut JointDiagnostics = &mut d.joints[i];
                j.valid_mask = arm.states[i].valid.0;
                j.fault_code = slot.fault;
                j.held = slot.held as u32;
                j.invalid_cycles = slot.invalid_cycles;
                j.fault_count = slot.fault_count;
                let e = arm.controllers[i].events;
                j.setpoint_clamps = e.setpoint_clamps;
                j.torque_clamps = e.torque_clamps;
                j.rate_limited = e.rate_limited;
                j.watchdog_trips = e.watchdog_trips;
                j.missing_inputs = e.missing_inputs;
                j.plugin_budget_ns = slot.budget_ns;
                j.plugin_max_ns = slot.max_used_ns;
                j.over_budget_cycles = slot.over_budget_cycles;
                j.setpoint_rejections = slot.setpoint_rejections;
                // Written when it changes only: faults are rare and hold until restart.
                if slot.fault == 0 {
                    if j.fault_message[0] != 0 {
                        j.fault_message = [0; jointctl_ipc::FAULT_MESSAGE_LEN];
                    }
                } else if j.fault_message[0] == 0 {
                    j.fault_message = encode_name(if slot.fault_reason().is_empty() { "no reason given" } else { slot.fault_reason() });
                }
            }
        }
        arm.device_health(&mut self.health);
        for (d, h) in self.record.diagnostics.devices.iter_mut().zip(&self.health) {
            (d.missing, d.invalid, d.implausible, d.emcy, d.flags) = (h.missing, h.invalid, h.implausible, h.emcy, h.flags);
        }
        if self.log_hops {
            self.record.readings_ns = arm.readings_ns;
            self.record.handed_ns = monotonic_ns();
        }
        // No empty box: the publisher thread holds them all, behind by the ring's length.
        match self.spare.take().or_else(|| self.spent.pop().ok()) {
            Some(mut next) => {
                next.copy_from(&self.record);
                if let Err(rtrb::PushError::Full(next)) = self.producer.push(next) {
                    // Cannot happen (as many boxes as places); the record is lost, the box
                    // kept (never freed on this thread).
                    self.drops += 1;
                    self.spare = Some(next);
                }
            }
            None => self.drops += 1,
        }
        if let Some(t) = &self.thread {
            t.thread().unpark();
        }
    }

    /// Records dropped because the publisher thread fell behind.
    pub fn drops(&self) -> u64 {
        self.drops
    }

    /// Sends what is queued, stops the publisher thread and releases shared memory. Returns
    /// the samples iceoryx2 refused.
    pub fn close(&mut self) -> u64 {
        self.stop.store(true, Ordering::Release);
        if let Some(t) = self.thread.take() {
            t.thread().unpark();
            match t.join() {
                Ok(done) => (self.failures, self.hops) = done,
                // Outside the loop: the arm is held already; say that its last samples may be missing.
                Err(_) => tracing::error!("the publisher thread panicked: the last samples may not have been published"),
            }
        }
        self.failures
    }

    /// The publisher thread's [`HopSample`] log ([`ArmPublisher::with_hop_log`]), in cycle
    /// order; empty before [`ArmPublisher::close`] or when no log was asked for.
    pub fn hops(&self) -> &[HopSample] {
        &self.hops
    }
}

impl Drop for ArmPublisher {
    fn drop(&mut self) {
        self.close();
    }
}
