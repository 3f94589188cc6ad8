//! crashrig-mc (being built; see docs/ARCHITECTURE.md).
