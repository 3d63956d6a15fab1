//! Samples that carry several arrays sized by the arm ([`crate::Diagnostics`]: joints and
//! devices; [`crate::raw::RawFrame`]: encoders, drives and force/torque sensors). iceoryx2 gives
//! a sample one slice, of one type: these samples are a slice of bytes holding the arrays one
//! after the other, in their `#[repr(C)]` layout, and a user header with the cycle's fields and
//! each array's length. The element types have no padding and accept any bit pattern
//! (`zerocopy`'s derives check both at compile time), so a payload is read by copying, with its
//! length checked against the header: never by reinterpreting memory. [`send_sliced`] sends a
//! typed slice (the joint state, the plugin instances).

use iceoryx2::port::publisher::Publisher;
use iceoryx2::prelude::*;
use zerocopy::{FromBytes, Immutable, IntoBytes};


/// A sample's payload is not as long as its header says.
///
/// ```
/// let header = jointctl_ipc::DiagnosticsHeader { joint_count: 2, ..Default::default() };
/// let e = jointctl_ipc::Diagnostics::from_parts(&header, &[0u8; 10]).unwrap_err();
/// assert!(e.to_string().contains("2 joints"), "{e}");
/// ```
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
#[error("a {record} sample's payload is {got} bytes, but its header says {what}: {expected} bytes")]
pub struct PayloadSizeError {
    /// The sample's kind.
    pub record: &'static str,
    /// What the header says it holds.
    pub what: String,
    /// The bytes that takes.
    pub expected: usize,
    /// The payload's bytes.
    pub got: usize,
}

/// A sample made of a header and arrays laid out in a byte payload.
pub trait ByteRecord {
    /// The sample's user header.
    type Header: Copy + Default + std::fmt::Debug + ZeroCopySend + 'static;
    /// The header of this record.
    fn header(&self) -> Self::Header;
    /// Bytes of this record's payload.
    fn payload_len(&self) -> usize;
    /// Writes the payload into `out` (`payload_len` bytes).
    fn write_payload(&self, out: &mut [u8]);
    /// This record overwritten by a received sample; allocation-free when it holds as many
    /// entries already. A payload of another length than the header says is refused (and the
    /// record left as it was).
    fn copy_from_parts(&mut self, header: &Self::Header, payload: &[u8]) -> Result<(), PayloadSizeError>;
}

/// Sends `record` on a byte-payload service whose publisher admits its length.
pub fn send_record<R: ByteRecord>(publisher: &Publisher<ipc::Service, [u8], R::Header>, record: &R) -> Result<(), SliceSendError> {
    let len = record.payload_len();
    let mut sample = publisher.loan_slice(len).map_err(|source| SliceSendError::Loan { len, source })?;
    *sample.user_header_mut() = record.header();
    record.write_payload(sample.payload_mut());
    sample.send().map(|_| ()).map_err(SliceSendError::Send)
}

/// Bytes of `n` elements of `T`.
pub(crate) const fn bytes_of<T>(n: usize) -> usize {
    n * std::mem::size_of::<T>()
}

/// Appends `items` at `at` in `out`.
pub(crate) fn put<T: IntoBytes + Immutable>(out: &mut [u8], at: &mut usize, items: &[T]) {
    let bytes = items.as_bytes();
    out[*at..*at + bytes.len()].copy_from_slice(bytes);
    *at += bytes.len();
}

/// Reads `n` elements of `T` at `at` into `into` (its length checked before by the caller).
pub(crate) fn take<T: FromBytes>(bytes: &[u8], at: &mut usize, n: usize, into: &mut Vec<T>) {
    let size = std::mem::size_of::<T>();
    into.clear();
    let end = (*at + n * size).min(bytes.len());
    into.extend(bytes[*at..end].chunks_exact(size).filter_map(|c| T::read_from_bytes(c).ok()));
    *at = end;
}

/// Why a slice sample was not sent.
#[derive(Debug, thiserror::Error)]
pub enum SliceSendError {
    /// No sample could be loaned (more elements than the publisher's `initial_max_slice_len`,
    /// or every sample in use).
    #[error("cannot loan a sample of {len} elements")]
    Loan {
        /// Elements asked for.
        len: usize,
        /// iceoryx2's reason.
        source: iceoryx2::port::LoanError,
    },
    /// The sample could not be sent.
    #[error("cannot send the sample")]
    Send(#[source] iceoryx2::port::SendError),
}

/// Sends one sample of a sliced service: `header` and a copy of `items`.
///
/// ```
/// use iceoryx2::prelude::*;
/// let node = jointctl_ipc::create_node(None, "doc-send-sliced").unwrap();
/// let service = jointctl_ipc::create_joint_state_service(&node, "doc-send-sliced/joint_state", Default::default()).unwrap();
/// let publisher = service.publisher_builder().initial_max_slice_len(2).create().unwrap();
/// let subscriber = service.subscriber_builder().create().unwrap();
/// let mut state = jointctl_ipc::ArmState::named(["q1", "q2"]);
/// state.cycle = 3;
/// jointctl_ipc::send_sliced(&publisher, state.header(), state.joints()).unwrap();
/// let got = jointctl_ipc::ArmState::from(&subscriber.receive().unwrap().unwrap());
/// assert_eq!((got.cycle, got.joints().len()), (3, 2));
/// assert_eq!(jointctl_ipc::decode_name(&got.joints()[1].name), "q2");
/// ```
pub fn send_sliced<T, H>(publisher: &iceoryx2::port::publisher::Publisher<ipc::Service, [T], H>, header: H, items: &[T]) -> Result<(), SliceSendError>
where
    T: Copy + std::fmt::Debug + ZeroCopySend + 'static,
    H: Default + std::fmt::Debug + ZeroCopySend,
{
    let mut sample = publisher.loan_slice_uninit(items.len()).map_err(|source| SliceSendError::Loan { len: items.len(), source })?;
    *sample.user_header_mut() = header;
    sample.write_from_slice(items).send().map(|_| ()).map_err(SliceSendError::Send)
}
