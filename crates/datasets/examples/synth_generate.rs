//! Writes the synthetic dataset (what `pl2map synth` will call) and prints the time.
//! Usage: synth_generate OUT [--tiny] [--frames N] [--seed S] [--cambridge] [--overwrite]

use datasets::synth::{Layout, SynthConfig, generate};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut cfg = SynthConfig::default();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--tiny" => cfg.tiny = true,
            "--cambridge" => cfg.layout = Layout::Cambridge,
            "--overwrite" => cfg.overwrite = true,
            "--frames" => cfg.frames = args.next().ok_or("--frames N")?.parse()?,
            "--seed" => cfg.seed = args.next().ok_or("--seed S")?.parse()?,
            _ => cfg.out = a.into(),
        }
    }
    let t = Instant::now();
    let out = generate(&cfg)?;
    println!(
        "{} frames written to {} in {:.2} s ({} rayon threads)",
        out.frames.len(),
        out.root.display(),
        t.elapsed().as_secs_f64(),
        rayon::current_num_threads()
    );
    Ok(())
}
