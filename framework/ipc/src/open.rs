//! The typed openers of each publish-subscribe service of an arm: one to read (open an existing
//! service, whatever its limits) and one for the runtime (create it with the arm's QoS).

use iceoryx2::prelude::*;
use iceoryx2::service::port_factory::publish_subscribe::PortFactory;

use crate::descriptor::{JointDescriptor, JointsDescriptorHeader};
use crate::diagnostics::DiagnosticsHeader;
use crate::raw;
use crate::services::{IpcSetupError, PortLimits, SUBSCRIBER_BUFFER, service_name};
use crate::state::{ArmStateHeader, JointSample};

/// What each `create_*_service` function is: the runtime's way to create one of an arm's
/// publish-subscribe services with payload `T` and user header `H`.
pub type ServiceCreator<T, H = ()> = fn(&Node<ipc::Service>, &str, PortLimits) -> Result<PortFactory<ipc::Service, T, H>, IpcSetupError>;

macro_rules! service_opener {
    ($open:ident, $create:ident, $ty:ty, $what:literal) => {
        service_opener!($open, $create, $ty, (), $what);
    };
    ($open:ident, $create:ident, $ty:ty, $header:ty, $what:literal) => {
        #[doc = concat!("Opens an arm's ", $what, " service as a reader: it must exist (a runtime created it), and")]
        /// nothing is required of its limits, so a reader works with whatever the arm's YAML set.
        pub fn $open(node: &Node<ipc::Service>, name: &str) -> Result<PortFactory<ipc::Service, $ty, $header>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .user_header::<$header>()
                .open()
                .map_err(|source| IpcSetupError::OpenPublishSubscribe { service: name.to_string(), source })
        }

        #[doc = concat!("Creates (or re-opens) an arm's ", $what, " service for the runtime: one publisher (a")]
        /// second runtime of the same arm is refused), `limits.max_subscribers` subscribers, the
        /// last sample kept for late subscribers, and overflow that drops the oldest sample in a
        /// slow subscriber's buffer.
        pub fn $create(node: &Node<ipc::Service>, name: &str, limits: PortLimits) -> Result<PortFactory<ipc::Service, $ty, $header>, IpcSetupError> {
            node.service_builder(&service_name(name)?)
                .publish_subscribe::<$ty>()
                .user_header::<$header>()
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

service_opener!(joint_state_service, create_joint_state_service, [JointSample], ArmStateHeader, "joint-state (a slice of joints sized by the arm)");
service_opener!(diagnostics_service, create_diagnostics_service, [u8], DiagnosticsHeader, "diagnostics (bytes of joints and devices sized by the arm, `wire`)");
service_opener!(raw_service, create_raw_service, [u8], raw::RawFrameHeader, "raw-readings (bytes of devices sized by the arm, `wire`)");
service_opener!(raw_descriptor_service, create_raw_descriptor_service, [u8], raw::RawDescriptorHeader, "raw-descriptor (bytes sized by the arm, `wire`)");
service_opener!(commands_service, create_commands_service, raw::CommandRecord, "accepted-commands");
service_opener!(joints_service, create_joints_service, [JointDescriptor], JointsDescriptorHeader, "plugin-instance (a slice sized by the arm)");

