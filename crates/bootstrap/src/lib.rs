//! crashrig-bootstrap (being built; see docs/ARCHITECTURE.md).
