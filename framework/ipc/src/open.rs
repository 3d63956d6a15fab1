//! The typed openers of each publish-subscribe service of an arm: one to read (open an existing
//! service, whatever its limits) and one for the runtime (create it with the arm's QoS).

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

use crate::descriptor::JointsDescriptor;
use crate::diagnostics::Diagnostics;
use crate::raw;
use crate::services::{IpcSetupError, PortLimits, SUBSCRIBER_BUFFER, service_name};
use crate::state::ArmState;

/// What each `create_*_service` function is: the runtime's way to create one of an arm's
/// publish-subscribe services with payload `T`.
pub type ServiceCreator<T> = fn(&Node<ipc::Service>, &str, PortLimits) -> Result<PortFactory<ipc::Service, T, ()>, IpcSetupError>;

macro_rules! service_opener {
    ($open:ident, $create:ident, $ty:ty, $what:literal) => {
        #[doc = concat!("Opens an arm's ", $what, " service as a reader: it must exist (a runtime created it), and")]
        /// nothing is required of its limits, so a reader works with whatever the arm's YAML set.
        pub fn $open(node: &Node<ipc::Service>, name: &str) -> Result<PortFactory<ipc::Service, $ty, ()>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .open()
                .map_err(|source| IpcSetupError::OpenPublishSubscribe { service: name.to_string(), source })
        }

        #[doc = concat!("Creates (or re-opens) an arm's ", $what, " service for the runtime: one publisher (a")]
        /// second runtime of the same arm is refused), `limits.max_subscribers` subscribers, the
        /// last sample kept for late subscribers, and overflow that drops the oldest sample in a
        /// slow subscriber's buffer.
        pub fn $create(node: &Node<ipc::Service>, name: &str, limits: PortLimits) -> Result<PortFactory<ipc::Service, $ty, ()>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .max_publishers(1)
                .max_subscribers(limits.max_subscribers)
                .history_size(1)
                .subscriber_max_buffer_size(SUBSCRIBER_BUFFER)
                .enable_safe_overflow(true)
                .open_or_create()
                .map_err(|source| IpcSetupError::PublishSubscribe { service: name.to_string(), source })
        }
    };
}

service_opener!(joint_state_service, create_joint_state_service, ArmState, "joint-state");
service_opener!(diagnostics_service, create_diagnostics_service, Diagnostics, "diagnostics");
service_opener!(raw_service, create_raw_service, raw::RawFrame, "raw-readings");
service_opener!(raw_descriptor_service, create_raw_descriptor_service, raw::RawDescriptor, "raw-descriptor");
service_opener!(commands_service, create_commands_service, raw::CommandRecord, "accepted-commands");
service_opener!(joints_service, create_joints_service, JointsDescriptor, "plugin-instance");
