//! crashrig-colmap (being built; see docs/ARCHITECTURE.md).
