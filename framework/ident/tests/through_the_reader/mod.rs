//! A record written to a CSV file and read back by the project's CSV reader, as a user's file
//! is: the tests that take the blind generator's records see them as identify's users would.

use jointctl_ident::csv::Data;

/// `write` a file at a temporary path named by `tag` (unique among the tests that run at once),
/// read it with the CSV reader, and remove it.
pub fn through_a_file(tag: &str, write: impl FnOnce(&std::path::Path)) -> Data {
    let path = std::env::temp_dir().join(format!("jointctl-through-the-reader-{}-{tag}.csv", std::process::id()));
    write(&path);
    let data = jointctl_ident::csv::read(&path);
    let _ = std::fs::remove_file(&path);
    data.unwrap()
}

/// The blind generator's `case`, written by the generator's own CSV writer and read back.
pub fn blind_case(case: &jointctl_blind_gen::Case, tag: &str) -> Data {
    through_a_file(tag, |path| jointctl_blind_gen::write_csv(case, path).unwrap())
}
