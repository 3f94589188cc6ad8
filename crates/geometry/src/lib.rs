//! crashrig-geometry (being built; see docs/ARCHITECTURE.md).
