//! # jointctl-hal-socketcan
//!
//! The real buses: the ELMO drives as CANopen nodes over SocketCAN, the absolute encoders over
//! Linux spidev. Lost or late frames are never data: every reading goes through a
//! [`Conditioner`], carries its age, and is stale or invalid rather than zero.
//!
//! Start-up (blocking, before the loop): per drive, SDO writes of the mode of operation
//! (0x6060), the heartbeat producer time (0x1017), SYNC-triggered TPDO1 (0x1800:02 = 1), the
//! consumer heartbeat of the host (0x1016:01) and what to do when it stops (0x6007, abort
//! connection option: quick stop by default) and the drive's own limits of the config (software
//! position limits 0x607D, max profile velocity 0x607F, max torque 0x6072, following error
//! window and time out 0x6065/0x6066, quick stop deceleration 0x6085), each read back; then NMT
//! start. So a host that stalls or dies
//! cannot leave a drive moving: the drive stops on its own after `comm_loss_timeout_ms`. The
//! write step sends the host's heartbeat every `host_heartbeat_ms`.
//!
//! Force/torque sensors are read from ATI Net F/T boxes over UDP ([`netft`]).
//!
//! In the loop (never blocking): read drains the socket (TPDO1 statusword +
//! position, heartbeats, EMCY, error frames) and each encoder's pipelined SPI answer; write sends
//! every drive's RPDO1 (controlword + target) and one SYNC with its counter. The CiA 402 enable
//! sequence advances one step per cycle, and only once the drive's actual position is known (the
//! first target is where the drive is). A faulted drive stays faulted until [`Hal::reset_faults`].
//!
//! Stop (blocking, after the loop): [`Hal::stop`] takes every drive through `safety.stop_sequence`
//! (quick stop, disable operation or voltage, NMT pre-operational), each step's controlword sent
//! with SYNC and the host's heartbeat until every drive reports the step's state or its timeout
//! passes.
//!
//! [`Conditioner`]: jointctl_hal::condition::Conditioner
//! [`Hal::reset_faults`]: jointctl_hal::Hal::reset_faults
//! [`Hal::stop`]: jointctl_hal::Hal::stop

#![warn(missing_docs)]
mod can;
mod encoder;
mod hardware;
pub mod netft;

pub use can::{BusHealth, DriveHealth};
pub use hardware::HardwareHal;

