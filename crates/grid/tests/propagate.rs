//! `crashrig_grid::run_propagate`, the library entry of `crashrig propagate` (moved here from
//! the CLI with the code): the contract's fields, reproducibility, errors with the line.

use crashrig_grid::{PropagateConfig, run_propagate};
use std::path::Path;

#[test]
fn propagate_entry_contract_fields_and_same_seed_same_numbers() {
    let scenario =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../fixtures/scenarios/paper_chain.toml");
    let config = PropagateConfig {
        scenario,
        samples: Some(2000),
        seed: Some(1),
    };
    let run = run_propagate(&config, None).unwrap();
    let v = serde_json::to_value(&run.document).unwrap();
    assert_eq!(v["samples"], 2000);
    let cams = v["cameras"].as_array().unwrap();
    assert_eq!(cams.len(), 3);
    for c in cams {
        for key in [
            "name",
            "position_mm",
            "angles_deg",
            "position_sigma_mm",
            "angles_sigma_deg",
        ] {
            assert!(c.get(key).is_some(), "camera lacks {key}");
        }
        assert_eq!(
            c["linear"]["position_sigma_mm"].as_array().unwrap().len(),
            3
        );
        assert_eq!(c["linear"]["angles_sigma_deg"].as_array().unwrap().len(), 3);
    }
    let again = run_propagate(&config, None).unwrap();
    assert_eq!(again.document.cameras, run.document.cameras);
}

#[test]
fn propagate_entry_syntax_error_has_line() {
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("s.toml");
    std::fs::write(&p, "seed = 1\nsamples = = 3\n").unwrap();
    let config = PropagateConfig {
        scenario: p,
        samples: None,
        seed: None,
    };
    let msg = run_propagate(&config, None).unwrap_err().to_string();
    assert!(msg.contains("s.toml:2:"), "{msg}");
}
