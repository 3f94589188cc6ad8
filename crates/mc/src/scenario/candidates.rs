//! The candidates file of `crashrig place`: `[[candidate]]` tables, each a `name` and the keys
//! of a `[[grid.observer]]` (read by the same code, so every key means the same; users'
//! reference: `docs/PLACE.md`).

use super::{RawObserver, nominal_world_poses, observer_from_raw, toml_error};
use crate::error::Error;
use crate::limits::key_line;
use crate::model::{Observer, Scenario, check_observers};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RawCandidates {
    #[serde(default)]
    candidate: Vec<RawObserver>,
}

/// Reads the candidates file `path` for `scenario` (its cameras for `sigma_from`, its grid for
/// the geometric checks): one [`Observer`] per `[[candidate]]`, in file order, named by its
/// `name`. Paths (`camera_from`) are relative to the candidates file.
///
/// # Errors
/// Every error names the file and the line: unreadable or too large files, TOML syntax,
/// unknown keys, a missing, empty or repeated `name`, no candidate at all, any error of a
/// `[[grid.observer]]` with the same keys (`candidate[i].key`), [`Error::NoGrid`].
pub fn read_candidates(path: &Path, scenario: &Scenario) -> Result<Vec<Observer>, Error> {
    let text = crate::limits::read_text(path)?;
    candidates_from_toml_str(&text, path, scenario)
}

/// [`read_candidates`] from text (`path` names the file in errors and anchors relative paths).
///
/// # Errors
/// As [`read_candidates`].
pub fn candidates_from_toml_str(
    text: &str,
    path: &Path,
    scenario: &Scenario,
) -> Result<Vec<Observer>, Error> {
    crate::limits::check_document(text, path)?;
    let raw: RawCandidates = toml::from_str(text).map_err(|e| toml_error(&e, text, path))?;
    let base = path.parent().unwrap_or(Path::new(""));
    validate(&raw, scenario, base).map_err(|e| Error::Located {
        path: PathBuf::from(path),
        line: e.key().and_then(|k| key_line(text, k)).unwrap_or(1),
        source: Box::new(e),
    })
}

fn validate(raw: &RawCandidates, scenario: &Scenario, base: &Path) -> Result<Vec<Observer>, Error> {
    let grid = scenario.grid.as_ref().ok_or(Error::NoGrid)?;
    if raw.candidate.is_empty() {
        return Err(Error::Invalid {
            key: "candidate".into(),
            problem: "no [[candidate]] table: list the candidate mounts, each with a name and the keys of a [[grid.observer]]",
        });
    }
    let mut out: Vec<Observer> = Vec::with_capacity(raw.candidate.len());
    for (i, c) in raw.candidate.iter().enumerate() {
        let key = format!("candidate[{i}].name");
        let name = match c.name.as_deref() {
            None => {
                return Err(Error::Invalid {
                    key,
                    problem: "is missing: every candidate needs a unique name",
                });
            }
            Some("") => {
                return Err(Error::Invalid {
                    key,
                    problem: "must not be empty",
                });
            }
            Some(n) => n,
        };
        if out.iter().any(|o| o.name == name) {
            return Err(Error::DuplicateName {
                key,
                name: name.to_string(),
            });
        }
        out.push(observer_from_raw(
            "candidate",
            i,
            c,
            &scenario.cameras,
            base,
        )?);
    }
    let world: Vec<_> = nominal_world_poses(&scenario.cameras)
        .iter()
        .map(|p| p.translation.vector)
        .collect();
    let names: Vec<String> = scenario.cameras.iter().map(|c| c.name.clone()).collect();
    check_observers(grid, &out, "candidate", &world, &names)?;
    Ok(out)
}
