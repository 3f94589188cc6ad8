//! Integration tests of crashrig-colmap against pycolmap-written fixtures (`fixtures/colmap`).

mod commands;
mod common;
mod database;
mod fuzz;
mod golden;
mod malformed;
mod roundtrip;
