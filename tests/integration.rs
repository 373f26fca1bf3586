//! The Rust integration tests, one test binary for all of them (each file below is a module): a
//! release build links one binary instead of one per file, each with fat LTO. Run them with
//! `cargo test --release --test integration`, one file's with a filter, e.g.
//! `cargo test --release --test integration newton::`.

mod common;
mod constant_rate;
mod engine;
mod newton;
mod plan;
mod rigid;
mod study;
