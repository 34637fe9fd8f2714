//! No library: this crate is its test, `tests/manifests.rs` (see Cargo.toml for why it stands apart).
