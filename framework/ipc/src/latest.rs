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

//!
//! A blackboard's values are fixed-size, and an arm's joints are not: the state is kept as pages
//! of [`PAGE_JOINTS`] joints, one blackboard entry each (key = page number). The loop writes
//! every page each cycle; a reader reads them all and takes them only when every page is of
//! one cycle (a page is written whole or not at all, but the loop may write between two pages'
//! reads: the reader then reads again).

use iceoryx2::port::reader::EntryHandle;
use iceoryx2::port::writer::EntryHandleMut;
use iceoryx2::prelude::*;

use crate::services::{IpcScope, IpcSetupError, create_node_of, service_name};
use crate::state::{ArmState, JointSample};

/// The service kind: handles that may move between threads (a runtime's `ArmPublisher` is
/// `Send`); its write is the same lock-free store.
type Kind = ipc_threadsafe::Service;

/// Joints per blackboard page.
pub const PAGE_JOINTS: usize = 16;

/// How often [`LatestStateReader::latest`] reads the pages again when the loop wrote between
/// two of them, before it says so: each read is a few microseconds per page, a cycle is a
/// millisecond, so a reader that keeps meeting a write is itself stalled.
const READ_ATTEMPTS: usize = 64;

/// One blackboard entry: up to [`PAGE_JOINTS`] joints of the arm's latest state, and the cycle
/// they are of.
#[derive(Clone, Copy, Debug, ZeroCopySend)]
#[repr(C)]
#[type_name("jointctl.LatestStatePage.v1")]
pub struct LatestStatePage {
    /// Cycle counter.
    pub cycle: u64,
    /// CLOCK_MONOTONIC time of the cycle's sensor read [ns].
    pub stamp_ns: u64,
    /// The arm's DOFs (every page says it).
    pub arm_joint_count: u32,
    /// Index of `joints[0]` in the arm's joints.
    pub first_joint: u32,
    /// Valid entries in `joints`.
    pub joint_count: u32,
    /// 1 in the final state, written at shutdown.
    pub final_sample: u32,
    /// The page's joints.
    pub joints: [JointSample; PAGE_JOINTS],
}

impl LatestStatePage {
    /// Page `page` of `state`.
    fn of(state: &ArmState, page: usize) -> Self {
        let mut p = LatestStatePage { cycle: 0, stamp_ns: 0, arm_joint_count: 0, first_joint: 0, joint_count: 0, final_sample: 0, joints: [JointSample::EMPTY; PAGE_JOINTS] };
        p.fill(state, page);
        p
    }

    /// This page made page `page` of `state`: its header and its part of the joints (the
    /// entries past them left as they are).
    fn fill(&mut self, state: &ArmState, page: usize) {
        let first = page * PAGE_JOINTS;
        let part = &state.joints[first.min(state.joints.len())..(first + PAGE_JOINTS).min(state.joints.len())];
        self.joints[..part.len()].copy_from_slice(part);
        (self.cycle, self.stamp_ns, self.final_sample) = (state.cycle, state.stamp_ns, state.final_sample);
        (self.arm_joint_count, self.first_joint, self.joint_count) = (state.joints.len() as u32, first as u32, part.len() as u32);
    }
}

/// Pages for `joints` joints (one at least, so that an arm's cycle is known before it has any).
fn pages_for(joints: usize) -> usize {
    joints.div_ceil(PAGE_JOINTS).max(1)
}

fn error(service: &str, what: &'static str, source: impl std::error::Error + Send + Sync + 'static) -> IpcSetupError {
    IpcSetupError::LatestState { service: service.to_string(), what, source: Box::new(source) }
}

/// Why a read of the latest state failed.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum LatestReadError {
    /// The loop wrote between the reads of two pages every time.
    #[error("the latest state's {pages} pages were of different cycles in {attempts} reads in a row")]
    Torn {
        /// Pages of the arm's state.
        pages: usize,
        /// Reads tried.
        attempts: usize,
    },
    /// The blackboard holds another arm's shape than when it was opened (a runtime of the same
    /// arm name with other joints wrote it since).
    #[error("the latest-state blackboard now holds {now} joints, {opened} when it was opened: open it again")]
    Reshaped {
        /// Joints when opened.
        opened: usize,
        /// Joints now.
        now: usize,
    },
}

/// The loop's side: creates the arm's latest-state blackboard and writes it.
///
/// ```
/// let scope = jointctl_ipc::IpcScope::domain(None);
/// let names: Vec<String> = (0..20).map(|i| format!("q{i}")).collect();
/// let mut state = jointctl_ipc::ArmState::named(names.iter().map(String::as_str));
/// let mut writer = jointctl_ipc::LatestStateWriter::create(&scope, "doc-latest-arm", 2, &state).unwrap();
/// state.cycle = 7;
/// state.joints[19].torque_nm = 1.5;
/// writer.write(&state);
/// let reader = jointctl_ipc::LatestStateReader::open(&scope, "doc-latest-arm").unwrap();
/// let latest = reader.latest().unwrap();
/// assert_eq!((latest.cycle, latest.joints.len(), latest.joints[19].torque_nm), (7, 20, 1.5));
/// ```
pub struct LatestStateWriter {
    entries: Vec<EntryHandleMut<Kind, u32, LatestStatePage>>,
    /// One page per entry, filled in place each write (made at creation: a write allocates
    /// nothing and copies each joint once before the store).
    pages: Vec<LatestStatePage>,
    _writer: iceoryx2::port::writer::Writer<Kind, u32>,
    _service: iceoryx2::service::port_factory::blackboard::PortFactory<Kind, u32>,
    _node: Node<Kind>,
}

impl LatestStateWriter {
    /// Creates the blackboard `{arm}/latest_state` in `scope`, admitting `max_readers` readers,
    /// and its writer; `first` is its value until the loop's first write, and its joints are
    /// the arm's (every later write has as many). A blackboard that outlived its runtime (an
    /// inspector still holds it open: iceoryx2 keeps a service while any port of it lives) is
    /// opened and written again; one that another runtime still writes is refused, and so is
    /// one of another shape.
    pub fn create(scope: &IpcScope, arm: &str, max_readers: usize, first: &ArmState) -> Result<Self, IpcSetupError> {
        let name = crate::ServiceNames::for_arm(arm).latest_state;
        let node = create_node_of::<Kind>(scope, &format!("{arm}-latest-writer"))?;
        let builder = || service_name(&name).map(|n| node.service_builder(&n));
        let pages = pages_for(first.joints.len());
        let mut creator = builder()?.blackboard_creator::<u32>();
        for page in 0..pages {
            creator = creator.add::<LatestStatePage>(page as u32, LatestStatePage::of(first, page));
        }
        let service = match creator.max_readers(max_readers.max(1)).create() {
            Ok(service) => service,
            Err(iceoryx2::service::builder::blackboard::BlackboardCreateError::AlreadyExists) => builder()?.blackboard_opener::<u32>().open().map_err(|e| error(&name, "open", e))?,
            Err(e) => return Err(error(&name, "create", e)),
        };
        let writer = service.writer_builder().create().map_err(|e| match e {
            iceoryx2::port::writer::WriterCreateError::ExceedsMaxSupportedWriters => error(&name, "write to (another runtime of the arm writes it)", e),
            e => error(&name, "write to", e),
        })?;
        let mut entries = Vec::with_capacity(pages);
        let page_buffers = (0..pages).map(|page| LatestStatePage::of(first, page)).collect();
        for page in 0..pages {
            let entry = writer.entry::<LatestStatePage>(&(page as u32)).map_err(|e| error(&name, "write to (a blackboard of the arm with fewer joints is still open)", e))?;
            entries.push(entry);
        }
        let mut out = LatestStateWriter { entries, pages: page_buffers, _writer: writer, _service: service, _node: node };
        // Written once here as well: a reopened blackboard shows the last run's final state
        // until then, and the first write touches the entries' cells before the loop does.
        out.write(first);
        Ok(out)
    }

    /// Writes `state` as the latest, page by page: copies into shared memory, lock-free,
    /// allocation-free. `state` has the arm's joints (as many as the state it was created with).
    pub fn write(&mut self, state: &ArmState) {
        for (page, (entry, buffer)) in self.entries.iter().zip(&mut self.pages).enumerate() {
            buffer.fill(state, page);
            entry.update_with_copy(*buffer);
        }
    }
}

/// An inspector's side: reads the arm's latest state.
pub struct LatestStateReader {
    entries: Vec<EntryHandle<Kind, u32, LatestStatePage>>,
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
        let first = reader.entry::<LatestStatePage>(&0).map_err(|e| error(&name, "read", e))?;
        let pages = pages_for(first.get().arm_joint_count as usize);
        let mut entries = vec![first];
        for page in 1..pages {
            entries.push(reader.entry::<LatestStatePage>(&(page as u32)).map_err(|e| error(&name, "read", e))?);
        }
        Ok(LatestStateReader { entries, _reader: reader, _service: service, _node: node })
    }

    /// The latest state written (a copy): before the loop's first cycle, the runtime's first
    /// value (its joints named, `stamp_ns` 0); after its last, the final state
    /// (`final_sample` 1). Every joint is of the one cycle the state names.
    pub fn latest(&self) -> Result<ArmState, LatestReadError> {
        let mut state = ArmState::EMPTY;
        self.latest_into(&mut state)?;
        Ok(state)
    }

    /// [`LatestStateReader::latest`] into `state`, its allocation reused (a reader that polls).
    /// On an error `state` holds a part of what was read.
    pub fn latest_into(&self, state: &mut ArmState) -> Result<(), LatestReadError> {
        let mut attempts = 0;
        loop {
            attempts += 1;
            state.joints.clear();
            let first: LatestStatePage = *self.entries[0].get();
            let now = first.arm_joint_count as usize;
            if pages_for(now) != self.entries.len() {
                return Err(LatestReadError::Reshaped { opened: self.entries.len() * PAGE_JOINTS, now });
            }
            (state.cycle, state.stamp_ns, state.final_sample) = (first.cycle, first.stamp_ns, first.final_sample);
            let mut whole = true;
            for (page, entry) in self.entries.iter().enumerate() {
                let p: LatestStatePage = if page == 0 { first } else { *entry.get() };
                if p.cycle != state.cycle || p.arm_joint_count as usize != now {
                    whole = false;
                    break;
                }
                state.joints.extend_from_slice(&p.joints[..(p.joint_count as usize).min(PAGE_JOINTS)]);
            }
            if whole && state.joints.len() == now {
                return Ok(());
            }
            if attempts >= READ_ATTEMPTS {
                return Err(LatestReadError::Torn { pages: self.entries.len(), attempts });
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pages_of_different_cycles_are_never_read_as_one_state() {
        let scope = IpcScope::domain(None);
        let arm = format!("latest-torn-{}", std::process::id());
        let names: Vec<String> = (0..20).map(|i| format!("q{i}")).collect();
        let mut state = ArmState::named(names.iter().map(String::as_str));
        let mut writer = LatestStateWriter::create(&scope, &arm, 2, &state).unwrap();
        state.cycle = 5;
        writer.write(&state);
        let reader = LatestStateReader::open(&scope, &arm).unwrap();
        assert_eq!(reader.latest().map(|s| (s.cycle, s.joints.len())), Ok((5, 20)));
        // The second page from another cycle, as a loop writing between two pages' reads
        // leaves it for a moment; here it stays.
        let mut later = state.clone();
        later.cycle = 6;
        writer.entries[1].update_with_copy(LatestStatePage::of(&later, 1));
        assert_eq!(reader.latest().err(), Some(LatestReadError::Torn { pages: 2, attempts: READ_ATTEMPTS }));
        writer.write(&later);
        assert_eq!(reader.latest().map(|s| s.cycle), Ok(6));
    }
}
