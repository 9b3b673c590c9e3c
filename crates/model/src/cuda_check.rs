//! The CUDA backend against the CPU's (Flex): the same network (seeded on the host, so
//! the same weights on both), the same images and the same training steps must agree up
//! to float rounding, the graph network's attention, the line encoder and gradient groups
//! included. Built only with the `cuda` feature; needs an NVIDIA GPU and CUDA's nvrtc at
//! run time and says SKIPPED without a device (CI checks that the feature compiles and
//! has no GPU). Run on a GPU machine with
//! `cargo test --release -p model --features cuda --lib cuda_check`.

#[cfg(test)]
mod tests {
    use crate::config::LayerKind;
    use crate::testing::{flat, tiny_sample};
    use crate::{
        CpuAutodiffBackend, CudaAutodiffBackend, LossConfig, ModelConfig, Pl2MapBackend, Sample,
        StepOptions, TrainState,
    };
    use burn::tensor::backend::AutodiffBackend;

    fn gpu_present() -> bool {
        std::path::Path::new("/dev/nvidiactl").exists()
    }

    /// A small graph network: both attention kinds, the line encoder, two-layer heads.
    fn config() -> ModelConfig {
        ModelConfig {
            descriptor_dim: 64,
            heads: 4,
            line_tokens: 4,
            ffn_dim: 128,
            layers: vec![LayerKind::SelfAttention, LayerKind::Cross],
            head_hidden: vec![128, 128],
            line_head_hidden: None,
            dropout: 0.0,
            reliability_beta: 100.0,
            point_input_scale: 1.0,
            head_init: crate::HeadInit::He,
        }
    }

    /// Predictions of the fresh network, and after `steps` Adam steps on `batch` in
    /// `groups` gradient groups.
    fn run<B: AutodiffBackend<InnerBackend: Pl2MapBackend> + Pl2MapBackend>(
        device: &B::Device,
        batch: &[Sample],
        probe: &Sample,
        steps: usize,
        groups: usize,
    ) -> (Vec<f32>, Vec<f32>) {
        let cfg = config();
        let mut state = TrainState::<B>::init(&cfg, LossConfig::indoor(), 7, device).unwrap();
        state.set_batch_groups(groups, None).unwrap();
        let predict = |s: &TrainState<B>| {
            flat(
                &s.inference_model()
                    .predict(&probe.point_descriptors, &probe.line_descriptors)
                    .unwrap(),
            )
        };
        let fresh = predict(&state);
        for i in 0..steps {
            let options = StepOptions {
                progress: 0.9,
                learning_rate: 1e-3,
                dropout_seed: i as u64,
            };
            assert!(state.step_batch(batch, &options).unwrap().updated);
        }
        (fresh, predict(&state))
    }

    /// Largest |a - b| / (1 + |b|).
    fn worst(a: &[f32], b: &[f32]) -> f32 {
        assert_eq!(a.len(), b.len());
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs() / (1.0 + y.abs()))
            .fold(0.0, f32::max)
    }

    #[test]
    fn cuda_matches_the_cpu_before_and_after_training() {
        if !gpu_present() {
            eprintln!("SKIPPED: no NVIDIA device (/dev/nvidiactl): the CUDA check needs a GPU");
            return;
        }
        let cfg = config();
        let batch: Vec<Sample> = (0..4)
            .map(|i| tiny_sample(&cfg, 48 + 16 * (i % 2), 8))
            .collect();
        let probe = tiny_sample(&cfg, 40, 6);
        let cuda = Default::default();
        for groups in [1, 2] {
            let (cpu_fresh, cpu_trained) =
                run::<CpuAutodiffBackend>(&Default::default(), &batch, &probe, 5, groups);
            let (gpu_fresh, gpu_trained) =
                run::<CudaAutodiffBackend>(&cuda, &batch, &probe, 5, groups);
            let (f, t) = (
                worst(&gpu_fresh, &cpu_fresh),
                worst(&gpu_trained, &cpu_trained),
            );
            eprintln!(
                "groups {groups}: fresh network max rel. difference {f:.2e}, after 5 steps {t:.2e} ({} values)",
                cpu_fresh.len()
            );
            // Bounds for f32 products in another order (or TF32 tensor cores): a wrong
            // kernel gives differences of the order of the outputs themselves.
            assert!(f < 2e-3, "fresh network: CUDA and CPU differ by {f}");
            assert!(t < 1e-2, "after 5 steps: CUDA and CPU differ by {t}");
            // Training moved the network far more than the backends differ, so the
            // comparison after it says something.
            let moved = worst(&cpu_trained, &cpu_fresh);
            assert!(
                moved > 10.0 * t,
                "training moved {moved}, backends differ {t}"
            );
        }
    }
}
