//! The latest observed state of an arm, without a thread in between: a blackboard (iceoryx2's
//! latest-value service) that the loop thread writes as soon as the cycle's readings are
//! observed, and that an inspector reads when it likes.
//!
//! The publish-subscribe state ([`crate::joint_state_service`]) carries every cycle, for
//! recorders, but iceoryx2 0.10 allocates a reference count in every loan, so the loop hands
//! each record to a publisher thread, and the thread's wake-up and the cycle's own control work
//! lie between a reading and its sample. A blackboard entry is written by a lock-free store of
//! the value into shared memory (no loan, no allocation, never waits): the loop writes it
//! between observing and controlling. A reader sees the latest value only (a slow reader misses
//! cycles, and knows it by the cycle counter).

use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;

use crate::services::{IpcScope, IpcSetupError, create_node_of, service_name};

/// The service kind: handles that may move between threads (a runtime's `ArmPublisher` is
/// `Send`); its write is the same lock-free store.
type Kind = ipc_threadsafe::Service;
use crate::state::ArmState;

/// The blackboard's one key.
const KEY: u32 = 0;

fn error(service: &str, what: &'static str, source: impl std::error::Error + Send + Sync + 'static) -> IpcSetupError {
    IpcSetupError::LatestState { service: service.to_string(), what, source: Box::new(source) }
}

/// The loop's side: creates the arm's latest-state blackboard and writes it.
///
/// ```
/// let scope = jointctl_ipc::IpcScope::domain(Some("jointctl-doc-latest-w"));
/// let writer = jointctl_ipc::LatestStateWriter::create(&scope, "doc-arm", 2).unwrap();
/// let mut state = jointctl_ipc::ArmState::EMPTY;
/// state.cycle = 7;
/// writer.write(&state);
/// let reader = jointctl_ipc::LatestStateReader::open(&scope, "doc-arm").unwrap();
/// assert_eq!(reader.latest().cycle, 7);
/// ```
pub struct LatestStateWriter {
    entry: EntryHandleMut<Kind, u32, ArmState>,
    _writer: iceoryx2::port::writer::Writer<Kind, u32>,
    _service: iceoryx2::service::port_factory::blackboard::PortFactory<Kind, u32>,
    _node: Node<Kind>,
}

impl LatestStateWriter {
    /// Creates the blackboard `{arm}/latest_state` in `scope`, admitting `max_readers` readers,
    /// and its writer. A second runtime of the arm is refused (the service exists).
    pub fn create(scope: &IpcScope, arm: &str, max_readers: usize) -> Result<Self, IpcSetupError> {
        let name = crate::ServiceNames::for_arm(arm).latest_state;
        let node = create_node_of::<Kind>(scope, &format!("{arm}-latest-writer"))?;
        let service = node.service_builder(&service_name(&name)?).blackboard_creator::<u32>().add::<ArmState>(KEY, ArmState::EMPTY).max_readers(max_readers.max(1)).create().map_err(|e| error(&name, "create", e))?;
        let writer = service.writer_builder().create().map_err(|e| error(&name, "write to", e))?;
        let entry = writer.entry::<ArmState>(&KEY).map_err(|e| error(&name, "write to", e))?;
        Ok(LatestStateWriter { entry, _writer: writer, _service: service, _node: node })
    }

    /// Writes `state` as the latest: a copy into shared memory, lock-free, allocation-free.
    pub fn write(&self, state: &ArmState) {
        self.entry.update_with_copy(*state);
    }
}

/// An inspector's side: reads the arm's latest state.
pub struct LatestStateReader {
    entry: EntryHandle<Kind, u32, ArmState>,
    _reader: iceoryx2::port::reader::Reader<Kind, u32>,
    _service: iceoryx2::service::port_factory::blackboard::PortFactory<Kind, u32>,
    _node: Node<Kind>,
}

impl LatestStateReader {
    /// Opens the arm's blackboard in `scope` (a runtime must be running the arm there).
    pub fn open(scope: &IpcScope, arm: &str) -> Result<Self, IpcSetupError> {
        let name = crate::ServiceNames::for_arm(arm).latest_state;
        let node = create_node_of::<Kind>(scope, &format!("{arm}-latest-reader"))?;
        let service = node.service_builder(&service_name(&name)?).blackboard_opener::<u32>().open().map_err(|e| error(&name, "open", e))?;
        let reader = service.reader_builder().create().map_err(|e| error(&name, "read", e))?;
        let entry = reader.entry::<ArmState>(&KEY).map_err(|e| error(&name, "read", e))?;
        Ok(LatestStateReader { entry, _reader: reader, _service: service, _node: node })
    }

    /// The latest state written (a copy).
    pub fn latest(&self) -> ArmState {
        *self.entry.get()
    }
}
