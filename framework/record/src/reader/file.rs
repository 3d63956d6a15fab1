//! The file: its messages in order, in either form, up to a cut a crash left.

use std::path::{Path, PathBuf};

use super::ReadError;

/// How a message is written: the JSON form, or the ROS 2 profile's CDR.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Encoding {
    Json,
    Cdr,
    /// The ROS 2 profile's raw frames as written before drives reported their torque (their
    /// `jointctl_msgs/RawDrive` has no `torque_nm`): read with that definition.
    CdrRawBeforeTorque,
}

/// The arm's channel a file's channel holds: itself in the JSON form; in the ROS 2 profile the
/// jointctl topic made from it (`/joint_states` is a subset of `/jointctl/joint_details`, and
/// not read).
pub(super) fn source_of(topic: &str, message_encoding: &str) -> Option<(&'static str, Encoding)> {
    if message_encoding == "cdr" {
        return match topic {
            jointctl_ros2::JOINT_DETAILS => Some(("joint_state", Encoding::Cdr)),
            jointctl_ros2::RAW => Some(("raw", Encoding::Cdr)),
            jointctl_ros2::COMMANDS => Some(("commands", Encoding::Cdr)),
            jointctl_ros2::DIAGNOSTICS => Some(("diagnostics", Encoding::Cdr)),
            _ => None,
        };
    }
    crate::messages::CHANNELS.iter().find(|(t, _)| *t == topic).map(|(t, _)| (*t, Encoding::Json))
}

/// Calls `each(channel, encoding, sequence, data)` for every message of one of the arm's
/// channels `topics`, in file order (the file is read and decompressed once), whichever form
/// the file has.
pub(super) fn for_each_message(path: &Path, topics: &[&str], mut each: impl FnMut(&str, Encoding, u32, &[u8]) -> Result<(), ReadError>) -> Result<(), ReadError> {
    let bytes = read_recording(path)?;
    let mcap_error = |source| ReadError::Mcap { file: path.into(), source };
    // A file without its end (the recorder killed, the machine off, the disk full) is read up to
    // its last complete chunk.
    let stream = mcap::MessageStream::new_with_options(&bytes, mcap::read::Options::IgnoreEndMagic.into()).map_err(mcap_error)?;
    let mut read = 0u64;
    let mut stopped = None;
    for message in stream {
        match message {
            Ok(m) => {
                read += 1;
                if let Some((source, mut encoding)) = source_of(&m.channel.topic, &m.channel.message_encoding)
                    && topics.contains(&source)
                {
                    if encoding == Encoding::Cdr && source == "raw" && m.channel.schema.as_ref().is_some_and(|s| !super::before_torque::raw_schema_has_torque(&String::from_utf8_lossy(&s.data))) {
                        encoding = Encoding::CdrRawBeforeTorque;
                    }
                    each(source, encoding, m.sequence, &m.data)?;
                }
            }
            Err(source) if is_cut(&bytes) => {
                stopped = Some(source);
                break;
            }
            Err(source) => return Err(mcap_error(source)),
        }
    }
    // A cut file stops inside a record, or between two (the stream then ends without an error:
    // no footer, no closing magic); either is said. One after the data section's end (in the
    // summary, which the recorder writes last) lost no message.
    if is_cut(&bytes) {
        if stopped.is_none() && data_section_complete(&bytes) {
            warn_summary_cut(path, read);
            return Ok(());
        }
        let source = stopped.unwrap_or(mcap::McapError::BadFooter);
        if read == 0 {
            return Err(ReadError::CutBeforeData { file: path.into(), bytes: bytes.len() as u64, source });
        }
        warn_cut(path, read, &source);
    }
    Ok(())
}

/// The bytes of a recording, refused when they do not begin as MCAP's (a cut file keeps its
/// beginning, so a file that begins otherwise is no recording, and is said to be none).
pub(super) fn read_recording(path: &Path) -> Result<Vec<u8>, ReadError> {
    let bytes = jointctl_files::read(path, jointctl_files::FileKind::Recording)?;
    let head = &bytes[..bytes.len().min(mcap::MAGIC.len())];
    if mcap::MAGIC.starts_with(head) {
        return Ok(bytes);
    }
    let start = &bytes[..bytes.len().min(24)];
    let begins = if start.iter().all(|b| b.is_ascii_graphic() || *b == b' ' || *b == b'\n' || *b == b'\r' || *b == b'\t') {
        format!("text, `{}` (a CSV file? data files are read by their .csv name)", String::from_utf8_lossy(start).escape_debug())
    } else {
        format!("the bytes {}", start.iter().take(8).map(|b| format!("{b:02x}")).collect::<Vec<_>>().join(" "))
    };
    Err(ReadError::NotMcap { file: path.into(), begins })
}

/// A file that does not end with MCAP's closing magic was cut short while it was written.
pub(super) fn is_cut(bytes: &[u8]) -> bool {
    bytes.len() < 2 * mcap::MAGIC.len() || !bytes.ends_with(mcap::MAGIC)
}

/// Whether this is the first warning about `path` (each file's cut is said once).
fn first_warning(path: &Path) -> bool {
    static WARNED: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());
    let mut warned = WARNED.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let first = !warned.iter().any(|p| p == path);
    if first {
        warned.push(path.to_path_buf());
    }
    first
}

/// Says once per file that a recording was cut short and what is read of it.
pub(super) fn warn_cut(path: &Path, messages: u64, source: &mcap::McapError) {
    if first_warning(path) {
        tracing::warn!(
            "{}: the recording was cut short (its writer was killed, the machine stopped or the disk filled: {source}); \
             reading the {messages} messages of its complete chunks, the rest is lost",
            path.display()
        );
    }
}

/// Says once per file that a recording was cut short after its data: no message is lost, the
/// summary that indexes them is.
fn warn_summary_cut(path: &Path, messages: u64) {
    if first_warning(path) {
        tracing::warn!(
            "{}: the recording was cut short after its data, in the summary written last (its writer was killed, the machine stopped or the disk filled); \
             every message is read ({messages}), by a scan instead of the summary's index",
            path.display()
        );
    }
}

/// Whether a cut file holds its data section's end (MCAP's DataEnd record): it was cut in the
/// summary after it, with every message written.
fn data_section_complete(bytes: &[u8]) -> bool {
    match mcap::read::LinearReader::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into()) {
        Ok(reader) => reader.map_while(Result::ok).any(|r| matches!(r, mcap::records::Record::DataEnd(_))),
        Err(_) => false,
    }
}

/// The top-level records of a file that was cut short, up to the cut (its summary, at the end, is
/// not there to index them).
pub(super) fn records_before_cut(bytes: &[u8]) -> Vec<mcap::records::Record<'_>> {
    match mcap::read::LinearReader::new_with_options(bytes, mcap::read::Options::IgnoreEndMagic.into()) {
        Ok(reader) => reader.map_while(Result::ok).collect(),
        Err(_) => Vec::new(),
    }
}
