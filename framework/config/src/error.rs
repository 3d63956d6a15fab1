use std::fmt;
use std::path::PathBuf;

/// One problem in an arm description, located in its file.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ConfigError {
    /// The YAML file.
    pub file: PathBuf,
    /// 1-based line.
    pub line: usize,
    /// 1-based column.
    pub column: usize,
    /// Field path (`joints[2].limits.torque_nm`); empty for the whole document.
    pub field: String,
    /// What is wrong and, where it helps, how to fix it.
    pub message: String,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}:{}:{}: ", self.file.display(), self.line, self.column)?;
        if !self.field.is_empty() {
            write!(f, "{}: ", self.field)?;
        }
        f.write_str(&self.message)
    }
}

/// Every problem found in an arm description (at least one).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub struct ConfigErrors(pub Vec<ConfigError>);

impl fmt::Display for ConfigErrors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                writeln!(f)?;
            }
            write!(f, "{e}")?;
        }
        Ok(())
    }
}

impl From<ConfigError> for ConfigErrors {
    fn from(e: ConfigError) -> Self {
        ConfigErrors(vec![e])
    }
}

/// Longest value quoted whole in a message [chars]; a longer one is cut and its size said.
pub const MAX_QUOTED: usize = 64;
/// Longest message [chars], whatever it quotes.
const MAX_MESSAGE: usize = 2000;

/// A number as a person reads it in a message: plainly between a thousandth and a million,
/// otherwise with four significant digits and an exponent (a 309-digit value cut at a line's
/// end loses the reason).
///
/// ```
/// assert_eq!(jointctl_config::short_number(-1.0), "-1");
/// assert_eq!(jointctl_config::short_number(1e-300), "1.000e-300");
/// ```
pub fn short_number(x: f64) -> String {
    if x == 0.0 || (1e-3..1e6).contains(&x.abs()) { format!("{x}") } else { format!("{x:.3e}") }
}

/// A message with every `` `quoted` `` value longer than [`MAX_QUOTED`] characters shortened
/// to its start and its size, and the whole cut at 2000 characters: a 50 MB name in a file
/// must not come back as a 50 MB error.
///
/// ```
/// let long = "x".repeat(1000);
/// let m = jointctl_config::bounded_message(&format!("`{long}` is not a valid name"));
/// assert_eq!(m, format!("`{}...` (1000 bytes) is not a valid name", "x".repeat(48)));
/// ```
pub fn bounded_message(message: &str) -> String {
    let mut out = String::with_capacity(message.len().min(MAX_MESSAGE + 16));
    let mut parts = message.split('`');
    let mut quoted = false;
    let mut first = true;
    while let Some(part) = parts.next() {
        if !first {
            out.push('`');
        }
        first = false;
        if quoted && part.chars().count() > MAX_QUOTED {
            let start: String = part.chars().take(48).collect();
            // Closing backtick and size after it.
            out.push_str(&start);
            out.push_str("...`");
            out.push_str(&format!(" ({} bytes)", part.len()));
            // The closing backtick is already written: skip the one the next part would add.
            if let Some(next) = parts.next() {
                out.push_str(next);
                quoted = !quoted;
            }
        } else {
            out.push_str(part);
        }
        quoted = !quoted;
        if out.len() > MAX_MESSAGE {
            let mut cut = MAX_MESSAGE;
            while !out.is_char_boundary(cut) {
                cut -= 1;
            }
            out.truncate(cut);
            out.push_str("... (message cut)");
            break;
        }
    }
    out
}
