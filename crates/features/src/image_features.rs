//! What a front-end gives for one image: [`Detections`] (keypoints, scores,
//! descriptors) and [`ImageFeatures`] (everything the network needs, lines included).
//! Their own file because both the front-end trait (`frontend.rs`) and the SIFT
//! extraction (`extract.rs`) produce them.

/// Keypoints detected in one image, strongest first, with their descriptors.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Detections {
    /// N x 2, COLMAP pixels.
    pub keypoints: Vec<[f64; 2]>,
    /// N: the detector's score (SIFT response, SuperPoint probability).
    pub scores: Vec<f32>,
    /// N x D, rows L2-normalised.
    pub descriptors: Vec<f32>,
    /// D.
    pub dim: usize,
}

/// Front-end output for one image, as plain row-major arrays (COLMAP pixels).
#[derive(Clone, Debug, PartialEq, Default)]
pub struct ImageFeatures {
    /// N x 2.
    pub keypoints: Vec<[f64; 2]>,
    /// N x D.
    pub descriptors: Vec<f32>,
    /// M x 4: x1 y1 x2 y2.
    pub segments: Vec<[f64; 4]>,
    /// M x T x D.
    pub line_descriptors: Vec<f32>,
    /// T.
    pub samples_per_line: usize,
    /// D.
    pub dim: usize,
}

impl ImageFeatures {
    /// A front-end's detections with the segments and their T descriptors each.
    pub fn from_detections(
        det: Detections,
        segments: Vec<[f64; 4]>,
        line_descriptors: Vec<f32>,
        samples_per_line: usize,
    ) -> Self {
        ImageFeatures {
            keypoints: det.keypoints,
            descriptors: det.descriptors,
            segments,
            line_descriptors,
            samples_per_line,
            dim: det.dim,
        }
    }

    pub fn num_keypoints(&self) -> usize {
        self.keypoints.len()
    }

    pub fn num_segments(&self) -> usize {
        self.segments.len()
    }

    pub fn descriptor(&self, i: usize) -> &[f32] {
        &self.descriptors[i * self.dim..(i + 1) * self.dim]
    }

    /// The T descriptors of line `j`, T x D.
    pub fn line_descriptor(&self, j: usize) -> &[f32] {
        let n = self.samples_per_line * self.dim;
        &self.line_descriptors[j * n..(j + 1) * n]
    }
}
