//! Timings of the synthetic scene: scene build, one 640 x 480 frame on one core, and the
//! whole tiny and default datasets. Run: cargo bench -p bench --bench synth
//!
//! Besides wall time it prints the CPU time of the measuring thread (Linux
//! /proc/thread-self/schedstat), which stays meaningful on a loaded machine.

use std::time::Instant;
use synth::{Scene, SynthConfig, SynthDataset, generate};

/// CPU time of the current thread in seconds, if the kernel reports it.
fn thread_cpu() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    let ns: f64 = s.split_whitespace().next()?.parse().ok()?;
    Some(ns * 1e-9)
}

fn measure<T>(f: impl FnOnce() -> T) -> (T, f64, Option<f64>) {
    let c0 = thread_cpu();
    let t = Instant::now();
    let r = f();
    let wall = t.elapsed().as_secs_f64();
    let cpu = c0.and_then(|c0| thread_cpu().map(|c1| c1 - c0));
    (r, wall, cpu)
}

fn fmt(cpu: Option<f64>) -> String {
    cpu.map_or("n/a".into(), |c| format!("{c:.3} s"))
}

fn main() {
    // Single-threaded part: build and render on one core.
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("pool");
    let (scene, wall, cpu) = pool.install(|| measure(|| Scene::generate(0)));
    println!("scene build (1 thread): wall {wall:.3} s, cpu {}", fmt(cpu));
    let ds = SynthDataset::new(300, 0, false).expect("dataset");
    drop(scene);
    let mut walls = Vec::new();
    let mut cpus = Vec::new();
    for i in (0..ds.len()).step_by(10) {
        let (r, wall, cpu) = measure(|| ds.render_frame(i).expect("render"));
        assert_eq!(r.width, 640);
        walls.push(wall);
        if let Some(c) = cpu {
            cpus.push(c);
        }
    }
    walls.sort_by(f64::total_cmp);
    cpus.sort_by(f64::total_cmp);
    println!(
        "render 640x480, 5 samples/pixel, {} frames: median wall {:.4} s, median cpu {}, max cpu {}",
        walls.len(),
        walls[walls.len() / 2],
        cpus.get(cpus.len() / 2)
            .map_or("n/a".into(), |c| format!("{c:.4} s")),
        cpus.last().map_or("n/a".into(), |c| format!("{c:.4} s")),
    );
    // Whole datasets on the default rayon pool (RAYON_NUM_THREADS to choose).
    for (name, tiny) in [("tiny (32 frames)", true), ("default (300 frames)", false)] {
        let dir = std::env::temp_dir().join(format!("pl2map-synth-bench-{}", std::process::id()));
        let cfg = SynthConfig {
            tiny,
            ground_truth: false,
            ..SynthConfig::default()
        };
        let write = synth::WriteOptions {
            overwrite: true,
            progress: false,
            ..synth::WriteOptions::new(&dir)
        };
        let t = Instant::now();
        let out = generate(&cfg, &write).expect("generate");
        println!(
            "generate {name}: {} frames in {:.2} s wall on {} threads",
            out.frames.len(),
            t.elapsed().as_secs_f64(),
            rayon::current_num_threads()
        );
        let _ = std::fs::remove_dir_all(&dir);
    }
}
