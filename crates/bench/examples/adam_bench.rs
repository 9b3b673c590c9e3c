//! The Adam update alone: burn's Adam against this crate's fused one (`kernels::adam`) on
//! the reference network's parameters, the gradients of one synthetic image, in one run.
//!
//! cargo run --release -p bench --example adam_bench -- [--iters N] [--dims 128,256]
//!
//! Both run in the training threads' pool (`kernels::denormals::flushing_pool`, all cores).
//! The gradients are computed before each timed update, outside the timer. The last two
//! columns step with two gradient groups (`train::step::groups`): their gradients summed first,
//! then the fused Adam, against the sum made inside the fused pass (what training does).

use bench::step::synthetic_sample;
use model::burn::module::Module;
use model::burn::optim::{GradientsParams, Optimizer};
use model::{CpuAutodiffBackend as AD, ModelConfig, Pl2Map, Sample};
use std::time::Instant;
use train::step::groups::{adam_step_groups, sum_gradients};
use train::step::{adam_config, cpu_gradients, new_optimizer};

/// Median seconds of `iters` updates by `optimizer` (after one untimed update, which
/// creates the moments).
fn time_updates<O: Optimizer<Pl2Map<AD>, AD>>(
    mut optimizer: O,
    net: &Pl2Map<AD>,
    sample: &Sample,
    iters: usize,
) -> f64 {
    let mut net = net.clone();
    let mut times = Vec::with_capacity(iters);
    for i in 0..=iters {
        let grads = cpu_gradients(&net, sample).expect("a valid synthetic sample");
        let start = Instant::now();
        net = optimizer.step(1e-4, net, grads);
        if i > 0 {
            times.push(start.elapsed().as_secs_f64());
        }
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

/// Median seconds of `iters` two-group updates: `fused` sums inside the Adam pass,
/// otherwise the sum is made first (both timed).
fn time_group_updates(net: &Pl2Map<AD>, samples: [&Sample; 2], iters: usize, fused: bool) -> f64 {
    let mut optimizer = new_optimizer::<AD>();
    let mut net = net.clone();
    let mut times = Vec::with_capacity(iters);
    for i in 0..=iters {
        let parts: Vec<GradientsParams> = samples
            .iter()
            .map(|s| cpu_gradients(&net, s).expect("a valid synthetic sample"))
            .collect();
        let start = Instant::now();
        net = if fused {
            adam_step_groups(&mut optimizer, 1e-4, net, parts)
        } else {
            let grads = sum_gradients(&net, parts);
            optimizer.step(1e-4, net, grads)
        };
        if i > 0 {
            times.push(start.elapsed().as_secs_f64());
        }
    }
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() {
    let mut iters = 20;
    let mut dims = vec![128, 256];
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        let value = args.next().unwrap_or_default();
        match arg.as_str() {
            "--iters" => iters = value.parse().unwrap_or(iters),
            "--dims" => dims = value.split(',').filter_map(|d| d.parse().ok()).collect(),
            other => {
                eprintln!("unknown argument {other} (--iters N, --dims 128,256)");
                std::process::exit(2);
            }
        }
    }
    let pool = kernels::denormals::flushing_pool().expect("a thread pool");
    println!(
        "Adam update, median of {iters} ({} threads)\n",
        pool.current_num_threads()
    );
    println!(
        "| D | parameters | burn's Adam ms | fused ms | fused / burn | 2 groups: sum, then fused ms | 2 groups: sum inside ms |"
    );
    println!("|---:|---:|---:|---:|---:|---:|---:|");
    for d in dims {
        let cfg = ModelConfig::new(d);
        let net = cfg
            .init::<AD>(1, &Default::default())
            .expect("a valid network");
        let sample = synthetic_sample(&cfg, 1024, 128, 7);
        let other = synthetic_sample(&cfg, 1024, 128, 8);
        let (burn, fused, sum_first, sum_inside) = pool.install(|| {
            (
                time_updates(adam_config().init::<AD, Pl2Map<AD>>(), &net, &sample, iters),
                time_updates(new_optimizer::<AD>(), &net, &sample, iters),
                time_group_updates(&net, [&sample, &other], iters, false),
                time_group_updates(&net, [&sample, &other], iters, true),
            )
        });
        println!(
            "| {d} | {} | {:.2} | {:.2} | {:.2}x | {:.2} | {:.2} |",
            net.num_params(),
            burn * 1e3,
            fused * 1e3,
            fused / burn,
            sum_first * 1e3,
            sum_inside * 1e3
        );
    }
}
