//! See `benches/runtime.rs`.
