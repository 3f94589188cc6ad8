//! crashrig-pose (being built; see docs/ARCHITECTURE.md).
