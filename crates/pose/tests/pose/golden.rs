//! Goldens from pycolmap 4.2.1's estimators (fixtures/bootstrap, see its README).
