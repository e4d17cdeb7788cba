//! The crate's integration tests as one binary (one link instead of one
//! per file): `cargo test --release -p twinray-cli --test all`, or
//! `... --test all MODULE::` for one file's tests.

mod animation;
mod bench_stereo;
mod cli;
mod hardening;
mod job;
mod messages;
mod panorama;
mod preview;
mod spec_args;
mod video;
