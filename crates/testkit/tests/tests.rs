//! Integration tests of crashrig-testkit: the helpers are themselves tested.

mod fd;
mod pose;
mod scene;
mod strategies;
