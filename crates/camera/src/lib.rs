//! crashrig-camera (being built; see docs/ARCHITECTURE.md).
