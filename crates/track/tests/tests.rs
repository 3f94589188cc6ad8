//! Tests of crashrig-track against rendered frames whose truth is known.

mod support;

mod fit_stats;
mod fixtures;
