//! Network configuration (docs/method.md section 2), serialisable so that a checkpoint
//! can record exactly which network it holds.

use crate::error::ModelError;
use serde::{Deserialize, Serialize};

/// Which edges one attentional propagation layer uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LayerKind {
    /// Points attend to points, lines attend to lines.
    #[serde(rename = "self")]
    SelfAttention,
    /// Points attend to lines, lines attend to points.
    Cross,
}

/// Shape and regularisation of a PL2Map network.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ModelConfig {
    /// Descriptor dimension D (128 for SIFT, 256 for SuperPoint-like descriptors).
    pub descriptor_dim: usize,
    /// Attention heads in the line encoder and in every graph layer.
    pub heads: usize,
    /// Descriptors sampled along each line segment (T), endpoints included.
    pub line_tokens: usize,
    /// Hidden width of the line encoder's feed-forward block. The spec says 4 D; the
    /// reference fixes 1024, which is the same number at D = 256.
    pub ffn_dim: usize,
    /// The graph network, in order.
    pub layers: Vec<LayerKind>,
    /// Hidden widths of the point head, and of the line head unless `line_head_hidden`
    /// says otherwise.
    pub head_hidden: Vec<usize>,
    /// Hidden widths of the line head when they differ from the point head's (None: the
    /// same, as the reference). A scene has far fewer line tracks than points to
    /// remember, so a deep point head need not be paid for on every line too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub line_head_hidden: Option<Vec<usize>>,
    /// Dropout probability of the line encoder during training.
    pub dropout: f64,
    /// Reliability r = 1 / (1 + |beta u|).
    pub reliability_beta: f64,
    /// Multiplies the point descriptors before the graph network (1 = the reference).
    /// L2-normalised descriptors have per-dimension scale 1/sqrt(D), while the line
    /// stream leaves the line encoder LayerNorm-ed (scale 1): sqrt(D) puts both streams
    /// on the same scale, and the heads learn much faster (see docs/training-notes.md).
    /// Lines are not scaled: it would sharpen the line encoder's softmax.
    #[serde(default = "unit_scale", skip_serializing_if = "is_unit_scale")]
    pub point_input_scale: f64,
    /// How the regression heads' weights start (see [`HeadInit`]).
    #[serde(default, skip_serializing_if = "HeadInit::is_reference")]
    pub head_init: HeadInit,
}

/// Initial weights of the point and line heads (the MLPs after the graph network).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum HeadInit {
    /// PyTorch's default for Linear layers, U(+-1/sqrt(fan_in)) for weights and biases, as
    /// the reference. Each ReLU layer then shrinks the signal's second moment about
    /// six-fold, so a deep head starts out nearly constant and the map loss sits at the
    /// labels' spread until the weights have grown (docs/training-notes.md, "Head
    /// initialisation").
    #[default]
    Reference,
    /// He (Kaiming) uniform: U(+-sqrt(6/fan_in)) for the weights of layers followed by a
    /// ReLU, which keeps the signal's scale through the head; biases start at zero. The
    /// last layer keeps the reference's distribution. The draws are the reference's,
    /// scaled, so the rest of the network gets the same values either way.
    He,
}

impl HeadInit {
    pub fn is_reference(&self) -> bool {
        *self == HeadInit::Reference
    }
}

fn unit_scale() -> f64 {
    1.0
}

// serde's skip_serializing_if hands a reference.
#[allow(clippy::trivially_copy_pass_by_ref)]
fn is_unit_scale(v: &f64) -> bool {
    *v == 1.0
}

impl ModelConfig {
    /// The reference network for descriptors of dimension `descriptor_dim`.
    pub fn new(descriptor_dim: usize) -> Self {
        use LayerKind::{Cross, SelfAttention};
        ModelConfig {
            descriptor_dim,
            heads: 4,
            line_tokens: 12,
            ffn_dim: 4 * descriptor_dim,
            layers: vec![SelfAttention, Cross, SelfAttention, Cross, SelfAttention],
            head_hidden: vec![512, 1024, 512],
            line_head_hidden: None,
            dropout: 0.1,
            reliability_beta: 100.0,
            point_input_scale: 1.0,
            head_init: HeadInit::Reference,
        }
    }

    /// SIFT descriptors (D = 128).
    pub fn sift() -> Self {
        Self::new(128)
    }

    /// SuperPoint-like descriptors (D = 256), the paper's network.
    pub fn superpoint() -> Self {
        Self::new(256)
    }

    /// Hidden widths of the line head.
    pub fn line_head_widths(&self) -> &[usize] {
        self.line_head_hidden
            .as_deref()
            .unwrap_or(&self.head_hidden)
    }

    pub fn head_dim(&self) -> usize {
        self.descriptor_dim / self.heads.max(1)
    }

    pub fn validate(&self) -> Result<(), ModelError> {
        let bad = |msg: String| Err(ModelError::InvalidConfig(msg));
        if self.descriptor_dim == 0 {
            return bad("descriptor_dim must be positive".into());
        }
        if self.heads == 0 || !self.descriptor_dim.is_multiple_of(self.heads) {
            return bad(format!(
                "descriptor_dim {} must be a positive multiple of heads {}",
                self.descriptor_dim, self.heads
            ));
        }
        if self.line_tokens == 0 {
            return bad("line_tokens must be at least 1".into());
        }
        if self.ffn_dim == 0 {
            return bad("ffn_dim must be positive".into());
        }
        for (name, widths) in [
            ("head_hidden", &self.head_hidden[..]),
            ("line_head_hidden", self.line_head_widths()),
        ] {
            if widths.contains(&0) {
                return bad(format!("{name} widths must be positive, got {widths:?}"));
            }
        }
        if !(0.0..1.0).contains(&self.dropout) {
            return bad(format!("dropout must be in [0, 1), got {}", self.dropout));
        }
        if !(self.reliability_beta.is_finite() && self.reliability_beta > 0.0) {
            return bad(format!(
                "reliability_beta must be positive and finite, got {}",
                self.reliability_beta
            ));
        }
        if !(self.point_input_scale.is_finite() && self.point_input_scale > 0.0) {
            return bad(format!(
                "point_input_scale must be positive and finite, got {}",
                self.point_input_scale
            ));
        }
        Ok(())
    }
}

impl Default for ModelConfig {
    fn default() -> Self {
        Self::superpoint()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn layer_names_match_the_reference_spelling() {
        let json = serde_json::to_string(&ModelConfig::sift().layers).unwrap();
        assert_eq!(json, r#"["self","cross","self","cross","self"]"#);
        let back: Vec<LayerKind> = serde_json::from_str(&json).unwrap();
        assert_eq!(back, ModelConfig::sift().layers);
    }

    #[test]
    fn rejects_heads_that_do_not_divide_d() {
        let mut c = ModelConfig::new(130);
        assert!(c.validate().is_err());
        c.heads = 5;
        assert!(c.validate().is_ok());
        c.dropout = 1.0;
        assert!(c.validate().is_err());
    }

    #[test]
    fn head_init_defaults_to_the_reference_and_is_written_only_when_not() {
        let text = serde_json::to_string(&ModelConfig::sift()).unwrap();
        assert!(!text.contains("head_init"), "{text}");
        let back: ModelConfig = serde_json::from_str(&text).unwrap();
        assert_eq!(back.head_init, HeadInit::Reference);
        let mut he = ModelConfig::sift();
        he.head_init = HeadInit::He;
        let text = serde_json::to_string(&he).unwrap();
        assert!(text.contains(r#""head_init":"he""#), "{text}");
        assert_eq!(serde_json::from_str::<ModelConfig>(&text).unwrap(), he);
        assert!(serde_json::from_str::<HeadInit>(r#""kaiming""#).is_err());
    }
}
