//! A reshape followed by a permutation as one recorded operation, whose backward pass
//! makes the gradient contiguous with a direct strided copy.
//!
//! Why: the line encoder splits its keys and values into heads (`[M*T, D]` ->
//! `[M, T, h, dk]` -> `[M, h, dk, T]` / `[M, h, T, dk]`, crates/model/src/line_encoder.rs). Composed from
//! burn's operations, the backward pass of that reshape receives the permuted-back
//! gradient, a 3-D or 4-D view that burn-flex cannot reshape in place, and burn-flex
//! copies it element by element through its generic strided iterator: about 4 % of the
//! main job's training step (docs/performance.md, "The main job's step"). The forward pass
//! here is burn's reshape and permute (the same views, so the products that read them
//! are unchanged), and the backward pass permutes the gradient back and copies it with
//! nested loops of fixed strides (`contiguous`), which gives the same values: a copy.

use crate::flex_matrix;
use burn::tensor::DType;
use burn_flex::FlexTensor;

/// The permutation that undoes `axes`.
pub(crate) fn inverse(axes: &[usize]) -> Vec<usize> {
    let mut inv = vec![0; axes.len()];
    for (i, &a) in axes.iter().enumerate() {
        inv[a] = i;
    }
    inv
}

/// A row-major copy of an f32 view with non-negative strides inside its storage.
/// None for other dtypes or layouts, and for a tensor that is row-major already (the
/// caller then leaves it to burn-flex, whose reshape of it copies nothing).
pub(crate) fn contiguous(t: &FlexTensor) -> Option<FlexTensor> {
    let layout = t.layout();
    if t.dtype() != DType::F32 || layout.is_contiguous() {
        return None;
    }
    let shape: Vec<usize> = layout.shape().iter().copied().collect();
    let strides = layout
        .strides()
        .iter()
        .map(|&s| usize::try_from(s).ok())
        .collect::<Option<Vec<usize>>>()?;
    let src = t.storage::<f32>();
    let offset = layout.start_offset();
    if !flex_matrix::within(src.len(), offset, &shape, &strides) {
        return None;
    }
    let n: usize = shape.iter().product();
    let mut out = Vec::with_capacity(n);
    if n > 0 {
        copy_dims(&mut out, src, offset, &shape, &strides);
    }
    Some(flex_matrix::tensor(out, shape))
}

/// Appends the elements of the view (`shape`, `strides` from `offset`) in row-major
/// order; the bounds were checked by the caller.
fn copy_dims(out: &mut Vec<f32>, src: &[f32], offset: usize, shape: &[usize], strides: &[usize]) {
    match (shape, strides) {
        ([], _) => out.push(src[offset]),
        ([n], [1]) => out.extend_from_slice(&src[offset..offset + n]),
        ([n], [s]) => out.extend((0..*n).map(|i| src[offset + i * s])),
        _ => {
            for i in 0..shape[0] {
                copy_dims(
                    out,
                    src,
                    offset + i * strides[0],
                    &shape[1..],
                    &strides[1..],
                );
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::{B, bits, pseudo, tensor};
    use burn::tensor::Tensor;

    /// The copy equals burn-flex's own for the line encoder's two head layouts and a
    /// narrowed view (offset and gaps); a row-major tensor is left to burn-flex.
    #[test]
    fn copies_like_burn_flex() {
        let (m, t, h, dk) = (5, 3, 2, 4);
        let x = tensor::<B, 2>(pseudo(m * t * h * dk, 1), [m * t, h * dk]);
        let plain = x.clone().reshape([m, t, h, dk]).into_primitive().tensor();
        assert!(contiguous(&plain).is_none());
        let views: Vec<Tensor<B, 4>> = vec![
            x.clone().reshape([m, t, h, dk]).permute([0, 2, 3, 1]),
            x.clone().reshape([m, t, h, dk]).swap_dims(1, 2),
            x.clone()
                .reshape([m, t, h, dk])
                .narrow(3, 1, 2)
                .swap_dims(0, 2),
        ];
        for view in views {
            let flex = view.clone().into_primitive().tensor();
            let ours = contiguous(&flex).expect("an f32 view with positive strides");
            assert!(ours.layout().is_contiguous());
            let theirs = flex.to_contiguous();
            assert_eq!(ours.layout().shape(), theirs.layout().shape());
            assert_eq!(
                bits(ours.storage::<f32>()),
                bits(&theirs.storage::<f32>()[..ours.storage::<f32>().len()])
            );
        }
    }
}
