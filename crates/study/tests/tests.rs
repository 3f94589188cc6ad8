//! The integration tests of crashrig-study, one test binary (`cargo test -p crashrig-study --test tests`; a filter such as `a_from_bundle::` runs one file).

mod a_from_bundle;
mod contract_documents;
mod length_report;
mod pixel_report;
mod progress;
mod reference_keys;
