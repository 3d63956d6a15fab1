//! Why the loop, or its shared memory, could not run: one error for [`crate::runner::run`] and
//! [`crate::publisher::ArmPublisher`], so that the command line reports either the same way.

use iceoryx2::port::publisher::PublisherCreateError;
use iceoryx2::service::port_factory::server::ServerCreateError;

/// Why the loop could not run.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Shared memory could not be set up.
    #[error(transparent)]
    Ipc(#[from] jointctl_ipc::IpcSetupError),
    /// Another runtime publishes this arm already.
    #[error("arm `{arm}` is already running (its service `{service}` has a publisher): stop it first ({reason})")]
    AlreadyRunning {
        /// Arm name.
        arm: String,
        /// Service.
        service: String,
        /// iceoryx2's reason.
        reason: String,
    },
    /// A port of the arm's services could not be created for another reason than a running
    /// runtime (iceoryx2's reason kept).
    #[error("cannot create the {port} of `{service}`")]
    Port {
        /// "publisher" or "server".
        port: &'static str,
        /// Service.
        service: String,
        /// iceoryx2's reason.
        source: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The publisher thread could not start.
    #[error("cannot start the publisher thread: {0}")]
    Thread(String),
    /// Signal handlers could not be installed.
    #[error("cannot install the signal handlers")]
    Signals(#[source] std::io::Error),
}

/// A port-creation failure of iceoryx2 that may mean "another runtime holds this port".
pub(crate) trait PortCreateFailure: std::error::Error + Send + Sync + 'static {
    /// "publisher" or "server".
    const PORT: &'static str;
    /// The port's one slot is taken: another runtime runs the arm.
    fn slot_taken(&self) -> bool;
}

impl PortCreateFailure for PublisherCreateError {
    const PORT: &'static str = "publisher";
    fn slot_taken(&self) -> bool {
        *self == PublisherCreateError::ExceedsMaxSupportedPublishers
    }
}

impl PortCreateFailure for ServerCreateError {
    const PORT: &'static str = "server";
    fn slot_taken(&self) -> bool {
        *self == ServerCreateError::ExceedsMaxSupportedServers
    }
}

/// Only "the one publisher/server slot is taken" means another runtime runs this arm; any
/// other failure is reported as what it is, with iceoryx2's error as the source.
pub(crate) fn port_error<E: PortCreateFailure>(arm: &str, service: &str, e: E) -> RunError {
    if e.slot_taken() {
        RunError::AlreadyRunning { arm: arm.into(), service: service.into(), reason: format!("{e:?}") }
    } else {
        RunError::Port { port: E::PORT, service: service.into(), source: Box::new(e) }
    }
}

#[cfg(test)]
mod port_error_tests {
    use super::*;

    #[test]
    fn only_a_taken_slot_reads_as_already_running() {
        assert!(matches!(port_error("a", "a/s", PublisherCreateError::ExceedsMaxSupportedPublishers), RunError::AlreadyRunning { .. }));
        assert!(matches!(port_error("a", "a/c", ServerCreateError::ExceedsMaxSupportedServers), RunError::AlreadyRunning { .. }));
        let e = port_error("a", "a/s", PublisherCreateError::UnableToCreateDataSegment);
        assert!(matches!(e, RunError::Port { port: "publisher", .. }), "{e}");
        assert!(std::error::Error::source(&e).is_some(), "iceoryx2's error is kept");
        assert!(matches!(port_error("a", "a/c", ServerCreateError::UnableToCreatePortTag), RunError::Port { port: "server", .. }));
    }
}
