//! crashrig-testkit (being built; see docs/ARCHITECTURE.md).
