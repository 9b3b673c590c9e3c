//! Datasets of pl2map-rs: the procedural synthetic room ([`synth`]) that serves as the
//! embedded default data of the demo and the tests, written in the 7-Scenes or the
//! Cambridge Landmarks layout; the dataset descriptors ([`descriptor`], the files of the
//! repository's `datasets/` folder).

pub mod descriptor;
pub mod frames;
pub mod ingest;
pub mod synth;
