//! The trainer of pl2map-rs.

pub mod augment;
