//! crashrig-plot (being built; see docs/ARCHITECTURE.md).
