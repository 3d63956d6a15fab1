//! Commands to a running arm: the request and response types and a client (`<arm>/command`,
//! request-response).

use iceoryx2::prelude::*;

use crate::services::{IpcScope, IpcSetupError, PortLimits, create_node_in, iceoryx2_config_in, service_name};
use crate::{CommandKind, NAME_LEN, TorqueWaveform, encode_name};

/// Most trajectory points one command carries.
pub const MAX_COMMAND_POINTS: usize = 64;

/// A command to a running arm, sent on `<arm>/command` (request-response).
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.CommandRequest.v2")]
pub struct CommandRequest {
    /// What is asked.
    pub kind: CommandKind,
    /// 1: a streamed command that must be renewed within the joint's watchdog time.
    pub streamed: u32,
    /// NUL-padded joint name; empty for all joints (hold, stop).
    pub joint: [u8; NAME_LEN],
    /// The torque reference's waveform ([`CommandKind::TORQUE`] only).
    pub waveform: TorqueWaveform,
    _reserved0: u32,
    /// Kind-specific numbers (see [`CommandKind`]).
    pub values: [f64; 8],
    /// Valid entries in `points`.
    pub point_count: u32,
    _reserved: u32,
    /// Trajectory points (time [s], position [rad], velocity [rad/s] or NaN).
    pub points: [[f64; 3]; MAX_COMMAND_POINTS],
}

impl CommandRequest {
    /// A torque reference for `joint`: `waveform` with [amplitude [Nm], frequency [Hz], offset
    /// [Nm], start delay [s]].
    ///
    /// ```
    /// use jointctl_ipc::{CommandRequest, TorqueWaveform};
    /// let r = CommandRequest::torque("q2", TorqueWaveform::SINE, &[5.0, 0.1, 0.0, 0.0]);
    /// assert_eq!((r.waveform, r.values[1]), (TorqueWaveform::SINE, 0.1));
    /// ```
    pub fn torque(joint: &str, waveform: TorqueWaveform, values: &[f64]) -> Self {
        CommandRequest { waveform, ..Self::new(CommandKind::TORQUE, joint, values) }
    }

    /// A request of `kind` for `joint` ("" for all) with `values`.
    ///
    /// ```
    /// use jointctl_ipc::{CommandKind, CommandRequest};
    /// let r = CommandRequest::new(CommandKind::POSITION, "q1", &[0.5]);
    /// assert_eq!((jointctl_ipc::decode_name(&r.joint), r.values[0]), ("q1", 0.5));
    /// ```
    pub fn new(kind: CommandKind, joint: &str, values: &[f64]) -> Self {
        let mut v = [f64::NAN; 8];
        for (d, s) in v.iter_mut().zip(values) {
            *d = *s;
        }
        CommandRequest {
            kind,
            streamed: 0,
            joint: encode_name(joint),
            waveform: TorqueWaveform::STEP,
            _reserved0: 0,
            values: v,
            point_count: 0,
            _reserved: 0,
            points: [[f64::NAN; 3]; MAX_COMMAND_POINTS],
        }
    }
}

/// The runtime's answer to a [`CommandRequest`].
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.CommandResponse.v2")]
pub struct CommandResponse {
    /// 1 when the command was accepted and queued for the next cycle.
    pub accepted: u32,
    /// Bytes of `message` used.
    pub message_len: u32,
    /// Why it was refused, or what was done.
    pub message: [u8; 240],
}

impl CommandResponse {
    /// A response with a message (truncated to 240 bytes at a character boundary).
    ///
    /// ```
    /// let r = jointctl_ipc::CommandResponse::new(false, "joint `q9` does not exist");
    /// assert_eq!(r.text(), "joint `q9` does not exist");
    /// ```
    pub fn new(accepted: bool, message: &str) -> Self {
        let mut m = [0u8; 240];
        let n = jointctl_api::abi::copy_utf8_prefix(&mut m, message);
        CommandResponse { accepted: accepted as u32, message_len: n as u32, message: m }
    }

    /// The message.
    pub fn text(&self) -> &str {
        core::str::from_utf8(&self.message[..(self.message_len as usize).min(240)]).unwrap_or("?")
    }
}

/// Name of an arm's command service.
pub fn command_service_name(arm: &str) -> String {
    format!("{arm}/command")
}

/// Opens an arm's command service. The runtime creates it (`Some(limits)`); a client only opens
/// it (`None`), requiring nothing of its limits, so that "no runtime is running" is an error
/// instead of a service nobody serves.
pub fn command_service(
    node: &Node<ipc::Service>,
    name: &str,
    create: Option<PortLimits>,
) -> Result<iceoryx2::service::port_factory::request_response::PortFactory<ipc::Service, CommandRequest, (), CommandResponse, ()>, IpcSetupError> {
    let builder = node.service_builder(&service_name(name)?).request_response::<CommandRequest, CommandResponse>();
    let service = || name.to_string();
    match create {
        Some(limits) => builder
            .max_servers(1)
            .max_clients(limits.max_clients)
            .max_active_requests_per_client(4)
            .max_response_buffer_size(4)
            .open_or_create()
            .map_err(|source| IpcSetupError::CreateRequestResponse { service: service(), source }),
        None => builder.open().map_err(|source| IpcSetupError::OpenRequestResponse { service: service(), source }),
    }
}

/// Why a command got no answer from the runtime.
#[derive(Debug, thiserror::Error)]
pub enum CommandError {
    /// The node could not be created.
    #[error(transparent)]
    Setup(#[from] IpcSetupError),
    /// No runtime serves the arm.
    #[error("no runtime is running arm `{arm}` (no service `{service}`): start `jointctl run`")]
    NoRuntime {
        /// The arm.
        arm: String,
        /// The command service.
        service: String,
    },
    /// Every client slot is taken.
    #[error("every client slot of `{service}` is taken (the YAML's ipc.max_clients)")]
    SlotsTaken {
        /// The command service.
        service: String,
    },
    /// iceoryx2 refused the client, the request or the response.
    #[error("cannot talk to `{service}`: {reason}")]
    Port {
        /// The command service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// The runtime did not answer in time.
    #[error("no answer from arm `{arm}` within {timeout_s} s (is its runtime running?)")]
    NoAnswer {
        /// The arm.
        arm: String,
        /// How long it waited [s].
        timeout_s: f64,
    },
}

/// A client of an arm's command service: `jointctl cmd` and the network bridges send through it.
pub struct CommandClient {
    arm: String,
    service: String,
    client: iceoryx2::port::client::Client<ipc::Service, CommandRequest, (), CommandResponse, ()>,
    // Last: the port above must be dropped before its node.
    _node: Node<ipc::Service>,
}

impl CommandClient {
    /// Connects to the command service of `arm` as `node_name`.
    ///
    /// ```
    /// let e = jointctl_ipc::CommandClient::open(&Default::default(), "nobody-runs-this-arm", "doc-client").err().unwrap();
    /// assert!(matches!(e, jointctl_ipc::CommandError::NoRuntime { .. }), "{e}");
    /// ```
    pub fn open(scope: &IpcScope, arm: &str, node_name: &str) -> Result<CommandClient, CommandError> {
        let service = command_service_name(arm);
        // Looked up before this client makes a node: a node makes its domain's management
        // segment in /dev/shm for good, and `cmd --domain` with a typo left one behind.
        let config = iceoryx2_config_in(scope)?;
        let exists = <ipc::Service as iceoryx2::service::Service>::does_exist(&service_name(&service)?, &config, MessagingPattern::RequestResponse);
        if matches!(exists, Ok(false)) {
            return Err(CommandError::NoRuntime { arm: arm.to_string(), service });
        }
        let node = create_node_in(scope, node_name)?;
        let factory = command_service(&node, &service, None).map_err(|_| CommandError::NoRuntime { arm: arm.to_string(), service: service.clone() })?;
        let client = factory.client_builder().create().map_err(|e| match e {
            iceoryx2::service::port_factory::client::ClientCreateError::ExceedsMaxSupportedClients => CommandError::SlotsTaken { service: service.clone() },
            e => CommandError::Port { service: service.clone(), reason: format!("{e:?}") },
        })?;
        Ok(CommandClient { arm: arm.to_string(), service, client, _node: node })
    }

    /// Sends `request` and waits up to `timeout_s` for the runtime's answer.
    pub fn send(&self, request: CommandRequest, timeout_s: f64) -> Result<CommandResponse, CommandError> {
        let port = |e: &dyn std::fmt::Debug| CommandError::Port { service: self.service.clone(), reason: format!("{e:?}") };
        let pending = self.client.send_copy(request).map_err(|e| port(&e))?;
        let start = std::time::Instant::now();
        loop {
            match pending.receive().map_err(|e| port(&e))? {
                Some(response) => return Ok(*response.payload()),
                None if start.elapsed().as_secs_f64() < timeout_s => std::thread::sleep(std::time::Duration::from_millis(1)),
                None => return Err(CommandError::NoAnswer { arm: self.arm.clone(), timeout_s }),
            }
        }
    }
}
