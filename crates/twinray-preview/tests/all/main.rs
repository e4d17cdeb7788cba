//! The crate's integration tests as one binary (one link instead of one
//! per file): `cargo test --release -p twinray-preview --test all`, or
//! `... --test all MODULE::` for one file's tests.

mod api;
mod browser;
