//! Dataset adapters of pl2map-rs: the ingest stage ([`ingest_stage`], its steps in
//! [`ingest`]) reads Microsoft 7-Scenes and Cambridge Landmarks in their published
//! layouts (and the built-in synthetic scene, which the `synth` crate writes in either
//! layout) into the frames table (`tables::frames`). Each adapter converts its dataset's
//! conventions once: poses become world-to-camera, cameras COLMAP models, names
//! dataset-relative paths.
//! The dataset descriptors ([`descriptor`]) are the files of the repository's
//! `datasets/` folder, compiled in.

pub mod camera_spec;
mod dataset_kind;
pub mod descriptor;
pub mod ingest;
pub mod ingest_stage;
