//! The SuperPoint front-end (DeTone, Malisiewicz, Rabinovich: "SuperPoint:
//! Self-Supervised Interest Point Detection and Description", CVPRW 2018) on burn, as
//! docs/method.md section 2b describes it. A front-end of either kind is built from a
//! [`features::FrontEndConfig`] by the `frontends` crate (`frontends::build`).
//!
//! - `weights.rs`: the released state dict (`superpoint_v1.pth`, supplied by the user,
//!   never downloaded) read directly with burn's PyTorch reader; a missing key or a
//!   wrong shape is an error naming the file and the key.
//! - `net.rs`: the network (encoder, detector head, descriptor head).
//! - `keypoints.rs`: NMS, threshold, border, top-k; bilinear descriptor sampling.
//! - `frontend.rs`: [`SuperPointFrontEnd`]: resize, COLMAP coordinates, batches.
//!
//! It is a crate of its own so that `features` (OpenCV) does not depend on burn
//! (ARCHITECTURE.md, "... a front-end").

mod error;
mod frontend;
pub mod keypoints;
pub mod net;
pub mod weights;

pub use error::SuperPointError;
pub use frontend::{SuperPointFrontEnd, weights_sha256};
pub use net::{DenseMaps, SuperPointBackend, SuperPointNet};
pub use weights::{LAYERS, StateDict, Weights, file_sha256, parameter_count};
