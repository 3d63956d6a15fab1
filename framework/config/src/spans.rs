//! Where each field of a YAML document is, by field path (`joints[2].limits.torque_nm`), so that
//! errors found after parsing can still point at file, line and column.

use std::collections::HashMap;

use yaml_rust2::parser::{Event, MarkedEventReceiver, Parser};
use yaml_rust2::scanner::Marker;

/// A 1-based line and column in the YAML text.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Location {
    /// Line, from 1.
    pub line: usize,
    /// Column, from 1.
    pub column: usize,
}

/// Field path → location of its value (and of its key, for mapping entries).
#[derive(Clone, Debug, Default)]
pub struct SpanIndex {
    values: HashMap<String, Location>,
    keys: HashMap<String, Location>,
}

impl SpanIndex {
    /// Indexes a YAML text. A text that does not parse gives an empty index (the parse error is
    /// reported by the typed parser, with its own location).
    ///
    /// ```
    /// let idx = jointctl_config::SpanIndex::build("a:\n  b: [1, 2]\n");
    /// assert_eq!(idx.value("a.b[1]").map(|l| l.line), Some(2));
    /// ```
    pub fn build(text: &str) -> Self {
        let mut builder = Builder::default();
        let mut parser = Parser::new_from_str(text);
        if parser.load(&mut builder, false).is_err() {
            return SpanIndex::default();
        }
        SpanIndex { values: builder.values, keys: builder.keys }
    }

    /// Where the value at `path` starts.
    pub fn value(&self, path: &str) -> Option<Location> {
        self.values.get(path).copied()
    }

    /// Where the key of the mapping entry at `path` is.
    pub fn key(&self, path: &str) -> Option<Location> {
        self.keys.get(path).copied()
    }

    /// The location of `path`, or of its nearest ancestor that exists (a missing field is
    /// reported at the mapping that lacks it).
    pub fn nearest(&self, path: &str) -> Location {
        let mut p = path;
        loop {
            if let Some(l) = self.value(p) {
                return l;
            }
            match p.rfind(['.', '[']) {
                Some(cut) => p = &p[..cut],
                None => return self.value("").unwrap_or(Location { line: 1, column: 1 }),
            }
        }
    }
}

enum Frame {
    Map { path: String, key: Option<String> },
    Seq { path: String, index: usize },
}

#[derive(Default)]
struct Builder {
    stack: Vec<Frame>,
    values: HashMap<String, Location>,
    keys: HashMap<String, Location>,
}

fn loc(mark: Marker) -> Location {
    Location { line: mark.line(), column: mark.col() + 1 }
}

fn child(parent: &str, key: &str) -> String {
    if parent.is_empty() { key.to_string() } else { format!("{parent}.{key}") }
}

impl Builder {
    /// Path of the value about to start, or `None` when the next scalar is a mapping key.
    fn next_value_path(&self) -> Option<String> {
        match self.stack.last() {
            None => Some(String::new()),
            Some(Frame::Map { path, key: Some(k) }) => Some(child(path, k)),
            Some(Frame::Map { key: None, .. }) => None,
            Some(Frame::Seq { path, index }) => Some(format!("{path}[{index}]")),
        }
    }

    fn value_done(&mut self) {
        match self.stack.last_mut() {
            Some(Frame::Map { key, .. }) => *key = None,
            Some(Frame::Seq { index, .. }) => *index += 1,
            None => {}
        }
    }
}

impl MarkedEventReceiver for Builder {
    fn on_event(&mut self, ev: Event, mark: Marker) {
        match ev {
            Event::Scalar(text, ..) => match self.next_value_path() {
                Some(path) => {
                    self.values.entry(path).or_insert(loc(mark));
                    self.value_done();
                }
                None => {
                    if let Some(Frame::Map { path, key }) = self.stack.last_mut() {
                        self.keys.entry(child(path, &text)).or_insert(loc(mark));
                        *key = Some(text);
                    }
                }
            },
            Event::Alias(_) => self.value_done(),
            Event::MappingStart(..) | Event::SequenceStart(..) => {
                // A collection used as a mapping key is not supported here; index it as a key-less value.
                let path = self.next_value_path().unwrap_or_default();
                self.values.entry(path.clone()).or_insert(loc(mark));
                self.stack.push(if matches!(ev, Event::MappingStart(..)) {
                    Frame::Map { path, key: None }
                } else {
                    Frame::Seq { path, index: 0 }
                });
            }
            Event::MappingEnd | Event::SequenceEnd => {
                self.stack.pop();
                self.value_done();
            }
            _ => {}
        }
    }
}
