//! crashrig-rig (being built; see docs/ARCHITECTURE.md).
