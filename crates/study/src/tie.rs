//! The tie link of a third camera: correspondences from a COLMAP database and model, bootstrapped.
