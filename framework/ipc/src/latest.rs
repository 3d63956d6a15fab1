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
use crate::state::ArmState;

/// The service kind: handles that may move between threads (a runtime's `ArmPublisher` is
/// `Send`); its write is the same lock-free store.
type Kind = ipc_threadsafe::Service;

/// The blackboard's one key.
const KEY: u32 = 0;

fn error(service: &str, what: &'static str, source: impl std::error::Error + Send + Sync + 'static) -> IpcSetupError {
    IpcSetupError::LatestState { service: service.to_string(), what, source: Box::new(source) }
}

/// The loop's side: creates the arm's latest-state blackboard and writes it.
///
/// ```
/// let scope = jointctl_ipc::IpcScope::domain(None);
/// let writer = jointctl_ipc::LatestStateWriter::create(&scope, "doc-latest-arm", 2, &jointctl_ipc::ArmState::EMPTY).unwrap();
/// let mut state = jointctl_ipc::ArmState::EMPTY;
/// state.cycle = 7;
/// writer.write(&state);
/// let reader = jointctl_ipc::LatestStateReader::open(&scope, "doc-latest-arm").unwrap();
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
    /// and its writer; `first` is its value until the loop's first write. A blackboard that
    /// outlived its runtime (an inspector still holds it open: iceoryx2 keeps a service while
    /// any port of it lives) is opened and written again; one that another runtime still writes
    /// is refused.
    pub fn create(scope: &IpcScope, arm: &str, max_readers: usize, first: &ArmState) -> Result<Self, IpcSetupError> {
        let name = crate::ServiceNames::for_arm(arm).latest_state;
        let node = create_node_of::<Kind>(scope, &format!("{arm}-latest-writer"))?;
        let builder = || service_name(&name).map(|n| node.service_builder(&n));
        let service = match builder()?.blackboard_creator::<u32>().add::<ArmState>(KEY, *first).max_readers(max_readers.max(1)).create() {
            Ok(service) => service,
            Err(iceoryx2::service::builder::blackboard::BlackboardCreateError::AlreadyExists) => builder()?.blackboard_opener::<u32>().open().map_err(|e| error(&name, "open", e))?,
            Err(e) => return Err(error(&name, "create", e)),
        };
        let writer = service.writer_builder().create().map_err(|e| match e {
            iceoryx2::port::writer::WriterCreateError::ExceedsMaxSupportedWriters => error(&name, "write to (another runtime of the arm writes it)", e),
            e => error(&name, "write to", e),
        })?;
        let entry = writer.entry::<ArmState>(&KEY).map_err(|e| error(&name, "write to", e))?;
        // Written once here as well: a reopened blackboard shows the last run's final state
        // until then, and the first write touches the entry's cells before the loop does.
        entry.update_with_copy(*first);
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

    /// The latest state written (a copy): before the loop's first cycle, the runtime's first
    /// value (its joints named, `stamp_ns` 0); after its last, the final state
    /// (`final_sample` 1).
    pub fn latest(&self) -> ArmState {
        *self.entry.get()
    }
}
