//! A record written to a CSV file and read back by the project's CSV reader, as a user's file
//! is: the tests that take the blind generator's records see them as identify's users would.
// Each test that includes this module uses a part of it.
#![allow(dead_code)]

use std::sync::atomic::{AtomicUsize, Ordering};

use jointctl_ident::csv::Data;

/// A path of its own for every file of the process: tests run on several threads at once, and
/// two of them may write a case of the same name (`suite(1)` and `suite(2)` both have a
/// `000_viscous_plain`), one reading the other's file or finding it gone.
fn temporary_path(tag: &str) -> std::path::PathBuf {
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    let n = NEXT.fetch_add(1, Ordering::Relaxed);
    std::env::temp_dir().join(format!("jointctl-through-the-reader-{}-{n}-{tag}.csv", std::process::id()))
}

/// `write` a file at a temporary path named by `tag`, read it with the CSV reader, and remove it:
/// the data, or why the file could not be written or read (for a suite that counts refused
/// records).
pub fn try_through_a_file(tag: &str, write: impl FnOnce(&std::path::Path) -> Result<(), String>) -> Result<Data, String> {
    let path = temporary_path(tag);
    write(&path)?;
    let data = jointctl_ident::csv::read(&path).map_err(|e| e.to_string());
    let _ = std::fs::remove_file(&path);
    data
}

/// [`try_through_a_file`] for a file that must be read.
pub fn through_a_file(tag: &str, write: impl FnOnce(&std::path::Path)) -> Data {
    try_through_a_file(tag, |path| {
        write(path);
        Ok(())
    })
    .unwrap()
}

/// The blind generator's `case`, written by the generator's own CSV writer and read back, or why
/// it could not be.
pub fn try_blind_case(case: &jointctl_blind_gen::Case, tag: &str) -> Result<Data, String> {
    try_through_a_file(tag, |path| jointctl_blind_gen::write_csv(case, path).map_err(|e| e.to_string()))
}

/// [`try_blind_case`] for a case that must be read.
pub fn blind_case(case: &jointctl_blind_gen::Case, tag: &str) -> Data {
    try_blind_case(case, tag).unwrap()
}

/// The blind generator's record `name` of seed `seed`'s suite (that case alone generated),
/// through the CSV reader.
pub fn suite_record(seed: u64, name: &str) -> Data {
    let (case, _) = jointctl_blind_gen::suite_plan(seed).into_iter().find(|s| s.name == name).unwrap().generate().unwrap();
    blind_case(&case, &format!("suite-{seed}-{name}"))
}
