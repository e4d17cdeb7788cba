//! The crate's integration tests as one binary (one link instead of one
//! per file): `cargo test --release -p twinray-preview --test all`, or
//! `... --test all MODULE::` for one file's tests. The browser test has a
//! harness of its own (`--test browser`).

mod api;
mod common;
mod correlation;
mod panorama;
mod security;
